//! Shared helpers: statistics for Monte Carlo tests and small scenes built in code.

use statrs::distribution::{ContinuousCDF, StudentsT};

/// Significance level of every statistical test in the suite (two-sided where it applies).
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

#[path = "../shared/temp_dir.rs"]
mod temp;
pub use temp::TempDir;

/// A fresh, empty temporary directory for one test (see [`TempDir`]).
pub fn temp_dir(test: &str) -> TempDir {
    TempDir::new("test", test)
}

/// A seeded random stream for the tests' own random choices (xoshiro256++, portable).
pub struct Rng(rand::rngs::Xoshiro256PlusPlus);

impl Rng {
    /// The stream for `(seed, stream)`.
    pub fn new(seed: u64, stream: u64) -> Self {
        use rand::SeedableRng;
        Self(rand::rngs::Xoshiro256PlusPlus::seed_from_u64(
            seed ^ stream.wrapping_mul(0x9e37_79b9_7f4a_7c15),
        ))
    }

    /// Uniform in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        use rand::Rng as _;
        (self.0.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Uniform in [0, 1), with 53 random bits.
    pub fn next_f64(&mut self) -> f64 {
        use rand::Rng as _;
        (self.0.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform integer in [0, n).
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next_f32() as f64) * n as f64) as usize % n.max(1)
    }

    /// A uniformly distributed unit vector.
    pub fn unit_vector(&mut self) -> haze::glam::Vec3 {
        let z = 1.0 - 2.0 * self.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * std::f32::consts::PI * self.next_f32();
        haze::glam::Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}
