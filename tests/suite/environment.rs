//! Environment lights against known answers: a white furnace lit by a constant environment, in
//! every integrator; a map-lit scene on which the path tracer and the photon modes agree; and
//! the scene format's environment table, with its errors.

use crate::common::{assert_agrees, mean_and_se, t_critical};
use crate::media::{METHODS, homogeneous, volume_settings};
use haze::glam::Vec3;
use haze::progress::Silent;
use haze::scene::{CameraDesc, EnvMap, LightDesc, Material, MediumDesc, SceneBuilder, ShapeDesc};
use haze::settings::{Integrator, RenderSettings, VolumeEstimate};
use haze::{Image, Scene};
use std::sync::atomic::AtomicBool;

fn render(scene: &Scene, settings: &RenderSettings) -> Image {
    haze::render(scene, settings, &mut Silent, &AtomicBool::new(false)).unwrap()
}

/// Half-angle of the furnace camera's view cone (diagonal), degrees.
const FOV_DEG: f32 = 20.0;

/// A unit sphere of `medium` (a pass-through boundary) in vacuum under the environment `light`;
/// the camera sits at its centre, in the medium.
fn sphere_under(light: LightDesc, medium: MediumDesc) -> Scene {
    let camera = CameraDesc::perspective(Vec3::ZERO, -Vec3::Z, FOV_DEG).resolution(8, 8);
    let mut b = SceneBuilder::new(camera.medium("fog"));
    b.medium("fog", medium).unwrap();
    b.material("boundary", Material::Interface).unwrap();
    b.shape(ShapeDesc::sphere(Vec3::ZERO, 1.0).material("boundary").interior("fog")).unwrap();
    b.light(light).unwrap();
    b.build().unwrap()
}

/// Mean pixel of each seed's render, per channel.
fn means(scene: &Scene, settings: impl Fn(u64) -> RenderSettings, seeds: u64) -> Vec<[f64; 3]> {
    (0..seeds).map(|seed| mean_and_bias(&render(scene, &settings(seed))).0).collect()
}

/// An image's mean pixel and the mean of its kernel-bias layer (zero without one), per channel.
fn mean_and_bias(img: &Image) -> ([f64; 3], [f64; 3]) {
    assert_eq!(img.info.nonfinite_samples, 0);
    let n = img.pixels.len() as f64;
    let (mut m, mut b) = ([0.0; 3], [0.0; 3]);
    for (i, p) in img.pixels.iter().enumerate() {
        for c in 0..3 {
            m[c] += p[c] as f64 / n;
            b[c] += img.bias.as_ref().map_or(0.0, |bias| bias[i][c] as f64) / n;
        }
    }
    (m, b)
}

/// White furnace under the sky: a non-absorbing medium in vacuum, lit by a constant environment
/// of radiance L, has radiance L everywhere in every direction (whatever its density and phase
/// function), so every pixel of a camera inside it is L — through the environment's next-event
/// estimation (with MIS against phase sampling), its photons from the emitting disc, eye paths
/// that leave the medium and see it, and the combined estimator's weights.
///
/// Bias of the kernel estimates: the support they lose beyond the sphere. Every eye ray from the
/// centre leaves the sphere at distance 1 along its normal; only collisions within r of it lose
/// support, with probability at most σ_t r e^{−σ_t (1 − r)}, and at most half of it (the sphere is
/// convex), so the pixel mean's bias is at most L σ_t r / 2 · e^{−σ_t (1 − r)} per channel.
#[test]
fn white_furnace_under_a_constant_environment_in_every_integrator() {
    let le = Vec3::new(0.5, 0.6, 0.8);
    let cases = [(Vec3::splat(0.7), 0.0f32, 0.03f64), (Vec3::new(0.5, 1.5, 3.0), 0.6, 0.02)];
    let combined = (VolumeEstimate::Beam, Integrator::Combined);
    for (sigma_s, g, r) in cases {
        let scene = sphere_under(LightDesc::environment(le), homogeneous(Vec3::ZERO, sigma_s, g));
        for (estimate, integrator) in METHODS.into_iter().chain([combined]) {
            let settings = |seed| {
                let mut s = volume_settings(estimate, r, seed);
                s.integrator = integrator;
                s.max_bounces = 1000;
                s
            };
            let per_seed = means(&scene, settings, 12);
            for c in 0..3 {
                let sigma = sigma_s[c] as f64;
                let bias = match integrator {
                    Integrator::Path => 0.0,
                    _ => le[c] as f64 * sigma * r / 2.0 * (-sigma * (1.0 - r)).exp(),
                };
                let xs: Vec<f64> = per_seed.iter().map(|m| m[c]).collect();
                let what = format!(
                    "environment furnace σ_s = {sigma_s}, g = {g}, {estimate:?}, {integrator:?}, \
                     channel {c}"
                );
                assert_agrees(&what, &xs, le[c] as f64, bias);
            }
        }
    }
}

