//! Participating media: one closed set that the integrators use without knowing the kind. Every
//! medium answers the same questions: sample a free-flight distance, the transmittance along a
//! ray, σ_s at a point, and its phase function.
//!
//! ```toml
//! [media.fog]
//! type = "homogeneous"
//! sigma_a = [0.01, 0.01, 0.01]  # absorption, 1/length …
//! sigma_s = [0.5, 0.5, 0.5]     # … and scattering; or give `albedo` and `sigma_t` (extinction)
//! g = 0.3                       # Henyey–Greenstein mean cosine; 0 = isotropic (default)
//! ```

pub mod grid;
pub mod homogeneous;
pub mod phase;

use crate::math::Rgb;
use glam::Vec3;
use homogeneous::Homogeneous;
use phase::HenyeyGreenstein;

/// The outcome of free-flight sampling along a ray segment.
#[derive(Clone, Copy, Debug)]
pub struct FreeFlight {
    /// Distance to the collision, or the segment's end if none.
    pub t: f32,
    /// True if a real collision (scattering or absorption event) happened before the end.
    pub scattered: bool,
    /// Throughput factor: T(t)/p(t) at a collision, T(t_max)/P(no collision) otherwise.
    pub weight: Rgb,
}

/// A participating medium.
#[derive(Clone, Debug, PartialEq)]
pub enum Medium {
    /// Constant coefficients.
    Homogeneous(Homogeneous),
}

/// Transmittance along one ray segment, T(0, t), for many lookups (the beam estimate asks it for
/// every photon on the segment).
#[derive(Clone, Copy, Debug)]
pub enum SegmentTransmittance {
    /// exp(−σ_t t).
    Exponential {
        /// Extinction.
        sigma_t: Rgb,
    },
    /// exp(−σ_t t) with the same σ_t in every channel: one exponential instead of three.
    Grey {
        /// Extinction.
        sigma_t: f32,
    },
}

impl SegmentTransmittance {
    /// T(0, t).
    #[inline]
    pub fn at(&self, t: f32) -> Rgb {
        match self {
            SegmentTransmittance::Exponential { sigma_t } => (-*sigma_t * t).exp(),
            SegmentTransmittance::Grey { sigma_t } => Rgb::splat((-sigma_t * t).exp()),
        }
    }
}

impl Medium {
    /// Samples a collision along `o + t d`, 0 < t < `t_max` (`t_max` may be infinite), from
    /// three uniforms.
    #[inline]
    pub fn sample_free_flight(&self, _o: Vec3, _d: Vec3, t_max: f32, u: [f32; 2]) -> FreeFlight {
        match self {
            Medium::Homogeneous(h) => h.sample_free_flight(t_max, u[0], u[1]),
        }
    }

    /// Transmittance along `o + t d` for 0 < t < `t_max`.
    #[inline]
    pub fn transmittance(&self, _o: Vec3, _d: Vec3, t_max: f32) -> Rgb {
        match self {
            Medium::Homogeneous(h) => h.transmittance(t_max),
        }
    }

    /// A transmittance function T(0, t) along `o + t d` for t < `t_max`.
    #[inline]
    pub fn segment(&self, _o: Vec3, _d: Vec3, _t_max: f32) -> SegmentTransmittance {
        match self {
            Medium::Homogeneous(h) => {
                let sigma_t = h.sigma_t();
                if sigma_t.x == sigma_t.y && sigma_t.y == sigma_t.z {
                    SegmentTransmittance::Grey { sigma_t: sigma_t.x }
                } else {
                    SegmentTransmittance::Exponential { sigma_t }
                }
            }
        }
    }

    /// Scattering coefficient at `p`.
    #[inline]
    pub fn sigma_s(&self, _p: Vec3) -> Rgb {
        match self {
            Medium::Homogeneous(h) => h.sigma_s,
        }
    }

    /// The phase function.
    #[inline]
    pub fn phase(&self) -> &HenyeyGreenstein {
        match self {
            Medium::Homogeneous(h) => &h.phase,
        }
    }
}
