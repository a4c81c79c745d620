//! The two distributions over a scene's lights. Photons leave the lights in proportion to their
//! emitted power, which spreads the flux correctly over the photon pass. Next-event estimation
//! chooses a light by its estimated contribution at the receiving point instead ([`LightTree`]):
//! power says nothing about which light matters where (a directional light's "power" grows with
//! the scene it is spread over, and choosing by it starves every other light), and every MIS weight
//! that involves light sampling ([`LightSampler::pdf_li`]) uses the same receiver-dependent
//! probabilities.

use super::Light;
use super::tree::{LightTree, Receiver, Segment};
use crate::math::luminance;
use glam::Vec3;

/// Chooses lights for photon emission and for next-event estimation, and knows which shapes are
/// area lights.
pub struct LightSampler {
    /// Cumulative mean-channel power (photon emission).
    cdf: Vec<f32>,
    total: f32,
    /// Next-event estimation.
    tree: LightTree,
    /// For each shape, the index of its area light and that light's area, if it emits.
    area_lights: Vec<Option<(usize, f32)>>,
    /// The index of the environment light, if there is one.
    environment: Option<usize>,
}

impl LightSampler {
    /// The distributions over `lights`, for a scene of `shapes` shapes.
    pub fn new(lights: &[Light], shapes: usize) -> Self {
        let mut total = 0.0;
        let cdf = lights
            .iter()
            .map(|l| {
                total += luminance(l.power());
                total
            })
            .collect();
        let mut area_lights = vec![None; shapes];
        for (i, l) in lights.iter().enumerate() {
            if let Light::Area { shape, emitter, .. } = l {
                area_lights[*shape as usize] = Some((i, emitter.area()));
            }
        }
        let environment = lights.iter().position(|l| matches!(l, Light::Environment(_)));
        Self { cdf, total, tree: LightTree::new(lights), area_lights, environment }
    }

    /// The area light of shape `shape` and its area, if the shape emits.
    pub fn area_light(&self, shape: u32) -> Option<(usize, f32)> {
        self.area_lights.get(shape as usize).copied().flatten()
    }

    /// True if a direction sampled by a BSDF or phase function can reach a light: some shape is
    /// an area light, or an environment light surrounds the scene.
    pub fn reachable(&self) -> bool {
        self.environment.is_some() || self.area_lights.iter().any(Option::is_some)
    }

    /// Total emitted power of the lights (mean channel, W).
    pub fn total_power(&self) -> f32 {
        self.total
    }

    /// True if no light emits anything.
    pub fn is_empty(&self) -> bool {
        self.total <= 0.0
    }

    /// The number of lights.
    pub fn len(&self) -> usize {
        self.cdf.len()
    }

    /// The probability that [`Self::pick_emission`] returns light `i`: its share of the power.
    pub fn emission_prob(&self, i: usize) -> f32 {
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        (self.cdf[i] - lo) / self.total
    }

    /// A light to emit a photon from, in proportion to power: its index and probability.
    pub fn pick_emission(&self, u: f32) -> (usize, f32) {
        let target = u * self.total;
        let i = self.cdf.partition_point(|&c| c <= target).min(self.cdf.len() - 1);
        (i, self.emission_prob(i))
    }

    /// A light for next-event estimation at `r`, by its estimated contribution there: its index
    /// and probability, or `None` if no light can reach `r`. A scene's only light is always
    /// chosen, with probability 1.
    #[inline]
    pub(crate) fn pick(&self, r: &Receiver, u: f32) -> Option<(usize, f32)> {
        self.tree.pick(r, u)
    }

    /// The probability that [`Self::pick`] returns light `i` at `r`.
    #[inline]
    pub(crate) fn prob(&self, r: &Receiver, i: usize) -> f32 {
        self.tree.prob(r, i)
    }

    /// A light with a position (point, spot, area) for equiangular single scattering along
    /// `seg`: its index and probability, or `None` if there is none.
    #[inline]
    pub(crate) fn pick_along(&self, seg: &Segment, u: f32) -> Option<(usize, f32)> {
        self.tree.pick_along(seg, u)
    }

    /// The probability that [`Self::pick_along`] returns light `i` for `seg`.
    #[inline]
    pub(crate) fn prob_along(&self, seg: &Segment, i: usize) -> f32 {
        self.tree.prob_along(seg, i)
    }

    /// The density with which next-event estimation at `from` (choosing a light with
    /// [`Self::pick`], then [`Light::sample_li`]) picks the direction towards the point `to` of
    /// the emitting shape `shape`, whose surface there has the cosine `cos_l` with that direction:
    /// P(light | from) · d² / (|cos_l| · area), per solid angle. Zero if the shape does not emit.
    pub(crate) fn pdf_li(
        &self,
        lights: &[Light],
        shape: u32,
        from: &Receiver,
        to: Vec3,
        cos_l: f32,
    ) -> f32 {
        let Some((li, _)) = self.area_light(shape) else { return 0.0 };
        let pdf = lights[li].pdf_li(from.p, to, cos_l);
        if pdf <= 0.0 {
            return 0.0;
        }
        self.prob(from, li) * pdf
    }

