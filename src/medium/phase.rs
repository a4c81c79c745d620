//! Phase functions.
//!
//! Convention: `p(d_in, d_out)` takes both directions as **directions of travel** — `d_in` the way
//! light travelled to the scattering point, `d_out` the way it leaves — so cos θ = d_in · d_out and
//! forward scattering (g > 0) keeps light going the way it went: the mean of cos θ is g.
//! Phase functions are normalised over the sphere: ∫ p dω = 1.

use crate::math::Frame;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// The Henyey–Greenstein phase function (Henyey & Greenstein 1941); g = 0 is isotropic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HenyeyGreenstein {
    /// Mean cosine, in (−1, 1).
    pub g: f32,
}

/// A sampled scattering direction with what callers need to weigh it, so that none evaluates the
/// phase function again.
#[derive(Clone, Copy, Debug)]
pub struct PhaseSample {
    /// Outgoing direction of travel.
    pub wi: Vec3,
    /// p(d_in, wi).
    pub value: f32,
    /// Solid-angle density of `wi` (equal to `value`: Henyey–Greenstein sampling is exact).
    pub pdf: f32,
    /// Solid-angle density of the reverse decision: of sampling `−d_in` for light arriving along
    /// `−wi` ([`HenyeyGreenstein::pdf`]`(−wi, −d_in)`), which a bidirectional weight asks for.
    /// No estimator reads it yet (the combined estimator of the next capability will); its
    /// test holds it to the forward density of the reverse decision.
    #[allow(dead_code)]
    pub pdf_reverse: f32,
}

impl HenyeyGreenstein {
    /// p(cos θ) = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}).
    #[inline]
    pub fn eval_cos(&self, cos_theta: f32) -> f32 {
        let g = self.g;
        if g == 0.0 {
            return 1.0 / (4.0 * PI);
        }
        let denom = (1.0 + g * g - 2.0 * g * cos_theta).max(1e-12);
        (1.0 - g * g) / (4.0 * PI * denom * denom.sqrt())
    }

    /// The smallest value of the phase function, (1 − |g|) / (4π (1 + |g|)²) (at θ = π for
    /// g > 0, at θ = 0 for g < 0).
    #[inline]
    pub fn min_value(&self) -> f32 {
        self.eval_cos(-self.g.signum())
    }

    /// p(d_in, d_out).
    #[inline]
    pub fn eval(&self, d_in: Vec3, d_out: Vec3) -> f32 {
        self.eval_cos(d_in.dot(d_out))
    }

    /// The solid-angle density with which [`Self::sample`] draws `d_out` given `d_in`: the
    /// phase function itself, as the sampling is exact. Callers that weigh samples (multiple
    /// importance sampling) ask this, not [`Self::eval`], for a density.
    #[inline]
    pub fn pdf(&self, d_in: Vec3, d_out: Vec3) -> f32 {
        self.eval(d_in, d_out)
    }

    /// Samples d_out ∝ p(d_in, ·) by inverting the CDF of cos θ (pbrt-v4, §11.3.1).
    pub fn sample(&self, d_in: Vec3, u: Vec2) -> PhaseSample {
        let g = self.g;
        let cos_theta = if g.abs() < 1e-3 {
            1.0 - 2.0 * u.x
        } else {
            let sq = (1.0 - g * g) / (1.0 + g - 2.0 * g * u.x);
            ((1.0 + g * g - sq * sq) / (2.0 * g)).clamp(-1.0, 1.0)
        };
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        let local = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta);
        let wi = Frame::new(d_in).to_world(local).normalize();
        // From the direction as returned (not from cos θ before rounding), so that a caller's
        // own evaluation of `wi` gives the same number.
        let value = self.eval(d_in, wi);
        // The reverse decision turns through the same angle, (−wi)·(−d_in) = d_in·wi, and
        // Henyey–Greenstein depends on that angle alone: the same density, to the bit.
        PhaseSample { wi, value, pdf: value, pdf_reverse: value }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{ChiSquare, Domain, Sample, assert_agrees};

    /// Sampled directions follow p(d_in, ·) (chi-square; the peaked cases along +z, where the
    /// binning is fine in cos θ, one case tilted), the reported value is p, and the mean cosine
    /// between the directions of travel is g (t-test on batch means): the direction convention.
    #[test]
    fn henyey_greenstein_sampling_matches_its_density_and_mean_cosine() {
        let tilted = Vec3::new(0.2, -0.5, 0.84).normalize();
        let cases =
            [(-0.9f32, Vec3::Z), (-0.3, Vec3::Z), (0.0, Vec3::Z), (0.5, tilted), (0.95, Vec3::Z)];
        for (k, (g, d_in)) in cases.into_iter().enumerate() {
            let hg = HenyeyGreenstein { g };
            let mut test =
                ChiSquare::new(format!("Henyey–Greenstein g = {g}"), Domain::Sphere, cases.len());
            test.seed = 20 + k as u64;
            let mut cosines = Vec::new();
            test.run(
                |s| {
                    let ps = hg.sample(d_in, s.next_2d());
                    cosines.push(ps.wi.dot(d_in) as f64);
                    assert!(ps.value == hg.eval(d_in, ps.wi) && ps.pdf == hg.pdf(d_in, ps.wi));
                    // The reverse decision: from −wi, drawing −d_in.
                    let reverse = hg.pdf(-ps.wi, -d_in);
                    assert_eq!(ps.pdf_reverse, reverse, "{ps:?}");
                    Some(Sample::Direction(ps.wi))
                },
                |d| hg.pdf(d_in, d.direction()) as f64,
            );
            let batches: Vec<f64> = cosines
                .chunks(cosines.len() / 20)
                .map(|c| c.iter().sum::<f64>() / c.len() as f64)
                .collect();
            assert_agrees(&format!("mean cosine, g = {g}"), &batches, g as f64, 0.0);
        }
    }

    #[test]
    fn hg_integrates_to_one() {
        for g in [-0.95f32, -0.5, 0.0, 0.3, 0.9] {
            let hg = HenyeyGreenstein { g };
            let n = 200_000;
            let mut sum = 0.0f64;
            for i in 0..n {
                let c = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                sum += hg.eval_cos(c as f32) as f64 * 2.0 * std::f64::consts::PI * 2.0 / n as f64;
            }
            assert!((sum - 1.0).abs() < 2e-3, "g = {g}: ∫p = {sum}");
        }
    }
}
