//! The surface radiance estimate (Jensen 2001, eq. 7.6) with a normalised 2-D kernel:
//!
//!   L(x, ω) ≈ (1/M) Σ_p f_r(x, ω_p, ω) β_p K₂(‖x − x_p‖ / r) / r²
//!
//! over the photons p within r of x that landed on a surface facing the same way, with M the number
//! of light paths emitted in the iteration.

use super::kernel::Kernel;
use crate::math::Rgb;
use crate::photon::map::PhotonGrid;
use crate::photon::{BounceRange, Photon};
use glam::Vec3;

/// Photons whose surface normal deviates more than this cosine from the query's are ignored, so
/// that light does not leak between the two sides of a thin wall or around a corner.
pub const NORMAL_COS: f32 = 0.5;

/// Density-estimation parameters of one iteration.
#[derive(Clone, Copy, Debug)]
pub struct Gather {
    /// Query radius.
    pub radius: f32,
    /// Kernel.
    pub kernel: Kernel,
    /// 1 / (light paths emitted this iteration).
    pub inv_paths: f32,
}

/// Reflected radiance at `p` (normal `n`, on the viewer's side) of a diffuse surface with BRDF
/// value `f` (albedo / π), from the photons in `map`.
/// Only photons whose light paths had a number of events in `bounces` take part.
pub fn surface_radiance(
    map: &PhotonGrid<Photon>,
    p: Vec3,
    n: Vec3,
    f: Rgb,
    g: &Gather,
    bounces: BounceRange,
) -> Rgb {
    let inv_r2 = 1.0 / (g.radius * g.radius);
    let mut sum = Rgb::ZERO;
    map.query(p, g.radius, |ph, d2| {
        if ph.n.dot(n) > NORMAL_COS && bounces.contains(ph.bounces) {
            sum += ph.beta * g.kernel.eval(d2 * inv_r2, 2);
        }
    });
    f * sum * (inv_r2 * g.inv_paths)
}
