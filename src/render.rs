//! The render loop: it only schedules iterations, checks the stop conditions and reports
//! progress. What one iteration does belongs to the method ([`crate::integrator::Method`]):
//! photon pass → photon maps → camera pass for photon mapping, one path per pixel for the path
//! tracer; the film then takes the iteration's image.

use crate::error::{Error, Result};
use crate::film::Film;
use crate::integrator::Method;
use crate::integrator::frame::Stopwatch;
pub use crate::integrator::ppm::PhotonUsage;
use crate::output::{Image, RenderInfo};
use crate::partial::Partial;
use crate::plan::{MethodKind, Plan};
use crate::progress::{Progress, Status};
use crate::scene::Scene;
use crate::settings::{Progression, RenderSettings};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

/// Renders `scene` with `settings`, reporting to `progress` after every iteration, until the
/// iteration count or time limit is reached or `stop` is raised. Both the time limit and `stop`
/// are honoured inside an iteration (the passes look at them every pixel and every batch of light
/// paths, so a stop takes effect within a fraction of a second); the iteration they interrupt is
/// discarded, and every finished one is in the returned image.
///
/// On more than one thread, the render's working buffers (photon maps and scratch space) are
/// freed on a thread of its own started as the render returns, so that the caller can write the
/// image meanwhile; a caller that starts the next render at once may hold both renders' buffers
/// for those few tens of milliseconds. A render on one thread frees them before returning.
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
    render_partial(scene, settings, Start::At(1), progress, stop).map(|p| p.image())
}

