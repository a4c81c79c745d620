//! `haze render`: a scene file to OpenEXR and a PNG preview, with a progress bar.

use crate::shared::{Overrides, check_output_dir, default_output, thread_pool};
use crate::signals::Interrupt;
use anyhow::{Result, bail};
use clap::Args;
use haze::progress::Status;
use haze::settings::Integrator;
use haze::{Image, Partial, RenderSettings, Start};
use indicatif::ProgressBar;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

#[derive(Args)]
#[command(allow_negative_numbers = true)]
pub(crate) struct RenderArgs {
    /// Scene file (TOML; see docs/scene-format.md).
    scene: PathBuf,
    /// Output file: .exr writes OpenEXR with a PNG preview beside it, .png the preview alone,
    /// .hpr a partial render only (for `haze merge` or `--resume`) [default: SCENE-NAME.exr].
    /// Ranges, resumed, interrupted and snapshotted renders also write a partial render beside
    /// an image output (same name, .hpr).
    #[arg(short = 'o', long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Continue the partial render PART (same scene and settings) from the iteration after its
    /// last, up to --iterations (an index) or for --time; bit-identical to an uninterrupted render.
    #[arg(long, value_name = "PART")]
    resume: Option<PathBuf>,
    /// The first iteration of a range (set by `--iterations A..B`).
    #[arg(long, hide = true, value_name = "A")]
    first_iteration: Option<u64>,
    #[command(flatten)]
    overrides: Overrides,
    /// Write the image so far every this often (e.g. 30s) to the output files.
    #[arg(long, value_name = "DURATION", value_parser = haze::settings::parse_duration)]
    snapshot_every: Option<f64>,
    /// Exposure multiplier for the PNG preview (the EXR stays linear and unscaled).
    #[arg(long, default_value_t = 1.0, value_name = "E")]
    exposure: f32,
    /// Write a reference for `haze converge`: the EXR gets a `haze:reference` attribute saying
    /// how it was made and a `variance` layer (each pixel's variance of the mean).
    #[arg(long)]
    reference: bool,
    /// No progress bar.
    #[arg(short, long)]
    quiet: bool,
}

/// Renders; the exit code is 0, or 128 + the signal's number if SIGINT (130) or SIGTERM (143)
/// stopped the render (what was finished is written first).
pub(crate) fn run(args: RenderArgs) -> Result<ExitCode> {
    // Listening from the start: a signal while the scene loads exits at once (a large grid can
    // take seconds to load), one during the render stops it cleanly.
    let interrupt = Interrupt::install()?;
    // A resume continues what its partial records — image size, settings and output files —
    // unless the command line says otherwise.
    let resumed = args.resume.as_deref().map(Partial::read).transpose()?;
    // Loading's parallel parts (grids, majorants, the BVH) run on the render's threads too.
    let pool = thread_pool(args.overrides.threads)?;
    let mut scene = pool.install(|| args.overrides.load_scene(&args.scene))?;
    let settings = settings_of(&args, resumed.as_ref(), &mut scene)?;
    if !(args.exposure.is_finite() && args.exposure > 0.0) {
        bail!("--exposure must be a positive number, got {}", args.exposure);
    }
    let outs = outputs(&args, resumed.as_ref())?;
    let start = start_of(&args, resumed, &settings, &outs.partial_path)?;
    let ranged = args.first_iteration.is_some() || args.resume.is_some() || outs.partial_only;
    let stop = interrupt.flag();
    if !args.quiet {
        // How each grid is stored (dense or bricks), so that memory is never a surprise.
        for g in scene.grids() {
            eprintln!("{g}");
        }
    }
    let bar = progress_bar(args.quiet, &settings);
    // Every write of the outputs — snapshots and the last — in one place: the partial render if
    // asked for, then the image unless the output is a partial alone; a second signal waits.
    let write = |part: &Partial, image: Option<&Image>, with_partial: bool| {
        interrupt.writing(|| outs.write(part, image, with_partial, args.reference, args.exposure))
    };
    let mut last_snapshot = Instant::now();
    let mut snapshot_error = None;
    let started = Instant::now();
    let log = crate::shared::LogLines::new(args.quiet);
    let mut on_iteration = |s: &Status| {
        update_bar(&bar, s);
        log.report(|| log_line(s));
        if let Some(every) = args.snapshot_every {
            if last_snapshot.elapsed().as_secs_f64() >= every {
                last_snapshot = Instant::now();
                let mut part = s.partial();
                part.output = outs.recorded.clone();
                if let Err(e) = write(&part, None, true) {
                    snapshot_error.get_or_insert(e);
                }
            }
        }
    };
    interrupt.arm();
    let mut part =
        pool.install(|| haze::render_partial(&scene, &settings, start, &mut on_iteration, stop))?;
    part.output = outs.recorded.clone();
    bar.finish_and_clear();
    if let Some(e) = snapshot_error {
        eprintln!("warning: a snapshot could not be written: {e}");
    }
    if part.info.iterations == 0 {
        return nothing_rendered(&interrupt, &settings);
    }
    let keep_partial = ranged || args.snapshot_every.is_some() || interrupt.name().is_some();
    // On the render's threads too: the image's layers and the EXR's compression are parallel,
    // and the summary's figures are worked out while the files are written (whose end waits on
    // the disk).
    let (written, figures) = pool.install(|| {
        let image = part.image();
        rayon::join(|| write(&part, Some(&image), keep_partial), || Figures::of(&image, &settings))
    });
    let written = written?;
    eprintln!("{}", summary(&part, &settings, &written, ranged, interrupt.name(), &figures));
    if interrupt.name().is_some() {
        eprintln!("{}", resume_hint(&args, &settings, started, &outs.partial_path));
    }
    warn_about(&part.info);
    Ok(interrupt.exit_code().unwrap_or(ExitCode::SUCCESS))
}

