//! Probabilistic progressive photon mapping (Knaus & Zwicker 2011): iteration i is an ordinary
//! photon-mapping render with radius r_i from the schedule of [`crate::estimate::radius`]; the
//! image is the mean of the iterations. Each iteration traces a fresh set of photons, rebuilds the
//! photon map into the buffers of the previous one (memory stays constant) and renders one
//! jittered eye path per pixel.

use super::camera::{CameraPass, Maps, render_pass};
use super::original::{OriginalState, gather_pass};
use super::path::{self, PathPass};
use crate::error::{Error, Result};
use crate::estimate::radius::radius;
use crate::estimate::surface::Gather;
use crate::film::Film;
use crate::math::Rgb;
use crate::output::{Image, RenderInfo};
use crate::photon::beam::{BeamMap, Thinning};
use crate::photon::map::PhotonGrid;
use crate::photon::trace::{LightSampler, PhotonPass, Photons, trace_photons};
use crate::progress::{Progress, Status};
use crate::scene::Scene;
use crate::settings::{Integrator, Progression, Radius, RenderSettings, VolumeEstimate};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

/// A radius setting in `scene`'s units.
pub fn resolve_radius(scene: &Scene, radius: Radius) -> f64 {
    match radius {
        Radius::Absolute(r) => r,
        Radius::Fraction(f) => f * scene.diagonal() as f64,
    }
}

