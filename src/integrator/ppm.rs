//! Probabilistic progressive photon mapping (Knaus & Zwicker 2011): iteration i is an ordinary
//! photon-mapping render with radii r_i from the schedule of [`crate::estimate::radius`]; the
//! image is the mean of the iterations. An iteration is three steps, each a function: the photon
//! pass traces fresh light paths, the photon maps are rebuilt into the buffers of the previous
//! iteration (memory stays constant), and the camera pass renders one jittered eye path per pixel.

use super::camera::{CameraPass, Maps, render_pass};
use super::frame::{StepTimes, Stopwatch};
use crate::estimate::surface::Gather;
use crate::photon::beam::{BeamMap, Thinning};
use crate::photon::guide::{EmissionGuide, LightUse, PilotPath, light_use};
use crate::photon::importance::Importance;
use crate::photon::map::PhotonGrid;
use crate::photon::marks::{GatherMarks, Tally};
use crate::photon::sort::CountingSort;
use crate::photon::trace::{PhotonPass, Photons, trace_photons};
use crate::photon::{Photon, VolumePhoton};
use crate::plan::Plan;
use crate::scene::Scene;
use crate::scene::light::LightSampler;
use crate::scene::light::media::EmitterPool;
use crate::settings::VolumeEstimate;
use std::sync::atomic::{AtomicBool, AtomicU64};

/// A photon mapper's plan and buffers, kept between iterations.
pub(crate) struct PhotonMapper {
    plan: Plan,
    lights: LightSampler,
    /// Whether the guiding pilot (docs/theory.md) ran, the guide it learnt (none if guiding could
    /// gain little), and what it found per light.
    pilot_done: bool,
    guide: Option<EmissionGuide>,
    /// With splitting: whether its pilots ran, and the importance they found (none if they found
    /// nothing to split by).
    split_done: bool,
    importance: Option<Importance>,
    usage: Vec<LightUse>,
    gain: f64,
    photons: Photons,
    surface_map: PhotonGrid<Photon>,
    volume_points: PhotonGrid<VolumePhoton>,
    volume_beams: BeamMap,
    /// The iteration's candidate points for next-event estimation towards emitting media.
    emitters: EmitterPool,
}

impl PhotonMapper {
    pub(crate) fn new(scene: &Scene, plan: &Plan) -> Self {
        Self {
            plan: plan.clone(),
            lights: LightSampler::new(&scene.lights, scene.shapes.len()),
            pilot_done: false,
            guide: None,
            split_done: false,
            importance: None,
            usage: Vec::new(),
            gain: 1.0,
            photons: Photons::default(),
            surface_map: PhotonGrid::default(),
            volume_points: PhotonGrid::default(),
            volume_beams: BeamMap::new(),
            emitters: EmitterPool::default(),
        }
    }

    /// Light paths per iteration.
    pub(crate) fn paths(&self) -> u64 {
        self.plan.paths
    }

    /// The plan it renders.
    pub(crate) fn plan(&self) -> &Plan {
        &self.plan
    }

    /// Surface and volume photons stored by the last photon pass.
    pub(crate) fn stored(&self) -> [u64; 2] {
        [self.photons.surface.len() as u64, self.photons.volume.len() as u64]
    }

    /// One iteration: photon pass, photon maps, camera pass.
    pub(crate) fn iterate(
        &mut self,
        scene: &Scene,
        i: u64,
        stop: &AtomicBool,
        nonfinite: &AtomicU64,
        frame: &mut super::frame::Frame,
    ) -> Option<StepTimes> {
        let mut times = StepTimes::default();
        let clock = Stopwatch::start();
        if !self.learn_guide(scene, stop) || !self.learn_importance(scene, stop) {
            return None;
        }
        (times.pilot, times.processor.pilot) = clock.lap();
        let clock = Stopwatch::start();
        if !self.trace(scene, i, stop) {
            return None;
        }
        (times.photon_trace, times.processor.photon_trace) = clock.lap();
        let clock = Stopwatch::start();
        let radii = self.plan.radii(i);
        self.build_surface_map(radii.surface);
        (times.surface_map, times.processor.surface_map) = clock.lap();
        let clock = Stopwatch::start();
        self.build_volume_map(scene, i, radii.volume);
        (times.volume_map, times.processor.volume_map) = clock.lap();
        let clock = Stopwatch::start();
        let pass = self.camera_pass(i);
        if !render_pass(scene, &self.maps(), &pass, stop, nonfinite, frame) {
            return None;
        }
        (times.camera, times.processor.camera) = clock.lap();
        times.volume_estimates = super::camera::take_volume_times();
        Some(times)
    }

