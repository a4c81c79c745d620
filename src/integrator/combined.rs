//! The combined estimator: eye paths, next-event estimation and photon merging on surfaces, at
//! points and along beams in media, weighed against each other by multiple importance sampling
//! (the technique set of UPBP, Křivánek et al. 2014, without vertex connections and photon
//! beams; weights in `estimate/mis.rs`, derived in docs/theory.md).
//!
//! Each iteration is one render of the probabilistic schedule: a photon pass at the iteration's
//! radii, whose light paths record at every photon the light's side of the weights; then one
//! eye path per pixel that goes on through media and surfaces as the path tracer's does
//! (`path.rs`), and at every vertex
//!
//! - along a segment in a medium gathers the volume photons near it (the beam radiance estimate,
//!   point–beam) and, at the collision it samples, those within the volume radius (point–point);
//! - on a diffuse surface gathers the surface photons within the surface radius;
//! - connects to a light (next-event estimation), and counts the light it reaches,
//!
//! each contribution multiplied by its technique's weight. Emitting media's light is gathered by
//! the eye paths alone, in full (the photon pass emits from lights only).
//!
//! This file holds the passes, the pilots and the photon maps; `combined/eye.rs` the eye paths
//! and their weights; `combined/budget.rs` the light-path pilot.

pub(crate) mod budget;
mod eye;
use eye::Context;

use super::frame::{Frame, StepTimes, Stopwatch};
use super::walk::{EyePath, EyeVisitor, Next, environment_seen, roulette, walk_eye};
use crate::accel::Hit;
use crate::estimate::Estimate;
use crate::estimate::mis::weight;
use crate::estimate::mis::{
    Emitted, Kernels, LightMis, Site, collision_share, crossing_share, eye_carry, hit_weight,
    merge_total, nee_weight,
};
use crate::estimate::surface::{Gather, NORMAL_COS};
use crate::estimate::volume::BeamReach;
use crate::math::{Rgb, offset_origin};
use crate::medium::{Medium, SegmentTransmittance, TransmittanceDistance};
use crate::photon::beam::BeamMap;
use crate::photon::importance::Importance;
use crate::photon::map::PhotonGrid;
use crate::photon::trace::{PhotonPass, Photons, emitted, nee_density, trace_photons};
use crate::photon::{BounceRange, Photon, VolumePhoton};
use crate::plan::{Plan, Radii};
use crate::scene::Scene;
use crate::scene::light::{LightSampler, Receiver};
use crate::scene::material::{Material, Transport};
use crate::settings::{Merges, PointMerges, Technique, Techniques};
use crate::work::Work;
pub(crate) use budget::Budget;
use budget::{PixelDone, Tallies};
use glam::Vec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

/// The combined estimator's plan and buffers, kept between iterations.
pub(crate) struct Combined {
    plan: Plan,
    lights: LightSampler,
    photons: Photons,
    surface_map: PhotonGrid<Photon>,
    volume_points: PhotonGrid<VolumePhoton>,
    volume_beams: BeamMap,
    /// With `Plan::techniques`: each technique's contribution so far.
    layers: Layers,
    /// The light paths per iteration, once chosen (by the pilot, or the plan's).
    budget: Option<Budget>,
    /// With splitting, the importance its pilots found (learnt with the budget, before it).
    importance: Option<Importance>,
}

/// Each technique's contribution, summed over the iterations, per pixel ([`LAYERS`] layers in
/// turn), and the iterations summed.
#[derive(Default)]
struct Layers {
    sums: Vec<[f64; 3]>,
    iterations: u64,
}

/// The layers `--techniques` writes: each weighted technique of [`Technique::ALL`], and then
/// the light of emitting media that the eye paths gather along their segments (every pixel's
/// value less the weighted techniques, so that the layers sum to it).
const LAYERS: usize = Technique::ALL.len() + 1;

/// The name of layer `k`.
fn layer_name(k: usize) -> &'static str {
    Technique::ALL.get(k).map_or("emitted", |t| t.name())
}

/// One path's contribution by weighted technique, indexed by `Technique as usize`.
type Tally = [Rgb; Technique::ALL.len()];