/// Renders `scene` with `settings`, reporting to `progress` after every iteration, until the
/// iteration count or time limit is reached or `stop` is raised. An iteration interrupted by
/// `stop` is discarded; every finished one is in the returned image.
pub fn render(
    scene: &Scene,
    settings: &RenderSettings,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<Image> {
    settings.validate().map_err(|e| Error::Settings(format!("{}: {}", e.key, e.message)))?;
    let original = settings.progression == Progression::Original;
    if original && !scene.media.is_empty() {
        return Err(Error::Settings(
            "progression: \"original\" is a comparison mode for the surface estimate; this scene has media (use \"probabilistic\")".into(),
        ));
    }
    let start = Instant::now();
    let [width, height] = scene.camera.resolution;
    let r1 = resolve_radius(scene, settings.radius);
    let r1_vol = resolve_radius(scene, settings.volume_radius);
    let lights = LightSampler::new(scene);
    let mut film = Film::new(width, height);
    let mut photons = Photons::default();
    let mut surface_map = PhotonGrid::default();
    let mut volume_points = PhotonGrid::default();
    let mut volume_beams = BeamMap::new();
    let mut image = vec![Rgb::ZERO; (width * height) as usize];
    let nonfinite = AtomicU64::new(0);
    let mut light_paths = 0u64;
    // The original progression's per-pixel statistics, and a spare copy that an iteration updates
    // so that an interrupted one leaves the statistics untouched (empty otherwise).
    let stats_len = if original { (width * height) as usize } else { 0 };
    let mut pixel_stats = OriginalState::new(stats_len, r1, settings.alpha);
    let mut next_stats = OriginalState::new(stats_len, r1, settings.alpha);
    let mut last: Option<RenderInfo> = None;
    let make_info = |iterations, light_paths, radius, volume_radius, elapsed| RenderInfo {
        iterations,
        light_paths,
        initial_radius: r1,
        radius,
        alpha: settings.alpha,
        volume_initial_radius: r1_vol,
        volume_radius,
        volume_alpha: settings.volume_alpha,
        volume_dimension: settings.volume_dimension,
        volume_estimate: settings.volume_estimate,
        integrator: settings.integrator,
        progression: settings.progression,
        kernel: settings.kernel,
        seed: settings.seed,
        elapsed,
        scene: scene.source.clone(),
        nonfinite_samples: nonfinite.load(Ordering::Relaxed),
    };
    let mut iteration = 0u64;
    loop {
        if settings.iterations.is_some_and(|n| iteration >= n)
            || settings.time_limit.is_some_and(|t| start.elapsed().as_secs_f64() >= t)
            || stop.load(Ordering::Relaxed)
        {
            break;
        }
        let i = iteration + 1;
        let r = if original { pixel_stats.rms_radius() } else { radius(i, r1, settings.alpha, 2) };
        let r_vol = radius(i, r1_vol, settings.volume_alpha, settings.volume_dimension);
        let t0 = Instant::now();
        let t1;
        let (mut t_traced, mut t_surface) = (t0, t0);
        match settings.integrator {
            Integrator::PhotonMapping => {
                let pass = PhotonPass {
                    seed: settings.seed,
                    iteration: i,
                    paths: settings.photons,
                    max_depth: settings.max_depth,
                };
                if !trace_photons(scene, &lights, &pass, stop, &mut photons) {
                    break;
                }
                t_traced = Instant::now();
                let r_build = if original { pixel_stats.max_radius() } else { r };
                surface_map.build(&photons.surface, r_build as f32);
                t_surface = Instant::now();
                match settings.volume_estimate {
                    _ if original => {}
                    VolumeEstimate::Beam => {
                        let thinning = settings.beam_cell_budget.map(|budget| Thinning {
                            budget,
                            seed: settings.seed,
                            iteration: i,
                        });
                        volume_beams.build(
                            &photons.volume,
                            r_vol as f32,
                            thinning,
                            Some(&scene.camera),
                            |p| p.beta * scene.media[p.medium as usize].sigma_s(p.p),
                        );
                    }
                    VolumeEstimate::Point => volume_points.build(&photons.volume, r_vol as f32),
                }
                t1 = Instant::now();
                let camera = CameraPass {
                    seed: settings.seed,
                    iteration: i,
                    max_depth: settings.max_depth,
                    surface: Gather {
                        radius: r as f32,
                        kernel: settings.kernel,
                        inv_paths: 1.0 / settings.photons as f32,
                    },
                    volume: Gather {
                        radius: r_vol as f32,
                        kernel: settings.kernel,
                        inv_paths: 1.0 / settings.photons as f32,
                    },
                    estimate: settings.volume_estimate,
                    time_volume: settings.time_volume_estimate,
                };
                let maps = Maps {
                    surface: &surface_map,
                    volume_points: &volume_points,
                    volume_beams: &volume_beams,
                };
                if original {
                    let paths = light_paths + settings.photons;
                    next_stats.pixels.copy_from_slice(&pixel_stats.pixels);
                    if !gather_pass(
                        scene,
                        &maps,
                        &camera,
                        &mut next_stats,
                        paths,
                        stop,
                        &nonfinite,
                        &mut image,
                    ) {
                        break;
                    }
                    std::mem::swap(&mut pixel_stats, &mut next_stats);
                } else if !render_pass(scene, &maps, &camera, stop, &nonfinite, &mut image) {
                    break;
                }
            }
            Integrator::Path => {
                t1 = t0;
                let pass =
                    PathPass { seed: settings.seed, iteration: i, max_depth: settings.max_depth };
                if !path::render_pass(scene, &lights, &pass, stop, &nonfinite, &mut image) {
                    break;
                }
            }
        }
        let t2 = Instant::now();
        let volume_estimate_seconds = settings.time_volume_estimate.then(|| {
            let threads = rayon::current_num_threads() as f64;
            rayon::broadcast(|_| super::camera::take_volume_time()).iter().sum::<f64>() / threads
        });
        if original {
            film.replace(&image);
        } else {
            film.add(&image);
        }
        iteration = i;
        if settings.integrator == Integrator::PhotonMapping {
            light_paths += settings.photons;
        }
        let info = make_info(iteration, light_paths, r, r_vol, start.elapsed().as_secs_f64());
        progress.iteration(&Status {
            target_iterations: settings.iterations,
            time_limit: settings.time_limit,
            photons_stored: photons.surface.len() as u64,
            volume_photons_stored: photons.volume.len() as u64,
            photon_seconds: (t1 - t0).as_secs_f64(),
            map_seconds: (t1 - t_traced).as_secs_f64(),
            volume_map_seconds: (t1 - t_surface).as_secs_f64(),
            volume_estimate_seconds,
            camera_seconds: (t2 - t1).as_secs_f64(),
            film: &film,
            info: &info,
        });
        last = Some(info);
    }
    let mut info = last.unwrap_or_else(|| make_info(0, 0, r1, r1_vol, 0.0));
    info.elapsed = start.elapsed().as_secs_f64();
    info.nonfinite_samples = nonfinite.load(Ordering::Relaxed);
    Ok(Image::from_film(&film, info))
}
