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
//! One light is chosen by power and one point of it sampled (uniformly by area for area lights);
//! both distances connect to that point, so for a fixed point the two strategies sample the same
//! integrand and their balance-heuristic weights sum to one. Directional lights have no point:
//! only the transmittance strategy applies. Shadow rays pass through pass-through interfaces,
//! with exact transmittance in homogeneous media and ratio tracking in grids.

use super::direct::{emitted, power_heuristic, shadow};
use crate::estimate::volume::EyeSegment;
use crate::math::Rgb;
use crate::medium::{Medium, SegmentTransmittance, TransmittanceDistance};
use crate::rng::Sampler;
use crate::scene::Scene;
use crate::scene::light::{LightPoint, LightSampler};
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
    let (li, p_light) = lights.pick(s.next_f32());
    let light = &scene.lights[li];
    let point = light.sample_point(s);
    let along = TransmittanceDistance::new(tr, t0, t1);
    let towards = point.as_ref().and_then(|y| Equiangular::new(o, d, y.p, t0, t1));
    let pdfs = |t: f32| {
        (towards.as_ref().map_or(0.0, |e| e.pdf(t)), along.as_ref().map_or(0.0, |a| a.pdf(t)))
    };
    let mut sum = Rgb::ZERO;
    let (u_e, u_a) = (s.next_f32(), s.next_f32());
    let samples = [towards.as_ref().map(|e| e.sample(u_e)), along.as_ref().map(|a| a.sample(u_a))];
    let light = Connection { lights, li, p_light, point: point.as_ref() };
    for (t, pdf) in samples.into_iter().flatten() {
        if !(pdf > 0.0 && t.is_finite()) {
            continue;
        }
        // Balance heuristic: the weight over the density is 1 / (p_e + p_a).
        let (p_e, p_a) = pdfs(t);
        let x = o + d * t;
        let c = in_scattered(scene, (id, medium), x, d, &light, s);
        sum += tr.at(t) * c / (p_e + p_a);
    }
    sum
}

/// The light chosen for a segment: its index, its selection probability, and its sampled point.
struct Connection<'a> {
    lights: &'a LightSampler,
    li: usize,
    p_light: f32,
    point: Option<&'a LightPoint>,
}

/// σ_s(x) ∫ f_p(ω', −d) L_d(x, ω') dω': the direct light at `x` scattered towards the eye, by two
/// strategies combined by MIS (power heuristic over solid-angle densities, as the path tracer's
/// next-event estimation): a shadow ray to the chosen light's point, and a phase-sampled
/// direction that may reach an emitter straight away. Phase sampling is what keeps a point close
/// to a large emitter (a glowing wall in dense fog) from being found rarely and hugely by uniform
/// points of the emitter.
fn in_scattered(
    scene: &Scene,
    (id, medium): (u32, &Medium),
    x: Vec3,
    d: Vec3,
    light: &Connection,
    s: &mut Sampler,
) -> Rgb {
    let sigma_s = medium.sigma_s(x);
    if sigma_s.max_element() <= 0.0 {
        return Rgb::ZERO;
    }
    let phase = medium.phase();
    let mut l = Rgb::ZERO;
    let chosen = &scene.lights[light.li];
    let ls = match light.point {
        Some(y) => chosen.li_from(x, y),
        None => chosen.sample_li(x, s),
    };
    if let Some(ls) = ls {
        let f = phase.eval(d, ls.wi);
        if f > 0.0 && ls.value.max_element() > 0.0 {
            let w = ls.pdf.map_or(1.0, |p| power_heuristic(light.p_light * p, f));
            let tr = shadow(scene, x, ls.wi, ls.dist, Some(id), s);
            l += ls.value * tr * (f * w / light.p_light);
        }
    }
    // Phase sampling: an emitter the sampled direction reaches, weighed against light sampling
    // (only area lights can be reached).
    if !light.lights.has_area_lights() {
        return sigma_s * l;
    }
    let wi = phase.sample(d, s.next_2d()).d_out;
    let pdf = phase.eval(d, wi);
    sigma_s * (l + emitted(scene, light.lights, x, wi, pdf, Rgb::ONE, Some(id), s))
}
