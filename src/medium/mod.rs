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
pub mod vdb;

use crate::math::Rgb;
use crate::rng::Sampler;
use glam::Vec3;
use homogeneous::Homogeneous;
use phase::HenyeyGreenstein;
use vdb::VdbMedium;

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
#[derive(Clone, Debug)]
pub enum Medium {
    /// Constant coefficients.
    Homogeneous(Homogeneous),
    /// Coefficients proportional to an OpenVDB density grid.
    Vdb(Box<VdbMedium>),
}

/// Transmittance along one ray segment, T(0, t), for many lookups (the beam estimate asks it for
/// every photon on the segment).
#[derive(Clone, Debug)]
pub enum SegmentTransmittance {
    /// One ratio-tracking estimate kept as a step function (heterogeneous media).
    Steps(vdb::TransmittanceSteps),
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
            // A zero coefficient transmits fully even over an infinite distance (not 0·∞ = NaN).
            SegmentTransmittance::Exponential { sigma_t } => {
                Rgb::select(sigma_t.cmpgt(Rgb::ZERO), (-*sigma_t * t).exp(), Rgb::ONE)
            }
            SegmentTransmittance::Grey { sigma_t } => {
                Rgb::splat(if *sigma_t > 0.0 { (-sigma_t * t).exp() } else { 1.0 })
            }
            SegmentTransmittance::Steps(steps) => Rgb::splat(vdb::steps_at(steps, t)),
        }
    }
}

impl Medium {
    /// Samples a collision along `o + t d`, 0 < t < `t_max` (`t_max` may be infinite).
    #[inline]
    pub fn sample_free_flight(&self, o: Vec3, d: Vec3, t_max: f32, s: &mut Sampler) -> FreeFlight {
        match self {
            Medium::Homogeneous(h) => h.sample_free_flight(t_max, s.next_f32(), s.next_f32()),
            Medium::Vdb(v) => v.sample_free_flight(o, d, t_max, s),
        }
    }

    /// Transmittance along `o + t d` for 0 < t < `t_max` (an unbiased estimate for grids).
    #[inline]
    pub fn transmittance(&self, o: Vec3, d: Vec3, t_max: f32, s: &mut Sampler) -> Rgb {
        match self {
            Medium::Homogeneous(h) => h.transmittance(t_max),
            Medium::Vdb(v) => v.transmittance(o, d, t_max, s),
        }
    }

    /// A transmittance function T(0, t) along `o + t d` for t < `t_max`: exact for homogeneous
    /// media, one ratio-tracking estimate for grids.
    #[inline]
    pub fn segment(&self, o: Vec3, d: Vec3, t_max: f32, s: &mut Sampler) -> SegmentTransmittance {
        match self {
            Medium::Homogeneous(h) => {
                let sigma_t = h.sigma_t();
                if sigma_t.x == sigma_t.y && sigma_t.y == sigma_t.z {
                    SegmentTransmittance::Grey { sigma_t: sigma_t.x }
                } else {
                    SegmentTransmittance::Exponential { sigma_t }
                }
            }
            Medium::Vdb(v) => SegmentTransmittance::Steps(v.transmittance_steps(o, d, t_max, s)),
        }
    }

    /// Scattering coefficient at `p`.
    #[inline]
    pub fn sigma_s(&self, p: Vec3) -> Rgb {
        match self {
            Medium::Homogeneous(h) => h.sigma_s,
            Medium::Vdb(v) => v.sigma_s(p),
        }
    }

    /// The phase function.
    #[inline]
    pub fn phase(&self) -> &HenyeyGreenstein {
        match self {
            Medium::Homogeneous(h) => &h.phase,
            Medium::Vdb(v) => v.phase(),
        }
    }
}
