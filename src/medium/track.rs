//! What tracking a ray through a medium gives back: the free flight sampled along a segment,
//! shared by every kind of medium.

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
    /// The densities of the decision taken and of its reverse, for a homogeneous medium; `None`
    /// for grids, whose densities are those of the null-scattering path (Miller, Georgiev &
    /// Jarosz 2019): a method that needs them records the null collisions
    /// (`tracker::free_flight_with`) and evaluates `tracker::ln_flight_pdf` forward and on the
    /// reversed ray, which costs a walk over the majorants that a render without such weights
    /// should not pay.
    #[allow(dead_code)] // for the combined estimator's weights; read by the tests now
    pub pdfs: Option<DistancePdfs>,
}

/// The densities of a sampled free flight, for the weights of a method that could have sampled
/// the same segment from either end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistancePdfs {
    /// Density per unit length of the collision sampled at t, or, if the flight reached the end
    /// of its segment, the probability of that.
    pub forward: f32,
    /// The reverse decision: a free flight from where this one ended back to its start that
    /// collides at the start (a density per unit length).
    pub reverse: f32,
}
