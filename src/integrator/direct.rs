//! Direct lighting by next-event estimation: choose a light by power, sample a point of it
//! ([`Light::sample_li`](crate::scene::light::Light::sample_li)), and connect by a shadow ray
//! that passes through pass-through interfaces (multiplying their media's transmittance: exact
//! for homogeneous media, ratio tracking for grids) and is blocked by anything else. For area
//! lights the estimate is combined with BSDF or phase-function sampling of the same light by
//! multiple importance sampling (power heuristic over solid-angle densities; Veach 1997):
//! [`next_event`] weighs the light sample, [`emission_weight`] an emitter the path reaches.

use crate::accel::Hit;
use crate::math::{Rgb, offset_origin};
use crate::rng::Sampler;
use crate::scene::Scene;
use crate::scene::light::LightSampler;
use crate::scene::material::{MAX_CROSSINGS, Material, Transport};
use glam::Vec3;

/// What a ray meets when followed through pass-through interfaces.
enum Crossing {
    /// It reached its end (or left the scene) with this transmittance.
    Reached(Rgb),
    /// It met a surface that is not pass-through, with the transmittance up to it.
    Surface(Hit, Rgb),
    /// No light gets through (zero transmittance, or more than `MAX_CROSSINGS` interfaces).
    Blocked,
}

/// Follows `o + t d`, t ≤ `dist`, starting in `medium`, through pass-through interfaces,
/// multiplying the transmittance of the media it crosses (exact for homogeneous media, ratio
/// tracking for grids), to the first other surface or the end.
fn cross(
    scene: &Scene,
    mut o: Vec3,
    d: Vec3,
    dist: f32,
    mut medium: Option<u32>,
    s: &mut Sampler,
) -> Crossing {
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
                return Crossing::Blocked;
            }
        }
        let Some(hit) = hit else { return Crossing::Reached(tr) };
        let shape = &scene.shapes[hit.tag as usize];
        if scene.materials[shape.material as usize] != Material::Interface {
            return Crossing::Surface(hit, tr);
        }
        medium = shape.medium_after(medium, -d, d, hit.ng);
        o = offset_origin(hit.p, hit.ng, d);
        match end {
            Some(end) => {
                let to_end = end - o;
                left = to_end.length();
                if left <= 0.0 || to_end.dot(d) <= 0.0 {
                    return Crossing::Reached(tr);
                }
                d = to_end / left;
            }
            None => left = f32::INFINITY,
        }
    }
    Crossing::Blocked
}

/// Transmittance from `o` along `d` over `dist`, starting in `medium`, through pass-through
/// interfaces; zero if anything else is in the way.
pub(crate) fn shadow(
    scene: &Scene,
    o: Vec3,
    d: Vec3,
    dist: f32,
    medium: Option<u32>,
    s: &mut Sampler,
) -> Rgb {
    match cross(scene, o, d, dist, medium, s) {
        Crossing::Reached(tr) => tr,
        Crossing::Surface(..) | Crossing::Blocked => Rgb::ZERO,
    }
}

/// Power-heuristic weight of a strategy with density `a` against one with density `b`, written
/// as 1/(1 + (b/a)²) so that large densities do not overflow (the two weights of a pair always
/// sum to one).
#[inline]
pub(crate) fn power_heuristic(a: f32, b: f32) -> f32 {
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
pub(crate) fn next_event(
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
    let Some(ls) = scene.lights[li].sample_li(p, s) else { return Rgb::ZERO };
    let fv = f(ls.wi);
    if fv.max_element() <= 0.0 || ls.value.max_element() <= 0.0 {
        return Rgb::ZERO;
    }
    let weight = ls.pdf.map_or(1.0, |p_l| power_heuristic(p_light * p_l, pdf(ls.wi)));
    fv * ls.value * shadow(scene, p, ls.wi, ls.dist, medium, s) * (weight / p_light)
}

/// The first surface that is not pass-through along `o + t d` (starting in `medium`) and the
/// transmittance up to it, or `None` if nothing is hit or no light gets through. For the direct
/// light a sampled direction brings from an emitter.
fn transmitted_hit(
    scene: &Scene,
    o: Vec3,
    d: Vec3,
    medium: Option<u32>,
    s: &mut Sampler,
) -> Option<(Hit, Rgb)> {
    match cross(scene, o, d, f32::INFINITY, medium, s) {
        Crossing::Surface(hit, tr) => Some((hit, tr)),
        Crossing::Reached(_) | Crossing::Blocked => None,
    }
}

/// Direct light at a diffuse surface point `hit` (seen from direction `wo`, in medium `medium`):
/// next-event estimation and BSDF sampling of the emitters, combined by MIS (power heuristic), as
/// the path tracer does at its diffuse vertices, but without following the sampled direction
/// further than the emitter it may reach straight away.
pub(crate) fn surface_direct(
    scene: &Scene,
    lights: &LightSampler,
    hit: &Hit,
    wo: Vec3,
    material: &Material,
    medium: Option<u32>,
    s: &mut Sampler,
) -> Rgb {
    let ng = if wo.dot(hit.ng) >= 0.0 { hit.ng } else { -hit.ng };
    let p = offset_origin(hit.p, ng, ng);
    let (hit_ng, hit_ns) = (hit.ng, hit.ns);
    let l = next_event(
        scene,
        lights,
        p,
        medium,
        s,
        |wi| material.eval(wo, wi, hit_ng, hit_ns, Transport::Radiance),
        |wi| material.pdf(wo, wi, hit_ng, hit_ns),
    );
    if !lights.has_area_lights() {
        return l;
    }
    let u = s.next_2d();
    let Some(bs) = material.sample(wo, hit.ng, hit.ns, u, 0.0, Transport::Radiance) else {
        return l;
    };
    l + emitted(scene, lights, p, bs.wi, bs.pdf, bs.weight, medium, s)
}

/// Light from an emitter that the direction `wi`, sampled at `from` with density `pdf_dir`,
/// reaches straight away (through pass-through interfaces), times `weight` and the
/// transmittance, weighed by MIS against next-event estimation; zero if it reaches none.
#[allow(clippy::too_many_arguments)]
pub(crate) fn emitted(
    scene: &Scene,
    lights: &LightSampler,
    from: Vec3,
    wi: Vec3,
    pdf_dir: f32,
    weight: Rgb,
    medium: Option<u32>,
    s: &mut Sampler,
) -> Rgb {
    let Some((hit, tr)) = transmitted_hit(scene, from, wi, medium, s) else { return Rgb::ZERO };
    let shape = &scene.shapes[hit.tag as usize];
    match shape.emission.filter(|_| (-wi).dot(hit.ng) > 0.0) {
        Some(le) => weight * tr * le * emission_weight(lights, &hit, -wi, from, pdf_dir),
        None => Rgb::ZERO,
    }
}

/// MIS weight of reaching an emitting shape at `hit` (seen from direction `wo`) by a direction
/// sampled with density `pdf_dir` at `from`, against next-event estimation.
pub(crate) fn emission_weight(
    lights: &LightSampler,
    hit: &Hit,
    wo: Vec3,
    from: Vec3,
    pdf_dir: f32,
) -> f32 {
    if lights.area_light(hit.tag).is_none() {
        return 1.0;
    }
    let p_l = lights.pdf_li(hit.tag, from, hit.p, wo.dot(hit.ng));
    if p_l <= 0.0 {
        return 1.0;
    }
    power_heuristic(pdf_dir, p_l)
}
