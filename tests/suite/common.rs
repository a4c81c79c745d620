//! Shared helpers: statistics for Monte Carlo tests and small scenes built in code.

#[path = "../shared/stats.rs"]
mod stats;
pub use stats::{SIGNIFICANCE, assert_agrees, mean_and_se, t_critical, t_critical_at};

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
