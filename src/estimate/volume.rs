//! In-scattered radiance in media from volume photons (power convention: [`VolumePhoton`]).
//!
//! Beam radiance estimate (Jarosz, Zwicker & Jensen 2008, eq. 21) along an eye segment [0, s] of
//! the ray o + tω, with a 2-D kernel around the ray:
//!
//!   L_b ≈ (1/M) Σ_{p: 0 < t_p < s, d_p < r} β_p T(0, t_p) σ_s(x_p) f_p(ω_p, −ω) K₂(d_p / r) / r²
//!
//! Point estimate (Jensen & Christensen 1998) at a point x with a 3-D kernel:
//!
//!   L_s(x, −ω) ≈ (1/M) σ_s(x) Σ_{p: ‖x − x_p‖ < r} f_p(ω_p, −ω) β_p K₃(‖x − x_p‖ / r) / r³
//!
//! Only photons of the segment's own medium take part, and only those whose light paths had a
//! number of scattering events in the given range. f_p takes directions of travel: the photon's
//! ω_p and −ω, the direction towards the eye.

use super::Estimate;
use super::surface::Gather;
use crate::math::Rgb;
use crate::math::luminance;
use crate::medium::{Medium, SegmentTransmittance};
use crate::photon::beam::BeamMap;
use crate::photon::map::PhotonGrid;
use crate::photon::marks::Tally;
use crate::photon::{BounceRange, VolumePhoton};
use crate::rng::Sampler;
use glam::Vec3;

/// A segment o + tω, 0 < t < `t_max`, of an eye path in a medium.
#[derive(Clone, Copy, Debug)]
pub struct EyeSegment {
    /// Origin.
    pub o: Vec3,
    /// Unit direction ω.
    pub w: Vec3,
    /// End of the segment.
    pub t_max: f32,
}

/// Optical depth of an eye segment past which a beam gather takes the photons by Russian
/// roulette ([`BeamReach`]) …
pub(crate) const BEAM_TAIL_DEPTH: f32 = 10.0;

/// … with this chance, their contributions divided by it.
pub(crate) const BEAM_TAIL_CHANCE: f32 = 1.0 / 32.0;

/// How far along its segment a beam gather takes photons: all of them up to `tail`, those past
/// it (up to `end`) weighed by `scale`. Past an optical depth of [`BEAM_TAIL_DEPTH`] in a
/// homogeneous medium (every channel's), the rest of the segment is gathered with chance
/// [`BEAM_TAIL_CHANCE`] and its photons then count 1 / chance: unbiased, and in a dense medium a
/// gather no longer finds the photons all along a segment that its transmittance has made
/// worthless (dense-fog, optical depth 120 across the room). A photon there has at most
/// e^{−10} = 4.5 · 10⁻⁵ of the transmittance at the segment's start, so the roulette adds at
/// most (32 − 1) × that squared, 6 · 10⁻⁸, to the second moment relative to the transmittance
/// (the photons' powers and weights are what they are). A grid's step function that its walk's roulette
/// ended at zero ends the gather there, exactly (no draw). Where the segment is shallower than
/// that, nothing is drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct BeamReach {
    pub end: f32,
    pub tail: f32,
    pub scale: f32,
}

impl BeamReach {
    /// The reach of a gather along 0 < t < `t_max` of transmittance `tr`, a number drawn from
    /// `s` where the tail is played for.
    pub(crate) fn new(tr: &SegmentTransmittance, t_max: f32, s: &mut Sampler) -> Self {
        let whole = Self { end: t_max, tail: f32::INFINITY, scale: 1.0 };
        let tail = tr.reach(BEAM_TAIL_DEPTH);
        if tail >= t_max {
            whole
        } else if matches!(tr, SegmentTransmittance::Steps(_)) {
            Self { end: tail, ..whole }
        } else if s.next_f32() < BEAM_TAIL_CHANCE {
            Self { tail, scale: 1.0 / BEAM_TAIL_CHANCE, ..whole }
        } else {
            Self { end: tail, ..whole }
        }
    }

    /// The weight of a photon at `t`.
    #[inline]
    pub(crate) fn at(&self, t: f32) -> f32 {
        if t >= self.tail { self.scale } else { 1.0 }
    }
}