    /// Step 1, the photon pass of iteration `i`, with the iteration's pool of emitter points
    /// if the hybrid estimates emitting media's light by next-event estimation. Returns `false`
    /// if `stop` was raised before it finished (the photons are then incomplete).
    pub(crate) fn trace(&mut self, scene: &Scene, i: u64, stop: &AtomicBool) -> bool {
        if self.plan.media_near.is_finite() {
            self.emitters = EmitterPool::new(scene, self.plan.seed, i);
        }
        let pass = self.photon_pass(i, self.plan.paths, false);
        trace_photons(
            scene,
            &self.lights,
            self.guide.as_ref(),
            self.importance.as_ref(),
            &pass,
            stop,
            &mut self.photons,
        )
    }

    fn photon_pass(&self, iteration: u64, paths: u64, record: bool) -> PhotonPass {
        PhotonPass {
            seed: self.plan.seed,
            iteration,
            first_path: 0,
            paths,
            max_bounces: self.plan.max_bounces,
            skip_direct: self.plan.hybrid,
            media_near: self.plan.media_near,
            record,
            mis: None,
        }
    }

    /// The pilots of splitting by importance (`splitting.rs`), once per render with splitting on.
    /// Returns `false` if `stop` was raised first.
    fn learn_importance(&mut self, scene: &Scene, stop: &AtomicBool) -> bool {
        if !self.plan.splitting || self.split_done {
            return true;
        }
        let Ok(importance) = super::splitting::learn(scene, &self.lights, &self.plan, stop) else {
            return false;
        };
        (self.importance, self.split_done) = (importance, true);
        true
    }

    /// The guiding pilot (docs/theory.md, "Photons where the camera looks"), once per render:
    /// unguided light paths of "iteration 0", maps at iteration 1's radii, and a camera pass that
    /// marks the photons it gathers; the guide follows the light paths they belong to. Rounds of
    /// pilot paths continue (up to [`PILOT_ROUNDS`]) while a light that wastes photons has too
    /// few visible paths to learn from; if the guide's estimated gain is small, photons are
    /// emitted unguided. Returns `false` if `stop` was raised first.
    fn learn_guide(&mut self, scene: &Scene, stop: &AtomicBool) -> bool {
        if !self.plan.guiding || self.pilot_done {
            return true;
        }
        let per_round = self.plan.paths.clamp(PILOT_PATHS.0, PILOT_PATHS.1);
        // Room for every round (pages are touched only as the rounds fill them), so that a second
        // round does not copy the first's paths on one thread.
        let mut paths: Vec<PilotPath> = Vec::with_capacity((PILOT_ROUNDS * per_round) as usize);
        // Paths and visible paths per light over the rounds so far, each round's counted once.
        let mut usage = vec![LightUse::default(); self.lights.len()];
        for round in 0..PILOT_ROUNDS {
            let pass = PhotonPass {
                first_path: round * per_round,
                ..self.photon_pass(0, per_round, true)
            };
            if !trace_photons(scene, &self.lights, None, None, &pass, stop, &mut self.photons) {
                return false;
            }
            let Some(marks) = self.gather_marks(scene, 0, stop) else { return false };
            let counted = paths.len();
            self.pilot_paths(&marks, pass.first_path, &mut paths);
            let more = light_use(self.lights.len(), &paths[counted..]);
            usage.iter_mut().zip(&more).for_each(|(u, m)| u.add(m));
            let wanting = |u: &LightUse| u.visible < PILOT_VISIBLE && 2 * u.visible < u.paths;
            if !usage.iter().any(wanting) {
                break;
            }
        }
        (self.guide, self.usage, self.gain) = EmissionGuide::from_pilot(&self.lights, &paths);
        self.pilot_done = true;
        true
    }

