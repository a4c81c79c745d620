//! The photon pass and the photon maps.

pub mod beam;
mod entries;
pub mod guide;
pub(crate) mod importance;
pub mod map;
pub(crate) mod marks;
pub(crate) mod sort;
pub mod trace;
mod view;

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
    /// Geometric normal of the surface it landed on, on the side it arrived from.
    pub n: Vec3,
    /// Power (W per emitted path, see above).
    pub beta: Rgb,
    /// Scattering events of the light path before it arrived here (0: straight from the light,
    /// through pass-through interfaces only).
    pub bounces: u16,
}

/// A photon stored in a medium, at a real collision of a light path.
///
/// Power convention (docs/theory.md): `beta` is the light path's throughput **after** division by the
/// free-flight pdf of this collision — β · T(t)/p(t) — and **before** the scattering albedo:
/// estimates multiply by σ_s(x) and the phase function when merging. Like surface photons, it is
/// in watts per emitted light path (divide sums by the number of emitted paths).
#[derive(Clone, Copy, Debug, Default)]
pub struct VolumePhoton {
    /// Position.
    pub p: Vec3,
    /// Direction of travel of the photon when it collided (unit).
    pub d: Vec3,
    /// Power (see above).
    pub beta: Rgb,
    /// The medium it is in.
    pub medium: u16,
    /// Scattering events of the light path before this collision (0: straight from the light).
    pub bounces: u16,
}

/// Which photons an estimate gathers: those whose light paths had `min..=max` scattering events
/// before arriving (see [`Photon::bounces`]). The bounce limit of the whole path and the split of
/// light between next-event estimation and photons both come down to such a range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct BounceRange {
    /// Fewest events before arrival.
    pub min: u16,
    /// Most events before arrival.
    pub max: u16,
}

impl BounceRange {
    /// True if a photon of `bounces` events is gathered.
    #[inline]
    pub(crate) fn contains(&self, bounces: u16) -> bool {
        bounces >= self.min && bounces <= self.max
    }
}

/// Anything with a position, so the grid can hold surface and volume photons.
pub trait Located {
    /// Position.
    fn position(&self) -> Vec3;
}

impl Located for Photon {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}

impl Located for VolumePhoton {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}
