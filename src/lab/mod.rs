//! The lab: tools that check and measure the renderer through its public API only — analytic
//! references for participating media ([`analytic`]), `haze validate` against them
//! ([`validate`]), and `haze converge`'s error-against-time measurements ([`converge`]) with their
//! charts ([`chart`]). Enabled by the `lab` feature (on by default).

pub mod analytic;
pub mod chart;
pub mod converge;
pub mod tiles;
pub mod validate;
