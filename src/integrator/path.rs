//! An unbiased volumetric path tracer with next-event estimation, on the same scenes, media and
//! lights as the photon mapper. It gives references for scenes without closed forms and is the
//! baseline photon mapping is measured against.
//!
//! Each iteration traces one path per pixel. At every diffuse surface vertex, and along every
//! segment in a medium (single scattering, `single.rs`), one light is chosen by its estimated
//! contribution there (`LightSampler::pick`) and connected by a shadow ray; the shadow ray passes through pass-through interfaces (switching media and multiplying
//! their transmittance: exact for homogeneous media, ratio tracking for grids) and is blocked by
//! anything else. An area light reached by the path after a diffuse or phase-function scattering
//! also counts, and the two ways of finding it are combined by multiple importance sampling (power
//! heuristic over the solid-angle densities of light sampling and of BSDF/phase sampling; Veach
//! 1997): light sampling alone makes collisions close to a large emitter — in a dense medium next
//! to a glowing wall — rare and huge (the geometry term's 1/d²). Emitters seen straight from the
//! camera or through a specular bounce count in full, and point, spot and directional lights only
//! through next-event estimation. The free-flight
//! weights follow the photon pass's convention (`Medium::sample_free_flight`), so path tracing
//! and photon mapping estimate the same integral. Paths that see light only through specular
//! chains from point-like lights (caustics) are not found by next-event estimation: that is the
//! known weakness photon mapping is for.

use super::direct::{emission_weight, environment_weight, next_event};
use super::frame::{StepTimes, Stopwatch};
use super::single::single_scattering;
use super::walk::{EyePath, EyeVisitor, Next, roulette, walk_eye};
use crate::accel::Hit;
use crate::estimate::volume::EyeSegment;
use crate::math::{Rgb, offset_origin};
use crate::medium::Medium;
use crate::plan::{Plan, Radii};
use crate::scene::Scene;
use crate::scene::light::{LightSampler, Receiver};
use crate::scene::material::{Material, Transport};
use std::sync::atomic::{AtomicBool, AtomicU64};

/// The path tracer: its plan and the light sampler, kept between iterations.
pub(crate) struct PathTracer {
    plan: Plan,
    lights: LightSampler,
}

impl PathTracer {
    pub(crate) fn new(scene: &Scene, plan: &Plan) -> Self {
        Self { plan: plan.clone(), lights: LightSampler::new(&scene.lights, scene.shapes.len()) }
    }

    /// The schedule's radii at iteration `i` (reported; the path tracer does not use them).
    pub(crate) fn radii(&self, i: u64) -> Radii {
        self.plan.radii(i)
    }

    /// One iteration: one path per pixel.
    pub(crate) fn iterate(
        &mut self,
        scene: &Scene,
        i: u64,
        stop: &AtomicBool,
        nonfinite: &AtomicU64,
        frame: &mut super::frame::Frame,
    ) -> Option<StepTimes> {
        let clock = Stopwatch::start();
        let pass =
            PathPass { seed: self.plan.seed, iteration: i, max_bounces: self.plan.max_bounces };
        if !render_pass(scene, &self.lights, &pass, stop, nonfinite, frame) {
            return None;
        }
        let mut times = StepTimes::default();
        (times.camera, times.processor.camera) = clock.lap();
        Some(times)
    }
}

/// Settings of one path-tracing pass.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PathPass {
    /// Render seed.
    pub seed: u64,
    /// Iteration number (1-based).
    pub iteration: u64,
    /// Maximum scattering events per path, surface and medium (pass-through interfaces are not
    /// events): light paths of up to `max_bounces` scattering events are counted.
    pub max_bounces: u32,
}

/// Radiance along one path for pixel (x, y).
fn pixel_radiance(scene: &Scene, lights: &LightSampler, pass: &PathPass, x: u32, y: u32) -> Rgb {
    let mut visitor = PathEye { lights, count_emission: true, scattered_from: None };
    walk_eye(scene, pass.seed, pass.iteration, [x, y], pass.max_bounces, &mut visitor)
}

/// The path tracer's eye path: next-event estimation at every scattering vertex, emitters
/// weighed against it by MIS, Russian roulette.
struct PathEye<'a> {
    lights: &'a LightSampler,
    /// Emitters the path reaches count in full (from the camera or after a specular bounce).
    count_emission: bool,
    /// After a diffuse scattering: where it happened and the density of the direction taken,
    /// for the MIS weight of an emitter the path reaches.
    scattered_from: Option<(Receiver, f32)>,
}