/// A 32 × 16 sky for the tests: blue overhead, paler towards the horizon, a sun of 4 texels at
/// 40° elevation, dark ground.
pub(crate) fn test_sky() -> EnvMap {
    let (w, h) = (32u32, 16u32);
    let mut t = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let c = if y >= h / 2 {
                [0.08, 0.07, 0.06]
            } else if (11..13).contains(&x) && (3..5).contains(&y) {
                [300.0, 280.0, 250.0]
            } else {
                let f = y as f32 / (h / 2) as f32;
                [0.2 + 0.5 * f, 0.35 + 0.4 * f, 0.9]
            };
            t.push(c);
        }
    }
    EnvMap::new(w, h, t).unwrap()
}

/// A grey floor and a box under the test sky, with a block of thin fog beside the box.
fn sky_scene(visible: bool) -> Scene {
    let camera = CameraDesc::perspective([0.0, 1.2, 4.0], [0.0, 0.3, 0.0], 45.0).resolution(12, 9);
    let mut b = SceneBuilder::new(camera);
    b.material("grey", Material::diffuse(0.6)).unwrap();
    b.material("boundary", Material::Interface).unwrap();
    b.medium("fog", homogeneous(Vec3::splat(0.05), Vec3::splat(0.4), 0.3)).unwrap();
    let floor = ShapeDesc::rectangle(6.0, 6.0).material("grey").rotate([-90.0, 0.0, 0.0]);
    b.shape(floor).unwrap();
    b.shape(ShapeDesc::cuboid([0.8, 0.8, 0.8]).material("grey").translate([0.4, 0.4, 0.0]))
        .unwrap();
    let fog = ShapeDesc::cuboid([1.8, 1.5, 2.0]).material("boundary").interior("fog");
    b.shape(fog.translate([-1.0, 0.76, 0.5])).unwrap();
    let sky = LightDesc::environment_map(test_sky()).rotate([0.0, 30.0, 0.0]).visible(visible);
    b.light(sky).unwrap();
    b.build().unwrap()
}

