//! A homogeneous medium with RGB coefficients.
//!
//! Free-flight sampling with chromatic σ_t picks a channel uniformly and samples its exponential;
//! the distance's pdf is then the average over channels (the balance heuristic, Miller et al. 2019
//! §4; pbrt-v4 §14.2.2), so no channel's weight blows up:
//!
//!   p(t) = (1/3) Σ_c σ_t,c e^{−σ_t,c t},  P(no collision before t_max) = (1/3) Σ_c e^{−σ_t,c t_max}.

use super::phase::HenyeyGreenstein;
use super::track::{DistancePdfs, FreeFlight};
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
    /// Emitted radiance L_e: the medium adds σ_a L_e per unit length (zero: no emission).
    pub emission: Rgb,
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

    /// ∫₀^t_max T(0, t) σ_a L_e dt, the emitted radiance reaching the start of a segment of
    /// length `t_max` (may be infinite): σ_a L_e (1 − e^{−σ_t t_max}) / σ_t per channel, exactly.
    pub fn emitted(&self, t_max: f32) -> Rgb {
        let sigma_t = self.sigma_t();
        let source = self.sigma_a * self.emission;
        // σ_a ≤ σ_t, so a channel without extinction has no source either.
        let absorbed = -(-sigma_t * t_max).map(f32::exp_m1);
        Rgb::select(sigma_t.cmpgt(Rgb::ZERO), source * absorbed / sigma_t, Rgb::ZERO)
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
            let pdfs = DistancePdfs { forward: pdf, reverse: pdf };
            FreeFlight { t, scattered: true, weight: tr / pdf, pdfs: Some(pdfs) }
        } else {
            let tr = self.transmittance(t_max);
            let p_pass = tr.element_sum() / 3.0;
            let weight = if p_pass > 0.0 { tr / p_pass } else { Rgb::ZERO };
            let pdfs = DistancePdfs { forward: p_pass, reverse: self.collision_pdf(t_max) };
            FreeFlight { t: t_max, scattered: false, weight, pdfs: Some(pdfs) }
        }
    }

    /// The density per unit length with which [`Self::sample_free_flight`] collides at distance
    /// `t` (the reverse density of a flight of length `t`: a homogeneous medium is the same both
    /// ways): (1/3) Σ_c σ_t,c e^{−σ_t,c t}.
    pub fn collision_pdf(&self, t: f32) -> f32 {
        (self.sigma_t() * self.transmittance(t)).element_sum() / 3.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{ChiSquare, Domain, Sample};
    use glam::DVec2;

    /// The emitted radiance along a segment, in closed form, against a midpoint quadrature of
    /// ∫ σ_a L_e e^{−σ_t t} dt per channel (relative 10⁻⁴, f32 arithmetic), including a channel
    /// without extinction and an infinite segment (σ_a L_e / σ_t).
    #[test]
    fn emission_along_a_segment_has_its_closed_form() {
        let h = Homogeneous {
            sigma_a: Rgb::new(0.5, 0.0, 1.0),
            sigma_s: Rgb::new(0.5, 0.0, 3.0),
            phase: HenyeyGreenstein { g: 0.0 },
            emission: Rgb::new(2.0, 5.0, 0.25),
        };
        let len = 1.7f64;
        let n = 100_000;
        for c in 0..3 {
            let (sa, st, le) = (h.sigma_a[c] as f64, h.sigma_t()[c] as f64, h.emission[c] as f64);
            let quad: f64 = (0..n)
                .map(|i| {
                    let t = len * (i as f64 + 0.5) / n as f64;
                    sa * le * (-st * t).exp() * len / n as f64
                })
                .sum();
            let got = h.emitted(len as f32)[c] as f64;
            assert!((got - quad).abs() <= 1e-4 * quad.max(1e-12), "channel {c}: {got} vs {quad}");
            let infinite = h.emitted(f32::INFINITY)[c] as f64;
            let want = if st > 0.0 { sa * le / st } else { 0.0 };
            assert!((infinite - want).abs() <= 1e-6 * want.max(1e-12), "channel {c}: {infinite}");
        }
    }

    /// Free-flight distances with chromatic extinction follow the channel-averaged density
    /// p(t) = (1/3) Σ σ_c e^{−σ_c t}, and reaching t_max has the averaged probability (the
    /// failure bin); the weights are T(t)/p(t) and T(t_max)/P, and the reported pdfs, forward and
    /// reverse, are those densities.
    #[test]
    fn free_flight_follows_the_averaged_density() {
        let h = Homogeneous {
            sigma_a: Rgb::new(0.5, 0.5, 1.0),
            sigma_s: Rgb::new(0.5, 1.5, 3.0),
            phase: HenyeyGreenstein { g: 0.0 },
            emission: Rgb::ZERO,
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
                // The pdfs it reports: the density the histogram tests (the probability of
                // the failure bin when it passes), and for the reverse decision the same
                // density at the flight's length, a collision at the start seen from the end.
                let pdfs = f.pdfs.expect("a homogeneous medium gives its pdfs");
                let forward = if f.scattered { density(t) } else { tr.element_sum() / 3.0 };
                let close = |a: f32, b: f64| (a as f64 - b).abs() <= 1e-4 * b;
                assert!(close(pdfs.forward, forward), "{pdfs:?} {forward}");
                assert!(close(pdfs.reverse, density(t)), "{pdfs:?}");
                assert_eq!(pdfs.reverse, h.collision_pdf(f.t));
                f.scattered.then(|| Sample::Point(DVec2::new(t / t_max, 0.5)))
            },
            |p| t_max * density(p.point().x * t_max),
        );
    }
}
