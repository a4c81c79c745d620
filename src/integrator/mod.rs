//! Integrators: what one iteration of a render does. [`Method`] is the closed set the render loop
//! ([`crate::render`]) drives:
//!
//! - probabilistic progressive photon mapping (`ppm.rs`): photon pass → photon maps → camera pass
//!   (`camera.rs`), the film takes the mean of the iterations;
//! - the original PPM's per-pixel statistics (`original.rs`), a comparison mode on the same photon
//!   pass and maps, whose film holds the running estimate instead of a mean;
//! - the unbiased reference path tracer (`path.rs`): one path per pixel;
//! - the combined estimator (`combined.rs`): eye paths, next-event estimation and photon
//!   merging weighed by multiple importance sampling, on the probabilistic schedule.

pub(crate) mod camera;
pub(crate) mod combined;
pub(crate) mod direct;
pub(crate) mod frame;
pub(crate) mod original;
pub(crate) mod path;
pub(crate) mod ppm;
pub(crate) mod single;
pub(crate) mod splitting;
pub(crate) mod walk;

use crate::film::Film;
use crate::plan::{MethodKind, Plan, Radii};
use crate::scene::Scene;
use combined::Combined;
use frame::{Frame, StepTimes};
use original::OriginalPpm;
use path::PathTracer;
use ppm::PhotonMapper;
use std::sync::atomic::{AtomicBool, AtomicU64};

/// One rendering method and its state between iterations.
pub(crate) enum Method {
    /// Probabilistic progressive photon mapping, alone or with light sampling (the hybrid).
    PhotonMapping(PhotonMapper),
    /// The original PPM (comparison mode).
    Original(OriginalPpm),
    /// The reference path tracer.
    Path(PathTracer),
    /// Eye paths, next-event estimation and photon merging combined by MIS.
    Combined(Combined),
}

impl Method {
    /// The method `plan` names, ready to render `scene`.
    pub(crate) fn new(scene: &Scene, plan: &Plan) -> Self {
        match plan.method {
            MethodKind::Path => Method::Path(PathTracer::new(scene, plan)),
            MethodKind::PhotonMapping => Method::PhotonMapping(PhotonMapper::new(scene, plan)),
            MethodKind::Original => Method::Original(OriginalPpm::new(scene, plan)),
            MethodKind::Combined => Method::Combined(Combined::new(scene, plan)),
        }
    }

    /// Renders iteration `i` (1-based) into `frame`. Returns the time each step took, or `None`
    /// if `stop` was raised before it finished (the image and the method's state are then
    /// unusable for this iteration, which is discarded).
    pub(crate) fn iterate(
        &mut self,
        scene: &Scene,
        i: u64,
        stop: &AtomicBool,
        nonfinite: &AtomicU64,
        frame: &mut Frame,
    ) -> Option<StepTimes> {
        match self {
            Method::PhotonMapping(m) => m.iterate(scene, i, stop, nonfinite, frame),
            Method::Original(m) => m.iterate(scene, i, stop, nonfinite, frame),
            Method::Path(m) => m.iterate(scene, i, stop, nonfinite, frame),
            Method::Combined(m) => m.iterate(scene, i, stop, nonfinite, frame),
        }
    }

    /// An empty film for this method's iterations: with the kernel-bias sums for photon
    /// mapping (the path tracer has no kernel).
    pub(crate) fn film(&self, width: u32, height: u32) -> Film {
        match self {
            Method::Path(_) => Film::new(width, height),
            _ => Film::with_bias(width, height),
        }
    }

    /// Iteration `i` instrumented (photon mapping only): what its photons were used for.
    pub(crate) fn photon_usage(
        &mut self,
        scene: &Scene,
        i: u64,
        stop: &AtomicBool,
    ) -> Option<ppm::PhotonUsage> {
        match self {
            Method::PhotonMapping(m) => m.photon_usage(scene, i, stop),
            Method::Original(_) | Method::Path(_) | Method::Combined(_) => None,
        }
    }

    /// The state the method carries from one iteration to the next, for partial renders (only
    /// the original PPM has one: its per-pixel statistics).
    pub(crate) fn save_state(&self) -> Option<Vec<u8>> {
        match self {
            Method::Original(m) => Some(m.save_state()),
            _ => None,
        }
    }

    /// Restores a state saved by [`Self::save_state`].
    pub(crate) fn load_state(&mut self, state: &[u8]) -> Result<(), String> {
        match self {
            Method::Original(m) => m.load_state(state),
            _ => Err("the partial render holds per-pixel statistics of the original PPM, but \
                 these settings use another method"
                .into()),
        }
    }

    /// Adds a finished iteration's frame to the film.
    pub(crate) fn accumulate(&self, film: &mut Film, frame: &Frame) {
        match self {
            // The original PPM's image is its running estimate, not a term of a mean.
            Method::Original(_) => film.replace(&frame.value, Some(&frame.bias)),
            _ => film.add_with_bias(&frame.value, &frame.bias),
        }
    }

    /// The surface and volume radii of iteration `i` (the original PPM reports its root-mean-square
    /// pixel radius).
    pub(crate) fn radii(&self, i: u64) -> Radii {
        match self {
            Method::PhotonMapping(m) => m.plan().radii(i),
            Method::Original(m) => m.radii(i),
            Method::Path(m) => m.radii(i),
            Method::Combined(m) => m.radii(i),
        }
    }

    /// Light paths traced per iteration (none for the path tracer).
    pub(crate) fn light_paths_per_iteration(&self) -> u64 {
        match self {
            Method::PhotonMapping(m) => m.paths(),
            Method::Original(m) => m.paths(),
            Method::Combined(m) => m.paths(),
            Method::Path(_) => 0,
        }
    }

    /// Each technique's weighted contribution to the image so far (the combined integrator
    /// with `techniques` on), named.
    pub(crate) fn technique_layers(&self) -> Option<Vec<(String, Vec<[f32; 3]>)>> {
        match self {
            Method::Combined(m) => m.technique_layers(),
            _ => None,
        }
    }

    /// Surface and volume photons stored by the last iteration.
    pub(crate) fn photons_stored(&self) -> [u64; 2] {
        match self {
            Method::PhotonMapping(m) => m.stored(),
            Method::Original(m) => m.stored(),
            Method::Combined(m) => m.stored(),
            Method::Path(_) => [0, 0],
        }
    }
}