    /// Appends to `out` the pilot paths of the photons in hand (the first numbered `first`), each
    /// with the sum of its photons' tallies in `marks`.
    fn pilot_paths(&self, marks: &GatherMarks, first: u64, out: &mut Vec<PilotPath>) {
        use rayon::prelude::*;
        let photons = &self.photons;
        let volume_origin = |slot| match self.plan.estimate {
            VolumeEstimate::Beam => self.volume_beams.origin(slot),
            VolumeEstimate::Point => self.volume_points.origin(slot),
        };
        // The gathered slots' paths and tallies, found in parallel and kept in slot order
        // (surface slots, then volume slots), then added up in that order: the sums of the
        // serial loop over every slot, bit for bit.
        let gathered = |tally: &Tally, path: &(dyn Fn(usize) -> u32 + Sync)| {
            (0..tally.len())
                .into_par_iter()
                .with_min_len(1 << 12)
                .filter_map(|slot| {
                    let v = tally.get(slot);
                    (v > 0.0).then(|| (path(slot), v))
                })
                .collect::<Vec<(u32, f32)>>()
        };
        let mut slots =
            gathered(&marks.surface, &|slot| photons.surface_path[self.surface_map.origin(slot)]);
        slots.par_extend(gathered(&marks.volume, &|slot| photons.volume_path[volume_origin(slot)]));
        // Each path's slots, in slot order (a stable counting sort by path), read once each.
        let keys: Vec<u32> = slots.par_iter().map(|&(path, _)| path - first as u32).collect();
        let (mut start, mut order) = (Vec::new(), Vec::new());
        let n = photons.paths.len();
        CountingSort::default().sort(&keys, n, &mut start, &mut order);
        let value = |j: usize| {
            let mine = &order[start[j] as usize..start[j + 1] as usize];
            mine.iter().fold(0.0f32, |sum, &k| sum + slots[k as usize].1)
        };
        let paths = photons.paths.par_iter().enumerate();
        out.par_extend(paths.map(|(j, &(light, u))| PilotPath { light, u, value: value(j) }));
    }

    /// Builds the maps of the photons in hand at iteration 1's radii (`iteration` keys their
    /// thinning), runs a camera pass of eye paths of `iteration` over them, and returns the marks
    /// of the photons it gathered; `None` if `stop` was raised first.
    fn gather_marks(
        &mut self,
        scene: &Scene,
        iteration: u64,
        stop: &AtomicBool,
    ) -> Option<GatherMarks> {
        let radii = self.plan.radii(iteration.max(1));
        self.set_tracking(true);
        self.build_surface_map(radii.surface);
        self.build_volume_map(scene, iteration, radii.volume);
        self.set_tracking(false);
        let volume = match self.plan.estimate {
            VolumeEstimate::Beam => self.volume_beams.len(),
            VolumeEstimate::Point => self.volume_points.len(),
        };
        let marks =
            GatherMarks { surface: Tally::new(self.surface_map.len()), volume: Tally::new(volume) };
        let pass = self.camera_pass(iteration);
        let maps = Maps { marks: Some(&marks), ..self.maps() };
        let [w, h] = scene.camera.resolution;
        let mut frame = super::frame::Frame::new(w as usize * h as usize);
        let nonfinite = AtomicU64::new(0);
        render_pass(scene, &maps, &pass, stop, &nonfinite, &mut frame).then_some(marks)
    }

    fn set_tracking(&mut self, on: bool) {
        self.surface_map.set_tracking(on);
        self.volume_points.set_tracking(on);
        self.volume_beams.set_tracking(on);
    }