/// The end of a render stopped before its first iteration finished: by a signal (its exit code)
/// or by the time limit (an error).
fn nothing_rendered(interrupt: &Interrupt, settings: &RenderSettings) -> Result<ExitCode> {
    if let (Some(name), Some(code)) = (interrupt.name(), interrupt.exit_code()) {
        eprintln!("error: {name} before the first iteration finished; nothing written");
        return Ok(code);
    }
    bail!(
        "the time limit ({} s) ended before the first iteration finished; nothing written \
         (allow more time, or lower the photons or the resolution)",
        settings.time_limit.unwrap_or(0.0)
    );
}

/// The settings of a render: the scene's, or for a resume its partial's (with the scene's goal
/// and, unless `--resolution` says otherwise, the partial's image size), then the command line's.
fn settings_of(
    args: &RenderArgs,
    resumed: Option<&Partial>,
    scene: &mut haze::Scene,
) -> Result<RenderSettings> {
    let base = match resumed {
        Some(part) => {
            if args.overrides.resolution.is_none() {
                scene.set_resolution([part.film.width(), part.film.height()])?;
            }
            RenderSettings {
                iterations: scene.settings.iterations,
                time_limit: scene.settings.time_limit,
                ..part.info.settings.clone()
            }
        }
        None => scene.settings.clone(),
    };
    args.overrides.settings(&base)
}

/// Where a render writes: the output file, the path recorded in its partials for a later resume
/// (none for a partial alone), whether the output is a partial alone, and the partial's path.
struct Outputs {
    output: PathBuf,
    recorded: Option<PathBuf>,
    partial_only: bool,
    partial_path: PathBuf,
}

impl Outputs {
    /// Writes `part`: the partial render if `with_partial`, then its image — `image` if given
    /// (made by [`Partial::image`]), a reference for `haze converge` if `reference` — unless the
    /// output is a partial alone. Returns the files.
    fn write(
        &self,
        part: &Partial,
        image: Option<&Image>,
        with_partial: bool,
        reference: bool,
        exposure: f32,
    ) -> haze::Result<Vec<PathBuf>> {
        let mut written = Vec::new();
        if with_partial {
            part.write(&self.partial_path)?;
            written.push(self.partial_path.clone());
        }
        if !self.partial_only {
            let made;
            let image = match image {
                Some(image) => image,
                None => {
                    made = part.image();
                    &made
                }
            };
            written.extend(if reference {
                image.write_reference(&self.output, exposure)?
            } else {
                image.write(&self.output, exposure)?
            });
        }
        Ok(written)
    }
}

