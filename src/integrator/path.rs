//! An unbiased volumetric path tracer with next-event estimation, on the same scenes, media and
//! lights as the photon mapper. It gives references for scenes without closed forms and is the
//! baseline photon mapping is measured against.
//!
//! Each iteration traces one path per pixel. At every diffuse surface vertex and every real
//! collision in a medium, one light is chosen in proportion to its power and connected by a shadow
//! ray; the shadow ray passes through pass-through interfaces (switching media and multiplying
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

use crate::accel::Hit;
use crate::estimate::radius::radius;
use crate::math::{Frame, Rgb, offset_origin, sample_cosine_hemisphere};
use crate::photon::trace::LightSampler;
use crate::progress::StepTimes;
use crate::rng::{Purpose, Sampler};
use crate::scene::Scene;
use crate::scene::light::Light;
use crate::scene::material::{MAX_CROSSINGS, Material, Transport};
use crate::settings::RenderSettings;
use glam::{Vec2, Vec3};
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::time::Instant;

/// The path tracer: its settings and the light sampler, kept between iterations.
pub(crate) struct PathTracer {
    seed: u64,
    max_depth: u32,
    /// The photon-mapping radii, reported but unused.
    r1: f64,
    alpha: f64,
    r1_vol: f64,
    volume_alpha: f64,
    volume_dimension: u32,
    lights: LightSampler,
}

impl PathTracer {
    pub(crate) fn new(scene: &Scene, settings: &RenderSettings) -> Self {
        let diagonal = scene.diagonal() as f64;
        Self {
            seed: settings.seed,
            max_depth: settings.max_depth,
            r1: settings.initial_radius(diagonal),
            alpha: settings.alpha,
            r1_vol: settings.initial_volume_radius(diagonal),
            volume_alpha: settings.volume_alpha,
            volume_dimension: settings.volume_dimension,
            lights: LightSampler::new(scene),
        }
    }

    /// The schedule's radii at iteration `i` (the path tracer does not use them).
    pub(crate) fn radii(&self, i: u64) -> (f64, f64) {
        (
            radius(i, self.r1, self.alpha, 2),
            radius(i, self.r1_vol, self.volume_alpha, self.volume_dimension),
        )
    }

