//! Single scattering along a segment of an eye path in a medium: the light that reaches a point
//! of the segment straight from a light (through pass-through interfaces only) and scatters once
//! towards the eye,
//!
//!   L₁ = ∫ T(0, t) σ_s(x_t) ∫ f_p(ω', −ω) L_d(x_t, ω') dω' dt,
//!
//! estimated by next-event estimation at distances drawn two ways and combined by multiple
//! importance sampling (balance heuristic; Veach 1997):
//!
//! - **equiangular sampling** towards a point y of the light (Kulla & Fajardo, "Importance
//!   Sampling Techniques for Path Tracing in Participating Media", EGSR 2012): t = Δ + D tan θ
//!   with θ uniform between the angles under which the segment's ends are seen from y, density
//!   D / ((θ_b − θ_a)(D² + (t − Δ)²)) — proportional to the 1/d² of the light's contribution, so
//!   points close to a point, spot or small area light are neither missed nor huge;
//! - **distances proportional to the transmittance** ([`TransmittanceDistance`]), which follow
//!   the medium where the light is far or spread out (directional lights, large area lights,
//!   dense media).
//!
//! The equiangular strategy chooses a light with a position for the whole segment
//! ([`LightSampler::pick_along`]), a point of it, then the distance; the transmittance strategy
//! draws the distance first and chooses the light at that point, as next-event estimation does
//! there ([`LightSampler::pick`]). The balance heuristic runs over (distance, light, point), so
//! the combination is unbiased whatever the segment's choice is (the transmittance strategy
//! alone reaches every light that can contribute); with one light in the scene both choose it and
//! share its point, as before lights were chosen by receiver. Directional lights have no point:
//! only the transmittance strategy reaches them. Shadow rays pass through pass-through
//! interfaces, with exact transmittance in homogeneous media and ratio tracking in grids
//! (docs/theory.md, "Single scattering along a segment").

use super::direct::{emitted, power_heuristic, shadow};
use crate::estimate::volume::EyeSegment;
use crate::math::Rgb;
use crate::medium::{Medium, SegmentTransmittance, TransmittanceDistance};
use crate::rng::Sampler;
use crate::scene::Scene;
use crate::scene::light::{LightPoint, LightSampler, Receiver, Segment};
use glam::Vec3;

/// Equiangular sampling of t ∈ [t0, t1] on the ray o + t d towards the point y.
struct Equiangular {
    /// Parameter of the point of the ray nearest y, and its distance from y.
    delta: f32,
    dist: f32,
    theta_a: f32,
    theta_b: f32,
}

impl Equiangular {
    fn new(o: Vec3, d: Vec3, y: Vec3, t0: f32, t1: f32) -> Option<Self> {
        let delta = (y - o).dot(d);
        let dist = (y - (o + d * delta)).length();
        // A ray through the light's point: the density would be singular.
        if dist.is_nan() || dist <= 1e-6 * (1.0 + delta.abs()) {
            return None;
        }
        let theta_a = ((t0 - delta) / dist).atan();
        let theta_b =
            if t1.is_finite() { ((t1 - delta) / dist).atan() } else { std::f32::consts::FRAC_PI_2 };
        (theta_b > theta_a).then_some(Self { delta, dist, theta_a, theta_b })
    }

    fn sample(&self, u: f32) -> (f32, f32) {
        let theta = self.theta_a + u * (self.theta_b - self.theta_a);
        let t = self.delta + self.dist * theta.tan();
        (t, self.pdf(t))
    }

    fn pdf(&self, t: f32) -> f32 {
        let x = t - self.delta;
        self.dist / ((self.theta_b - self.theta_a) * (self.dist * self.dist + x * x))
    }
}

