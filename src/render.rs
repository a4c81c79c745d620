//! The render loop: it only schedules iterations, checks the stop conditions and reports
//! progress. What one iteration does belongs to the method ([`crate::integrator::Method`]):
//! photon pass → photon maps → camera pass for photon mapping, one path per pixel for the path
//! tracer; the film then takes the iteration's image.

use crate::error::{Error, Result};
use crate::film::Film;
use crate::integrator::Method;
use crate::output::{Image, RenderInfo};
use crate::progress::{Progress, Status};
use crate::scene::Scene;
use crate::settings::RenderSettings;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

/// Renders `scene` with `settings`, reporting to `progress` after every iteration, until the
/// iteration count or time limit is reached or `stop` is raised. An iteration interrupted by
/// `stop` is discarded; every finished one is in the returned image.
///
/// ```no_run
/// use haze::{Scene, render, progress::Status};
/// use std::sync::atomic::AtomicBool;
///
/// let scene = Scene::load("scenes/cornell-box.toml")?;
/// let settings = haze::RenderSettings { iterations: Some(16), ..scene.settings.clone() };
/// let stop = AtomicBool::new(false); // raise it from another thread to stop early
/// let mut on_iteration = |s: &Status| eprintln!("iteration {}", s.iteration());
/// let image = render(&scene, &settings, &mut on_iteration, &stop)?;
/// image.write("cornell.exr".as_ref(), 1.0)?;
/// # Ok::<(), haze::Error>(())
/// ```
pub fn render(
    scene: &Scene,
    settings: &RenderSettings,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<Image> {
    settings.validate().map_err(|e| Error::Settings(e.to_string()))?;
    let start = Instant::now();
    let mut method = Method::new(scene, settings)?;
    let [width, height] = scene.camera.resolution;
    let mut film = Film::new(width, height);
    let mut image = vec![crate::math::Rgb::ZERO; (width * height) as usize];
    let nonfinite = AtomicU64::new(0);
    let diagonal = scene.diagonal() as f64;
    let info = |method: &Method, iterations: u64, nonfinite: &AtomicU64| {
        let (radius, volume_radius) = method.radii(iterations.max(1));
        RenderInfo {
            settings: settings.clone(),
            iterations,
            light_paths: iterations * method.light_paths_per_iteration(),
            initial_radius: settings.initial_radius(diagonal),
            radius,
            volume_initial_radius: settings.initial_volume_radius(diagonal),
            volume_radius,
            elapsed: start.elapsed().as_secs_f64(),
            scene: scene.source.clone(),
            nonfinite_samples: nonfinite.load(Ordering::Relaxed),
        }
    };
    let mut iteration = 0u64;
    while !done(settings, iteration, start, stop) {
        let i = iteration + 1;
        let Some(times) = method.iterate(scene, i, stop, &nonfinite, &mut image) else {
            break;
        };
        method.accumulate(&mut film, &image);
        iteration = i;
        let stored = method.photons_stored();
        progress.iteration(&Status {
            target_iterations: settings.iterations,
            time_limit: settings.time_limit,
            photons_stored: stored[0],
            volume_photons_stored: stored[1],
            times,
            film: &film,
            info: &info(&method, iteration, &nonfinite),
        });
    }
    Ok(Image::from_film(&film, info(&method, iteration, &nonfinite)))
}

/// True once the iteration count or the time limit is reached, or a stop was requested.
fn done(settings: &RenderSettings, iterations: u64, start: Instant, stop: &AtomicBool) -> bool {
    settings.iterations.is_some_and(|n| iterations >= n)
        || settings.time_limit.is_some_and(|t| start.elapsed().as_secs_f64() >= t)
        || stop.load(Ordering::Relaxed)
}