impl Combined {
    pub(crate) fn new(scene: &Scene, plan: &Plan) -> Self {
        let mut c = Self {
            plan: plan.clone(),
            lights: LightSampler::new(&scene.lights, scene.shapes.len()),
            photons: Photons::default(),
            surface_map: PhotonGrid::default(),
            volume_points: PhotonGrid::default(),
            volume_beams: BeamMap::new(),
            layers: Layers::default(),
            budget: None,
            importance: None,
        };
        // Each gathered photon's weight record is found by its index in the photon pass.
        c.surface_map.set_tracking(true);
        c.volume_points.set_tracking(true);
        c.volume_beams.set_tracking(true);
        c
    }

    /// Light paths per iteration: the pilot's choice once it has run (`budget.rs`), the plan's
    /// before.
    pub(crate) fn paths(&self) -> u64 {
        self.budget.as_ref().map_or(self.plan.paths, |b| b.paths)
    }

    /// The schedule's radii at iteration `i`.
    pub(crate) fn radii(&self, i: u64) -> Radii {
        self.plan.radii(i)
    }

    /// Surface and volume photons stored by the last photon pass.
    pub(crate) fn stored(&self) -> [u64; 2] {
        [self.photons.surface.len() as u64, self.photons.volume.len() as u64]
    }

    /// One iteration: photon pass with weight records, the maps at the iteration's radii, and
    /// the eye paths. The first runs the light-path pilot (`budget.rs`) unless the plan fixes
    /// the count.
    pub(crate) fn iterate(
        &mut self,
        scene: &Scene,
        i: u64,
        stop: &AtomicBool,
        nonfinite: &AtomicU64,
        frame: &mut Frame,
    ) -> Option<StepTimes> {
        let mut times = StepTimes::default();
        if self.budget.is_none() {
            let clock = Stopwatch::start();
            self.budget(scene, stop)?;
            (times.pilot, times.processor.pilot) = clock.lap();
        }
        let (seed, paths) = (self.plan.seed, self.paths());
        let kernels = self.photons_at(scene, seed, i, paths, stop, &mut times)?;
        let clock = Stopwatch::start();
        let mut layers = std::mem::take(&mut self.layers);
        let ctx = self.context(scene, seed, i, paths, kernels);
        let done = camera_pass(
            self.plan.techniques.then_some(&mut layers),
            scene,
            &ctx,
            stop,
            nonfinite,
            frame,
        );
        self.layers = layers;
        if !done {
            return None;
        }
        (times.camera, times.processor.camera) = clock.lap();
        Some(times)
    }

    /// The light paths per iteration and how they were chosen (running the pilot if no
    /// iteration has). `None` if `stop` was raised first.
    pub(crate) fn budget(&mut self, scene: &Scene, stop: &AtomicBool) -> Option<&Budget> {
        if self.budget.is_none() {
            let auto = self.plan.splitting_auto && self.runs_long(scene, stop)?;
            if self.plan.splitting || auto {
                self.importance =
                    super::splitting::learn(scene, &self.lights, &self.plan, stop).ok()?;
            }
            let b = self.choose_budget(scene, stop)?;
            let point_merges = point_merges(&self.plan, b.ends_at_merge);
            self.budget = Some(Budget { split: auto, point_merges, ..b });
        }
        self.budget.as_ref()
    }

    /// Whether the light paths run long (`photon_splitting = "auto"`): one photon pass of the
    /// scene's count, unsplit, on the pilot's streams, stores at least [`SPLIT_STORED`] photons
    /// per path. `None` if `stop` was raised first.
    fn runs_long(&mut self, scene: &Scene, stop: &AtomicBool) -> Option<bool> {
        let (seed, n) = (self.plan.seed ^ budget::PILOT_SEED, self.plan.paths);
        let mut times = StepTimes::default();
        self.photons_at(scene, seed, budget::PILOT_ITERATION, n, stop, &mut times)?;
        let stored = (self.photons.surface.len() + self.photons.volume.len()) as f64;
        Some(n > 0 && stored >= SPLIT_STORED * n as f64)
    }

