//! Chi-square tests of the sampling routines: cosine-weighted hemisphere, light emission (point,
//! spot, area) and light selection by power. Each test draws from fixed seeds and rejects at
//! [`SIGNIFICANCE`].

use crate::common::{SIGNIFICANCE, assert_agrees, chi_square_p};
use glam::Vec3;
use haze::math::{Frame, sample_cosine_hemisphere};
use haze::rng::{Purpose, Sampler};
use haze::scene::camera::{Camera, Projection};
use haze::scene::light::LightSampler;
use haze::scene::light::{Emitter, Light};
use haze::scene::material::Material;
use haze::scene::{Geometry, LightDesc, SceneBuilder, shape};
use std::f32::consts::PI;

const N: usize = 200_000;
const BINS: usize = 10;

/// Bins (a, b) ∈ [0, 1)² on a BINS × BINS grid.
fn grid_counts(samples: impl Iterator<Item = (f32, f32)>) -> Vec<u64> {
    let mut counts = vec![0u64; BINS * BINS];
    for (a, b) in samples {
        assert!((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b), "sample out of range");
        let i = ((a * BINS as f32) as usize).min(BINS - 1);
        let j = ((b * BINS as f32) as usize).min(BINS - 1);
        counts[i * BINS + j] += 1;
    }
    counts
}

fn uniform_p() -> Vec<f64> {
    vec![1.0 / (BINS * BINS) as f64; BINS * BINS]
}

fn phi01(v: Vec3) -> f32 {
    (v.y.atan2(v.x) / (2.0 * PI)).rem_euclid(1.0)
}

fn camera() -> Camera {
    Camera::new(Projection::Orthographic { height: 1.0 }, Vec3::Z, Vec3::ZERO, Vec3::Y, [4, 4])
}

#[test]
fn cosine_hemisphere_matches_cos_over_pi() {
    // Under p(ω) = cos θ / π, cos²θ and φ/2π are independent and uniform.
    let mut s = Sampler::new(11, Purpose::Other, 0, 0);
    let counts = grid_counts((0..N).map(|_| {
        let w = sample_cosine_hemisphere(s.next_2d());
        (w.z * w.z, phi01(w))
    }));
    let p = chi_square_p(&counts, &uniform_p());
    assert!(p > SIGNIFICANCE, "p = {p}");
}

#[test]
fn point_light_emits_uniformly_with_its_power() {
    let light = Light::Point { position: Vec3::ONE, intensity: Vec3::splat(2.0) };
    let mut s = Sampler::new(12, Purpose::Other, 0, 0);
    let counts = grid_counts((0..N).map(|_| {
        let e = light.sample_emission(s.next_f32(), s.next_2d(), s.next_2d());
        assert_eq!(e.p, Vec3::ONE);
        assert!((e.beta - light.power()).abs().max_element() < 1e-4);
        ((e.d.z + 1.0) / 2.0, phi01(e.d))
    }));
    let p = chi_square_p(&counts, &uniform_p());
    assert!(p > SIGNIFICANCE, "p = {p}");
}

#[test]
fn spot_light_fills_its_cone_and_carries_its_power() {
    let (cos_max, cos_start) = (35f32.to_radians().cos(), 20f32.to_radians().cos());
    let axis = Vec3::new(0.3, -1.0, 0.2).normalize();
    let power = 10.0;
    let omega = haze::scene::light::spot_solid_angle(cos_max, cos_start);
    let light = Light::Spot {
        position: Vec3::ZERO,
        frame: Frame::new(axis),
        intensity: Vec3::splat(power / omega),
        cos_max,
        cos_start,
    };
    let frame = Frame::new(axis);
    let mut s = Sampler::new(13, Purpose::Other, 0, 0);
    let mut betas = Vec::new();
    let counts = grid_counts((0..N).map(|_| {
        let e = light.sample_emission(s.next_f32(), s.next_2d(), s.next_2d());
        betas.push(e.beta.x as f64);
        let local = frame.to_local(e.d);
        ((1.0 - local.z) / (1.0 - cos_max), phi01(local))
    }));
    let p = chi_square_p(&counts, &uniform_p());
    assert!(p > SIGNIFICANCE, "direction p = {p}");
    // E[β] = Φ: the photons carry the spot's power on average (batch means for the t-test).
    let batches: Vec<f64> =
        betas.chunks(N / 20).map(|c| c.iter().sum::<f64>() / c.len() as f64).collect();
    assert_agrees("spot power", &batches, power as f64, 0.0);
}

