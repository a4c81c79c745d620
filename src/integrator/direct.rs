//! Direct lighting by next-event estimation: choose a light by its estimated contribution at the
//! receiving point ([`LightSampler::pick`]), sample a point of it
//! ([`Light::sample_li`](crate::scene::light::Light::sample_li)), and connect by a shadow ray
//! that passes through pass-through interfaces (multiplying their media's transmittance: exact
//! for homogeneous media, ratio tracking for grids) and is blocked by anything else. For area
//! lights the estimate is combined with BSDF or phase-function sampling of the same light by
//! multiple importance sampling (power heuristic over solid-angle densities; Veach 1997):
//! [`next_event`] weighs the light sample, [`emission_weight`] an emitter the path reaches.

use crate::accel::{Hit, Passage};
use crate::estimate::mis::crossing_share;
use crate::math::{Rgb, luminance, offset_origin, ray_offset};
use crate::medium::Medium;
use crate::rng::Sampler;
use crate::scene::Scene;
use crate::scene::light::media::{EmitterPoint, EmitterPool};
use crate::scene::light::{LightSampler, Receiver};
use crate::scene::material::{MAX_CROSSINGS, Material, Transport};
use crate::scene::step::medium_beyond;
use glam::Vec3;
use smallvec::SmallVec;

/// What a ray meets when followed through pass-through interfaces.
enum Crossing {
    /// It reached its end (or left the scene) with this transmittance.
    Reached(Rgb),
    /// It met a surface that is not pass-through, with the transmittance up to it.
    Surface(Hit, Rgb),
    /// No light gets through (zero transmittance, or more than `MAX_CROSSINGS` interfaces).
    Blocked,
}

/// What [`cross`] looks for.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Query {
    /// A shadow ray: blocked by any surface that is not pass-through (the traversal stops at
    /// the first it finds).
    Shadow,
    /// The nearest surface that is not pass-through, if the filter accepts it; a ray that
    /// meets none is `Blocked`.
    Surface,
    /// The same, but a ray that meets none leaves the scene: `Reached`, with the transmittance
    /// to infinity (towards an environment light).
    SurfaceOrSky,
}

/// Follows `o + t d`, t ≤ `dist`, starting in `medium`, through pass-through interfaces,
/// multiplying the transmittance of the media it crosses (exact for homogeneous media, ratio
/// tracking for grids), to the first other surface or the end; what it looks for is `query`'s
/// (a surface is the result if `wanted` accepts it). One traversal finds the interfaces and what
/// lies beyond (instead of a closest-hit query from each interface to the next), and no
/// transmittance is estimated for a ray that ends blocked, on an unwanted surface, or (looking
/// for a surface alone) on none.
/// Grids' transmittance is estimated by ratio tracking at `rate` times their majorants.
#[allow(clippy::too_many_arguments)]
fn cross(
    scene: &Scene,
    o: Vec3,
    d: Vec3,
    dist: f32,
    mut medium: Option<u32>,
    query: Query,
    wanted: impl Fn(&Hit) -> bool,
    rate: f32,
    s: &mut Sampler,
    mut crossed: Option<&mut f32>,
) -> Crossing {
    let mut crossings = SmallVec::<[Hit; 4]>::new();
    let stop = query == Query::Shadow;
    // Two hits of one interface within the ray offset are one crossing (its shared edge).
    let merge = ray_offset(o) + ray_offset(o + d * dist.min(scene.diagonal()));
    let end = match scene.accel.through(
        o,
        d,
        dist,
        &scene.passthrough,
        stop,
        merge,
        MAX_CROSSINGS as usize,
        &mut crossings,
    ) {
        Passage::Blocked => return Crossing::Blocked,
        // A ray that looks for a surface and finds none: what it crossed does not matter.
        Passage::Clear if query == Query::Surface => return Crossing::Blocked,
        Passage::Clear => None,
        Passage::Surface(hit) if wanted(&hit) => Some(hit),
        Passage::Surface(_) => return Crossing::Blocked,
    };
    let mut tr = Rgb::ONE;
    let mut t0 = 0.0f32;
    for hit in crossings.iter().map(Some).chain([end.as_ref()]) {
        let t1 = hit.map_or(dist, |h| h.t);
        if let Some(id) = medium {
            let m = &scene.media[id as usize];
            tr *= m.transmittance_at_rate(o + d * t0, d, t1 - t0, rate, s);
            if let (Some(c), Medium::Homogeneous(_)) = (crossed.as_deref_mut(), m) {
                *c *= crossing_share(m.mean_sigma_t(o), t1 - t0);
            }
            if tr.max_element() <= 0.0 {
                return Crossing::Blocked;
            }
        }
        let Some(hit) = hit else { break };
        medium = medium_beyond(scene, hit, medium, d);
        t0 = t1;
    }
    match end {
        Some(hit) => Crossing::Surface(hit, tr),
        None => Crossing::Reached(tr),
    }
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
    shadow_at_rate(scene, o, d, dist, medium, 1.0, s, None)
}

