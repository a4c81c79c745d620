//! Density estimation: kernels, the radius schedule, and the radiance estimates.

pub mod kernel;
pub mod radius;
pub mod surface;
pub mod volume;
