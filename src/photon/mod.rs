//! The photon pass and the photon maps.

pub mod map;
pub mod trace;

use crate::math::Rgb;
use glam::Vec3;

/// A photon stored on a diffuse surface.
///
/// Power convention: `beta` is the path throughput of the light path that reached the surface —
/// emitted power divided by the light-selection, emission and scattering pdfs, multiplied by the
/// BSDF weights of the bounces before it — in watts **per emitted light path**; estimates divide
/// the kernel-weighted sum by the number of light paths emitted in the iteration (not by the number
/// of photons stored).
#[derive(Clone, Copy, Debug, Default)]
pub struct Photon {
    /// Position.
    pub p: Vec3,
    /// Direction the photon came from (unit, pointing away from the surface).
    pub wi: Vec3,
    /// Geometric normal of the surface it landed on, on the side it arrived from.
    pub n: Vec3,
    /// Power (W per emitted path, see above).
    pub beta: Rgb,
}