    /// The density with which next-event estimation at `from` picks the direction `wi` towards
    /// the environment light: P(environment | from) · its density of `wi`. Zero without one.
    pub(crate) fn pdf_environment(&self, lights: &[Light], from: &Receiver, wi: Vec3) -> f32 {
        let Some(li) = self.environment else { return 0.0 };
        let Light::Environment(env) = &lights[li] else { return 0.0 };
        let pdf = env.pdf(wi);
        if pdf <= 0.0 {
            return 0.0;
        }
        self.prob(from, li) * pdf
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::rectangle;
    use super::super::{Emitter, Light, spot_solid_angle};
    use super::*;
    use crate::math::{Frame, Rgb, sample_uniform_sphere};
    use crate::rng::{Purpose, Sampler};
    use crate::testing::{SIGNIFICANCE, chi_square_p};
    use std::f32::consts::PI;

    fn point(p: Vec3, power: f32) -> Light {
        Light::Point { position: p, intensity: Rgb::splat(power / (4.0 * PI)) }
    }

    fn spot(p: Vec3, axis: Vec3, intensity: f32, cone: f32, start: f32) -> Light {
        Light::Spot {
            position: p,
            frame: Frame::new(axis.normalize()),
            intensity: Rgb::splat(intensity),
            cos_max: cone.to_radians().cos(),
            cos_start: start.to_radians().cos(),
        }
    }

    fn sun(direction: Vec3, e: f32, size: f32) -> Light {
        Light::directional(
            direction.normalize(),
            Rgb::splat(e),
            (-Vec3::ONE * size, Vec3::ONE * size),
        )
    }

    /// A rectangle area light of radiance `l` centred at `c`, facing +z (or −z if `down`).
    fn panel(shape: u32, c: Vec3, l: f32, down: bool) -> Light {
        let emitter = match rectangle(c) {
            Emitter::Triangles { triangles, cdf } if down => Emitter::Triangles {
                triangles: triangles.into_iter().map(|[a, b, c]| [a, c, b]).collect(),
                cdf,
            },
            e => e,
        };
        Light::Area { shape, radiance: Rgb::splat(l), emitter }
    }

    /// Photons leave the lights in proportion to their mean-channel power (chi-square), with the
    /// probability `pick_emission` reports.
    #[test]
    fn photons_leave_lights_in_proportion_to_power() {
        let powers = [1.0f32, 3.0, 6.0, 0.5];
        let mut lights: Vec<Light> = powers
            .iter()
            .enumerate()
            .map(|(i, &w)| point(Vec3::new(i as f32, 0.0, 0.0), w))
            .collect();
        lights.push(panel(1, Vec3::ZERO, 1.0 / PI, false));
        let sampler = LightSampler::new(&lights, 2);
        let powers = [1.0f32, 3.0, 6.0, 0.5, 2.0];
        let total: f32 = powers.iter().sum();
        let mut counts = vec![0u64; powers.len()];
        let mut s = Sampler::new(15, Purpose::Other, 0, 0);
        for _ in 0..200_000 {
            let (i, p) = sampler.pick_emission(s.next_f32());
            assert!((p - powers[i] / total).abs() < 1e-6);
            counts[i] += 1;
        }
        let expected: Vec<f64> = powers.iter().map(|&w| (w / total) as f64).collect();
        let p = chi_square_p(&counts, &expected);
        assert!(p > SIGNIFICANCE, "p = {p}");
        assert_eq!(sampler.area_light(1), Some((4, 2.0)));
        assert_eq!(sampler.area_light(0), None);
    }

    /// A scene of many lights of every kind: random points, spots, panels facing either way, a
    /// sphere and two suns.
    fn many_lights(s: &mut Sampler) -> Vec<Light> {
        let mut lights = Vec::new();
        let at =
            |s: &mut Sampler| (Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) - 0.5) * 8.0;
        for i in 0..40u32 {
            let p = at(s);
            let w = 0.1 + 10.0 * s.next_f32();
            lights.push(match i % 4 {
                0 => point(p, w),
                1 => {
                    spot(p, sample_uniform_sphere(s.next_2d()), w, 20.0 + 40.0 * s.next_f32(), 10.0)
                }
                2 => panel(i, p, w, s.next_f32() < 0.5),
                _ => point(p, 1e-3 * w),
            });
        }
        lights.push(Light::Area {
            shape: 40,
            radiance: Rgb::splat(2.0),
            emitter: Emitter::Sphere { center: Vec3::new(1.0, 2.0, -1.0), radius: 0.3 },
        });
        lights.push(sun(Vec3::new(0.3, -1.0, 0.2), 1.5, 100.0));
        lights.push(sun(Vec3::new(-0.6, -0.2, 0.5), 0.2, 100.0));
        lights
    }

