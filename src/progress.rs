//! Progress reporting. The library never prints: a render calls the caller's [`Progress`] after
//! every finished iteration, and the caller decides what to show (the CLI draws a progress bar).

use crate::film::Film;
pub use crate::integrator::frame::{ProcessorTimes, StepTimes, Stopwatch, processor_seconds};
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
    /// Seconds the last iteration spent in each step.
    pub times: StepTimes,
    /// The accumulated film.
    pub film: &'a Film,
    /// The render so far: iterations, light paths, current radii, elapsed time, …
    pub info: &'a RenderInfo,
    pub(crate) method: &'a crate::integrator::Method,
    pub(crate) scene: &'a crate::Scene,
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

    /// The image's estimated relative error so far, at the render's `target_confidence`
    /// ([`Film::error_estimate`]: the noise and, for photon mapping, the estimated kernel bias).
    pub fn error_estimate(&self) -> Option<crate::film::ErrorEstimate> {
        self.film
            .error_estimate(self.info.settings.target_confidence, self.info.settings.target_region)
    }

    /// The image so far, with its metadata (for snapshots).
    pub fn snapshot(&self) -> Image {
        Image::from_film(self.film, self.info.clone())
    }

    /// The render so far as a partial render, which a later render can resume exactly.
    pub fn partial(&self) -> crate::Partial {
        crate::Partial {
            info: self.info.clone(),
            film: self.film.clone(),
            fingerprint: self.scene.fingerprint(),
            state: self.method.save_state(),
            output: None,
            techniques: None,
        }
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
