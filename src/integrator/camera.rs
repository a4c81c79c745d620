//! The camera pass: one jittered eye path per pixel and iteration, followed through specular
//! events (mirror, glass with Fresnel, pass-through interfaces) to the first diffuse surface, where
//! the photon map gives the reflected radiance. Emitters seen directly or through specular chains
//! add their radiance.

use crate::estimate::surface::{Gather, surface_radiance};
use crate::math::{Rgb, offset_origin};
use crate::photon::map::PhotonGrid;
use crate::rng::{Purpose, Sampler};
use crate::scene::Scene;
use crate::scene::material::Transport;
use glam::Vec2;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Settings of one camera pass.
#[derive(Clone, Copy, Debug)]
pub struct CameraPass {
    /// Render seed.
    pub seed: u64,
    /// Iteration number (1-based).
    pub iteration: u64,
    /// Maximum scattering events per eye path.
    pub max_depth: u32,
    /// Density estimation.
    pub gather: Gather,
}

/// Radiance along one eye path for pixel `index`.
fn pixel_radiance(scene: &Scene, map: &PhotonGrid, pass: &CameraPass, x: u32, y: u32) -> Rgb {
    let width = scene.camera.resolution[0];
    let mut s = Sampler::new(
        pass.seed,
        Purpose::Camera,
        pass.iteration,
        (y * width + x) as u64,
    );
    let pixel = Vec2::new(x as f32, y as f32) + s.next_2d();
    let ray = scene.camera.generate_ray(pixel, s.next_2d());
    let (mut o, mut d) = (ray.o, ray.d);
    let mut beta = Rgb::ONE;
    let mut l = Rgb::ZERO;
    for _ in 0..pass.max_depth {
        let Some(hit) = scene.intersect(o, d, f32::INFINITY) else {
            break;
        };
        let wo = -d;
        let shape = &scene.shapes[hit.tag as usize];
        if let Some(le) = shape.emission {
            if wo.dot(hit.ng) > 0.0 {
                l += beta * le;
            }
        }
        let material = &scene.materials[shape.material as usize];
        if material.is_diffuse() {
            let n = if wo.dot(hit.ng) >= 0.0 {
                hit.ng
            } else {
                -hit.ng
            };
            l += beta * surface_radiance(map, hit.p, n, material.diffuse_f(), &pass.gather);
            break;
        }
        let Some(bs) = material.sample(
            wo,
            hit.ng,
            hit.ns,
            s.next_2d(),
            s.next_f32(),
            Transport::Radiance,
        ) else {
            break;
        };
        beta *= bs.weight;
        o = offset_origin(hit.p, hit.ng, bs.wi);
        d = bs.wi;
    }
    l
}

/// Renders one iteration image into `image` (row-major). Returns `false` if `stop` was raised
/// before it finished. Non-finite samples are replaced by black and counted in `nonfinite`.
pub fn render_pass(
    scene: &Scene,
    map: &PhotonGrid,
    pass: &CameraPass,
    stop: &AtomicBool,
    nonfinite: &AtomicU64,
    image: &mut [Rgb],
) -> bool {
    let width = scene.camera.resolution[0] as usize;
    image
        .par_chunks_mut(width)
        .enumerate()
        .for_each(|(y, row)| {
            if stop.load(Ordering::Relaxed) {
                return;
            }
            for (x, px) in row.iter_mut().enumerate() {
                let l = pixel_radiance(scene, map, pass, x as u32, y as u32);
                *px = if l.is_finite() {
                    l
                } else {
                    nonfinite.fetch_add(1, Ordering::Relaxed);
                    Rgb::ZERO
                };
            }
        });
    !stop.load(Ordering::Relaxed)
}
