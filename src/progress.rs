//! Progress reporting. The library never prints: a render calls the caller's [`Progress`] after
//! every finished iteration, and the caller decides what to show (the CLI draws a progress bar).

use crate::film::Film;
use crate::output::{Image, RenderInfo};

/// What is known after an iteration.
pub struct Status<'a> {
    /// Iterations requested, if bounded.
    pub target_iterations: Option<u64>,
    /// Time limit in seconds, if any.
    pub time_limit: Option<f64>,
    /// Surface photons stored by the last iteration.
    pub photons_stored: u64,
    /// Volume photons stored by the last iteration.
    pub volume_photons_stored: u64,
    /// Seconds the last iteration spent in the photon pass (tracing and building the maps).
    pub photon_seconds: f64,
    /// Of `photon_seconds`, the seconds spent building the photon maps from the stored photons.
    pub map_seconds: f64,
    /// Of `map_seconds`, the seconds spent building the volume photon map (beam map or point grid).
    pub volume_map_seconds: f64,
    /// With `RenderSettings::time_volume_estimate`, the seconds the last camera pass spent in
    /// volume estimates, summed over threads and divided by the thread count (the share of the
    /// camera pass's wall time, since every thread works through the pass).
    pub volume_estimate_seconds: Option<f64>,
    /// Seconds the last iteration spent in the camera pass.
    pub camera_seconds: f64,
    /// The accumulated film.
    pub film: &'a Film,
    /// The render so far: iterations, light paths, current radii, elapsed time, …
    pub info: &'a RenderInfo,
}

impl Status<'_> {
    /// Iterations finished.
    pub fn iteration(&self) -> u64 {
        self.info.iterations
    }

    /// Seconds since the render started.
    pub fn elapsed(&self) -> f64 {
        self.info.elapsed
    }

    /// The image so far, with its metadata (for snapshots).
    pub fn snapshot(&self) -> Image {
        Image::from_film(self.film, self.info.clone())
    }
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
