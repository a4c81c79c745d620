//! The camera pass: one jittered eye path per pixel and iteration, followed through specular
//! events (mirror, glass with Fresnel, pass-through interfaces) to the first diffuse surface, where
//! the photon map gives the reflected radiance. Emitters seen directly or through specular chains
//! add their radiance. Along every segment inside a medium, in-scattered radiance comes from the
//! volume photons by the beam estimate (the whole segment, then the path goes on attenuated by its
//! transmittance) or the point estimate (at a sampled collision, where the path ends; without a
//! collision the path goes on with the free-flight weight).

use crate::estimate::surface::{Gather, surface_radiance};
use crate::estimate::volume::{EyeSegment, beam_radiance, point_radiance};
use crate::math::{Rgb, offset_origin};
use crate::photon::beam::BeamMap;
use crate::photon::map::PhotonGrid;
use crate::photon::{Photon, VolumePhoton};
use crate::rng::{Purpose, Sampler};
use crate::scene::Scene;
use crate::scene::material::{MAX_CROSSINGS, Material, Transport};
use crate::settings::VolumeEstimate;
use glam::Vec2;
use std::sync::atomic::{AtomicBool, AtomicU64};

/// The photon maps of one iteration.
pub(crate) struct Maps<'a> {
    /// Surface photons.
    pub surface: &'a PhotonGrid<Photon>,
    /// Volume photons for point queries (used by the point estimate).
    pub volume_points: &'a PhotonGrid<VolumePhoton>,
    /// Volume photons for beam queries (used by the beam estimate).
    pub volume_beams: &'a BeamMap,
}

/// Settings of one camera pass.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CameraPass {
    /// Render seed.
    pub seed: u64,
    /// Iteration number (1-based).
    pub iteration: u64,
    /// Maximum scattering events per eye path (pass-through interfaces are not events): the path
    /// follows at most `max_depth − 1` specular bounces.
    pub max_depth: u32,
    /// Surface density estimation.
    pub surface: Gather,
    /// Volume density estimation.
    pub volume: Gather,
    /// Beam or point estimate in media.
    pub estimate: VolumeEstimate,
}