/// The outputs of `args` (a resumed partial's own unless `-o` says otherwise), checked: a known
/// extension, a writable directory.
fn outputs(args: &RenderArgs, resumed: Option<&Partial>) -> Result<Outputs> {
    let output = match (&args.output, resumed, &args.resume) {
        (Some(o), ..) => o.clone(),
        (None, Some(part), Some(path)) => part.output.clone().unwrap_or_else(|| path.clone()),
        _ => default_output(&args.scene, None, "exr"),
    };
    // Recorded in every partial this render writes, for a later resume.
    let recorded = output
        .extension()
        .is_none_or(|e| e != "hpr")
        .then(|| std::path::absolute(&output).unwrap_or_else(|_| output.clone()));
    let partial_only = output.extension().is_some_and(|e| e == "hpr");
    match output.extension().and_then(|e| e.to_str()) {
        Some("exr") => {}
        Some("png" | "hpr") if !args.reference => {}
        _ if args.reference => bail!("--output {}: a reference must end in .exr", output.display()),
        _ => bail!(
            "--output {}: the file name must end in .exr (OpenEXR plus a PNG preview), .png or \
             .hpr (a partial render)",
            output.display()
        ),
    }
    check_output_dir("--output", &output)?;
    let partial_path = output.with_extension("hpr");
    let preview = haze::output::preview_path(&output);
    if output.extension().is_some_and(|e| e == "exr")
        && preview.exists()
        && !haze::output::is_haze_preview(&preview)
    {
        bail!(
            "--output {}: its PNG preview would replace {}, which haze did not write; move that \
             file away or choose another output name",
            output.display(),
            preview.display()
        );
    }
    Ok(Outputs { output, recorded, partial_only, partial_path })
}

/// Where the render starts: after a resumed partial's last iteration, at the first of a range,
/// or at 1; refused where they contradict each other or the goal.
fn start_of(
    args: &RenderArgs,
    resumed: Option<Partial>,
    settings: &RenderSettings,
    partial_path: &Path,
) -> Result<Start> {
    Ok(match (resumed, args.first_iteration) {
        (Some(_), Some(_)) => bail!("--resume continues a partial render: give it no range"),
        (Some(part), None) => {
            let p = args.resume.as_deref().unwrap_or(partial_path);
            if settings.iterations.is_some_and(|n| n <= part.last_iteration()) {
                bail!(
                    "--resume {}: it already holds iterations {}..{}; ask for more with \
                     --iterations N (the last iteration's index) or --time",
                    p.display(),
                    part.info.first_iteration,
                    part.last_iteration()
                );
            }
            Start::Resume(Box::new(part))
        }
        (None, Some(a)) => {
            if settings.iterations.is_some_and(|b| b < a) || a == 0 {
                bail!(
                    "--iterations {a}..{}: not a range of iterations",
                    settings.iterations.unwrap_or(0)
                );
            }
            Start::At(a)
        }
        (None, None) => Start::At(1),
    })
}

/// The figures of a render's last line that read every pixel of its image: the noise (from the
/// variance layer), the kernel bias (from the bias layer) and, with a target error, the estimated
/// error at the target's confidence.
pub(crate) struct Figures {
    noise: Option<f64>,
    bias: Option<(f64, Option<f64>)>,
    error: Option<haze::film::ErrorEstimate>,
}

impl Figures {
    /// The figures of `image`, rendered with `settings`, each on a thread of its own where there
    /// are threads to spare. The error estimate is [`haze::film::Film::error_estimate`]'s for
    /// the film the image came from (the image keeps the layers it reads).
    pub(crate) fn of(image: &Image, settings: &RenderSettings) -> Self {
        let error = || {
            settings.target_error.and_then(|_| {
                image.error_estimate(settings.target_confidence, settings.target_region)
            })
        };
        let ((noise, bias), error) = rayon::join(
            || rayon::join(|| image.relative_noise(None), || image.relative_bias(None)),
            error,
        );
        Self { noise, bias, error }
    }
}

