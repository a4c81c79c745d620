//! Integrators: the progressive photon mapping loop and its camera pass.

pub mod camera;
pub mod path;
pub mod ppm;
