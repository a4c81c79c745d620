//! An analytic surface case: a closed diffuse sphere with an isotropic point light at its centre.
//!
//! Sphere radius R, albedo ρ, light power Φ: the direct irradiance is E₀ = Φ / (4πR²) everywhere,
//! and after a diffuse bounce inside a sphere the next hit point is again uniform on the sphere, so
//! the k-th bounce contributes E₀ ρ^(k−1). A light path stores a photon at each of its first D
//! hits (D = max_depth), hence the exact answer for the rendered radiance is
//!
//!   L = (ρ/π) · E₀ · (1 − ρ^D) / (1 − ρ).
//!
//! The path tracer's next-event estimate adds ρ^(k−1)·(ρ/π)·E₀ at its k-th vertex, k ≤ D: the same
//! sum. Bias: none for the path tracer, and none for photon mapping with any radial kernel, because the area of a sphere within chord distance d of a
//! point on it is exactly πd² (Archimedes' hat-box theorem), the same as on a plane; so only noise
//! remains, and the test is a t-test over independent seeds at the suite's significance.

use crate::common::assert_agrees;
use glam::Vec3;
use haze::estimate::kernel::Kernel;
use haze::progress::Silent;
use haze::scene::camera::{Camera, Projection};
use haze::scene::material::Material;
use haze::scene::{Geometry, LightDesc, SceneBuilder};
use haze::settings::{Integrator, RenderSettings};
use std::f64::consts::PI;
use std::sync::atomic::AtomicBool;

pub(crate) fn sphere_scene(albedo: f32, power: f32) -> haze::Scene {
    let camera = Camera::new(
        Projection::Perspective { tan_half_fov: 0.6, lens_radius: 0.0, focus_distance: 1.0 },
        Vec3::new(0.1, -0.2, 0.05),
        Vec3::new(1.0, 0.3, 0.2),
        Vec3::Y,
        [16, 12],
    );
    let mut b = SceneBuilder::new(camera);
    let m = b.material("wall", Material::Diffuse { albedo: Vec3::splat(albedo) }).unwrap();
    b.shape(Geometry::Sphere { center: Vec3::ZERO, radius: 1.0 }, m, None).unwrap();
    b.light(LightDesc::Point { position: Vec3::ZERO, power: Vec3::splat(power) }).unwrap();
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
                    max_depth: depth,
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
