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

/// The beam radiance estimate along o + tω, 0 < t < `t_max`, in medium `id`, with the segment's
/// transmittance `tr`. The photons in `map` carry β·σ_s(x_p) (see `BeamMap::build`). With a
/// tally and the factor the estimate is multiplied by afterwards, each photon's contribution is
/// added to the tally.
#[allow(clippy::too_many_arguments)]
pub(crate) fn beam_radiance(
    map: &BeamMap,
    medium: &Medium,
    id: u32,
    segment: &EyeSegment,
    tr: &SegmentTransmittance,
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
    map.query_slots(o, w, t_max, |ph, slot, t, d2| {
        if ph.medium as u32 == id && bounces.contains(ph.bounces) {
            let (k, k_inner) = g.kernel.eval_pair(d2 * inv_r2, 2);
            // The beam map stores β·σ_s(x_p) as the photon's power.
            let weight = ph.beta * tr.at(t) * phase.eval(ph.d, -w);
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
