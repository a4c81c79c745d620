//! Helpers for the unit tests: a reusable chi-square goodness-of-fit test of a sampling routine
//! against the density it claims (after Mitsuba 3's `chi2` test), with a multiple-comparison
//! correction, and small statistics.
//!
//! A test names its domain, draws samples, and gives the density; the harness bins the samples,
//! integrates the density over every bin (a midpoint rule on a finer grid), pools bins whose
//! expected count is below 5, and rejects the sampler if Pearson's statistic has a p-value below
//! [`SIGNIFICANCE`] divided by the number of tests the caller runs (Bonferroni). Samplers that may
//! fail (a BSDF sample below the surface) return `None`; the failures form one more bin, whose
//! expected share is the density's missing mass, 1 − ∫ pdf.

use crate::rng::{Purpose, Sampler};
use glam::{DVec2, Vec3};
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::f64::consts::PI;

/// The space samples live in.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Domain {
    /// Unit directions, binned by (cos θ, φ) about +z: equal solid angle per bin; the density is
    /// per steradian.
    Sphere,
    /// Points of the unit square; the density is per unit area.
    Square,
}

impl Domain {
    /// Coordinates in [0, 1)² of a sample of the domain.
    fn coordinates(self, p: Sample) -> DVec2 {
        match (self, p) {
            (Domain::Sphere, Sample::Direction(v)) => {
                let v = v.as_dvec3().normalize();
                let phi = v.y.atan2(v.x).rem_euclid(2.0 * PI);
                DVec2::new((v.z + 1.0) / 2.0, phi / (2.0 * PI))
            }
            (Domain::Square, Sample::Point(p)) => p,
            _ => panic!("a sample of the wrong kind for {self:?}"),
        }
    }

    /// The sample at coordinates `uv`, and the measure of the domain per unit of uv area.
    fn point(self, uv: DVec2) -> (Sample, f64) {
        match self {
            Domain::Sphere => {
                let z = 2.0 * uv.x - 1.0;
                let phi = 2.0 * PI * uv.y;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let v = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                (Sample::Direction(v), 4.0 * PI)
            }
            Domain::Square => (Sample::Point(uv), 1.0),
        }
    }
}

/// A sample: a direction or a point of the unit square.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Sample {
    /// A unit direction.
    Direction(Vec3),
    /// A point of [0, 1)².
    Point(DVec2),
}

impl Sample {
    /// The direction of a [`Sample::Direction`].
    pub(crate) fn direction(self) -> Vec3 {
        match self {
            Sample::Direction(v) => v,
            Sample::Point(_) => panic!("not a direction"),
        }
    }

    /// The point of a [`Sample::Point`].
    pub(crate) fn point(self) -> DVec2 {
        match self {
            Sample::Point(p) => p,
            Sample::Direction(_) => panic!("not a point"),
        }
    }
}

#[path = "../tests/shared/temp_dir.rs"]
mod temp;
pub(crate) use temp::TempDir;

/// A fresh, empty temporary directory for one test (see [`TempDir`]).
pub(crate) fn temp_dir(test: &str) -> TempDir {
    TempDir::new("unit", test)
}

#[path = "../tests/shared/stats.rs"]
#[allow(dead_code)]
mod stats;
pub(crate) use stats::{SIGNIFICANCE, assert_agrees};

/// Means of `batches` batches of `n` draws of `f`, each draw from a stream of its own (for
/// t-tests of estimators whose single draws are far from normal).
pub(crate) fn batch_means(
    batches: usize,
    n: usize,
    seed: u64,
    mut f: impl FnMut(&mut Sampler) -> f64,
) -> Vec<f64> {
    (0..batches)
        .map(|b| {
            (0..n)
                .map(|i| f(&mut Sampler::new(seed, Purpose::Other, b as u64, i as u64)))
                .sum::<f64>()
                / n as f64
        })
        .collect()
}

/// A chi-square test of one sampling routine.
pub(crate) struct ChiSquare {
    /// What is tested (for the failure message).
    pub(crate) name: String,
    pub(crate) domain: Domain,
    /// Bins along each coordinate.
    pub(crate) bins: [usize; 2],
    pub(crate) samples: usize,
    /// How many chi-square tests the caller runs in all (the Bonferroni correction).
    pub(crate) tests: usize,
    /// Seed of the sample stream.
    pub(crate) seed: u64,
}

impl ChiSquare {
    /// A test of `samples` draws over `domain` on a 24 × 48 grid, one of `tests`.
    pub(crate) fn new(name: impl Into<String>, domain: Domain, tests: usize) -> Self {
        Self { name: name.into(), domain, bins: [24, 48], samples: 200_000, tests, seed: 1 }
    }

