//! An analytic surface case: a closed diffuse sphere with an isotropic point light at its centre.
//!
//! Sphere radius R, albedo ρ, light power Φ: the direct irradiance is E₀ = Φ / (4πR²) everywhere,
//! and after a diffuse bounce inside a sphere the next hit point is again uniform on the sphere, so
//! the k-th bounce contributes E₀ ρ^(k−1). A light path stores a photon at each of its first D
//! hits (D = max_bounces), hence the exact answer for the rendered radiance is
//!
//!   L = (ρ/π) · E₀ · (1 − ρ^D) / (1 − ρ).
//!
//! The path tracer's next-event estimate adds ρ^(k−1)·(ρ/π)·E₀ at its k-th vertex, k ≤ D: the same
//! sum. Bias: none for the path tracer, and none for photon mapping with any radial kernel, because the area of a sphere within chord distance d of a
//! point on it is exactly πd² (Archimedes' hat-box theorem), the same as on a plane; so only noise
//! remains, and the test is a t-test over independent seeds at the suite's significance.

use crate::common::assert_agrees;
use haze::progress::Silent;
use haze::scene::{CameraDesc, LightDesc, Material, SceneBuilder, ShapeDesc};
use haze::settings::{Integrator, Kernel, RenderSettings};
use std::f64::consts::PI;
use std::sync::atomic::AtomicBool;

pub(crate) fn sphere_scene(albedo: f32, power: f32) -> haze::Scene {
    let fov = 2.0 * 0.6f32.atan().to_degrees();
    let camera =
        CameraDesc::perspective([0.1, -0.2, 0.05], [1.0, 0.3, 0.2], fov).resolution(16, 12);
    let mut b = SceneBuilder::new(camera);
    let wall = b.material("wall", Material::diffuse(albedo)).unwrap();
    b.shape(ShapeDesc::sphere([0.0, 0.0, 0.0], 1.0).material(wall)).unwrap();
    b.light(LightDesc::point([0.0, 0.0, 0.0], power)).unwrap();
    b.build().unwrap()
}

#[test]
fn closed_diffuse_sphere_with_central_point_light() {
    for (albedo, kernel, integrator) in [
        (0.5f32, Kernel::Epanechnikov, Integrator::PhotonMapping),
        (0.8, Kernel::Constant, Integrator::PhotonMapping),
        (0.5, Kernel::Epanechnikov, Integrator::Path),
        (0.8, Kernel::Epanechnikov, Integrator::Path),
    ] {
        let power = 4.0 * std::f32::consts::PI; // E₀ = 1 on the unit sphere
        let scene = sphere_scene(albedo, power);
        let depth = 12;
        let rho = albedo as f64;
        let reference = rho / PI * (1.0 - rho.powi(depth as i32)) / (1.0 - rho);
        let seeds = 10;
        let estimates: Vec<f64> = (0..seeds)
            .map(|seed| {
                let settings = RenderSettings {
                    iterations: Some(4),
                    photons: 20_000,
                    radius: Some(0.08),
                    kernel,
                    max_bounces: depth,
                    seed,
                    integrator,
                    ..RenderSettings::default()
                };
                let image =
                    haze::render(&scene, &settings, &mut Silent, &AtomicBool::new(false)).unwrap();
                image.mean()
            })
            .collect();
        let what = format!("sphere ρ = {albedo}, {kernel:?}, {integrator:?}");
        assert_agrees(&what, &estimates, reference, 0.0);
    }
}