/// The line that ends a render: iterations, work, time, noise and bias, target, files written.
fn summary(
    part: &Partial,
    settings: &RenderSettings,
    written: &[PathBuf],
    ranged: bool,
    interrupted_by: Option<&str>,
    figures: &Figures,
) -> String {
    let i = &part.info;
    let interrupted = interrupted_by.map(|n| format!(" (interrupted by {n})")).unwrap_or_default();
    let work = match i.settings.integrator {
        Integrator::PhotonMapping | Integrator::Hybrid => {
            format!("{} light paths, final radius {:.5}", i.light_paths, i.radius)
        }
        // A render records the integrator `auto` stood for (never `Auto` itself).
        Integrator::Combined | Integrator::Auto => {
            // The pilot may have chosen fewer light paths per iteration than `photons`.
            let per = i.light_paths.checked_div(i.iterations).unwrap_or(0);
            let chosen = if per != i.settings.photons && per > 0 {
                format!(" ({per} per iteration, chosen by the pilot from {})", i.settings.photons)
            } else if per == 0 && i.iterations > 0 {
                " (the pilot chose none: the eye's techniques alone, a path tracer)".to_string()
            } else {
                String::new()
            };
            format!("{} light paths{chosen}, final radius {:.5}", i.light_paths, i.radius)
        }
        Integrator::Path => "path tracing, one sample per pixel per iteration".to_string(),
    };
    let files: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
    let range = if ranged {
        format!(" ({}..{})", i.first_iteration, i.first_iteration + i.iterations - 1)
    } else {
        String::new()
    };
    // The noise estimate of the image (its variance layer) and, for photon mapping, its
    // estimated kernel bias over the image (the bias layer's mean relative to the image's).
    let noise = match figures.noise {
        Some(n) => format!(", relative noise {:.2} %", 100.0 * n),
        None => String::new(),
    };
    let noise = match figures.bias {
        Some((b, Some(se))) => {
            format!("{noise}, kernel bias {:+.2} % ± {:.2} %", 100.0 * b, 100.0 * se)
        }
        Some((b, None)) => format!("{noise}, kernel bias {:+.2} %", 100.0 * b),
        None => noise,
    };
    let noise = match (settings.target_error, figures.error) {
        (Some(target), Some(e)) => format!(
            "{noise} (error{} ≤ {:.2} % at {:.0} % confidence; target {:.2} %{})",
            settings
                .target_region
                .map_or(String::new(), |r| format!(" over {},{},{},{}", r.x0, r.y0, r.x1, r.y1)),
            100.0 * e.upper,
            100.0 * e.confidence,
            100.0 * target,
            if e.upper <= target { ", reached" } else { ", not reached" }
        ),
        _ => noise,
    };
    format!(
        "{} iterations{range}{interrupted}, {work}, {:.1} s{noise}: wrote {}",
        i.iterations,
        i.elapsed,
        files.join(" and ")
    )
}

/// The command that resumes an interrupted render: the partial records the size, settings and
/// outputs, so it needs only the goal (the iteration count, or the time left).
fn resume_hint(
    args: &RenderArgs,
    settings: &RenderSettings,
    started: Instant,
    partial: &Path,
) -> String {
    let goal = match (settings.iterations, settings.time_limit) {
        (Some(n), _) => format!(" --iterations {n}"),
        (None, Some(t)) => {
            format!(" --time {:.0}s", (t - started.elapsed().as_secs_f64()).max(1.0).ceil())
        }
        (None, None) => String::new(),
    };
    format!(
        "resume with: {} render {} --resume {}{goal}",
        invocation(),
        shell_word(&args.scene.display().to_string()),
        shell_word(&partial.display().to_string())
    )
}

/// Warnings about the render's samples: non-finite ones, trackings cut at the step cap.
fn warn_about(i: &haze::RenderInfo) {
    if i.nonfinite_samples > 0 {
        eprintln!("warning: {} non-finite samples were replaced by black", i.nonfinite_samples);
    }
    if i.truncated_trackings > 0 {
        eprintln!(
            "warning: {} trackings through VDB media reached the step cap and were treated as \
             opaque (the image is too dark there): the medium's extinction is extreme for its \
             grid; see docs/scene-format.md",
            i.truncated_trackings
        );
    }
}

/// The render's progress bar: iterations, or the time budget (hidden if `quiet`).
fn progress_bar(quiet: bool, settings: &RenderSettings) -> ProgressBar {
    let (len, template) = match (settings.iterations, settings.time_limit) {
        (Some(n), _) => (n, "{elapsed_precise} [{bar:30}] {pos}/{len} it, {msg}, ETA {eta}"),
        (None, Some(t)) => {
            ((t * 1000.0) as u64, "{elapsed_precise} [{bar:30}] time budget, {msg}, ETA {eta}")
        }
        // Neither (refused by the settings' validation): no length known in advance.
        (None, None) => (1, "{elapsed_precise} {spinner} {msg}"),
    };
    crate::shared::bar(quiet, len, template)
}

