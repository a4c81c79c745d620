//! A homogeneous medium with RGB coefficients.
//!
//! Free-flight sampling with chromatic σ_t picks a channel uniformly and samples its exponential;
//! the distance's pdf is then the average over channels (the balance heuristic, Miller et al. 2019
//! §4; pbrt-v4 §14.2.2), so no channel's weight blows up:
//!
//!   p(t) = (1/3) Σ_c σ_t,c e^{−σ_t,c t},  P(no collision before t_max) = (1/3) Σ_c e^{−σ_t,c t_max}.

use super::{FreeFlight, phase::HenyeyGreenstein};
use crate::math::Rgb;
use glam::Vec3;

/// A homogeneous medium.
#[derive(Clone, Debug, PartialEq)]
pub struct Homogeneous {
    /// Absorption coefficient (1/length).
    pub sigma_a: Rgb,
    /// Scattering coefficient (1/length).
    pub sigma_s: Rgb,
    /// Phase function.
    pub phase: HenyeyGreenstein,
}

impl Homogeneous {
    /// Extinction σ_t = σ_a + σ_s.
    #[inline]
    pub fn sigma_t(&self) -> Rgb {
        self.sigma_a + self.sigma_s
    }

    /// Transmittance over a distance `t`.
    #[inline]
    pub fn transmittance(&self, t: f32) -> Rgb {
        if t.is_infinite() {
            return Rgb::select(self.sigma_t().cmpgt(Vec3::ZERO), Rgb::ZERO, Rgb::ONE);
        }
        (-self.sigma_t() * t).exp()
    }

    /// Samples a collision before `t_max` (may be infinite) from uniforms `u_channel`, `u`.
    pub fn sample_free_flight(&self, t_max: f32, u_channel: f32, u: f32) -> FreeFlight {
        let sigma_t = self.sigma_t();
        let c = ((u_channel * 3.0) as usize).min(2);
        let s = sigma_t[c];
        let t = if s > 0.0 { -(1.0 - u).ln() / s } else { f32::INFINITY };
        if t < t_max {
            let tr = (-sigma_t * t).exp();
            let pdf = (sigma_t * tr).element_sum() / 3.0;
            FreeFlight { t, scattered: true, weight: tr / pdf }
        } else {
            let tr = self.transmittance(t_max);
            let p_pass = tr.element_sum() / 3.0;
            let weight = if p_pass > 0.0 { tr / p_pass } else { Rgb::ZERO };
            FreeFlight { t: t_max, scattered: false, weight }
        }
    }
}