    /// Next-event estimation's choice follows the probabilities `prob` reports, which sum to one
    /// (chi-square at receivers in a medium and on surfaces, among 43 lights), and `pick` reports
    /// the probability of the light it returns.
    #[test]
    fn receiver_choice_follows_its_probabilities() {
        let mut s = Sampler::new(21, Purpose::Other, 0, 0);
        let lights = many_lights(&mut s);
        let sampler = LightSampler::new(&lights, 41);
        let receivers = [
            Receiver::medium(Vec3::new(0.2, 0.1, -0.3)),
            Receiver::medium(Vec3::new(3.5, -2.0, 1.0)),
            Receiver::surface(Vec3::new(-1.0, 0.5, 0.5), Vec3::Y),
            Receiver::surface(Vec3::new(2.0, -3.5, 0.0), Vec3::new(0.3, 0.4, -0.8).normalize()),
        ];
        for r in receivers {
            let mut probs: Vec<f64> =
                (0..lights.len()).map(|i| sampler.prob(&r, i) as f64).collect();
            // A walk may end in a group whose bounds promised light that none of its lights can
            // bring: "no light", an unbiased choice, is the last category.
            let sum: f64 = probs.iter().sum();
            assert!(sum <= 1.0 + 1e-4 && sum > 0.5, "probabilities sum to {sum} at {r:?}");
            probs.push((1.0 - sum).max(0.0));
            let mut counts = vec![0u64; probs.len()];
            for _ in 0..400_000 {
                match sampler.pick(&r, s.next_f32()) {
                    Some((i, p)) => {
                        assert!((p as f64 / probs[i] - 1.0).abs() < 1e-4, "pick's probability");
                        counts[i] += 1;
                    }
                    None => counts[lights.len()] += 1,
                }
            }
            let p = chi_square_p(&counts, &probs);
            assert!(p > SIGNIFICANCE / 8.0, "p = {p} at {r:?}");
        }
        // With a few lights every light is judged by its own importance: the probabilities sum
        // to one and are in proportion to the importances.
        let few = &lights[..6];
        let sampler = LightSampler::new(few, 41);
        let r = Receiver::medium(Vec3::new(0.3, -0.2, 0.1));
        let probs: Vec<f32> = (0..few.len()).map(|i| sampler.prob(&r, i)).collect();
        let imps: Vec<f32> = few
            .iter()
            .map(|l| super::super::tree::LightBounds::of(l).unwrap().importance(&r))
            .collect();
        let total: f32 = imps.iter().sum();
        for (p, imp) in probs.iter().zip(&imps) {
            assert!((p - imp / total).abs() < 1e-5, "{probs:?} vs {imps:?}");
        }
    }

    /// The segment choice of single scattering follows `prob_along` (chi-square) among the
    /// lights with a position; directional lights are never chosen there.
    #[test]
    fn segment_choice_follows_its_probabilities() {
        let mut s = Sampler::new(22, Purpose::Other, 0, 0);
        let lights = many_lights(&mut s);
        let sampler = LightSampler::new(&lights, 41);
        let tr = |t: f32| (-0.2 * t).exp();
        for (o, d, t1) in [
            (Vec3::new(-4.0, 0.0, 0.0), Vec3::X, 8.0),
            (Vec3::new(1.0, 1.0, 5.0), Vec3::new(0.1, -0.2, -1.0).normalize(), f32::INFINITY),
        ] {
            let seg = Segment { o, d, t0: 0.5, t1, tr: &tr };
            let probs: Vec<f64> =
                (0..lights.len()).map(|i| sampler.prob_along(&seg, i) as f64).collect();
            assert!((probs.iter().sum::<f64>() - 1.0).abs() < 1e-4);
            assert_eq!(probs[41..], [0.0, 0.0], "suns have no point to aim at");
            let mut counts = vec![0u64; lights.len()];
            for _ in 0..400_000 {
                let (i, p) = sampler.pick_along(&seg, s.next_f32()).unwrap();
                assert!((p as f64 / probs[i] - 1.0).abs() < 1e-4);
                counts[i] += 1;
            }
            let p = chi_square_p(&counts, &probs);
            assert!(p > SIGNIFICANCE / 2.0, "p = {p}");
        }
    }

