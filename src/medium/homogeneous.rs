//! A homogeneous medium with RGB coefficients. The tracker (`medium/tracker.rs`) tracks it in
//! closed form ([`Constant`]): it is one majorant segment whose majorant is the extinction
//! everywhere.

use super::phase::HenyeyGreenstein;
use super::tracker::{Constant, Tracked};
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
}

impl Tracked for Homogeneous {
    #[inline]
    fn constant(&self) -> Option<Constant> {
        Some(Constant { sigma_t: self.sigma_t(), source: self.sigma_a * self.emission })
    }

    /// One piece, the whole ray, at the largest channel's extinction.
    fn majorants(
        &self,
        _o: Vec3,
        _d: Vec3,
        t_max: f32,
        _rate: f32,
        mut f: impl FnMut(f32, f32, f32) -> bool,
    ) {
        let mu = self.sigma_t().max_element();
        if mu > 0.0 && t_max > 0.0 {
            f(mu, 0.0, t_max);
        }
    }

    fn sigma_t(&self, _p: Vec3) -> f32 {
        self.sigma_t().max_element()
    }

    fn coloured(&self) -> bool {
        let t = self.sigma_t();
        t.max_element() != t.min_element()
    }

    fn tint(&self, _p: Vec3) -> Rgb {
        let t = self.sigma_t();
        if t.max_element() > 0.0 { t / t.max_element() } else { Rgb::ONE }
    }

    fn emission_at(&self, p: Vec3) -> (Rgb, Rgb, Rgb) {
        let max = self.sigma_t().max_element();
        let share = if max > 0.0 { self.sigma_a / max } else { Rgb::ZERO };
        (Tracked::tint(self, p), share, self.emission)
    }

    fn emits(&self) -> bool {
        (self.sigma_a * self.emission).max_element() > 0.0
    }

    fn cut(&self) {}
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::tracker::ln_flight_pdf;
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
        let c = h.constant().unwrap();
        let len = 1.7f64;
        let n = 100_000;
        for k in 0..3 {
            let (sa, st, le) = (h.sigma_a[k] as f64, h.sigma_t()[k] as f64, h.emission[k] as f64);
            let quad: f64 = (0..n)
                .map(|i| {
                    let t = len * (i as f64 + 0.5) / n as f64;
                    sa * le * (-st * t).exp() * len / n as f64
                })
                .sum();
            let got = c.emitted(len as f32)[k] as f64;
            assert!((got - quad).abs() <= 1e-4 * quad.max(1e-12), "channel {k}: {got} vs {quad}");
            let infinite = c.emitted(f32::INFINITY)[k] as f64;
            let want = if st > 0.0 { sa * le / st } else { 0.0 };
            assert!((infinite - want).abs() <= 1e-6 * want.max(1e-12), "channel {k}: {infinite}");
        }
    }

    /// Free-flight distances with chromatic extinction follow the channel-averaged density
    /// p(t) = (1/3) Σ σ_c e^{−σ_c t}, and reaching t_max has the averaged probability (the
    /// failure bin); the weights are T(t)/p(t) and T(t_max)/P, and `ln_flight_pdf` gives those
    /// densities, forward and reverse (to 10⁻⁴ in the log: f32 rounding of a few factors).
    #[test]
    fn free_flight_follows_the_averaged_density() {
        let h = Homogeneous {
            sigma_a: Rgb::new(0.5, 0.5, 1.0),
            sigma_s: Rgb::new(0.5, 1.5, 3.0),
            phase: HenyeyGreenstein { g: 0.0 },
            emission: Rgb::ZERO,
        };
        let (sigma_t, t_max) = (h.sigma_t().as_dvec3(), 1.2f64);
        let c = h.constant().unwrap();
        let density = |t: f64| ((sigma_t * (-sigma_t * t).exp()).element_sum()) / 3.0;
        let mut test = ChiSquare::new("homogeneous free flight", Domain::Square, 1);
        test.bins = [48, 1];
        test.run(
            |s| {
                let f = c.free_flight(t_max as f32, s.next_f32(), s.next_f32());
                let t = f.t as f64;
                let tr = (-sigma_t * t).exp();
                let want =
                    if f.scattered { tr / density(t) } else { tr / (tr.element_sum() / 3.0) };
                assert!(
                    (f.weight.as_dvec3() - want).abs().max_element() < 1e-4 * want.max_element()
                );
                // Its densities: forward, the density the histogram tests (the probability of
                // the failure bin when it passes); reverse, a flight from the end back to the
                // start colliding there, the same density at the flight's length.
                let (o, d) = (Vec3::ZERO, Vec3::X);
                let end = f.scattered.then_some(f.t);
                let forward = ln_flight_pdf(&h, o, d, t_max as f32, &[], end);
                let want = if f.scattered { density(t) } else { tr.element_sum() / 3.0 };
                assert!((forward - want.ln()).abs() < 1e-4, "{forward} vs {}", want.ln());
                let back = o + d * f.t;
                let reverse = ln_flight_pdf(&h, back, -d, 2.0 * f.t, &[], Some(f.t));
                assert!((reverse - density(t).ln()).abs() < 1e-4, "{reverse}");
                assert_eq!(ln_flight_pdf(&h, o, d, t_max as f32, &[0.1], end), f64::NEG_INFINITY);
                f.scattered.then(|| Sample::Point(DVec2::new(t / t_max, 0.5)))
            },
            |p| t_max * density(p.point().x * t_max),
        );
    }
}