/// On a map-lit scene with a floor, a box and fog, the photon modes (both estimates) agree with
/// the path tracer in every channel of the image mean, once each render's kernel bias, as its
/// own bias layer estimates it, is taken off (two-sample t-test on independent seeds); hiding
/// the environment from camera rays leaves the rest of the image as it was.
#[test]
fn a_map_lit_scene_agrees_across_integrators() {
    let scene = sky_scene(true);
    let settings = |integrator, estimate, seed: u64| RenderSettings {
        integrator,
        volume_estimate: estimate,
        iterations: Some(4),
        photons: 100_000,
        radius: Some(0.03),
        volume_radius: Some(0.03),
        max_bounces: 8,
        seed: seed + 100,
        ..RenderSettings::default()
    };
    let runs = |integrator, estimate| -> Vec<[f64; 3]> {
        (0..16)
            .map(|seed| {
                let (m, b) = mean_and_bias(&render(&scene, &settings(integrator, estimate, seed)));
                [m[0] - b[0], m[1] - b[1], m[2] - b[2]]
            })
            .collect()
    };
    let path = runs(Integrator::Path, VolumeEstimate::Beam);
    for (integrator, estimate) in [
        (Integrator::Hybrid, VolumeEstimate::Beam),
        (Integrator::PhotonMapping, VolumeEstimate::Point),
        (Integrator::Combined, VolumeEstimate::Beam),
    ] {
        let xs = runs(integrator, estimate);
        for c in 0..3 {
            let (mp, sp) = mean_and_se(&path.iter().map(|m| m[c]).collect::<Vec<_>>());
            let (my, sy) = mean_and_se(&xs.iter().map(|m| m[c]).collect::<Vec<_>>());
            // Two independent means of 16 seeds each: Welch's statistic against the t quantile
            // of the smaller sample (conservative).
            let t = (my - mp) / (sp * sp + sy * sy).sqrt();
            eprintln!(
                "{integrator:?} {estimate:?} channel {c}: {my:.5} ± {sy:.5} vs path {mp:.5} ± {sp:.5}"
            );
            assert!(
                t.abs() <= t_critical(16),
                "{integrator:?} {estimate:?} channel {c}: {my:.5} ± {sy:.5} vs path {mp:.5} ± {sp:.5} (t = {t:.2})"
            );
        }
    }
    // Hidden from the camera: the pixels that saw the sky straight on go black, the others are
    // the same render (the same random numbers: nothing else depends on visibility).
    let shown = render(&scene, &settings(Integrator::Hybrid, VolumeEstimate::Beam, 0));
    let hidden = render(&sky_scene(false), &settings(Integrator::Hybrid, VolumeEstimate::Beam, 0));
    let (mut same, mut darker) = (0, 0);
    for (a, b) in shown.pixels.iter().zip(&hidden.pixels) {
        if a == b {
            same += 1;
        } else {
            assert!((0..3).all(|c| b[c] <= a[c]), "hiding the sky brightened {a:?} -> {b:?}");
            darker += 1;
        }
    }
    assert!(same > 0 && darker > 0, "{same} pixels unchanged, {darker} darker");
}

/// A scene's fingerprint (what partial renders must share to merge or resume) covers the map's
/// contents, its rotation and visibility, and a sky's parameters: one texel or one degree changes
/// it; the same description gives the same fingerprint.
#[test]
fn the_fingerprint_covers_the_sky() {
    let scene = |light: LightDesc| {
        let camera = CameraDesc::perspective([0.0, 1.0, 3.0], Vec3::ZERO, 40.0).resolution(4, 4);
        let mut b = SceneBuilder::new(camera);
        b.material("grey", Material::diffuse(0.5)).unwrap();
        b.shape(ShapeDesc::rectangle(2.0, 2.0).material("grey").rotate([-90.0, 0.0, 0.0])).unwrap();
        b.light(light).unwrap();
        b.build().unwrap().fingerprint()
    };
    let map = |bump: f32| {
        let mut t = vec![[0.3f32, 0.4, 0.5]; 32];
        t[9][1] += bump;
        EnvMap::new(8, 4, t).unwrap()
    };
    let base = scene(LightDesc::environment_map(map(0.0)));
    assert_eq!(base, scene(LightDesc::environment_map(map(0.0))));
    assert_ne!(base, scene(LightDesc::environment_map(map(1e-3))), "a texel");
    assert_ne!(base, scene(LightDesc::environment_map(map(0.0)).rotate([0.0, 1.0, 0.0])), "rotate");
    assert_ne!(base, scene(LightDesc::environment_map(map(0.0)).visible(false)), "visible");
    assert_ne!(base, scene(LightDesc::environment_map(map(0.0)).scale(2.0)), "scale");
    let sky = scene(LightDesc::sky(30.0, 40.0));
    assert_eq!(sky, scene(LightDesc::sky(30.0, 40.0)));
    assert_ne!(sky, scene(LightDesc::sky(31.0, 40.0)), "elevation");
    assert_ne!(sky, scene(LightDesc::sky(30.0, 40.0).turbidity(4.0)), "turbidity");
    assert_ne!(sky, scene(LightDesc::sky(30.0, 40.0).with_sun(false)), "the sun");
}
