//! An unbiased volumetric path tracer with next-event estimation, on the same scenes, media and
//! lights as the photon mapper. It gives references for scenes without closed forms and is the
//! baseline photon mapping is measured against.
//!
//! Each iteration traces one path per pixel. At every diffuse surface vertex and every real
//! collision in a medium, one light is chosen in proportion to its power and connected by a shadow
//! ray; the shadow ray passes through pass-through interfaces (switching media and multiplying
//! their transmittance: exact for homogeneous media, ratio tracking for grids) and is blocked by
//! anything else. Emitters hit by the path count only after a specular bounce or straight from the
//! camera, so nothing is counted twice and no multiple-importance weights are needed. The free-flight
//! weights follow the photon pass's convention (`Medium::sample_free_flight`), so path tracing
//! and photon mapping estimate the same integral. Paths that see light only through specular
//! chains from point-like lights (caustics) are not found by next-event estimation: that is the
//! known weakness photon mapping is for.

use crate::math::{Frame, Rgb, offset_origin, sample_cosine_hemisphere};
use crate::photon::trace::LightSampler;
use crate::rng::{Purpose, Sampler};
use crate::scene::Scene;
use crate::scene::light::Light;
use crate::scene::material::{Material, Transport};
use glam::{Vec2, Vec3};
use std::sync::atomic::{AtomicBool, AtomicU64};

/// Settings of one path-tracing pass.
#[derive(Clone, Copy, Debug)]
pub struct PathPass {
    /// Render seed.
    pub seed: u64,
    /// Iteration number (1-based).
    pub iteration: u64,
    /// Maximum scattering events per path.
    pub max_depth: u32,
}

/// Light arriving at `p` from a sampled point of a light: direction, distance, and the incident
/// radiance times the geometry term divided by the sampling pdf (for a delta light, its
/// irradiance-like contribution).
struct LightSample {
    wi: Vec3,
    dist: f32,
    value: Rgb,
}

fn sample_light(light: &Light, p: Vec3, s: &mut Sampler) -> Option<LightSample> {
    match light {
        Light::Point { position, intensity } => {
            let v = *position - p;
            let d2 = v.length_squared();
            (d2 > 0.0).then(|| {
                let dist = d2.sqrt();
                LightSample { wi: v / dist, dist, value: *intensity / d2 }
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
            Some(LightSample { wi, dist, value })
        }
        Light::Directional { direction, irradiance, .. } => {
            Some(LightSample { wi: -*direction, dist: f32::INFINITY, value: *irradiance })
        }
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
            Some(LightSample { wi, dist, value: *radiance * (cos_l * emitter.area() / d2) })
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
    for _ in 0..64 {
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
        left -= t;
        if left <= 0.0 {
            return tr;
        }
    }
    Rgb::ZERO
}

/// Next-event estimate at `p`: `f(wi)` is the BSDF·cos or phase function towards `wi`.
fn next_event(
    scene: &Scene,
    lights: &LightSampler,
    p: Vec3,
    medium: Option<u32>,
    s: &mut Sampler,
    f: impl Fn(Vec3) -> Rgb,
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
    fv * ls.value * shadow(scene, p, ls.wi, ls.dist, medium, s) / p_light
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
    for depth in 0..pass.max_depth {
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
                    * next_event(scene, lights, x, medium, &mut s, |wi| {
                        Rgb::splat(phase.eval(d_in, wi))
                    });
                beta *= sigma_s;
                d = phase.sample(d, s.next_2d()).d_out;
                o = x;
                count_emission = false;
                if !roulette(&mut beta, depth, &mut s) {
                    break;
                }
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
            if count_emission && wo.dot(hit.ng) > 0.0 {
                l += beta * le;
            }
        }
        let material = &scene.materials[shape.material as usize];
        if let Material::Diffuse { albedo } = material {
            let ng = if wo.dot(hit.ng) >= 0.0 { hit.ng } else { -hit.ng };
            let ns = if hit.ns.dot(ng) >= 0.0 { hit.ns } else { -hit.ns };
            let f = material.diffuse_f();
            let p = offset_origin(hit.p, ng, ng);
            l += beta
                * next_event(scene, lights, p, medium, &mut s, |wi| {
                    if wi.dot(ng) <= 0.0 { Rgb::ZERO } else { f * wi.dot(ns).max(0.0) }
                });
            let wi = Frame::new(ns).to_world(sample_cosine_hemisphere(s.next_2d()));
            if wi.dot(ng) <= 0.0 {
                break;
            }
            beta *= *albedo;
            o = p;
            d = wi;
            count_emission = false;
        } else {
            let Some(bs) =
                material.sample(wo, hit.ng, hit.ns, s.next_2d(), s.next_f32(), Transport::Radiance)
            else {
                break;
            };
            beta *= bs.weight;
            medium = shape.medium_after(medium, wo, bs.wi, hit.ng);
            o = offset_origin(hit.p, hit.ng, bs.wi);
            d = bs.wi;
            // After a mirror or glass bounce next-event estimation could not have found the
            // emitter, so count it when hit; a pass-through interface changes nothing (shadow
            // rays pass through it), so the previous decision stands.
            if *material != Material::Interface {
                count_emission = true;
            }
        }
        if !roulette(&mut beta, depth, &mut s) {
            break;
        }
    }
    l
}

/// Russian roulette from the fourth event on, survival min(0.95, max β).
#[inline]
fn roulette(beta: &mut Rgb, depth: u32, s: &mut Sampler) -> bool {
    if beta.max_element() <= 0.0 {
        return false;
    }
    if depth < 3 {
        return true;
    }
    let q = beta.max_element().min(0.95);
    if s.next_f32() >= q {
        return false;
    }
    *beta /= q;
    true
}

/// Renders one path-traced iteration image into `image`. Returns `false` if `stop` was raised.
pub fn render_pass(
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