    /// Lights that cannot reach a receiver are never chosen there, and lights that can always
    /// may be: behind a one-sided panel, outside a spot's cone, a sun or a point light below a
    /// surface's horizon.
    #[test]
    fn lights_that_cannot_reach_a_receiver_are_never_chosen() {
        let lights = [
            panel(0, Vec3::new(0.0, 0.0, 2.0), 5.0, true), // faces down, at z = 2
            spot(Vec3::new(5.0, 0.0, 0.0), -Vec3::X, 100.0, 10.0, 5.0),
            sun(-Vec3::Z, 1.0, 10.0),
            point(Vec3::new(0.0, 3.0, -3.0), 10.0),
        ];
        let sampler = LightSampler::new(&lights, 1);
        let p = |r: Receiver| -> Vec<f32> { (0..4).map(|i| sampler.prob(&r, i)).collect() };
        // In a medium below the panel, on the spot's axis: every light reaches it.
        let all = p(Receiver::medium(Vec3::ZERO));
        assert!(all.iter().all(|&x| x > 0.0), "{all:?}");
        // Above the panel (behind it), 45° off the spot's axis: neither reaches.
        let probs = p(Receiver::medium(Vec3::new(0.0, 0.0, 5.0)));
        assert_eq!((probs[0], probs[1]), (0.0, 0.0), "{probs:?}");
        assert!(probs[2] > 0.0 && probs[3] > 0.0, "{probs:?}");
        // 30° off the spot's axis, below the panel: only the spot cannot reach.
        let off = Vec3::new(5.0, 0.0, 0.0) + Vec3::new(-1.0, 30f32.to_radians().tan(), 0.0) * 2.0;
        let probs = p(Receiver::medium(off));
        assert_eq!(probs[1], 0.0, "{probs:?}");
        assert!(probs[0] > 0.0 && probs[2] > 0.0 && probs[3] > 0.0, "{probs:?}");
        // A surface facing down below the panel: the panel and the sun (light travelling down)
        // reach only its back and the spot's cone misses it (22° off the axis); the point light,
        // to its side and below it, is the only choice left.
        let r = Receiver::surface(Vec3::new(0.0, 0.0, -2.0), -Vec3::Z);
        let probs = p(r);
        assert_eq!((probs[0], probs[1], probs[2]), (0.0, 0.0, 0.0), "{probs:?}");
        assert_eq!(sampler.pick(&r, 0.5), Some((3, 1.0)));
    }

    /// A directional light's share at a receiver does not depend on the scene it is spread over
    /// (its power does), and a scene's only light is chosen with probability 1 wherever it is.
    #[test]
    fn directional_importance_ignores_the_scene_size() {
        let r = Receiver::surface(Vec3::new(0.5, 0.0, 0.0), Vec3::Y);
        let spot_light = spot(Vec3::new(0.0, 3.0, 0.0), -Vec3::Y, 30.0, 25.0, 20.0);
        let probs: Vec<f32> = [10.0f32, 1000.0]
            .iter()
            .map(|&radius| {
                let lights = [sun(-Vec3::Y, 1.2, radius), spot_light.clone()];
                LightSampler::new(&lights, 0).prob(&r, 1)
            })
            .collect();
        assert_eq!(probs[0], probs[1]);
        // The spot brings I/d² ≈ 30/9.25 against the sun's 1.2 (cos ≈ 1 for both).
        let want = (30.0 / 9.25) / (30.0 / 9.25 + 1.2);
        assert!((probs[0] - want).abs() < 0.02, "{probs:?} vs {want}");
        for light in [sun(-Vec3::Y, 1.0, 3.0), spot_light, panel(0, Vec3::ZERO, 1.0, false)] {
            let one = LightSampler::new(std::slice::from_ref(&light), 1);
            let behind = Receiver::surface(Vec3::new(0.0, 0.0, -5.0), -Vec3::Z);
            assert_eq!(one.pick(&behind, 0.7), Some((0, 1.0)));
            assert_eq!(one.prob(&behind, 0), 1.0);
        }
    }

    /// `pdf_li` is the receiver's probability of the area light times d² / (|cos| A).
    #[test]
    fn pdf_li_uses_the_receivers_probabilities() {
        let lights = [panel(1, Vec3::ZERO, 1.0, false), point(Vec3::new(0.0, 0.0, 3.0), 5.0)];
        let sampler = LightSampler::new(&lights, 2);
        let from = Receiver::medium(Vec3::new(0.0, 0.0, 2.0));
        let pdf = sampler.pdf_li(&lights, 1, &from, Vec3::ZERO, 0.5);
        let want = sampler.prob(&from, 0) * 4.0 / (0.5 * 2.0);
        assert!(sampler.prob(&from, 0) > 0.0 && (pdf - want).abs() < 1e-6 * want);
        assert_eq!(
            sampler.pdf_li(&lights, 0, &from, Vec3::ZERO, 0.5),
            0.0,
            "shape 0 does not emit"
        );
        assert_eq!(lights[1].pdf_li(from.p, Vec3::ZERO, 0.5), 0.0, "a point light has no density");
        let _ = spot_solid_angle(0.5, 0.9);
    }
}
