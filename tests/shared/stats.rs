//! The statistics of the Monte Carlo tests, shared by the unit tests (`src/testing.rs`) and the
//! integration suite (`tests/suite/common.rs`), which include this file: one significance level,
//! the mean with its standard error, and the two-sided Student t-test every agreement check uses.

use statrs::distribution::{ContinuousCDF, StudentsT};

/// Significance level of every statistical test (two-sided where it applies; before any
/// multiple-comparison correction).
pub const SIGNIFICANCE: f64 = 1e-3;

/// Mean and standard error of the mean of `xs`.
pub fn mean_and_se(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// Two-sided Student-t critical value for `samples` independent samples at [`SIGNIFICANCE`].
pub fn t_critical(samples: usize) -> f64 {
    t_critical_at(samples, SIGNIFICANCE)
}

/// Two-sided Student-t critical value for `samples` independent samples at significance `alpha`.
pub fn t_critical_at(samples: usize, alpha: f64) -> f64 {
    StudentsT::new(0.0, 1.0, (samples - 1) as f64).unwrap().inverse_cdf(1.0 - alpha / 2.0)
}

/// Asserts that the mean of independent estimates `xs` agrees with `reference` by a two-sided
/// Student t-test at [`SIGNIFICANCE`], allowing a known bias bound `bias` on top of the noise.
pub fn assert_agrees(what: &str, xs: &[f64], reference: f64, bias: f64) {
    let (mean, se) = mean_and_se(xs);
    let t = t_critical(xs.len());
    let excess = ((mean - reference).abs() - bias).max(0.0);
    assert!(
        excess <= t * se,
        "{what}: mean {mean:.6} ± {se:.6} (n = {}) vs reference {reference:.6}: |Δ| − bias = {excess:.6} > {t:.2}·se",
        xs.len()
    );
}
