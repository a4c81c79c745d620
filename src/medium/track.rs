//! What tracking a ray through a medium gives back: the free flight sampled along a segment,
//! shared by every kind of medium. Its densities, forward and reverse, are
//! `tracker::ln_flight_pdf`'s, evaluated where a method asks for them.

use crate::math::Rgb;

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