/// [`shadow`] with grids' ratio tracking at `rate` times their majorants; with `crossed`, the
/// eye's crossing shares of its homogeneous media multiplied into it ([`shadow_crossed`]).
#[allow(clippy::too_many_arguments)]
fn shadow_at_rate(
    scene: &Scene,
    o: Vec3,
    d: Vec3,
    dist: f32,
    medium: Option<u32>,
    rate: f32,
    s: &mut Sampler,
    crossed: Option<&mut f32>,
) -> Rgb {
    match cross(scene, o, d, dist, medium, Query::Shadow, |_| true, rate, s, crossed) {
        Crossing::Reached(tr) => tr,
        Crossing::Surface(..) | Crossing::Blocked => Rgb::ZERO,
    }
}

/// [`shadow`], and the product of the combined integrator's eye crossing shares
/// (`mis::crossing_share`) over the homogeneous media it crosses: the eye path's density of
/// reaching the shadow ray's end over free flight's.
pub(crate) fn shadow_crossed(
    scene: &Scene,
    o: Vec3,
    d: Vec3,
    dist: f32,
    medium: Option<u32>,
    s: &mut Sampler,
) -> (Rgb, f32) {
    let mut crossed = 1.0;
    let tr = shadow_at_rate(scene, o, d, dist, medium, 1.0, s, Some(&mut crossed));
    (tr, crossed)
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

/// Next-event estimate at the receiver `r` (whose point is the shadow ray's origin): `f(wi)` is
/// the BSDF·cos or phase function towards `wi`, and
/// `pdf(wi)` the solid-angle density with which the path itself samples `wi` (for the MIS weight;
/// pass `|_| 0.0` at the path's last vertex, whose sampled direction is never followed, so that
/// next-event estimation takes the whole share).
pub(crate) fn next_event(
    scene: &Scene,
    lights: &LightSampler,
    r: &Receiver,
    medium: Option<u32>,
    s: &mut Sampler,
    f: impl Fn(Vec3) -> Rgb,
    pdf: impl Fn(Vec3) -> f32,
) -> Rgb {
    if lights.is_empty() {
        return Rgb::ZERO;
    }
    let Some((li, p_light)) = lights.pick(r, s.next_f32()) else { return Rgb::ZERO };
    let p = r.p;
    let Some(ls) = scene.lights[li].sample_li(p, s) else { return Rgb::ZERO };
    let fv = f(ls.wi);
    if fv.max_element() <= 0.0 || ls.value.max_element() <= 0.0 {
        return Rgb::ZERO;
    }
    let weight = ls.pdf.map_or(1.0, |p_l| power_heuristic(p_light * p_l, pdf(ls.wi)));
    fv * ls.value * shadow(scene, p, ls.wi, ls.dist, medium, s) * (weight / p_light)
}

/// Candidate emitter points per next-event estimate towards emitting media, of which one gets a
/// shadow ray ([`media_next_event`]).
pub(crate) const MEDIA_CANDIDATES: usize = 8;

/// Ratio tracking of the shadow rays towards emitting media runs at this many times the
/// majorants. Emitting media are mostly seen through their own smoke, whose majorants are tight
/// around the flames: at rate 1 each factor 1 − σ_t/μ̄ is nearly 0 there and the estimate all but
/// binary. On a stone face lit by the campfire (docs/theory.md) the variance of T over the
/// shadow rays to one point fell 5.4× at rate 4, the next-event estimate's 2.9×.
const MEDIA_SHADOW_RATE: f32 = 4.0;

/// Next-event estimate of the light that emitting media send to the receiver at `x` (in
/// `medium`) straight from their points at least `near` away,
///
///   ∫ f(ω) σ_a(p) L_e(p) T(x, p) / |p − x|² dp,  ω = (p − x)/|p − x|,
///
/// with `f(ω)` the BSDF·cos at the receiver, by resampled importance sampling (Talbot et al.
/// 2005): [`MEDIA_CANDIDATES`] points picked uniformly from the iteration's `pool` (each
/// distributed as a fresh draw by the emission bounds,
/// [`EmissiveMedia::sample_candidate`](crate::scene::light::media::EmissiveMedia::sample_candidate)),
/// each weighted by its unshadowed contribution p̂ = f σ_a L_e / |p − x|² (mean channel) over its
/// density; one of them chosen by weight and connected by a shadow ray through pass-through
/// interfaces, its contribution divided by p̂ and multiplied by the mean weight. Unbiased (p̂ is
/// positive wherever the contribution is, and the estimate is linear in its candidates, each
/// distributed as a fresh draw however the pool is shared), and towards the receiver: the
/// distance and the receiver's BSDF steer the choice, for one shadow ray. Points nearer than
/// `near` count zero: their light is left to the photons (`PhotonPass::media_near`), because
/// the 1/|p − x|² of a receiver inside or touching an emitting medium would give this estimate
/// infinite variance (docs/theory.md, "Next-event estimation towards emitting media").
pub(crate) fn media_next_event(
    scene: &Scene,
    x: Vec3,
    medium: Option<u32>,
    near: f32,
    pool: &EmitterPool,
    s: &mut Sampler,
    f: impl Fn(Vec3) -> Rgb,
) -> Rgb {
    // The chosen candidate: its point, direction and distance from x, unshadowed contribution
    // f σ_a L_e / |p − x|² (per channel) and its mean channel p̂.
    let mut chosen: Option<(&EmitterPoint, Vec3, f32, Rgb, f32)> = None;
    let mut total = 0.0f32;
    for _ in 0..MEDIA_CANDIDATES {
        let Some(e) = pool.pick(s) else { continue };
        let to = e.p - x;
        let dist2 = to.length_squared();
        if !(dist2 >= near * near && dist2 > 0.0) {
            continue;
        }
        let dist = dist2.sqrt();
        let wi = to / dist;
        let unshadowed = f(wi) * e.f / dist2;
        let target = luminance(unshadowed);
        let w = target / e.pdf;
        if !(w > 0.0 && w.is_finite()) {
            continue;
        }
        total += w;
        if s.next_f32() * total < w {
            chosen = Some((e, wi, dist, unshadowed, target));
        }
    }
    // A grid's point outside its medium (as the interfaces say) emits nothing there: asked of
    // the chosen point alone.
    let Some((e, wi, dist, unshadowed, target)) = chosen else { return Rgb::ZERO };
    if !e.inside(scene) {
        return Rgb::ZERO;
    }
    let tr = shadow_at_rate(scene, x, wi, dist, medium, MEDIA_SHADOW_RATE, s, None);
    unshadowed * tr * (total / MEDIA_CANDIDATES as f32 / target)
}

/// What a sampled direction reaches straight away (through pass-through interfaces).
enum Source {
    /// The front of an emitting shape, with the transmittance up to it and its radiance.
    Shape(Hit, Rgb, Rgb),
    /// Nothing: it leaves the scene towards the environment light, with the transmittance to
    /// infinity and the environment's radiance.
    Sky(Rgb, Rgb),
}

/// The first surface that is not pass-through along `o + t d` (starting in `medium`), if it is
/// an emitter facing the ray, or the environment light if the ray leaves the scene; with the
/// transmittance up to it. `None` if the ray meets any other surface, reaches nothing that
/// emits towards it, or no light gets through. For the direct light a sampled direction brings.
fn emitter_hit(
    scene: &Scene,
    o: Vec3,
    d: Vec3,
    medium: Option<u32>,
    s: &mut Sampler,
) -> Option<Source> {
    let sky = scene.environment().map(|(_, env)| env);
    // Most sampled directions miss every emitter: without an environment light, a test against
    // the emitters alone (a few primitives) spares them a traversal of the whole scene. Exact:
    // the same ray and triangle arithmetic, and a ray that meets no emitter draws no random
    // numbers below.
    if sky.is_none() && !scene.emitters.occluded(o, d, f32::INFINITY) {
        return None;
    }
    let query = if sky.is_some() { Query::SurfaceOrSky } else { Query::Surface };
    let wanted = |h: &Hit| scene.le(h, -d).is_some();
    match cross(scene, o, d, f32::INFINITY, medium, query, wanted, 1.0, s, None) {
        Crossing::Surface(hit, tr) => Some(Source::Shape(hit, tr, scene.le(&hit, -d)?)),
        Crossing::Reached(tr) => sky.map(|env| Source::Sky(tr, env.radiance(d))),
        Crossing::Blocked => None,
    }
}

/// Direct light at a diffuse surface point `hit` (seen from direction `wo`, in medium `medium`):
/// next-event estimation and BSDF sampling of the emitters, combined by MIS (power heuristic), as
/// the path tracer does at its diffuse vertices, but without following the sampled direction
/// further than the emitter it may reach straight away; and the light of emitting media from
/// their points at least `media.0` away, its candidates from the pool `media.1`
/// ([`media_next_event`]; `None`: none).
#[allow(clippy::too_many_arguments)]
pub(crate) fn surface_direct(
    scene: &Scene,
    lights: &LightSampler,
    hit: &Hit,
    wo: Vec3,
    material: &Material,
    medium: Option<u32>,
    media: Option<(f32, &EmitterPool)>,
    s: &mut Sampler,
) -> Rgb {
    let ng = if wo.dot(hit.ng) >= 0.0 { hit.ng } else { -hit.ng };
    let r = Receiver::surface(offset_origin(hit.p, ng, ng), ng);
    let (hit_ng, hit_ns) = (hit.ng, hit.ns);
    let f = |wi| material.eval(wo, wi, hit_ng, hit_ns, Transport::Radiance);
    let mut l =
        next_event(scene, lights, &r, medium, s, f, |wi| material.pdf(wo, wi, hit_ng, hit_ns));
    if let Some((near, pool)) = media {
        l += media_next_event(scene, r.p, medium, near, pool, s, f);
    }
    if !lights.reachable() {
        return l;
    }
    let u = s.next_2d();
    let Some(bs) = material.sample(wo, hit.ng, hit.ns, u, 0.0, Transport::Radiance) else {
        return l;
    };
    l + emitted(scene, lights, &r, bs.wi, bs.pdf, bs.weight, medium, s)
}

/// Light from an emitter (or the environment) that the direction `wi`, sampled at `from` with
/// density `pdf_dir`, reaches straight away (through pass-through interfaces), times `weight` and the
/// transmittance, weighed by MIS against next-event estimation; zero if it reaches none.
#[allow(clippy::too_many_arguments)]
pub(crate) fn emitted(
    scene: &Scene,
    lights: &LightSampler,
    from: &Receiver,
    wi: Vec3,
    pdf_dir: f32,
    weight: Rgb,
    medium: Option<u32>,
    s: &mut Sampler,
) -> Rgb {
    match emitter_hit(scene, from.p, wi, medium, s) {
        Some(Source::Shape(hit, tr, le)) => {
            weight * tr * le * emission_weight(scene, lights, &hit, -wi, from, pdf_dir)
        }
        Some(Source::Sky(tr, le)) => {
            weight * tr * le * environment_weight(scene, lights, wi, from, pdf_dir)
        }
        None => Rgb::ZERO,
    }
}

/// MIS weight of reaching an emitting shape at `hit` (seen from direction `wo`) by a direction
/// sampled with density `pdf_dir` at `from`, against next-event estimation at `from` (with the
/// probabilities next-event estimation chooses lights with there).
pub(crate) fn emission_weight(
    scene: &Scene,
    lights: &LightSampler,
    hit: &Hit,
    wo: Vec3,
    from: &Receiver,
    pdf_dir: f32,
) -> f32 {
    if lights.area_light(hit.tag).is_none() {
        return 1.0;
    }
    let p_l = lights.pdf_li(&scene.lights, hit.tag, from, hit.p, wo.dot(hit.ng));
    if p_l <= 0.0 {
        return 1.0;
    }
    power_heuristic(pdf_dir, p_l)
}

/// MIS weight of reaching the environment light along `wi` by a direction sampled with density
/// `pdf_dir` at `from`, against next-event estimation at `from`.
pub(crate) fn environment_weight(
    scene: &Scene,
    lights: &LightSampler,
    wi: Vec3,
    from: &Receiver,
    pdf_dir: f32,
) -> f32 {
    let p_l = lights.pdf_environment(&scene.lights, from, wi);
    if p_l <= 0.0 {
        return 1.0;
    }
    power_heuristic(pdf_dir, p_l)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Purpose;
    use crate::scene::{CameraDesc, Material as M, SceneBuilder, ShapeDesc};

    /// A receiver at the origin facing up, under panels facing down: `lights` are (side, centre)
    /// of square panels of radiance 1, each half hidden by a 2 × 2 checkerboard of opaque
    /// squares halfway to it (so every light's estimate is noisy: about half its sampled points
    /// are blocked).
    fn panels(lights: &[(f32, Vec3)]) -> Scene {
        let camera = CameraDesc::perspective([0.0, 1.0, 5.0], [0.0, 0.0, 0.0], 40.0);
        let mut b = SceneBuilder::new(camera.resolution(8, 8));
        let black = b.material("black", M::diffuse(0.0)).unwrap();
        for &(side, centre) in lights {
            let panel = ShapeDesc::rectangle(side, side).material(black).emission(1.0);
            b.shape(panel.rotate([90.0, 0.0, 0.0]).translate(centre)).unwrap();
            let cell = side / 4.0;
            for (x, z) in [(-0.5, -0.5), (0.5, 0.5)] {
                let square = ShapeDesc::rectangle(cell, cell).material(black);
                let at = 0.5 * centre + Vec3::new(x * cell, 0.0, z * cell);
                b.shape(square.rotate([90.0, 0.0, 0.0]).translate(at)).unwrap();
            }
        }
        b.build().unwrap()
    }

    /// Next-event estimates at the receiver: (mean, mean square, fourth central moment …) of
    /// `n` samples, and the scene's light sampler.
    fn moments(scene: &Scene, n: u64, seed: u64) -> (f64, f64, f64, LightSampler) {
        let lights = LightSampler::new(&scene.lights, scene.shapes.len());
        let r = Receiver::surface(Vec3::new(0.0, 1e-4, 0.0), Vec3::Y);
        let f = |wi: Vec3| Rgb::splat(wi.y.max(0.0) / std::f32::consts::PI);
        let xs: Vec<f64> = (0..n)
            .map(|i| {
                let mut s = Sampler::new(seed, Purpose::Other, 0, i);
                next_event(scene, &lights, &r, None, &mut s, f, |_| 0.0).x as f64
            })
            .collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        let m4 = xs.iter().map(|x| (x - mean).powi(4)).sum::<f64>() / n as f64;
        (mean, var, m4, lights)
    }

    /// The test against the emitters alone never turns away a ray that reaches one: over rays
    /// from points all over three bundled scenes with area lights (pass-through interfaces, grid
    /// media), every ray whose full query (`cross` without the test) finds an
    /// emitter facing it is one the emitters' own BVH says it meets; and it does turn most rays
    /// away (else it would be a cost, not a saving).
    #[test]
    fn the_emitter_test_keeps_every_ray_that_reaches_an_emitter() {
        let scenes = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        for name in ["cornell-fog.toml", "vdb-edges.toml", "cornell-cloud.toml"] {
            let scene = Scene::load(scenes.join(name)).unwrap();
            let (lo, hi) = scene.bounds;
            let (mut reached, mut passed) = (0, 0);
            let n = 20_000;
            for i in 0..n {
                let mut s = Sampler::new(3, Purpose::Other, 0, i);
                let o = lo + (hi - lo) * Vec3::new(s.next_f32(), s.next_f32(), s.next_f32());
                let d = crate::math::sample_uniform_sphere(s.next_2d());
                let emits = |h: &Hit| {
                    scene.shapes[h.tag as usize].emission.is_some() && (-d).dot(h.ng) > 0.0
                };
                // Start in no medium: which medium the origin lies in does not change geometry.
                let query = Query::Surface;
                let full =
                    cross(&scene, o, d, f32::INFINITY, None, query, emits, 1.0, &mut s, None);
                let kept = scene.emitters.occluded(o, d, f32::INFINITY);
                if let Crossing::Surface(..) = full {
                    reached += 1;
                    assert!(kept, "{name}: ray {i} from {o} along {d} reaches an emitter");
                }
                passed += kept as u32;
            }
            assert!(reached > 0, "{name}: no ray reached an emitter");
            assert!(passed < n as u32 / 2, "{name}: {passed} of {n} rays pass the emitter test");
        }
    }

    /// Two lights 10⁴ apart in power that bring the same light to the receiver: a 0.2 m panel
    /// above and beside it at (0.5, 1, 0), and a 20 m panel 125 m straight above it (power ratio
    /// 10⁴, irradiance equal within 1 %; neither's rays pass the other's panel or occluders).
    /// With one light sample per estimate, the variance of choosing light l with probability p_l
    /// is Σ E[X_l²] / p_l − m², whose least value, at p_l ∝ √E[X_l²], is twice the sum of the
    /// single-light variances when the two contribute equally (so the 1.5× cannot be
    /// reached by any one-sample choice). The test checks (a) that the measured variance is the
    /// one this formula predicts from the single-light moments and the sampler's probabilities,
    /// within the standard errors of the variance estimates (z at the suite's significance), and
    /// (b) that the sampler's probabilities make it at most 2.2× the sum of the single-light
    /// variances: within 10 % of the optimum, where choosing by power would give ~5000×.
    #[test]
    fn two_lights_apart_in_power_but_equal_at_the_receiver() {
        let n = 400_000u64;
        let (near, far) =
            ((0.2f32, Vec3::new(0.5, 1.0, 0.0)), (20.0f32, Vec3::new(0.0, 125.0, 0.0)));
        // Independent streams (seeds 5, 6, 7), so that the three means can be compared by a
        // z-test.
        let (m1, v1, q1, _) = moments(&panels(&[near]), n, 5);
        let (m2, v2, q2, _) = moments(&panels(&[far]), n, 6);
        assert!((m1 / m2 - 1.0).abs() < 0.05, "equal contributions: {m1} vs {m2}");
        let (m, v, q, lights) = moments(&panels(&[near, far]), n, 7);
        let r = Receiver::surface(Vec3::new(0.0, 1e-4, 0.0), Vec3::Y);
        let (p1, p2) = (lights.prob(&r, 0), lights.prob(&r, 1)) as (f32, f32);
        let (p1, p2) = (p1 as f64, p2 as f64);
        let predicted = (v1 + m1 * m1) / p1 + (v2 + m2 * m2) / p2 - (m1 + m2).powi(2);
        // Standard errors of sample variances: √((μ₄ − σ⁴) / n); the prediction's from v1, v2.
        let se = |v: f64, q: f64| ((q - v * v) / n as f64).sqrt();
        let se_pred = ((se(v1, q1) / p1).powi(2) + (se(v2, q2) / p2).powi(2)).sqrt();
        let z = (v - predicted) / (se(v, q).powi(2) + se_pred.powi(2)).sqrt();
        assert!(z.abs() < 3.3, "variance {v} vs predicted {predicted} (z = {z:.2})");
        // Unbiased: the two-light mean is the sum of the single-light means, by a z-test at the
        // suite's significance (two-sided 10⁻³: 3.29) on independent means.
        let z_sum = (m - (m1 + m2)) / ((v + v1 + v2) / n as f64).sqrt();
        assert!(z_sum.abs() < 3.29, "unbiased: {m} vs {} (z = {z_sum:.2})", m1 + m2);
        let ratio = v / (v1 + v2);
        let power = (lights.emission_prob(0) as f64, lights.emission_prob(1) as f64);
        let by_power =
            ((v1 + m1 * m1) / power.0 + (v2 + m2 * m2) / power.1 - (m1 + m2).powi(2)) / (v1 + v2);
        eprintln!(
            "two lights: {ratio:.3}× the single-light sum at p = ({p1:.3}, {p2:.3}); by power {by_power:.0}×"
        );
        assert!(ratio < 2.2, "variance {ratio:.3}× the single-light sum ({p1:.3}, {p2:.3})");
        assert!(by_power > 1000.0, "choosing by power would give {by_power:.0}×");
    }
}