    /// The light paths per iteration: the plan's where it fixes them or where nothing merges,
    /// else the pilot's choice (`budget.rs`). `None` if `stop` was raised first.
    fn choose_budget(&mut self, scene: &Scene, stop: &AtomicBool) -> Option<Budget> {
        let n = self.plan.paths;
        if !self.plan.budget_pilot || !self.merges() {
            return Some(Budget::fixed(n));
        }
        let seed = self.plan.seed ^ budget::PILOT_SEED;
        // The eye's techniques alone, where they count: next-event estimation and the eye
        // reaching the light, with merges at the first vertex only (deeper ones are on the
        // photons' light side, which the pilot's census reads).
        let eye_alone = self.plan.merges == Merges::First
            && self.counts(Technique::Nee)
            && self.counts(Technique::Hit);
        // Eye paths that end at their first merge, where the settings leave that open and
        // nothing rules it out (emitting media, whose light the light paths leave to the eye).
        let last = self.plan.merges_open
            && self.plan.merges == Merges::First
            && !scene.has_emissive_media();
        let resolution = scene.camera.resolution;
        budget::choose(n, resolution, seed, eye_alone, last, |paths, iterations, pixels| {
            self.pilot_iterations(scene, seed, paths, iterations, pixels, stop)
        })
    }

    /// `iterations` pilot iterations (`budget.rs`; random streams of `seed`) with `paths`
    /// light paths over `pixels`: each pixel's value and merges' part, and the work counted.
    fn pilot_iterations(
        &mut self,
        scene: &Scene,
        seed: u64,
        paths: u64,
        iterations: u64,
        pixels: &[[u32; 2]],
        stop: &AtomicBool,
    ) -> Option<Tallies> {
        let mut tallies = Tallies::new(pixels.len());
        for i in budget::PILOT_ITERATION..budget::PILOT_ITERATION + iterations {
            let mut times = StepTimes::default();
            let kernels = self.photons_at(scene, seed, i, paths, stop, &mut times)?;
            let stored = (self.photons.surface.len() + self.photons.volume.len()) as u64;
            let records = self.photons.surface_mis.par_iter().chain(&self.photons.volume_mis);
            let merges_only = records.filter(|r| r.light == LightMis::default()).count() as u64;
            let spent = times.photon_trace + times.surface_map + times.volume_map;
            let clock = Instant::now();
            let ctx = self.context(scene, seed, i, paths, kernels);
            let values = pilot_walks(&ctx, pixels);
            if stop.load(Ordering::Relaxed) {
                return None;
            }
            let camera = clock.elapsed().as_secs_f64();
            tallies.add((self.photons.work, stored, merges_only, spent), &values, camera);
        }
        Some(tallies)
    }

    /// Whether point–point merges are weighed: the budget's choice once made, the plan's
    /// before (during the pilot).
    fn point_merges(&self) -> bool {
        self.budget.as_ref().map_or_else(|| point_merges(&self.plan, false), |b| b.point_merges)
    }

    /// Whether technique `t` counts (`Plan::only`).
    fn counts(&self, t: Technique) -> bool {
        counts(self.plan.only, t)
    }

    /// Whether any merge counts: else no photon is traced.
    fn merges(&self) -> bool {
        [Technique::Surface, Technique::Point, Technique::Beam].into_iter().any(|t| self.counts(t))
    }

    /// The photon pass of `paths` light paths with weight records (random streams of `seed`)
    /// and the maps at iteration `i`'s radii, each step's time into `times`; the kernels the
    /// weights of the iteration take. `None` if `stop` was raised first.
    fn photons_at(
        &mut self,
        scene: &Scene,
        seed: u64,
        i: u64,
        paths: u64,
        stop: &AtomicBool,
        times: &mut StepTimes,
    ) -> Option<Kernels> {
        let radii = self.plan.radii(i);
        // Merging at the first vertex only is the default: there a merge is a photon-mapping
        // estimate without a final gather; deeper merges come after the eye path's own sampling,
        // which the densities in the weights do not see as noise, and each costs a query
        // (`Merges`; docs/performance.md, "Where the eye merges", measures both).
        let deep = self.plan.merges == Merges::Everywhere;
        let mut kernels = Kernels::new(paths, radii.surface, radii.volume, deep);
        // Without point merges their density is 0 in every weight: the other techniques' MIS.
        if !self.point_merges() {
            kernels.point = 0.0;
        }
        let clock = Stopwatch::start();
        let pass = PhotonPass {
            seed,
            iteration: i,
            first_path: 0,
            paths,
            max_bounces: self.plan.max_bounces,
            skip_direct: false,
            media_near: f32::INFINITY,
            record: false,
            mis: Some(kernels),
        };
        // With `only` the eye's techniques, no photon is gathered: none is traced.
        if self.merges()
            && !trace_photons(
                scene,
                &self.lights,
                None,
                self.importance.as_ref(),
                &pass,
                stop,
                &mut self.photons,
            )
        {
            return None;
        }
        (times.photon_trace, times.processor.photon_trace) = clock.lap();
        let clock = Stopwatch::start();
        self.surface_map.build(&self.photons.surface, radii.surface as f32);
        (times.surface_map, times.processor.surface_map) = clock.lap();
        let clock = Stopwatch::start();
        self.build_volume_maps(scene, i, radii.volume as f32);
        (times.volume_map, times.processor.volume_map) = clock.lap();
        Some(kernels)
    }

