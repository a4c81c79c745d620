//! Shared helpers: statistics for Monte Carlo tests and small scenes built in code.

use statrs::distribution::{ChiSquared, ContinuousCDF, StudentsT};

/// Significance level of every statistical test in the suite (two-sided where it applies).
pub const SIGNIFICANCE: f64 = 1e-3;

/// Pearson's chi-square goodness-of-fit test of `observed` counts against `expected`
/// probabilities. Bins with an expected count below 5 are pooled into one. Returns the p-value.
pub fn chi_square_p(observed: &[u64], expected_prob: &[f64]) -> f64 {
    assert_eq!(observed.len(), expected_prob.len());
    let n: u64 = observed.iter().sum();
    let (mut stat, mut dof) = (0.0, 0usize);
    let (mut pooled_o, mut pooled_e) = (0.0, 0.0);
    for (&o, &p) in observed.iter().zip(expected_prob) {
        let e = p * n as f64;
        if e < 5.0 {
            pooled_o += o as f64;
            pooled_e += e;
            continue;
        }
        stat += (o as f64 - e).powi(2) / e;
        dof += 1;
    }
    if pooled_e > 0.0 {
        if pooled_e >= 5.0 {
            stat += (pooled_o - pooled_e).powi(2) / pooled_e;
            dof += 1;
        } else {
            assert!(pooled_o <= 5.0 + 10.0 * pooled_e, "{pooled_o} samples in near-empty bins");
        }
    }
    assert!(dof >= 2, "too few usable bins");
    1.0 - ChiSquared::new((dof - 1) as f64).unwrap().cdf(stat)
}

/// Mean and standard error of the mean of `xs`.
pub fn mean_and_se(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// Two-sided Student-t critical value for `samples` independent samples at [`SIGNIFICANCE`].
pub fn t_critical(samples: usize) -> f64 {
    StudentsT::new(0.0, 1.0, (samples - 1) as f64).unwrap().inverse_cdf(1.0 - SIGNIFICANCE / 2.0)
}

/// Asserts that the mean of independent estimates `xs` agrees with `reference` by a two-sided
/// t-test at [`SIGNIFICANCE`], allowing a known bias bound `bias` on top of the noise.
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

/// Path of a bundled scene.
pub fn scene_path(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)
}

/// A fresh, empty temporary directory for one test.
pub fn temp_dir(test: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("haze-test-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}
