//! Progress reporting. The library never prints: a render calls the caller's [`Progress`] after
//! every finished iteration, and the caller decides what to show (the CLI draws a progress bar).

use crate::film::Film;

/// What is known after an iteration.
pub struct Status<'a> {
    /// Iterations finished.
    pub iteration: u64,
    /// Iterations requested, if bounded.
    pub target_iterations: Option<u64>,
    /// Time limit in seconds, if any.
    pub time_limit: Option<f64>,
    /// Seconds since the render started.
    pub elapsed: f64,
    /// Surface radius used by the last iteration.
    pub radius: f64,
    /// Light paths traced so far.
    pub light_paths: u64,
    /// Photons stored by the last iteration.
    pub photons_stored: u64,
    /// Seconds the last iteration spent in the photon pass (tracing and building the map).
    pub photon_seconds: f64,
    /// Seconds the last iteration spent in the camera pass.
    pub camera_seconds: f64,
    /// The accumulated film (for snapshots).
    pub film: &'a Film,
}

/// Receives render progress.
pub trait Progress {
    /// Called after each finished iteration.
    fn iteration(&mut self, status: &Status<'_>);
}

/// Ignores progress.
pub struct Silent;

impl Progress for Silent {
    fn iteration(&mut self, _: &Status<'_>) {}
}

impl<F: FnMut(&Status<'_>)> Progress for F {
    fn iteration(&mut self, status: &Status<'_>) {
        self(status)
    }
}