    /// What the eye paths of iteration `i` (random streams of `seed`) read, over the photons of
    /// [`Self::photons_at`] with `paths` light paths and its `kernels`.
    fn context<'a>(
        &'a self,
        scene: &'a Scene,
        seed: u64,
        i: u64,
        paths: u64,
        kernels: Kernels,
    ) -> Context<'a> {
        let last = self.plan.merges == Merges::Last
            || self.budget.as_ref().is_some_and(|b| b.ends_at_merge);
        Context {
            scene,
            surface: &self.surface_map,
            points: &self.volume_points,
            beams: &self.volume_beams,
            photons: &self.photons,
            lights: &self.lights,
            kernels,
            // No light paths (the pilot's choice): nothing is gathered, and nothing divided by 0.
            gather: Gather {
                kernel: self.plan.kernel,
                inv_paths: if paths == 0 { 0.0 } else { 1.0 / paths as f32 },
            },
            seed,
            iteration: i,
            max_bounces: self.plan.max_bounces,
            beyond_last: self.lights.reachable() || scene.has_emissive_media(),
            only: self.plan.only,
            // With only merges, and merges at the first vertex only, nothing deeper counts
            // (but the light of emitting media); with `merges = "last"` nothing deeper is
            // weighed either.
            ends_at_merge: last
                || !kernels.deep
                    && !scene.has_emissive_media()
                    && !self.counts(Technique::Hit)
                    && !self.counts(Technique::Nee),
            last,
            continues: self.budget.as_ref().map_or(1.0, |b| b.continues),
        }
    }

    /// Each technique's contribution to the image so far (the mean over the iterations), named
    /// as in [`layer_name`]: with `Plan::techniques` only.
    pub(crate) fn technique_layers(&self) -> Option<Vec<(String, Vec<[f32; 3]>)>> {
        if !self.plan.techniques || self.layers.iterations == 0 {
            return None;
        }
        let n = self.layers.sums.len() / LAYERS;
        let inv = 1.0 / self.layers.iterations as f64;
        let layer = |k: usize| {
            let sums = &self.layers.sums[k * n..(k + 1) * n];
            sums.iter().map(|s| s.map(|c| (c * inv) as f32)).collect()
        };
        Some((0..LAYERS).map(|k| (layer_name(k).to_string(), layer(k))).collect())
    }

    /// The volume photons for point queries and for beam queries, at radius `r`.
    fn build_volume_maps(&mut self, scene: &Scene, i: u64, r: f32) {
        let photons = &self.photons.volume;
        // Without point merges the point map stays empty.
        let points = if self.point_merges() { photons.as_slice() } else { &[] };
        self.volume_points.build(points, r);
        super::ppm::build_beam_map(&mut self.volume_beams, photons, scene, &self.plan, i, r);
    }
}

