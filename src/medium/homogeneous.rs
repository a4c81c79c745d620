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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{ChiSquare, Domain, Sample};
    use glam::DVec2;

    /// Free-flight distances with chromatic extinction follow the channel-averaged density
    /// p(t) = (1/3) Σ σ_c e^{−σ_c t}, and reaching t_max has the averaged probability (the
    /// failure bin); the weights are T(t)/p(t) and T(t_max)/P.
    #[test]
    fn free_flight_follows_the_averaged_density() {
        let h = Homogeneous {
            sigma_a: Rgb::new(0.5, 0.5, 1.0),
            sigma_s: Rgb::new(0.5, 1.5, 3.0),
            phase: HenyeyGreenstein { g: 0.0 },
        };
        let (sigma_t, t_max) = (h.sigma_t().as_dvec3(), 1.2f64);
        let density = |t: f64| ((sigma_t * (-sigma_t * t).exp()).element_sum()) / 3.0;
        let mut test = ChiSquare::new("homogeneous free flight", Domain::Square, 1);
        test.bins = [48, 1];
        test.run(
            |s| {
                let f = h.sample_free_flight(t_max as f32, s.next_f32(), s.next_f32());
                let t = f.t as f64;
                let tr = (-sigma_t * t).exp();
                let want =
                    if f.scattered { tr / density(t) } else { tr / (tr.element_sum() / 3.0) };
                assert!(
                    (f.weight.as_dvec3() - want).abs().max_element() < 1e-4 * want.max_element()
                );
                f.scattered.then(|| Sample::Point(DVec2::new(t / t_max, 0.5)))
            },
            |p| t_max * density(p.point().x * t_max),
        );
    }
}