#[cfg(feature = "profile")]
thread_local! {
    /// Nanoseconds this thread spent in volume estimates (with the `profile` feature).
    static VOLUME_NANOS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// With the `profile` feature, returns and resets the time the worker threads spent in volume
/// estimates since the last call, summed and divided by the thread count (the share of the
/// camera pass's wall time, since every thread works through the pass); `None` without it.
pub(crate) fn take_volume_times() -> Option<f64> {
    #[cfg(feature = "profile")]
    {
        let threads = rayon::current_num_threads() as f64;
        let take = || VOLUME_NANOS.with(|c| c.replace(0)) as f64 * 1e-9;
        Some(rayon::broadcast(|_| take()).iter().sum::<f64>() / threads)
    }
    #[cfg(not(feature = "profile"))]
    None
}

/// Runs `f`; with the `profile` feature, adds its duration to this thread's volume-estimate time.
#[inline(always)]
fn timed<T>(f: impl FnOnce() -> T) -> T {
    #[cfg(feature = "profile")]
    {
        let start = std::time::Instant::now();
        let out = f();
        let ns = start.elapsed().as_nanos() as u64;
        VOLUME_NANOS.with(|c| c.set(c.get() + ns));
        out
    }
    #[cfg(not(feature = "profile"))]
    f()
}

/// Radiance along one eye path for pixel (x, y).
fn pixel_radiance(scene: &Scene, maps: &Maps, pass: &CameraPass, x: u32, y: u32) -> Rgb {
    trace_eye(scene, maps, pass, x, y, |p, n, f, beta| {
        beta * surface_radiance(maps.surface, p, n, f, &pass.surface)
    })
}

/// Follows the eye path of pixel (x, y) and returns the radiance it collects, except that at the
/// first diffuse surface (position p, normal n on the viewer's side, BRDF value f, path throughput
/// β) the contribution is whatever `at_diffuse(p, n, f, β)` returns.
pub(crate) fn trace_eye(
    scene: &Scene,
    maps: &Maps,
    pass: &CameraPass,
    x: u32,
    y: u32,
    mut at_diffuse: impl FnMut(glam::Vec3, glam::Vec3, Rgb, Rgb) -> Rgb,
) -> Rgb {
    let width = scene.camera.resolution[0];
    let mut s = Sampler::new(pass.seed, Purpose::Camera, pass.iteration, (y * width + x) as u64);
    let pixel = Vec2::new(x as f32, y as f32) + s.next_2d();
    let ray = scene.camera.generate_ray(pixel, s.next_2d());
    let (mut o, mut d) = (ray.o, ray.d);
    let mut medium = scene.camera_medium;
    let mut beta = Rgb::ONE;
    let mut l = Rgb::ZERO;
    // Specular bounces so far, and pass-through crossings (which are not scattering events).
    let (mut bounces, mut crossings) = (0u32, 0u32);
    loop {
        let hit = scene.intersect(o, d, f32::INFINITY);
        if let Some(id) = medium {
            let m = &scene.media[id as usize];
            let t_max = hit.map_or(f32::INFINITY, |h| h.t);
            match pass.estimate {
                VolumeEstimate::Beam => {
                    // One transmittance estimate per segment, shared by every photon on it and by
                    // the path's continuation.
                    let tr = m.segment(o, d, t_max, &mut s);
                    let volume = &pass.volume;
                    let seg = EyeSegment { o, w: d, t_max };
                    l +=
                        beta * timed(|| beam_radiance(maps.volume_beams, m, id, &seg, &tr, volume));
                    beta *= tr.at(t_max);
                }
                VolumeEstimate::Point => {
                    let flight = m.sample_free_flight(o, d, t_max, &mut s);
                    beta *= flight.weight;
                    if flight.scattered {
                        let x = o + d * flight.t;
                        let points = maps.volume_points;
                        l += beta * timed(|| point_radiance(points, m, id, x, d, &pass.volume));
                        break;
                    }
                }
            }
            if beta.max_element() <= 0.0 {
                break;
            }
        }
        let Some(hit) = hit else { break };
        let wo = -d;
        let shape = &scene.shapes[hit.tag as usize];
        if let Some(le) = shape.emission {
            if wo.dot(hit.ng) > 0.0 {
                l += beta * le;
            }
        }
        let material = &scene.materials[shape.material as usize];
        if *material == Material::Interface {
            crossings += 1;
            if crossings > MAX_CROSSINGS {
                break;
            }
            medium = shape.medium_after(medium, wo, d, hit.ng);
            o = offset_origin(hit.p, hit.ng, d);
            continue;
        }
        if material.is_diffuse() {
            let n = if wo.dot(hit.ng) >= 0.0 { hit.ng } else { -hit.ng };
            let f = material.diffuse_f();
            l += at_diffuse(hit.p, n, f, beta);
            break;
        }
        // A specular bounce is a scattering event; pass-through crossings above were not.
        bounces += 1;
        if bounces >= pass.max_depth {
            break;
        }
        let Some(bs) =
            material.sample(wo, hit.ng, hit.ns, s.next_2d(), s.next_f32(), Transport::Radiance)
        else {
            break;
        };
        beta *= bs.weight;
        medium = shape.medium_after(medium, wo, bs.wi, hit.ng);
        o = offset_origin(hit.p, hit.ng, bs.wi);
        d = bs.wi;
    }
    l
}

/// Renders one iteration image into `image` (row-major). Returns `false` if `stop` was raised
/// before it finished. Non-finite samples are replaced by black and counted in `nonfinite`.
pub(crate) fn render_pass(
    scene: &Scene,
    maps: &Maps,
    pass: &CameraPass,
    stop: &AtomicBool,
    nonfinite: &AtomicU64,
    image: &mut [Rgb],
) -> bool {
    let width = scene.camera.resolution[0] as usize;
    super::render_rows(image, width, stop, nonfinite, |x, y| {
        pixel_radiance(scene, maps, pass, x, y)
    })
}