/// The eye paths of one iteration into `frame`, and with `layers` each technique's share into
/// them; `false` if `stop` was raised first.
fn camera_pass(
    layers: Option<&mut Layers>,
    scene: &Scene,
    ctx: &Context,
    stop: &AtomicBool,
    nonfinite: &AtomicU64,
    frame: &mut Frame,
) -> bool {
    let width = scene.camera.resolution[0] as usize;
    let Some(layers) = layers else {
        let pixel = |x, y| ctx.pixel(x, y).0;
        return super::frame::render_pixels(frame, width, stop, nonfinite, pixel);
    };
    let mut tallies = vec![Tally::default(); frame.value.len()];
    let pixel = |x, y| ctx.pixel(x, y);
    if !super::frame::render_pixels_with(frame, &mut tallies, width, stop, nonfinite, pixel) {
        return false;
    }
    let n = frame.value.len();
    layers.sums.resize(n * LAYERS, [0.0; 3]);
    for (i, (tally, value)) in tallies.iter().zip(&frame.value).enumerate() {
        let rest = *value - tally.iter().copied().sum::<Rgb>();
        for (k, v) in tally.iter().chain([&rest]).enumerate() {
            let sum = &mut layers.sums[k * n + i];
            for c in 0..3 {
                sum[c] += v[c] as f64;
            }
        }
    }
    layers.iterations += 1;
    true
}

/// Whether point–point merges are weighed under `plan` (`PointMerges`), the pilot having
/// ended the eye paths at their first merge or not: with `only`, where it names them; else as
/// the setting says, `auto` off where the eye paths end at their first merge.
fn point_merges(plan: &Plan, ends_at_merge: bool) -> bool {
    if plan.only.is_some() {
        return counts(plan.only, Technique::Point);
    }
    match plan.point_merges {
        PointMerges::On => true,
        PointMerges::Off => false,
        PointMerges::Auto => plan.merges != Merges::Last && !ends_at_merge,
    }
}

/// Light paths store at least this many photons each on average, at the scene's count, where
/// `photon_splitting = "auto"` splits them: dense-fog (albedo 0.999, optical thickness 120)
/// stores 213 per path, the other twelve bundled scenes 0.5–4.3 (docs/performance.md, "Past the
/// first merge, and ending there").
const SPLIT_STORED: f64 = 32.0;

/// Whether technique `t` counts where `only` (`RenderSettings::only`) names the ones that do.
fn counts(only: Option<Techniques>, t: Technique) -> bool {
    only.is_none_or(|o| o.contains(t))
}

/// One pilot iteration's eye paths over `pixels` (`budget.rs`).
fn pilot_walks(ctx: &Context, pixels: &[[u32; 2]]) -> Vec<PixelDone> {
    let walk = |[x, y]: [u32; 2]| {
        let before = Work::here();
        let eye = ctx.walk(x, y);
        let after = Work::here();
        let merged = budget::MERGES.iter().map(|&t| eye.tally[t as usize]).sum();
        let (l, at) = eye.deep.unwrap_or((eye.value, after));
        PixelDone {
            value: eye.value,
            merged,
            deep: eye.value - l,
            work: after - before,
            deep_work: after - at,
        }
    };
    // Runs of 8 pixels handed out one at a time to whichever thread is free (`par_bridge`, as
    // `frame::render_pixels_with` does), each into its own slots.
    let mut done: Vec<PixelDone> = pixels.iter().map(|_| PixelDone::default()).collect();
    done.chunks_mut(8).zip(pixels.chunks(8)).par_bridge().for_each(|(out, run)| {
        for (o, &p) in out.iter_mut().zip(run) {
            *o = walk(p);
        }
    });
    done
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tally's indices, the layers' names and `only`'s techniques are one order.
    #[test]
    fn the_techniques_are_listed_in_one_order() {
        let names: Vec<&str> = (0..LAYERS).map(layer_name).collect();
        assert_eq!(names, ["hit", "nee", "surface", "point", "beam", "emitted"]);
        for (k, &t) in Technique::ALL.iter().enumerate() {
            assert_eq!(t as usize, k, "{t}");
        }
        let set: Techniques = "surface+point".parse().unwrap();
        let counted: Vec<bool> = Technique::ALL.iter().map(|&t| set.contains(t)).collect();
        assert_eq!(counted, [false, false, true, true, false]);
        assert_eq!(set.to_string(), "surface+point");
        assert!("surface+surface".parse::<Techniques>().is_err());
        assert!("surface+points".parse::<Techniques>().unwrap_err().contains("\"point\""));
    }
}