    /// Iteration `i` instrumented: its photons (guided as in a render, the pilot run first if
    /// needed) and the numbers of surface and volume photons stored and gathered by its camera
    /// pass; `None` if `stop` was raised first.
    pub(crate) fn photon_usage(
        &mut self,
        scene: &Scene,
        i: u64,
        stop: &AtomicBool,
    ) -> Option<PhotonUsage> {
        if !self.learn_guide(scene, stop) || !self.trace(scene, i, stop) {
            return None;
        }
        let marks = self.gather_marks(scene, i, stop)?;
        let per_light = &self.usage;
        Some(PhotonUsage {
            guided: self.guide.is_some(),
            gain: self.gain,
            stored: [self.photons.surface.len() as u64, self.photons.volume.len() as u64],
            gathered: [marks.surface.count() as u64, marks.volume.count() as u64],
            kept: [marks.surface.len() as u64, marks.volume.len() as u64],
            pilot: per_light.iter().map(|u| (u.paths, u.visible, u.cells)).collect(),
        })
    }

    /// Step 2a, the surface photon map for queries of radius up to `r`.
    pub(crate) fn build_surface_map(&mut self, r: f64) {
        self.surface_map.build(&self.photons.surface, r as f32);
    }

    /// Step 2b, the volume photon map the volume estimate queries with radius `r_vol`.
    fn build_volume_map(&mut self, scene: &Scene, i: u64, r_vol: f64) {
        match self.plan.estimate {
            VolumeEstimate::Beam => build_beam_map(
                &mut self.volume_beams,
                &self.photons.volume,
                scene,
                &self.plan,
                i,
                r_vol as f32,
            ),
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
            marks: None,
            emitters: &self.emitters,
        }
    }

    /// Step 3's settings: the camera pass of iteration `i` over the maps in hand (each gather
    /// reads its radius from the map it queries: the radius the map was built with).
    pub(crate) fn camera_pass(&self, i: u64) -> CameraPass {
        let plan = &self.plan;
        let gather = Gather { kernel: plan.kernel, inv_paths: 1.0 / plan.paths as f32 };
        CameraPass {
            seed: plan.seed,
            iteration: i,
            max_bounces: plan.max_bounces,
            gather,
            estimate: plan.estimate,
            hybrid: plan.hybrid,
            direct_samples: plan.direct_samples,
            media_near: plan.media_near,
        }
    }
}

/// Builds `beams` over the volume photons of iteration `i` for queries of radius `r`: each photon
/// stored with β·σ_s(x_p) as its power, thinned where the plan says, with view bins for the
/// camera.
pub(crate) fn build_beam_map(
    beams: &mut BeamMap,
    photons: &[VolumePhoton],
    scene: &Scene,
    plan: &Plan,
    i: u64,
    r: f32,
) {
    let thinning =
        plan.beam_cell_budget.map(|budget| Thinning { budget, seed: plan.seed, iteration: i });
    beams.build(photons, r, thinning, Some(&scene.camera), |p| {
        p.beta * scene.media[p.medium as usize].sigma_s(p.p)
    });
}

/// Light paths per round of the guiding pilot: the paths of an iteration, within these bounds …
const PILOT_PATHS: (u64, u64) = (1 << 12, 1 << 21);

/// … in rounds, until every light that wastes photons has this many visible paths …
const PILOT_VISIBLE: u64 = 512;

/// … or this many rounds have run.
const PILOT_ROUNDS: u64 = 2;

/// What the photons of one iteration were used for ([`photon_usage`](crate::photon_usage)).
#[derive(Clone, Debug, Default)]
pub struct PhotonUsage {
    /// Surface and volume photons stored by the photon pass …
    pub stored: [u64; 2],
    /// … those the thinning of dense cells kept in the maps (all, without thinning) …
    pub kept: [u64; 2],
    /// … and those the camera pass gathered at least once.
    pub gathered: [u64; 2],
    /// True if the photons were emitted by a guide (guiding on, and the pilot found enough to
    /// gain).
    pub guided: bool,
    /// The pilot's estimate of the factor by which guiding lowers the second moment of a light
    /// path's contribution (1 without a pilot).
    pub gain: f64,
    /// With guiding, per light: the pilot's light paths, those visible, and the cells of its
    /// guiding table.
    pub pilot: Vec<(u64, u64, usize)>,
}