/// The single-scattered radiance along `segment` in medium `id` (`medium`), whose transmittance
/// from the segment's start is `tr`: an unbiased estimate of L₁ (module docs), to be multiplied by
/// the eye path's throughput.
pub(crate) fn single_scattering(
    scene: &Scene,
    lights: &LightSampler,
    segment: &EyeSegment,
    (id, medium): (u32, &Medium),
    tr: &SegmentTransmittance,
    s: &mut Sampler,
) -> Rgb {
    let EyeSegment { o, w: d, t_max } = *segment;
    if lights.is_empty() {
        return Rgb::ZERO;
    }
    let Some((t0, t1)) = medium.scattering_extent(o, d, t_max) else { return Rgb::ZERO };
    let tr_mean = |t: f32| crate::math::luminance(tr.at(t));
    let seg = Segment { o, d, t0, t1, tr: &tr_mean };
    // Strategy E (equiangular): a light with a position chosen for the segment, a point of it,
    // and a distance towards that point.
    let u_light = s.next_f32();
    let e_light = lights.pick_along(&seg, u_light);
    let e_point = e_light.and_then(|(li, _)| scene.lights[li].sample_point(s));
    let along = TransmittanceDistance::new(tr, t0, t1);
    let towards = e_point.as_ref().and_then(|y| Equiangular::new(o, d, y.p, t0, t1));
    let (u_e, u_a) = (s.next_f32(), s.next_f32());
    let t_e = towards.as_ref().map(|e| e.sample(u_e));
    let t_a = along.as_ref().map(|a| a.sample(u_a));
    // Strategy A (transmittance): a distance, then a light chosen at that point. With one light
    // in the scene the choice is that light, whose point strategy E has drawn already.
    let u_pick = if lights.len() > 1 { s.next_f32() } else { 0.0 };
    let p_a = |t: f32| along.as_ref().map_or(0.0, |a| a.pdf(t));
    let p_e = |t: f32| towards.as_ref().map_or(0.0, |e| e.pdf(t));
    let mut sum = Rgb::ZERO;
    if let (Some((t, pdf)), Some((li, p_seg)), Some(y)) = (t_e, e_light, e_point.as_ref()) {
        if pdf > 0.0 && t.is_finite() {
            let x = o + d * t;
            let p_light = lights.prob(&Receiver::medium(x), li);
            // A light the sampler gives no chance at x cannot light x (outside a spot's cone,
            // behind a panel; the transmittance strategy, which alone reaches every light,
            // relies on that), but for the f32 rounding of the light tree's cone test at the
            // edge of a spot's falloff, where the light is next to nothing: no light part then
            // (it divided by p_light = 0: 0 · ∞ = NaN, 2 samples in 12 M on
            // scenes/coloured-smoke.toml), while the phase part stays.
            let c = if p_light > 0.0 {
                let connection = Connection { li, p_light, point: Some(y) };
                // The light part's two densities over (t, light, point) against the phase part's
                // two over t (module docs): with one light they are equal.
                let (pa, pe) = (p_a(t), p_e(t));
                let ratio = (pe + pa) / (pa + p_seg * pe / p_light);
                in_scattered(scene, lights, (id, medium), x, d, Some(&connection), ratio, s)
            } else {
                in_scattered(scene, lights, (id, medium), x, d, None, 0.0, s)
            };
            sum += tr.at(t) * c / (p_e(t) + p_a(t));
        }
    }
    if let Some((t, pdf)) = t_a {
        if pdf > 0.0 && t.is_finite() {
            let x = o + d * t;
            let chosen = lights.pick(&Receiver::medium(x), u_pick);
            let (pa, pe) = (p_a(t), p_e(t));
            let mut ratio = 1.0;
            let mut own_point = None;
            let connection = chosen.map(|(li, p_light)| {
                let point = match e_light {
                    Some((e_li, _)) if e_li == li => e_point.as_ref(),
                    _ => {
                        own_point = scene.lights[li].sample_point(s);
                        own_point.as_ref()
                    }
                };
                // Strategy E's density of this light, point and distance.
                let pe_own = match (point, e_light) {
                    (Some(_), Some((e_li, _))) if e_li == li => pe,
                    (Some(y), _) => Equiangular::new(o, d, y.p, t0, t1).map_or(0.0, |e| e.pdf(t)),
                    (None, _) => 0.0,
                };
                let p_seg = if pe_own > 0.0 { lights.prob_along(&seg, li) } else { 0.0 };
                ratio = (pe + pa) / (pa + p_seg * pe_own / p_light);
                Connection { li, p_light, point }
            });
            let c = in_scattered(scene, lights, (id, medium), x, d, connection.as_ref(), ratio, s);
            sum += tr.at(t) * c / (pe + pa);
        }
    }
    sum
}

/// The light chosen at a point: its index, its selection probability there, and its sampled
/// point (`None` for a directional light).
struct Connection<'a> {
    li: usize,
    p_light: f32,
    point: Option<&'a LightPoint>,
}

/// σ_s(x) ∫ f_p(ω', −d) L_d(x, ω') dω': the direct light at `x` scattered towards the eye, by two
/// strategies combined by MIS (power heuristic over solid-angle densities, as the path tracer's
/// next-event estimation): a shadow ray to the chosen light's point (if a light was chosen),
/// and a phase-sampled direction that may reach an emitter straight away. Phase sampling is what
/// keeps a point close to a large emitter (a glowing wall in dense fog) from being found rarely
/// and hugely by uniform points of the emitter. The light part is scaled by `ratio`, the phase
/// part's density over distances divided by the light part's (module docs).
#[allow(clippy::too_many_arguments)]
fn in_scattered(
    scene: &Scene,
    lights: &LightSampler,
    (id, medium): (u32, &Medium),
    x: Vec3,
    d: Vec3,
    light: Option<&Connection>,
    ratio: f32,
    s: &mut Sampler,
) -> Rgb {
    let sigma_s = medium.sigma_s(x);
    if sigma_s.max_element() <= 0.0 {
        return Rgb::ZERO;
    }
    let phase = medium.phase();
    let mut l = Rgb::ZERO;
    if let Some(light) = light {
        let chosen = &scene.lights[light.li];
        let ls = match light.point {
            Some(y) => chosen.li_from(x, y),
            None => chosen.sample_li(x, s),
        };
        if let Some(ls) = ls {
            let f = phase.eval(d, ls.wi);
            if f > 0.0 && ls.value.max_element() > 0.0 {
                let w =
                    ls.pdf.map_or(1.0, |p| power_heuristic(light.p_light * p, phase.pdf(d, ls.wi)));
                let tr = shadow(scene, x, ls.wi, ls.dist, Some(id), s);
                l += ls.value * tr * (f * w / light.p_light);
            }
        }
    }
    // Phase sampling: an emitter the sampled direction reaches, weighed against light sampling
    // (only area lights can be reached).
    if !lights.reachable() {
        return sigma_s * (l * ratio);
    }
    let ps = phase.sample(d, s.next_2d());
    let from = Receiver::medium(x);
    let weight = Rgb::splat(ps.value / ps.pdf);
    let found = emitted(scene, lights, &from, ps.wi, ps.pdf, weight, Some(id), s);
    sigma_s * (l * ratio + found)
}