fn update_bar(bar: &ProgressBar, s: &Status) {
    let i = s.info;
    match (s.target_iterations, s.time_limit) {
        (Some(_), _) => bar.set_position(i.first_iteration + i.iterations - 1),
        (None, Some(_)) => bar.set_position((i.elapsed * 1000.0) as u64),
        (None, None) => bar.tick(),
    }
    let rate = i.iterations as f64 / i.elapsed.max(1e-9);
    let volume = if s.volume_photons_stored > 0 {
        format!(", volume r = {:.5}", i.volume_radius)
    } else {
        String::new()
    };
    // The estimate costs a pass over the image: only with a target to show it against.
    let error =
        match (i.settings.target_error, i.settings.target_error.and_then(|_| s.error_estimate())) {
            (Some(target), Some(e)) => format!(
                ", error ≤ {:.2} % ({:.0} % confidence; target {:.2} %)",
                100.0 * e.upper,
                100.0 * e.confidence,
                100.0 * target
            ),
            (Some(_), None) => ", error: not yet estimated".to_string(),
            _ => String::new(),
        };
    // One rate, the render's mean (the bar's own position says the iteration where it has one).
    let done = if s.target_iterations.is_some() {
        String::new()
    } else {
        format!("it {}, ", i.iterations)
    };
    bar.set_message(format!("{done}{rate:.2} it/s, r = {:.5}{volume}{error}", i.radius));
}

/// A plain progress line for a log: `12/100 iterations, 4.63 it/s, ETA 19 s, r = 0.02559`.
fn log_line(s: &Status) -> String {
    let i = s.info;
    let rate = i.iterations as f64 / i.elapsed.max(1e-9);
    let last = i.first_iteration + i.iterations - 1;
    let (done, left) = match (s.target_iterations, s.time_limit) {
        (Some(n), limit) => {
            let by_count = n.saturating_sub(last) as f64 / rate.max(1e-9);
            let left = limit.map_or(by_count, |t| by_count.min(t - i.elapsed));
            (format!("{last}/{n} iterations"), Some(left))
        }
        (None, Some(t)) => (format!("{last} iterations"), Some(t - i.elapsed)),
        (None, None) => (format!("{last} iterations"), None),
    };
    let eta = left.map_or(String::new(), |l| format!(", ETA {}", crate::shared::duration_words(l)));
    let error = match i.settings.target_error.and_then(|_| s.error_estimate()) {
        Some(e) => format!(", error ≤ {:.2} %", 100.0 * e.upper),
        None => String::new(),
    };
    format!("{done}, {rate:.2} it/s{eta}, r = {:.5}{error}", i.radius)
}

/// How this haze was started, for a command to paste: `cargo run --release --` (or `cargo run
/// --`) where cargo ran it from its target directory, otherwise the program as it was named
/// (`haze` found on the PATH, or a path such as `target/release/haze`, relative to the current
/// directory where it lies below it).
pub(crate) fn invocation() -> String {
    let argv0 = std::env::args_os().next().map(PathBuf::from).unwrap_or_else(|| "haze".into());
    let cwd = std::env::current_dir().ok();
    // cargo sets CARGO_MANIFEST_DIR for what `cargo run` starts.
    if let Some(manifest) = std::env::var_os("CARGO_MANIFEST_DIR").map(PathBuf::from) {
        let under = |profile: &str| argv0 == manifest.join("target").join(profile).join("haze");
        let here = cwd.as_deref() == Some(manifest.as_path());
        if here && under("release") {
            return "cargo run --release --".into();
        }
        if here && under("debug") {
            return "cargo run --".into();
        }
    }
    let shown = match &cwd {
        Some(c) if argv0.is_absolute() => argv0.strip_prefix(c).unwrap_or(&argv0).to_path_buf(),
        _ => argv0.clone(),
    };
    // A bare name would be looked up on the PATH: a program in the current directory is `./haze`.
    let shown = if argv0.is_absolute() && shown.components().count() == 1 {
        Path::new(".").join(shown)
    } else {
        shown
    };
    shell_word(&shown.display().to_string())
}

/// `w` quoted for a POSIX shell where it needs it.
pub(crate) fn shell_word(w: &str) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "/._-+=:,@%".contains(c);
    if !w.is_empty() && w.chars().all(plain) {
        w.to_string()
    } else {
        format!("'{}'", w.replace('\'', "'\\''"))
    }
}