    /// One iteration: one path per pixel.
    pub(crate) fn iterate(
        &mut self,
        scene: &Scene,
        i: u64,
        stop: &AtomicBool,
        nonfinite: &AtomicU64,
        image: &mut [Rgb],
    ) -> Option<StepTimes> {
        let clock = Instant::now();
        let pass = PathPass { seed: self.seed, iteration: i, max_depth: self.max_depth };
        if !render_pass(scene, &self.lights, &pass, stop, nonfinite, image) {
            return None;
        }
        Some(StepTimes { camera: super::ppm::lap(clock), ..StepTimes::default() })
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
    /// events): light paths of up to `max_depth` scattering events are counted.
    pub max_depth: u32,
}

/// Light arriving at `p` from a sampled point of a light: direction, distance, and the incident
/// radiance times the geometry term divided by the sampling pdf (for a delta light, its
/// irradiance-like contribution).
struct LightSample {
    wi: Vec3,
    dist: f32,
    value: Rgb,
    /// Solid-angle density of the sampled direction (area lights); `None` for delta lights.
    pdf: Option<f32>,
}

fn sample_light(light: &Light, p: Vec3, s: &mut Sampler) -> Option<LightSample> {
    match light {
        Light::Point { position, intensity } => {
            let v = *position - p;
            let d2 = v.length_squared();
            (d2 > 0.0).then(|| {
                let dist = d2.sqrt();
                LightSample { wi: v / dist, dist, value: *intensity / d2, pdf: None }
            })
        }
        Light::Spot { position, frame, .. } => {
            let v = *position - p;
            let d2 = v.length_squared();
            if d2 <= 0.0 {
                return None;
            }
            let dist = d2.sqrt();
            let wi = v / dist;
            let value = light.spot_intensity(frame.n.dot(-wi)) / d2;
            Some(LightSample { wi, dist, value, pdf: None })
        }
        Light::Directional { direction, irradiance, .. } => Some(LightSample {
            wi: -*direction,
            dist: f32::INFINITY,
            value: *irradiance,
            pdf: None,
        }),
        Light::Area { radiance, emitter, .. } => {
            let (q, n) = emitter.sample_point(s.next_f32(), s.next_2d());
            let v = q - p;
            let d2 = v.length_squared();
            if d2 <= 0.0 {
                return None;
            }
            let dist = d2.sqrt();
            let wi = v / dist;
            let cos_l = n.dot(-wi);
            if cos_l <= 0.0 {
                return None;
            }
            let dist = dist * (1.0 - 1e-4);
            let area = emitter.area();
            Some(LightSample {
                wi,
                dist,
                value: *radiance * (cos_l * area / d2),
                pdf: Some(d2 / (cos_l * area)),
            })
        }
    }
}

/// Transmittance from `o` along `d` over `dist`, starting in `medium`, through pass-through
/// interfaces; zero if anything else is in the way.
fn shadow(
    scene: &Scene,
    mut o: Vec3,
    d: Vec3,
    dist: f32,
    mut medium: Option<u32>,
    s: &mut Sampler,
) -> Rgb {
    let mut tr = Rgb::ONE;
    let mut left = dist;
    // Each pass-through interface moves the origin off the line by the ray offset; re-aim at the
    // fixed end point so that the ray still stops short of the light. (Only shortening the
    // remaining length let the end creep past an area light within ~10⁴ offsets of an interface,
    // and the light itself then blocked the shadow ray.)
    let end = if dist.is_finite() { Some(o + d * dist) } else { None };
    let mut d = d;
    for _ in 0..=MAX_CROSSINGS {
        let hit = scene.intersect(o, d, left);
        let t = hit.map_or(left, |h| h.t);
        if let Some(id) = medium {
            tr *= scene.media[id as usize].transmittance(o, d, t, s);
            if tr.max_element() <= 0.0 {
                return Rgb::ZERO;
            }
        }
        let Some(hit) = hit else { return tr };
        let shape = &scene.shapes[hit.tag as usize];
        if scene.materials[shape.material as usize] != Material::Interface {
            return Rgb::ZERO;
        }
        medium = shape.medium_after(medium, -d, d, hit.ng);
        o = offset_origin(hit.p, hit.ng, d);
        match end {
            Some(end) => {
                let to_end = end - o;
                left = to_end.length();
                if left <= 0.0 || to_end.dot(d) <= 0.0 {
                    return tr;
                }
                d = to_end / left;
            }
            None => left = f32::INFINITY,
        }
    }
    Rgb::ZERO
}

/// Power-heuristic weight of a strategy with density `a` against one with density `b`, written
/// as 1/(1 + (b/a)²) so that large densities do not overflow (the two weights of a pair always
/// sum to one).
#[inline]
fn power_heuristic(a: f32, b: f32) -> f32 {
    if a.is_nan() || a <= 0.0 {
        return 0.0;
    }
    let r = b / a;
    if r.is_finite() { 1.0 / (1.0 + r * r) } else { 0.0 }
}

/// Next-event estimate at `p`: `f(wi)` is the BSDF·cos or phase function towards `wi`, and
/// `pdf(wi)` the solid-angle density with which the path itself samples `wi` (for the MIS weight;
/// pass `|_| 0.0` at the path's last vertex, whose sampled direction is never followed, so that
/// next-event estimation takes the whole share).
fn next_event(
    scene: &Scene,
    lights: &LightSampler,
    p: Vec3,
    medium: Option<u32>,
    s: &mut Sampler,
    f: impl Fn(Vec3) -> Rgb,
    pdf: impl Fn(Vec3) -> f32,
) -> Rgb {
    if lights.is_empty() {
        return Rgb::ZERO;
    }
    let (li, p_light) = lights.pick(s.next_f32());
    let Some(ls) = sample_light(&scene.lights[li], p, s) else { return Rgb::ZERO };
    let fv = f(ls.wi);
    if fv.max_element() <= 0.0 || ls.value.max_element() <= 0.0 {
        return Rgb::ZERO;
    }
    let weight = ls.pdf.map_or(1.0, |p_l| power_heuristic(p_light * p_l, pdf(ls.wi)));
    fv * ls.value * shadow(scene, p, ls.wi, ls.dist, medium, s) * (weight / p_light)
}

/// MIS weight of reaching an emitting shape at `hit` (seen from direction `wo`) by a direction
/// sampled with density `pdf_dir` at `from`, against next-event estimation.
fn emission_weight(lights: &LightSampler, hit: &Hit, wo: Vec3, from: Vec3, pdf_dir: f32) -> f32 {
    let Some((li, area)) = lights.area_light(hit.tag) else { return 1.0 };
    let cos_l = wo.dot(hit.ng).abs();
    if cos_l <= 0.0 || area <= 0.0 {
        return 1.0;
    }
    let p_l = lights.prob(li) * (hit.p - from).length_squared() / (cos_l * area);
    power_heuristic(pdf_dir, p_l)
}

/// Radiance along one path for pixel (x, y).
fn pixel_radiance(scene: &Scene, lights: &LightSampler, pass: &PathPass, x: u32, y: u32) -> Rgb {
    let width = scene.camera.resolution[0];
    let mut s = Sampler::new(pass.seed, Purpose::Camera, pass.iteration, (y * width + x) as u64);
    let pixel = Vec2::new(x as f32, y as f32) + s.next_2d();
    let ray = scene.camera.generate_ray(pixel, s.next_2d());
    let (mut o, mut d) = (ray.o, ray.d);
    let mut medium = scene.camera_medium;
    let mut beta = Rgb::ONE;
    let mut l = Rgb::ZERO;
    let mut count_emission = true;
    // After a diffuse or phase-function scattering: where it happened and the density of the
    // direction taken, for the MIS weight of an emitter the path reaches.
    let mut scattered_from: Option<(Vec3, f32)> = None;
    // Scattering events so far (pass-through interfaces are not events), and crossings.
    let (mut depth, mut crossings) = (0u32, 0u32);
    loop {
        // The direction sampled at the last vertex is never followed.
        let last = depth + 1 == pass.max_depth;
        let hit = scene.intersect(o, d, f32::INFINITY);
        if let Some(id) = medium {
            let m = &scene.media[id as usize];
            let t_max = hit.map_or(f32::INFINITY, |h| h.t);
            let flight = m.sample_free_flight(o, d, t_max, &mut s);
            beta *= flight.weight;
            if flight.scattered {
                let x = o + d * flight.t;
                let sigma_s = m.sigma_s(x);
                let phase = m.phase();
                let d_in = d;
                l += beta
                    * sigma_s
                    * next_event(
                        scene,
                        lights,
                        x,
                        medium,
                        &mut s,
                        |wi| Rgb::splat(phase.eval(d_in, wi)),
                        |wi| if last { 0.0 } else { phase.eval(d_in, wi) },
                    );
                if last {
                    break;
                }
                beta *= sigma_s;
                let ps = phase.sample(d, s.next_2d());
                d = ps.d_out;
                o = x;
                count_emission = false;
                scattered_from = Some((x, ps.value));
                if !roulette(&mut beta, depth, &mut s) {
                    break;
                }
                depth += 1;
                continue;
            }
            if beta.max_element() <= 0.0 {
                break;
            }
        }
        let Some(hit) = hit else { break };
        let wo = -d;
        let shape = &scene.shapes[hit.tag as usize];
        if let Some(le) = shape.emission {
            if wo.dot(hit.ng) > 0.0 {
                if count_emission {
                    l += beta * le;
                } else if let Some((from, pdf_dir)) = scattered_from {
                    let w = emission_weight(lights, &hit, wo, from, pdf_dir);
                    l += beta * le * w;
                }
            }
        }
        let material = &scene.materials[shape.material as usize];
        match material {
            // A pass-through interface changes nothing but the medium (shadow rays pass through
            // it too), so the emission decision and the MIS state stand.
            Material::Interface => {
                crossings += 1;
                if crossings > MAX_CROSSINGS {
                    break;
                }
                medium = shape.medium_after(medium, wo, d, hit.ng);
                o = offset_origin(hit.p, hit.ng, d);
                continue;
            }
            Material::Diffuse { albedo } => {
                let ng = if wo.dot(hit.ng) >= 0.0 { hit.ng } else { -hit.ng };
                let ns = if hit.ns.dot(ng) >= 0.0 { hit.ns } else { -hit.ns };
                let f = material.diffuse_f();
                let p = offset_origin(hit.p, ng, ng);
                let pdf = |wi: Vec3| {
                    if wi.dot(ng) <= 0.0 {
                        0.0
                    } else {
                        wi.dot(ns).max(0.0) * std::f32::consts::FRAC_1_PI
                    }
                };
                l += beta
                    * next_event(
                        scene,
                        lights,
                        p,
                        medium,
                        &mut s,
                        |wi| if wi.dot(ng) <= 0.0 { Rgb::ZERO } else { f * wi.dot(ns).max(0.0) },
                        |wi| if last { 0.0 } else { pdf(wi) },
                    );
                if last {
                    break;
                }
                let wi = Frame::new(ns).to_world(sample_cosine_hemisphere(s.next_2d()));
                if wi.dot(ng) <= 0.0 {
                    break;
                }
                beta *= *albedo;
                o = p;
                d = wi;
                count_emission = false;
                scattered_from = Some((p, pdf(wi)));
            }
            _ => {
                if last {
                    break;
                }
                let Some(bs) = material.sample(
                    wo,
                    hit.ng,
                    hit.ns,
                    s.next_2d(),
                    s.next_f32(),
                    Transport::Radiance,
                ) else {
                    break;
                };
                beta *= bs.weight;
                medium = shape.medium_after(medium, wo, bs.wi, hit.ng);
                o = offset_origin(hit.p, hit.ng, bs.wi);
                d = bs.wi;
                // After a mirror or glass bounce next-event estimation could not have found the
                // emitter, so count it when hit.
                count_emission = true;
                scattered_from = None;
            }
        }
        if !roulette(&mut beta, depth, &mut s) {
            break;
        }
        depth += 1;
    }
    l
}

/// Russian roulette from the fourth event on, survival probability min(1, max β): a path whose
/// throughput has not fallen is never killed. (An earlier cap of 0.95 killed paths in albedo-1
/// media after ~20 events whatever their throughput; in optically thick media, where light needs
/// thousands of events to escape, the survivors' weights 0.95^−k then made the estimate useless.)
#[inline]
fn roulette(beta: &mut Rgb, depth: u32, s: &mut Sampler) -> bool {
    if beta.max_element() <= 0.0 {
        return false;
    }
    if depth < 3 || beta.max_element() >= 1.0 {
        return true;
    }
    let q = beta.max_element();
    if s.next_f32() >= q {
        return false;
    }
    *beta /= q;
    true
}

/// Renders one path-traced iteration image into `image`. Returns `false` if `stop` was raised.
fn render_pass(
    scene: &Scene,
    lights: &LightSampler,
    pass: &PathPass,
    stop: &AtomicBool,
    nonfinite: &AtomicU64,
    image: &mut [Rgb],
) -> bool {
    let width = scene.camera.resolution[0] as usize;
    super::render_rows(image, width, stop, nonfinite, |x, y| {
        pixel_radiance(scene, lights, pass, x, y)
    })
}