    /// Draws samples with `sample`, compares their histogram with the integral of `pdf` over each
    /// bin, and panics if the fit is rejected. Returns the p-value.
    pub(crate) fn run(
        &self,
        mut sample: impl FnMut(&mut Sampler) -> Option<Sample>,
        pdf: impl Fn(Sample) -> f64,
    ) -> f64 {
        let [nx, ny] = self.bins;
        let mut observed = vec![0u64; nx * ny + 1];
        let mut s = Sampler::new(self.seed, Purpose::Other, 0, 0);
        for _ in 0..self.samples {
            match sample(&mut s) {
                Some(p) => {
                    let uv = self.domain.coordinates(p);
                    let i = ((uv.x * nx as f64) as usize).min(nx - 1);
                    let j = ((uv.y * ny as f64) as usize).min(ny - 1);
                    observed[i * ny + j] += 1;
                }
                None => observed[nx * ny] += 1,
            }
        }
        let expected = self.expected(&pdf);
        let p = chi_square_p(&observed, &expected);
        assert!(
            p > SIGNIFICANCE / self.tests as f64,
            "{}: chi-square p-value {p:.3e} below {:.1e} / {} tests",
            self.name,
            SIGNIFICANCE,
            self.tests
        );
        p
    }

    /// Probability of each bin, and of failure last: ∫ pdf over each bin by the midpoint rule on
    /// a k × k sub-grid, k doubled from 32 (so that a density's edge across a bin is resolved)
    /// until two successive values agree to 10⁻⁵ (up to k = 1024, for peaked densities).
    fn expected(&self, pdf: &impl Fn(Sample) -> f64) -> Vec<f64> {
        let [nx, ny] = self.bins;
        let size = DVec2::new(1.0 / nx as f64, 1.0 / ny as f64);
        let midpoint = |lo: DVec2, k: usize| {
            let cell = size / k as f64;
            let mut sum = 0.0;
            for a in 0..k {
                for b in 0..k {
                    let (point, measure) =
                        self.domain.point(lo + (DVec2::new(a as f64, b as f64) + 0.5) * cell);
                    sum += pdf(point) * measure;
                }
            }
            sum * cell.x * cell.y
        };
        let mut p = vec![0.0; nx * ny + 1];
        for i in 0..nx {
            for j in 0..ny {
                let lo = DVec2::new(i as f64, j as f64) * size;
                let (mut k, mut q) = (32, midpoint(lo, 32));
                loop {
                    let finer = midpoint(lo, 2 * k);
                    k *= 2;
                    let done = (finer - q).abs() <= 1e-5 * finer.abs() + 1e-12 || k >= 1024;
                    q = finer;
                    if done {
                        break;
                    }
                }
                p[i * ny + j] = q;
            }
        }
        let total: f64 = p.iter().sum();
        assert!(total < 1.0 + 1e-3, "{}: the density integrates to {total} > 1", self.name);
        p[nx * ny] = (1.0 - total).max(0.0);
        p
    }
}

/// Pearson's chi-square test of `observed` counts against `expected` probabilities. Bins with an
/// expected count below 5 are pooled into one; a pooled bin too small for the test must hold no
/// more than its expectation allows. Returns the p-value.
pub(crate) fn chi_square_p(observed: &[u64], expected: &[f64]) -> f64 {
    assert_eq!(observed.len(), expected.len());
    let n: u64 = observed.iter().sum();
    let (mut stat, mut dof) = (0.0, 0usize);
    let (mut pooled_o, mut pooled_e) = (0.0, 0.0);
    for (&o, &p) in observed.iter().zip(expected) {
        let e = p * n as f64;
        if e < 5.0 {
            pooled_o += o as f64;
            pooled_e += e;
            continue;
        }
        stat += (o as f64 - e).powi(2) / e;
        dof += 1;
    }
    if pooled_e >= 5.0 {
        stat += (pooled_o - pooled_e).powi(2) / pooled_e;
        dof += 1;
    } else {
        assert!(
            pooled_o <= 5.0 + 10.0 * pooled_e,
            "{pooled_o} samples in near-empty bins (expected {pooled_e})"
        );
    }
    assert!(dof >= 2, "too few usable bins");
    1.0 - ChiSquared::new((dof - 1) as f64).unwrap().cdf(stat)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The harness accepts a correct density and rejects a wrong one.
    #[test]
    fn harness_accepts_the_right_density_and_rejects_a_wrong_one() {
        let test = ChiSquare::new("uniform sphere", Domain::Sphere, 1);
        let uniform = |s: &mut Sampler| {
            Some(Sample::Direction(crate::math::sample_uniform_sphere(s.next_2d())))
        };
        test.run(uniform, |_| 1.0 / (4.0 * PI));
        let wrong = std::panic::catch_unwind(|| {
            test.run(uniform, |d| match d {
                Sample::Direction(v) => (1.0 + 0.1 * v.z as f64) / (4.0 * PI),
                Sample::Point(_) => 0.0,
            })
        });
        assert!(wrong.is_err(), "a 10 % tilt went unnoticed");
        // Failures are compared with the missing mass: half the samples fail here.
        let half = ChiSquare::new("half", Domain::Square, 1);
        half.run(
            |s| {
                let u = s.next_2d().as_dvec2();
                (u.x < 0.5).then_some(Sample::Point(DVec2::new(2.0 * u.x, u.y)))
            },
            |_| 0.5,
        );
    }
}