/// The beam radiance estimate along o + tω, 0 < t < `t_max`, in medium `id`, with the segment's
/// transmittance `tr`, as far as `reach` takes it. The photons in `map` carry β·σ_s(x_p) (see
/// `BeamMap::build`). With a tally and the factor the estimate is multiplied by afterwards, each
/// photon's contribution is added to the tally.
#[allow(clippy::too_many_arguments)]
pub(crate) fn beam_radiance(
    map: &BeamMap,
    medium: &Medium,
    id: u32,
    segment: &EyeSegment,
    tr: &SegmentTransmittance,
    reach: BeamReach,
    g: &Gather,
    bounces: BounceRange,
    tally: Option<(&Tally, f32)>,
) -> Estimate {
    let phase = medium.phase();
    let radius = map.radius();
    let inv_r2 = 1.0 / (radius * radius);
    let (mut sum, mut inner) = (Rgb::ZERO, Rgb::ZERO);
    let EyeSegment { o, w, t_max } = *segment;
    let norm = inv_r2 * g.inv_paths;
    map.query_slots(o, w, t_max.min(reach.end), |ph, slot, t, d2| {
        if ph.medium as u32 == id && bounces.contains(ph.bounces) {
            let (k, k_inner) = g.kernel.eval_pair(d2 * inv_r2, 2);
            // The beam map stores β·σ_s(x_p) as the photon's power.
            let weight = ph.beta * tr.at(t) * (phase.eval(ph.d, -w) * reach.at(t));
            let term = weight * k;
            sum += term;
            inner += weight * k_inner;
            if let Some((tally, scale)) = tally {
                tally.add(slot, scale * norm * luminance(term));
            }
        }
    });
    Estimate::from_radii(sum * norm, inner * norm)
}

/// The point estimate of in-scattered radiance at `x` towards −`w`, in medium `id`. With a tally
/// and the factor the estimate is multiplied by afterwards, each photon's contribution is added
/// to the tally.
#[allow(clippy::too_many_arguments)]
pub(crate) fn point_radiance(
    grid: &PhotonGrid<VolumePhoton>,
    medium: &Medium,
    id: u32,
    x: Vec3,
    w: Vec3,
    g: &Gather,
    bounces: BounceRange,
    tally: Option<(&Tally, f32)>,
) -> Estimate {
    let phase = medium.phase();
    let radius = grid.radius();
    let inv_r2 = 1.0 / (radius * radius);
    let (mut sum, mut inner) = (Rgb::ZERO, Rgb::ZERO);
    let sigma_s = medium.sigma_s(x);
    let norm = inv_r2 / radius * g.inv_paths;
    grid.query_slots(x, radius, |ph, slot, d2| {
        if ph.medium as u32 == id && bounces.contains(ph.bounces) {
            let (k, k_inner) = g.kernel.eval_pair(d2 * inv_r2, 3);
            let weight = ph.beta * phase.eval(ph.d, -w);
            let term = weight * k;
            sum += term;
            inner += weight * k_inner;
            if let Some((tally, scale)) = tally {
                tally.add(slot, scale * norm * luminance(sigma_s * term));
            }
        }
    });
    Estimate::from_radii(sigma_s * sum * norm, sigma_s * inner * norm)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::tracker::TransmittanceSteps;
    use crate::rng::Purpose;

    /// A segment shallower than the tail's depth is gathered whole and draws nothing; a deeper
    /// one stops at 10 / min σ_t, or goes on with its tail weighed 32 ×, which keeps every
    /// photon's expected weight 1: over 200,000 draws the mean weight of a photon in the tail
    /// lies within 4.5 standard errors of 1 (a Bernoulli(1/32) × 32 has variance 31; a chance
    /// or scale that did not match would be off by far more). A step function that ends at zero
    /// ends the gather there exactly.
    #[test]
    fn the_beams_tail_keeps_every_photons_expected_weight() {
        let tr = SegmentTransmittance::Exponential { sigma_t: Rgb::new(60.0, 20.0, 40.0) };
        let tail = BEAM_TAIL_DEPTH / 20.0;
        assert_eq!(tr.reach(BEAM_TAIL_DEPTH), tail);
        let mut s = Sampler::new(1, Purpose::Other, 0, 0);
        let shallow = BeamReach::new(&tr, 0.9 * tail, &mut s);
        assert_eq!(shallow, BeamReach { end: 0.9 * tail, tail: f32::INFINITY, scale: 1.0 });
        let mut untouched = Sampler::new(1, Purpose::Other, 0, 0);
        assert_eq!(s.next_f64(), untouched.next_f64(), "a shallow segment draws nothing");
        let (n, t) = (200_000, 1.5 * tail);
        let mut sum = 0.0;
        for i in 0..n {
            let mut s = Sampler::new(2, Purpose::Other, 0, i);
            let reach = BeamReach::new(&tr, 4.0 * tail, &mut s);
            assert!(reach.at(0.5 * tail) == 1.0 && reach.end >= tail);
            if t < reach.end {
                sum += reach.at(t) as f64;
            }
        }
        let mean = sum / n as f64;
        let error = (31.0 / n as f64).sqrt();
        assert!((mean - 1.0).abs() < 4.5 * error, "mean weight {mean} ± {error}");
        let grey = SegmentTransmittance::Grey { sigma_t: 0.0 };
        assert_eq!(grey.reach(BEAM_TAIL_DEPTH), f32::INFINITY);
        let mut steps = TransmittanceSteps::new();
        steps.extend([(0.3, Rgb::splat(0.5)), (0.7, Rgb::ZERO)]);
        let stepped = SegmentTransmittance::Steps(steps);
        let reach = BeamReach::new(&stepped, 2.0, &mut s);
        assert_eq!(reach, BeamReach { end: 0.7, tail: f32::INFINITY, scale: 1.0 });
    }
}