/// The most worker threads a render accepts: 8 per core (more only adds overhead). The command
/// line's `--threads` and the Python module's `threads` are checked against it.
pub fn max_threads() -> usize {
    8 * std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Where a [`render_partial`] starts.
#[derive(Clone, Debug)]
pub enum Start {
    /// A fresh render whose first iteration has this index (1 for a whole render; a later one
    /// for a range of a render split over processes or machines).
    At(u64),
    /// Continue a partial render from the iteration after its last.
    Resume(Box<Partial>),
}

/// Renders a range of iterations into a [`Partial`]: from the start (an iteration index, or the
/// iteration after a partial render's last) up to iteration `settings.iterations` (an index: the
/// range `a..=b` is `Start::At(a)` with `iterations: Some(b)`) or until the time limit or `stop`,
/// as [`render`] does. Parts of one render made this way on any number of processes merge
/// exactly ([`Partial::merge`]), and a resumed render is bit-identical to an uninterrupted one.
///
/// ```
/// use haze::{Partial, RenderSettings, Start, progress::Silent, render_partial};
/// use haze::scene::{CameraDesc, LightDesc, Material, SceneBuilder, ShapeDesc};
/// use std::sync::atomic::AtomicBool;
///
/// let mut b = SceneBuilder::new(CameraDesc::perspective([0.0, 1.0, 3.0], [0.0, 0.0, 0.0], 40.0).resolution(16, 16));
/// b.material("floor", Material::diffuse(0.5))?;
/// b.shape(ShapeDesc::rectangle(4.0, 4.0).material("floor").rotate([-90.0, 0.0, 0.0]))?;
/// b.light(LightDesc::point([0.0, 2.0, 0.0], 50.0))?;
/// let scene = b.build()?;
/// let run = |start, last| {
///     let settings = RenderSettings { iterations: Some(last), photons: 2_000, ..RenderSettings::default() };
///     render_partial(&scene, &settings, start, &mut Silent, &AtomicBool::new(false))
/// };
/// let whole = run(Start::At(1), 6)?;
/// // Two pieces, rendered anywhere, merged in any order: the same film, bit for bit.
/// let (a, b) = (run(Start::At(1), 2)?, run(Start::At(3), 6)?);
/// let merged = Partial::merge(vec![b, a]).unwrap();
/// assert_eq!(merged.film, whole.film);
/// // A render stopped after iteration 4 and resumed.
/// let resumed = run(Start::Resume(Box::new(run(Start::At(1), 4)?)), 6)?;
/// assert_eq!(resumed.film, whole.film);
/// # Ok::<(), haze::Error>(())
/// ```
pub fn render_partial(
    scene: &Scene,
    settings: &RenderSettings,
    start: Start,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<Partial> {
    // What the render records: the integrator `auto` stands for in this scene.
    let settings = settings.resolved(scene.has_emissive_media());
    render_resolved(scene, &settings, start, progress, stop)
}

/// [`render_partial`] with settings whose integrator is the one that renders.
fn render_resolved(
    scene: &Scene,
    settings: &RenderSettings,
    start: Start,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<Partial> {
    let plan = Plan::new(scene, settings)?;
    std::thread::scope(|scope| {
        // The scene's fingerprint (SHA-256 over its grids: 6 ms on one thread for the cumulus)
        // is hashed on a thread of its own beside the first iteration, rather than before it
        // with every other thread idle, where the render has more than one and the scene has
        // not hashed it yet; its first use waits for it ([`Scene::fingerprint`]).
        if rayon::current_num_threads() > 1 && scene.fingerprint.get().is_none() {
            scope.spawn(|| scene.fingerprint());
        }
        render_planned(scene, settings, &plan, start, progress, stop)
    })
}

/// [`render_resolved`] once the render is planned.
fn render_planned(
    scene: &Scene,
    settings: &RenderSettings,
    plan: &Plan,
    start: Start,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<Partial> {
    let mut method = Method::new(scene, plan);
    let [width, height] = scene.camera.resolution;
    let (first, mut film, before) = starting_film(start, &mut method, scene, settings)?;
    // Last, as it traces a few light paths.
    check_memory(scene, plan)?;
    let start = Instant::now();
    let mut frame = crate::integrator::frame::Frame::new((width * height) as usize);
    let nonfinite = AtomicU64::new(0);
    let truncated_before = scene.truncated_trackings();
    let info = |method: &Method, last: u64, nonfinite: &AtomicU64| {
        let radii = method.radii(last.max(1));
        let iterations = (last + 1).saturating_sub(first);
        let (elapsed, nonfinite_before, truncated_before_run) = before
            .as_ref()
            .map_or((0.0, 0, 0), |b| (b.elapsed, b.nonfinite_samples, b.truncated_trackings));
        RenderInfo {
            settings: settings.clone(),
            first_iteration: first,
            iterations,
            light_paths: iterations * method.light_paths_per_iteration(),
            initial_radius: plan.surface.initial,
            radius: radii.surface,
            volume_initial_radius: plan.volume.initial,
            volume_radius: radii.volume,
            elapsed: elapsed + start.elapsed().as_secs_f64(),
            scene: scene.source.clone(),
            nonfinite_samples: nonfinite_before + nonfinite.load(Ordering::Relaxed),
            truncated_trackings: truncated_before_run + scene.truncated_trackings()
                - truncated_before,
        }
    };
    // The passes watch `halt`, raised by a watcher thread when `stop` is raised or the time
    // limit passes, so that neither waits for the end of an iteration.
    let halt = AtomicBool::new(false);
    let mut iteration = first - 1 + film.iterations(); // the last finished iteration
    std::thread::scope(|scope| {
        // The watcher returns as soon as `_finished` is dropped, as this closure ends (by a panic
        // too), before the scope waits for it.
        let (_finished, watching) = std::sync::mpsc::channel::<()>();
        scope.spawn(|| watch(settings, start, stop, &halt, watching));
        while !done(settings, iteration, start, stop) {
            let i = iteration + 1;
            let Some(mut times) = method.iterate(scene, i, &halt, &nonfinite, &mut frame) else {
                break;
            };
            let clock = Stopwatch::start();
            method.accumulate(&mut film, &frame);
            (times.film, times.processor.film) = clock.lap();
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
                method: &method,
                scene,
            });
            if reached_target(settings, &film) {
                break;
            }
        }
    });
    let info = info(&method, iteration, &nonfinite);
    Ok(finish(method, info, film, scene.fingerprint()))
}

/// The partial render of `method`'s iterations, `method`'s buffers released ([`release`]).
fn finish(method: Method, info: RenderInfo, film: Film, fingerprint: [u8; 32]) -> Partial {
    let (state, techniques) = (method.save_state(), method.technique_layers());
    release(method);
    Partial { info, film, fingerprint, state, output: None, techniques }
}

/// Frees a render's buffers — photon maps and their scratch space, hundreds of megabytes in a
/// large scene, whose release takes tens of milliseconds on one thread (cumulus's hybrid: 25 ms)
/// — on a thread of its own where the render had more than one, so that the caller can write
/// the image meanwhile instead of waiting. A single-threaded render frees them itself.
fn release<T: Send + 'static>(buffers: T) {
    if rayon::current_num_threads() > 1 {
        // If no thread can be started, the closure and the buffers are dropped here.
        let _ =
            std::thread::Builder::new().name("haze-release".into()).spawn(move || drop(buffers));
    }
}

/// Refuses a render that would need more memory per iteration than the machine has (the
/// settings themselves are checked by [`Plan::new`]).
fn check_memory(scene: &Scene, plan: &Plan) -> Result<()> {
    let Some(total) = physical_memory() else { return Ok(()) };
    let need = memory_need(scene, plan);
    if need > total {
        return Err(Error::Settings(format!(
            "photons = {} would need about {:.1} GB per iteration (measured on {PILOT_PATHS} \
             light paths of this scene), more than this machine's {:.1} GB; lower `photons`",
            plan.paths,
            need as f64 / 1e9,
            total as f64 / 1e9
        )));
    }
    Ok(())
}

/// Where a render starts: its first iteration, the film it adds to (a resumed partial's, or a
/// new one) and, for a resume, how the partial was made.
fn starting_film(
    start: Start,
    method: &mut Method,
    scene: &Scene,
    settings: &RenderSettings,
) -> Result<(u64, Film, Option<RenderInfo>)> {
    let [width, height] = scene.camera.resolution;
    Ok(match start {
        Start::At(0) => return Err(Error::Settings("iterations are numbered from 1".into())),
        Start::At(2..) | Start::Resume(_) if settings.techniques => {
            return Err(Error::Settings(
                "techniques: the technique layers are kept by a render in one process only; \
                 render the whole image at once (no range, no resume)"
                    .into(),
            ));
        }
        Start::At(a) => {
            if a > 1 && settings.progression == Progression::Original {
                return Err(Error::Settings(
                    "the original PPM (progression = \"original\") keeps per-pixel statistics \
                     that depend on every earlier iteration: it cannot render a range that does \
                     not start at 1 (it can resume)"
                        .into(),
                ));
            }
            (a, method.film(width, height), None)
        }
        Start::Resume(p) => {
            let p = *p;
            p.check_matches(&scene.fingerprint(), [width, height], settings).map_err(|m| {
                Error::Settings(format!("cannot resume from this partial render: {m}"))
            })?;
            if let Some(state) = &p.state {
                method.load_state(state).map_err(Error::Settings)?;
            }
            (p.info.first_iteration, p.film.clone(), Some(p.info))
        }
    })
}

/// Raises `halt` when `stop` is raised or the time limit passes, looking every 5 ms; returns at
/// once when the sender of `finished` is dropped (the render's end: it waits out no sleep).
fn watch(
    settings: &RenderSettings,
    start: Instant,
    stop: &AtomicBool,
    halt: &AtomicBool,
    finished: std::sync::mpsc::Receiver<()>,
) {
    use std::sync::mpsc::RecvTimeoutError;
    loop {
        let late = settings.time_limit.is_some_and(|t| start.elapsed().as_secs_f64() >= t);
        if late || stop.load(Ordering::Relaxed) {
            halt.store(true, Ordering::Relaxed);
            return;
        }
        let wait = finished.recv_timeout(std::time::Duration::from_millis(5));
        if wait != Err(RecvTimeoutError::Timeout) {
            return;
        }
    }
}

/// Light paths traced to measure photons stored per path for [`memory_estimate`].
pub const PILOT_PATHS: u64 = 1000;

/// Bytes one iteration of a render of `scene` with `settings` is expected to need: the photons
/// its light paths store (measured by tracing [`PILOT_PATHS`] of them; three times: the photon
/// pass's lists, its work items' buffers, and the photon maps built from them) and the image
/// buffers. An estimate: paths vary. Refuses the settings a
/// render refuses ([`Error::Settings`]).
pub fn memory_estimate(scene: &Scene, settings: &RenderSettings) -> Result<u64> {
    Ok(memory_need(scene, &Plan::new(scene, settings)?))
}

/// [`memory_estimate`] for a plan.
fn memory_need(scene: &Scene, plan: &Plan) -> u64 {
    let [w, h] = scene.camera.resolution;
    // Film sums and squares (i128 × 3 each; twice with photons: the kernel-bias sums), the
    // iteration frame (value and bias), and the original PPM's two copies of its per-pixel
    // statistics (88 bytes each).
    let photons = plan.method != MethodKind::Path;
    let per_pixel =
        96 * (1 + photons as u64) + 24 + if plan.method == MethodKind::Original { 176 } else { 0 };
    let image = w as u64 * h as u64 * per_pixel;
    if !photons || scene.lights.is_empty() {
        return image;
    }
    let pilot = plan.with_paths(PILOT_PATHS.min(plan.paths));
    let mut mapper = crate::integrator::ppm::PhotonMapper::new(scene, &pilot);
    mapper.trace(scene, 1, &AtomicBool::new(false));
    let [surface, volume] = mapper.stored();
    let per_path = (surface as f64 * std::mem::size_of::<crate::photon::Photon>() as f64
        + volume as f64 * std::mem::size_of::<crate::photon::VolumePhoton>() as f64)
        / pilot.paths as f64;
    image + (3.0 * per_path * plan.paths as f64) as u64
}

/// What the photons of iteration `iteration` of a render with `settings` are used for: how many
/// were stored and how many its camera pass gathered at least once, and with photon guiding what
/// the pilot found per light (`haze bench` reports it). `None` for methods without photons (the
/// path tracer, the original PPM) or if `stop` was raised.
pub fn photon_usage(
    scene: &Scene,
    settings: &RenderSettings,
    iteration: u64,
    stop: &AtomicBool,
) -> Result<Option<PhotonUsage>> {
    let mut method = Method::new(scene, &Plan::new(scene, settings)?);
    Ok(method.photon_usage(scene, iteration.max(1), stop))
}

/// The combined integrator's light paths per iteration for a render of `scene` with `settings`,
/// and what its pilot measured to choose them (`haze bench` reports it; docs/theory.md, "How
/// many light paths"). `None` for the other integrators or if `stop` was raised.
pub fn light_path_budget(
    scene: &Scene,
    settings: &RenderSettings,
    stop: &AtomicBool,
) -> Result<Option<crate::integrator::combined::Budget>> {
    let plan = Plan::new(scene, settings)?;
    if plan.method != MethodKind::Combined {
        return Ok(None);
    }
    let mut combined = crate::integrator::combined::Combined::new(scene, &plan);
    Ok(combined.budget(scene, stop).cloned())
}

/// Physical memory in bytes (Linux: /proc/meminfo), if known.
fn physical_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Iterations before a target error may stop a render: fewer make the variance estimates it
/// rests on too unreliable (docs/error.md).
pub const MIN_TARGET_ITERATIONS: u64 = 8;

/// True if the settings' target error is reached: the upper confidence limit of the image's
/// estimated relative error at or below it, after at least [`MIN_TARGET_ITERATIONS`].
fn reached_target(settings: &RenderSettings, film: &Film) -> bool {
    let Some(target) = settings.target_error else { return false };
    film.iterations() >= MIN_TARGET_ITERATIONS
        && film
            .error_estimate(settings.target_confidence, settings.target_region)
            .is_some_and(|e| e.upper <= target)
}

/// True once the last iteration (`settings.iterations`, an index) or the time limit is reached,
/// or a stop was requested.
fn done(settings: &RenderSettings, iteration: u64, start: Instant, stop: &AtomicBool) -> bool {
    settings.iterations.is_some_and(|n| iteration >= n)
        || settings.time_limit.is_some_and(|t| start.elapsed().as_secs_f64() >= t)
        || stop.load(Ordering::Relaxed)
}