impl EyeVisitor for PathEye<'_> {
    fn medium(
        &mut self,
        path: &mut EyePath,
        m: &Medium,
        id: u32,
        t_max: f32,
        _end: Option<&Hit>,
    ) -> Next {
        let (o, d) = (path.ray.o, path.ray.d);
        // Direct light scattered once anywhere along the segment (equiangular and
        // transmittance-proportional distances, MIS); the path itself goes on by free flight
        // and scatters for the higher orders.
        let tr = m.segment(o, d, t_max, 1.0, &mut path.s);
        let segment = EyeSegment { o, w: d, t_max };
        let scene = path.scene;
        path.l +=
            path.beta * single_scattering(scene, self.lights, &segment, (id, m), &tr, &mut path.s);
        let flight = m.sample_free_flight(o, d, t_max, &mut path.s);
        path.beta *= flight.weight;
        if !flight.scattered {
            return Next::Continue;
        }
        // At the last event only emission can still arrive without another one: from lights,
        // which the segment's single scattering counted, and from emitting media along the next
        // ray, which only following the path finds (the walker gathers it, and nothing else,
        // after the last event).
        if path.last() && !path.scene.has_emissive_media() {
            return Next::Stop;
        }
        let x = o + d * flight.t;
        let ps = m.phase().sample(d, path.s.next_2d());
        path.beta *= m.sigma_s(x) * (ps.value / ps.pdf);
        // Direct light at x was counted along the segment: an emitter this direction reaches
        // does not count again.
        self.count_emission = false;
        self.scattered_from = None;
        Next::Scatter { o: x, d: ps.wi }
    }

    fn emission(&mut self, path: &EyePath, hit: &Hit, le: Rgb) -> Rgb {
        if self.count_emission {
            path.beta * le
        } else if let Some((from, pdf_dir)) = &self.scattered_from {
            path.beta
                * le
                * emission_weight(path.scene, self.lights, hit, -path.ray.d, from, *pdf_dir)
        } else {
            Rgb::ZERO
        }
    }

    fn environment(&mut self, path: &EyePath, le: Rgb) -> Rgb {
        if self.count_emission {
            path.beta * le
        } else if let Some((from, pdf_dir)) = &self.scattered_from {
            let w = environment_weight(path.scene, self.lights, path.ray.d, from, *pdf_dir);
            path.beta * le * w
        } else {
            Rgb::ZERO
        }
    }

    fn diffuse(&mut self, path: &mut EyePath, hit: &Hit, material: &Material) -> Next {
        let wo = -path.ray.d;
        let ng = if wo.dot(hit.ng) >= 0.0 { hit.ng } else { -hit.ng };
        let r = Receiver::surface(offset_origin(hit.p, ng, ng), ng);
        let last = path.last();
        let (hit_ng, hit_ns) = (hit.ng, hit.ns);
        path.l += path.beta
            * next_event(
                path.scene,
                self.lights,
                &r,
                path.ray.medium,
                &mut path.s,
                |wi| material.eval(wo, wi, hit_ng, hit_ns, Transport::Radiance),
                |wi| if last { 0.0 } else { material.pdf(wo, wi, hit_ng, hit_ns) },
            );
        if last && !path.scene.has_emissive_media() {
            return Next::Stop;
        }
        let u = path.s.next_2d();
        let Some(bs) = material.sample(wo, hit.ng, hit.ns, u, 0.0, Transport::Radiance) else {
            return Next::Stop;
        };
        path.beta *= bs.weight;
        self.count_emission = false;
        // After the last event the path only gathers emitting media's light (next-event
        // estimation counted the emitters in full there: no MIS weight for one it reaches).
        self.scattered_from = if last { None } else { Some((r, bs.pdf)) };
        Next::Scatter { o: r.p, d: bs.wi }
    }

    fn after_specular(&mut self, _path: &mut EyePath, _hit: &Hit, _wo: glam::Vec3) {
        // Next-event estimation could not have found an emitter behind a mirror or glass.
        self.count_emission = true;
        self.scattered_from = None;
    }

    fn survive(&mut self, path: &mut EyePath) -> bool {
        roulette(&mut path.beta, path.depth, &mut path.s)
    }
}

/// Renders one path-traced iteration into `frame` (without kernel bias). Returns `false` if
/// `stop` was raised.
fn render_pass(
    scene: &Scene,
    lights: &LightSampler,
    pass: &PathPass,
    stop: &AtomicBool,
    nonfinite: &AtomicU64,
    frame: &mut super::frame::Frame,
) -> bool {
    let width = scene.camera.resolution[0] as usize;
    super::frame::render_pixels(frame, width, stop, nonfinite, |x, y| {
        crate::estimate::Estimate::exact(pixel_radiance(scene, lights, pass, x, y))
    })
}