#[test]
fn area_light_emits_uniformly_by_area_with_cosine_directions() {
    // A 2 × 1 rectangle in the xy-plane facing +z, made of two triangles of equal area, plus a
    // small third triangle: positions must be uniform by area over all of them.
    let mut b = SceneBuilder::new(camera());
    let m = b.material("m", Material::Diffuse { albedo: Vec3::splat(0.5) }).unwrap();
    b.shape(Geometry::Mesh(shape::rectangle(2.0, 1.0)), m, Some(Vec3::ONE)).unwrap();
    let scene = b.build().unwrap();
    let Light::Area { emitter, .. } = &scene.lights[0] else { panic!("no area light") };
    assert!(matches!(emitter, Emitter::Triangles { .. }));
    assert!((emitter.area() - 2.0).abs() < 1e-6);
    let light = &scene.lights[0];
    assert!((light.power() - Vec3::splat(2.0 * PI)).abs().max_element() < 1e-4);
    let mut s = Sampler::new(14, Purpose::Other, 0, 0);
    let mut dirs = Vec::new();
    let positions = grid_counts((0..N).map(|_| {
        let e = light.sample_emission(s.next_f32(), s.next_2d(), s.next_2d());
        assert!((e.n - Vec3::Z).length() < 1e-6);
        dirs.push(e.d);
        ((e.p.x + 1.0) / 2.0, e.p.y + 0.5)
    }));
    let p = chi_square_p(&positions, &uniform_p());
    assert!(p > SIGNIFICANCE / 2.0, "position p = {p}");
    let directions = grid_counts(dirs.iter().map(|d| (d.z * d.z, phi01(*d))));
    let p = chi_square_p(&directions, &uniform_p());
    assert!(p > SIGNIFICANCE / 2.0, "direction p = {p}");
}

#[test]
fn lights_are_chosen_in_proportion_to_power() {
    let mut b = SceneBuilder::new(camera());
    let powers = [1.0f32, 3.0, 6.0, 0.5];
    for (i, &w) in powers.iter().enumerate() {
        let position = Vec3::new(i as f32, 0.0, 0.0);
        b.light(LightDesc::Point { position, power: Vec3::splat(w) }).unwrap();
    }
    let scene = b.build().unwrap();
    let sampler = LightSampler::new(&scene.lights, scene.shapes.len());
    let total: f32 = powers.iter().sum();
    let mut counts = vec![0u64; powers.len()];
    let mut s = Sampler::new(15, Purpose::Other, 0, 0);
    for _ in 0..N {
        let (i, p) = sampler.pick(s.next_f32());
        assert!((p - powers[i] / total).abs() < 1e-6);
        counts[i] += 1;
    }
    let expected: Vec<f64> = powers.iter().map(|&w| (w / total) as f64).collect();
    let p = chi_square_p(&counts, &expected);
    assert!(p > SIGNIFICANCE, "p = {p}");
}

/// Henyey–Greenstein sampling: directions follow p(cos θ) (chi-square over cos θ × φ bins, with
/// expected bin probabilities integrated numerically from the phase function), and the mean cosine
/// between the incoming and outgoing directions of travel equals g (t-test on batch means).
#[test]
fn henyey_greenstein_sampling_matches_its_density_and_mean_cosine() {
    use haze::medium::phase::HenyeyGreenstein;
    const COS_BINS: usize = 20;
    for (k, g) in [-0.95f32, -0.4, 0.0, 0.3, 0.8, 0.95].into_iter().enumerate() {
        let hg = HenyeyGreenstein { g };
        let d_in = Vec3::new(0.2, -0.5, 0.84).normalize();
        let frame = Frame::new(d_in);
        // Expected probability of each (cos θ, φ) bin: ∫ 2π p(c) dc / BINS over the cos bin.
        let mut expected = Vec::with_capacity(COS_BINS * BINS);
        for i in 0..COS_BINS {
            let (a, b) = (
                -1.0 + 2.0 * i as f64 / COS_BINS as f64,
                -1.0 + 2.0 * (i + 1) as f64 / COS_BINS as f64,
            );
            let steps = 2000;
            let h = (b - a) / steps as f64;
            let mass: f64 = (0..steps)
                .map(|j| {
                    hg.eval_cos((a + (j as f64 + 0.5) * h) as f32) as f64
                        * 2.0
                        * std::f64::consts::PI
                        * h
                })
                .sum();
            expected.extend(std::iter::repeat_n(mass / BINS as f64, BINS));
        }
        let total: f64 = expected.iter().sum();
        assert!((total - 1.0).abs() < 1e-3, "g = {g}: p integrates to {total}");
        let mut s = Sampler::new(20 + k as u64, Purpose::Other, 0, 0);
        let mut counts = vec![0u64; COS_BINS * BINS];
        let mut cosines = Vec::with_capacity(N);
        for _ in 0..N {
            let ps = hg.sample(d_in, s.next_2d());
            let local = frame.to_local(ps.d_out);
            let c = local.z.clamp(-1.0, 1.0);
            cosines.push(ps.d_out.dot(d_in) as f64);
            assert!((ps.value - hg.eval_cos(c)).abs() <= 1e-3 * ps.value.max(1.0));
            let i = (((c + 1.0) / 2.0 * COS_BINS as f32) as usize).min(COS_BINS - 1);
            let j = ((phi01(local) * BINS as f32) as usize).min(BINS - 1);
            counts[i * BINS + j] += 1;
        }
        let p = chi_square_p(&counts, &expected);
        assert!(p > SIGNIFICANCE / 6.0, "g = {g}: chi-square p = {p}");
        let batches: Vec<f64> =
            cosines.chunks(N / 20).map(|c| c.iter().sum::<f64>() / c.len() as f64).collect();
        assert_agrees(&format!("mean cosine, g = {g}"), &batches, g as f64, 0.0);
    }
}
