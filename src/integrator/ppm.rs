//! Probabilistic progressive photon mapping (Knaus & Zwicker 2011): iteration i is an ordinary
//! photon-mapping render with radii r_i from the schedule of [`crate::estimate::radius`]; the
//! image is the mean of the iterations. An iteration is three steps, each a function: the photon
//! pass traces fresh light paths, the photon maps are rebuilt into the buffers of the previous
//! iteration (memory stays constant), and the camera pass renders one jittered eye path per pixel.

use super::camera::{CameraPass, Maps, render_pass};
use crate::estimate::kernel::Kernel;
use crate::estimate::radius::radius;
use crate::estimate::surface::Gather;
use crate::math::Rgb;
use crate::photon::beam::{BeamMap, Thinning};
use crate::photon::map::PhotonGrid;
use crate::photon::trace::{PhotonPass, Photons, trace_photons};
use crate::photon::{Photon, VolumePhoton};
use crate::progress::StepTimes;
use crate::scene::Scene;
use crate::scene::light::LightSampler;
use crate::settings::{Integrator, RenderSettings, VolumeEstimate};
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::time::Instant;

/// A photon mapper's settings and buffers, kept between iterations.
pub(crate) struct PhotonMapper {
    /// Render seed.
    seed: u64,
    /// Light paths per iteration.
    paths: u64,
    max_bounces: u32,
    /// Light sampling for direct light, photons for the rest (the hybrid integrator).
    hybrid: bool,
    /// Next-event estimates per eye vertex in the hybrid.
    direct_samples: u32,
    kernel: Kernel,
    estimate: VolumeEstimate,
    beam_cell_budget: Option<u32>,
    /// Surface schedule: initial radius and α (dimension 2).
    r1: f64,
    alpha: f64,
    /// Volume schedule: initial radius, α and dimension.
    r1_vol: f64,
    volume_alpha: f64,
    volume_dimension: u32,
    lights: LightSampler,
    photons: Photons,
    surface_map: PhotonGrid<Photon>,
    volume_points: PhotonGrid<VolumePhoton>,
    volume_beams: BeamMap,
}

impl PhotonMapper {
    pub(crate) fn new(scene: &Scene, settings: &RenderSettings) -> Self {
        let diagonal = scene.diagonal() as f64;
        Self {
            seed: settings.seed,
            paths: settings.photons,
            max_bounces: settings.max_bounces,
            hybrid: settings.integrator == Integrator::Hybrid,
            direct_samples: settings.direct_samples,
            kernel: settings.kernel,
            estimate: settings.volume_estimate,
            beam_cell_budget: settings.beam_cell_budget,
            r1: settings.initial_radius(diagonal),
            alpha: settings.alpha,
            r1_vol: settings.initial_volume_radius(diagonal),
            volume_alpha: settings.volume_alpha,
            volume_dimension: settings.volume_dimension,
            lights: LightSampler::new(&scene.lights, scene.shapes.len()),
            photons: Photons::default(),
            surface_map: PhotonGrid::default(),
            volume_points: PhotonGrid::default(),
            volume_beams: BeamMap::new(),
        }
    }

    /// Light paths per iteration.
    pub(crate) fn paths(&self) -> u64 {
        self.paths
    }

    /// The initial surface radius.
    pub(crate) fn initial_radius(&self) -> f64 {
        self.r1
    }

    /// Surface and volume photons stored by the last photon pass.
    pub(crate) fn stored(&self) -> [u64; 2] {
        [self.photons.surface.len() as u64, self.photons.volume.len() as u64]
    }

    /// The surface and volume radii of iteration `i`.
    pub(crate) fn radii(&self, i: u64) -> (f64, f64) {
        (
            radius(i, self.r1, self.alpha, 2),
            radius(i, self.r1_vol, self.volume_alpha, self.volume_dimension),
        )
    }

    /// One iteration: photon pass, photon maps, camera pass.
    pub(crate) fn iterate(
        &mut self,
        scene: &Scene,
        i: u64,
        stop: &AtomicBool,
        nonfinite: &AtomicU64,
        image: &mut [Rgb],
    ) -> Option<StepTimes> {
        let (r, r_vol) = self.radii(i);
        let mut times = StepTimes::default();
        let clock = Instant::now();
        if !self.trace(scene, i, stop) {
            return None;
        }
        times.photon_trace = lap(clock);
        let clock = Instant::now();
        self.build_surface_map(r);
        times.surface_map = lap(clock);
        let clock = Instant::now();
        self.build_volume_map(scene, i, r_vol);
        times.volume_map = lap(clock);
        let clock = Instant::now();
        let pass = self.camera_pass(i, r, r_vol);
        if !render_pass(scene, &self.maps(), &pass, stop, nonfinite, image) {
            return None;
        }
        times.camera = lap(clock);
        times.volume_estimates = super::camera::take_volume_times();
        Some(times)
    }

    /// Step 1, the photon pass of iteration `i`. Returns `false` if `stop` was raised before it
    /// finished (the photons are then incomplete).
    pub(crate) fn trace(&mut self, scene: &Scene, i: u64, stop: &AtomicBool) -> bool {
        let pass = PhotonPass {
            seed: self.seed,
            iteration: i,
            paths: self.paths,
            max_bounces: self.max_bounces,
            skip_direct: self.hybrid,
        };
        trace_photons(scene, &self.lights, &pass, stop, &mut self.photons)
    }

    /// Step 2a, the surface photon map for queries of radius up to `r`.
    pub(crate) fn build_surface_map(&mut self, r: f64) {
        self.surface_map.build(&self.photons.surface, r as f32);
    }

    /// Step 2b, the volume photon map the volume estimate queries with radius `r_vol`.
    fn build_volume_map(&mut self, scene: &Scene, i: u64, r_vol: f64) {
        match self.estimate {
            VolumeEstimate::Beam => {
                let thinning = self.beam_cell_budget.map(|budget| Thinning {
                    budget,
                    seed: self.seed,
                    iteration: i,
                });
                self.volume_beams.build(
                    &self.photons.volume,
                    r_vol as f32,
                    thinning,
                    Some(&scene.camera),
                    |p| p.beta * scene.media[p.medium as usize].sigma_s(p.p),
                );
            }
            VolumeEstimate::Point => self.volume_points.build(&self.photons.volume, r_vol as f32),
        }
    }

    /// The photon maps as the camera pass reads them.
    pub(crate) fn maps(&self) -> Maps<'_> {
        Maps {
            surface: &self.surface_map,
            volume_points: &self.volume_points,
            volume_beams: &self.volume_beams,
            lights: &self.lights,
        }
    }

    /// Step 3's settings: the camera pass of iteration `i` with radii `r` and `r_vol`.
    pub(crate) fn camera_pass(&self, i: u64, r: f64, r_vol: f64) -> CameraPass {
        let gather = |radius: f64| Gather {
            radius: radius as f32,
            kernel: self.kernel,
            inv_paths: 1.0 / self.paths as f32,
        };
        CameraPass {
            seed: self.seed,
            iteration: i,
            max_bounces: self.max_bounces,
            surface: gather(r),
            volume: gather(r_vol),
            estimate: self.estimate,
            hybrid: self.hybrid,
            direct_samples: self.direct_samples,
        }
    }
}

/// Seconds since `clock`.
pub(crate) fn lap(clock: Instant) -> f64 {
    clock.elapsed().as_secs_f64()
}
