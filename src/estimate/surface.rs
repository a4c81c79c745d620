//! The surface radiance estimate (Jensen 2001, eq. 7.6) with a normalised 2-D kernel:
//!
//!   L(x, ω) ≈ (1/M) Σ_p f_r(x, ω_p, ω) β_p K₂(‖x − x_p‖ / r) / r²
//!
//! over the photons p within r of x that landed on a surface facing the same way, with M the number
//! of light paths emitted in the iteration.

use super::Estimate;
use super::kernel::Kernel;
use crate::math::Rgb;
use crate::math::luminance;
use crate::photon::map::PhotonGrid;
use crate::photon::marks::Tally;
use crate::photon::{BounceRange, Photon};
use glam::Vec3;

/// Photons whose surface normal deviates more than this cosine from the query's are ignored, so
/// that light does not leak between the two sides of a thin wall or around a corner.
pub const NORMAL_COS: f32 = 0.5;

/// Density-estimation parameters of one iteration. The radius is not one of them: a gather uses
/// the radius its photon map was built with.
#[derive(Clone, Copy, Debug)]
pub struct Gather {
    /// Kernel.
    pub kernel: Kernel,
    /// 1 / (light paths emitted this iteration).
    pub inv_paths: f32,
}

/// Reflected radiance at `p` (normal `n`, on the viewer's side) of a diffuse surface with BRDF
/// value `f` (albedo / π), from the photons in `map`.
/// Only photons whose light paths had a number of events in `bounces` take part. With a tally
/// and the factor `(tally, scale)` the pixel's estimate is multiplied by afterwards (the eye
/// path's throughput, in luminance), each photon's contribution is added to the tally.
#[allow(clippy::too_many_arguments)]
pub(crate) fn surface_radiance(
    map: &PhotonGrid<Photon>,
    p: Vec3,
    n: Vec3,
    f: Rgb,
    g: &Gather,
    bounces: BounceRange,
    tally: Option<(&Tally, f32)>,
) -> Estimate {
    let radius = map.radius();
    let inv_r2 = 1.0 / (radius * radius);
    let (mut sum, mut inner) = (Rgb::ZERO, Rgb::ZERO);
    let norm = inv_r2 * g.inv_paths;
    map.query_slots(p, radius, |ph, slot, d2| {
        if ph.n.dot(n) > NORMAL_COS && bounces.contains(ph.bounces) {
            let (k, k_inner) = g.kernel.eval_pair(d2 * inv_r2, 2);
            let term = ph.beta * k;
            sum += term;
            inner += ph.beta * k_inner;
            if let Some((t, scale)) = tally {
                t.add(slot, scale * norm * luminance(f * term));
            }
        }
    });
    Estimate::from_radii(f * sum * norm, f * inner * norm)
}
