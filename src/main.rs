//! The `haze` command line: render scenes, benchmark the passes.

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use haze::Scene;
use haze::estimate::kernel::Kernel;
use haze::progress::Status;
use haze::settings::{Integrator, Progression, Radius, RenderSettings, VolumeEstimate};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// haze: a progressive photon mapper for participating media.
#[derive(Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene file to OpenEXR (plus a PNG preview beside it).
    Render(RenderArgs),
    /// Measure photon-pass and camera-pass throughput on a scene.
    Bench(BenchArgs),
    /// Chart error against time: render the scene while measuring its error against a reference
    /// image at log-spaced iteration counts, for one or more series of settings; writes CSV, SVG
    /// and PNG, and prints fitted and theoretical slopes.
    Converge(ConvergeArgs),
    /// Render media with known answers (furnace, Beer–Lambert, half-space) with every method
    /// and report agreement with the analytic references; exits 1 if a case fails.
    Validate(ValidateArgs),
}

#[derive(Args)]
struct ValidateArgs {
    /// A short run (fewer seeds, iterations and photons).
    #[arg(long)]
    quick: bool,
    /// Also write the table as Markdown to this file.
    #[arg(long, value_name = "FILE")]
    markdown: Option<PathBuf>,
    /// Also write the table as CSV to this file.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Directory holding the OpenVDB assets (box.vdb, gradient.vdb).
    #[arg(long, value_name = "DIR", default_value = "media")]
    media: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(short = 'j', long, value_name = "T")]
    threads: Option<usize>,
    /// Run only the cases whose name contains this text (e.g. "half-space").
    #[arg(long, value_name = "TEXT")]
    case: Option<String>,
}

/// Options that override the scene file's [render] table.
#[derive(Args, Clone)]
struct Overrides {
    /// Number of iterations (photon-mapping passes) to average.
    #[arg(short = 'n', long, value_name = "N")]
    iterations: Option<u64>,
    /// Time budget, e.g. 90, 90s, 1.5m, 1h; the render stops at N iterations or this, whichever first.
    #[arg(short = 't', long, value_name = "DURATION", value_parser = parse_duration)]
    time: Option<f64>,
    /// Light paths emitted per iteration.
    #[arg(short = 'p', long, value_name = "N")]
    photons: Option<u64>,
    /// Radius reduction α in (0, 1): r²(i+1)/r²(i) = (i+α)/(i+1).
    #[arg(short = 'a', long, value_name = "A")]
    alpha: Option<f64>,
    /// Initial gathering radius in scene units.
    #[arg(short = 'r', long, value_name = "R", conflicts_with = "radius_fraction")]
    radius: Option<f64>,
    /// Initial gathering radius as a fraction of the scene's bounding-box diagonal.
    #[arg(long, value_name = "F")]
    radius_fraction: Option<f64>,
    /// Density-estimation kernel: constant, epanechnikov or biweight.
    #[arg(short = 'k', long, value_name = "KERNEL", value_parser = parse_kernel)]
    kernel: Option<Kernel>,
    /// Maximum scattering events on light and eye paths (pass-through interfaces are not events).
    #[arg(long, value_name = "D")]
    max_depth: Option<u32>,
    /// Random seed; the same scene, seed and iteration count give the same image.
    #[arg(short = 's', long, value_name = "S")]
    seed: Option<u64>,
    /// In-scattering estimate in media: beam (beam radiance estimate) or point (3-D kernel).
    #[arg(long, value_name = "KIND", value_parser = parse_volume_estimate)]
    volume_estimate: Option<VolumeEstimate>,
    /// Radius reduction α of the volume schedule r^d(i+1)/r^d(i) = (i+α)/(i+1).
    #[arg(long, value_name = "A")]
    volume_alpha: Option<f64>,
    /// Initial volume radius in scene units.
    #[arg(long, value_name = "R", conflicts_with = "volume_radius_fraction")]
    volume_radius: Option<f64>,
    /// Initial volume radius as a fraction of the scene's bounding-box diagonal.
    #[arg(long, value_name = "F")]
    volume_radius_fraction: Option<f64>,
    /// Dimension d of the volume radius schedule (3 by default; 2 for experiments).
    #[arg(long, value_name = "D")]
    volume_dimension: Option<u32>,
    /// Integrator: ppm (progressive photon mapping) or path (unbiased reference path tracer).
    #[arg(long, value_name = "NAME", value_parser = parse_integrator)]
    integrator: Option<Integrator>,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(short = 'j', long, value_name = "T")]
    threads: Option<usize>,
    /// Image size WIDTHxHEIGHT instead of the scene's (the field of view is kept).
    #[arg(long, value_name = "WxH", value_parser = parse_resolution)]
    resolution: Option<[u32; 2]>,
    /// Original PPM (per-pixel statistics, surfaces only) or probabilistic PPM.
    #[arg(long, value_name = "KIND", value_parser = parse_progression)]
    progression: Option<Progression>,
    /// Thin volume photons in cells (of ~4 photons on average) holding more than B photons (unbiased).
    #[arg(long, value_name = "B")]
    beam_cell_budget: Option<u32>,
}

#[derive(Args)]
#[command(allow_negative_numbers = true)]
struct ConvergeArgs {
    /// Scene file.
    scene: PathBuf,
    /// Reference image (OpenEXR at the render's resolution), e.g. from
    /// `haze render SCENE --reference --integrator path -t 30m`.
    #[arg(long, value_name = "REF.exr")]
    reference: PathBuf,
    // The time budget per run and series is --time (default 60 s); --iterations caps each run.
    /// Independent runs per series (seeds S, S+1, …); their squared errors are averaged.
    #[arg(long, value_name = "K", default_value_t = 1)]
    runs: u32,
    /// A named comparison: estimate, alpha, volume-alpha, kernel, dimension, photons,
    /// progression or integrator (repeatable).
    #[arg(long, value_name = "NAME")]
    compare: Vec<String>,
    /// A series LABEL:KEY=VALUE,… with keys of the scene's [render] table, e.g.
    /// "alpha 0.5:alpha=0.5" (repeatable).
    #[arg(long, value_name = "SPEC")]
    series: Vec<String>,
    /// Measure over the pixels X0,Y0,X1,Y1 only (X1, Y1 exclusive).
    #[arg(long, value_name = "X0,Y0,X1,Y1")]
    region: Option<haze::converge::Region>,
    /// Output prefix: writes PREFIX.csv, PREFIX.svg, PREFIX.png and PREFIX.md
    /// [default: converge-SCENE-NAME].
    #[arg(short = 'o', long, value_name = "PREFIX")]
    output: Option<PathBuf>,
    /// Chart title [default: the scene's file name].
    #[arg(long)]
    title: Option<String>,
    #[command(flatten)]
    overrides: Overrides,
    /// No progress bar.
    #[arg(short, long)]
    quiet: bool,
}

#[derive(Args)]
#[command(allow_negative_numbers = true)]
struct RenderArgs {
    /// Scene file (TOML; see docs/scene-format.md).
    scene: PathBuf,
    /// Output OpenEXR file; the PNG preview is written beside it [default: SCENE-NAME.exr].
    #[arg(short = 'o', long, value_name = "FILE")]
    output: Option<PathBuf>,
    #[command(flatten)]
    overrides: Overrides,
    /// Write the image so far every this often (e.g. 30s) to the output files.
    #[arg(long, value_name = "DURATION", value_parser = parse_duration)]
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

#[derive(Args)]
#[command(allow_negative_numbers = true)]
struct BenchArgs {
    /// Scene file [default: scenes/cornell-box.toml].
    scene: Option<PathBuf>,
    #[command(flatten)]
    overrides: Overrides,
}

fn parse_duration(s: &str) -> Result<f64, String> {
    let s = s.trim();
    let (num, unit) = match s.find(|c: char| c.is_ascii_alphabetic()) {
        Some(i) => (&s[..i], &s[i..]),
        None => (s, "s"),
    };
    let scale = match unit {
        "ms" => 1e-3,
        "s" => 1.0,
        "m" | "min" => 60.0,
        "h" => 3600.0,
        _ => return Err(format!("unknown unit `{unit}` (use ms, s, m or h)")),
    };
    let v: f64 = num.trim().parse().map_err(|_| format!("`{s}` is not a duration such as 60s"))?;
    if !(v.is_finite() && v > 0.0) {
        return Err(format!("`{s}` must be a positive duration"));
    }
    Ok(v * scale)
}

fn parse_kernel(s: &str) -> Result<Kernel, String> {
    s.parse()
}

fn parse_volume_estimate(s: &str) -> Result<VolumeEstimate, String> {
    s.parse()
}

fn parse_integrator(s: &str) -> Result<Integrator, String> {
    s.parse()
}

fn parse_progression(s: &str) -> Result<Progression, String> {
    s.parse()
}

fn parse_resolution(s: &str) -> Result<[u32; 2], String> {
    let bad = || format!("`{s}` is not a resolution WIDTHxHEIGHT such as 256x256");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h): (u32, u32) =
        (w.trim().parse().map_err(|_| bad())?, h.trim().parse().map_err(|_| bad())?);
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("resolution `{s}`: each side must lie in 1..=16384"));
    }
    Ok([w, h])
}

/// Loads the scene and applies the resolution override.
fn load_scene(path: &std::path::Path, o: &Overrides) -> Result<Scene> {
    let mut scene = Scene::load(path)?;
    if let Some(r) = o.resolution {
        scene.camera.resolution = r;
    }
    Ok(scene)
}

/// The scene's settings with the command-line overrides applied and validated.
fn apply(base: &RenderSettings, o: &Overrides) -> Result<RenderSettings> {
    let mut s = base.clone();
    match (o.iterations, o.time) {
        (Some(n), t) => {
            s.iterations = Some(n);
            s.time_limit = t.or(s.time_limit);
        }
        (None, Some(t)) => {
            // A time budget alone means "render until the time is up".
            s.iterations = None;
            s.time_limit = Some(t);
        }
        (None, None) => {}
    }
    s.photons = o.photons.unwrap_or(s.photons);
    s.alpha = o.alpha.unwrap_or(s.alpha);
    if let Some(r) = o.radius {
        s.radius = Radius::Absolute(r);
    }
    if let Some(f) = o.radius_fraction {
        s.radius = Radius::Fraction(f);
    }
    s.kernel = o.kernel.unwrap_or(s.kernel);
    s.max_depth = o.max_depth.unwrap_or(s.max_depth);
    s.seed = o.seed.unwrap_or(s.seed);
    s.volume_estimate = o.volume_estimate.unwrap_or(s.volume_estimate);
    s.volume_alpha = o.volume_alpha.unwrap_or(s.volume_alpha);
    if let Some(r) = o.volume_radius {
        s.volume_radius = Radius::Absolute(r);
    }
    if let Some(f) = o.volume_radius_fraction {
        s.volume_radius = Radius::Fraction(f);
    }
    s.volume_dimension = o.volume_dimension.unwrap_or(s.volume_dimension);
    s.integrator = o.integrator.unwrap_or(s.integrator);
    s.progression = o.progression.unwrap_or(s.progression);
    s.beam_cell_budget = o.beam_cell_budget.or(s.beam_cell_budget);
    if let Err(e) = s.validate() {
        let flag = match e.key {
            "time_limit" => "time".to_string(),
            k => k.replace('_', "-"),
        };
        bail!("--{flag} (or the scene's render.{}): {}", e.key, e.message);
    }
    if o.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    Ok(s)
}

fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        b = b.num_threads(t);
    }
    b.build().context("cannot start worker threads")
}

fn stop_on_ctrl_c() -> Arc<AtomicBool> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    // A second Ctrl-C exits at once.
    let _ = ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
    });
    stop
}

fn render(args: RenderArgs) -> Result<()> {
    let scene = load_scene(&args.scene, &args.overrides)?;
    let settings = apply(&scene.settings, &args.overrides)?;
    if !(args.exposure.is_finite() && args.exposure > 0.0) {
        bail!("--exposure must be a positive number, got {}", args.exposure);
    }
    if args.snapshot_every.is_some_and(|s| !s.is_finite()) {
        bail!("--snapshot-every must be finite");
    }
    let output = args.output.clone().unwrap_or_else(|| {
        PathBuf::from(args.scene.file_stem().unwrap_or("render".as_ref())).with_extension("exr")
    });
    if output.extension().and_then(|e| e.to_str()) != Some("exr") {
        bail!("--output {}: the file name must end in .exr", output.display());
    }
    if let Some(dir) = output.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.is_dir() {
            bail!("--output {}: directory {} does not exist", output.display(), dir.display());
        }
    }
    let pool = thread_pool(args.overrides.threads)?;
    let stop = stop_on_ctrl_c();
    let bar = if args.quiet { ProgressBar::hidden() } else { progress_bar(&settings) };
    let mut last_snapshot = Instant::now();
    let mut snapshot_error = None;
    let mut on_iteration = |s: &Status| {
        update_bar(&bar, s);
        if let Some(every) = args.snapshot_every {
            if last_snapshot.elapsed().as_secs_f64() >= every {
                last_snapshot = Instant::now();
                if let Err(e) = s.snapshot().write(&output, args.exposure) {
                    snapshot_error.get_or_insert(e);
                }
            }
        }
    };
    let image = pool.install(|| haze::render(&scene, &settings, &mut on_iteration, &stop))?;
    bar.finish_and_clear();
    if let Some(e) = snapshot_error {
        eprintln!("warning: a snapshot could not be written: {e}");
    }
    if image.info.iterations == 0 {
        bail!("stopped before the first iteration finished; nothing written");
    }
    let png = if args.reference {
        image.write_reference(&output, args.exposure)?
    } else {
        image.write(&output, args.exposure)?
    };
    let i = &image.info;
    let interrupted = if stop.load(Ordering::Relaxed) { " (interrupted)" } else { "" };
    let work = match i.integrator {
        Integrator::PhotonMapping => {
            format!("{} light paths, final radius {:.5}", i.light_paths, i.radius)
        }
        Integrator::Path => "path tracing, one sample per pixel per iteration".to_string(),
    };
    eprintln!(
        "{} iterations{interrupted}, {work}, {:.1} s: wrote {} and {}",
        i.iterations,
        i.elapsed,
        output.display(),
        png.display()
    );
    if i.nonfinite_samples > 0 {
        eprintln!("warning: {} non-finite samples were replaced by black", i.nonfinite_samples);
    }
    Ok(())
}

fn progress_bar(settings: &RenderSettings) -> ProgressBar {
    let (len, template) = match settings.iterations {
        Some(n) => (n, "{elapsed_precise} [{bar:30}] {pos}/{len} it, {per_sec}, ETA {eta} {msg}"),
        None => (
            (settings.time_limit.unwrap_or(1.0) * 1000.0) as u64,
            "{elapsed_precise} [{bar:30}] time budget, ETA {eta} {msg}",
        ),
    };
    let bar = ProgressBar::new(len);
    if let Ok(style) = ProgressStyle::with_template(template) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}

fn update_bar(bar: &ProgressBar, s: &Status) {
    let i = s.info;
    match s.target_iterations {
        Some(_) => bar.set_position(i.iterations),
        None => bar.set_position((i.elapsed * 1000.0) as u64),
    }
    let rate = i.iterations as f64 / i.elapsed.max(1e-9);
    let volume = if s.volume_photons_stored > 0 {
        format!(", volume r = {:.5}", i.volume_radius)
    } else {
        String::new()
    };
    bar.set_message(format!("it {} ({rate:.2} it/s), r = {:.5}{volume}", i.iterations, i.radius));
}

fn bench(args: BenchArgs) -> Result<()> {
    let path = args.scene.unwrap_or_else(|| PathBuf::from("scenes/cornell-box.toml"));
    let scene = load_scene(&path, &args.overrides)?;
    let mut o = args.overrides.clone();
    o.iterations = o.iterations.or(Some(8));
    let mut settings = apply(&scene.settings, &o)?;
    let media = !scene.media.is_empty() && settings.integrator == Integrator::PhotonMapping;
    settings.time_volume_estimate = media;
    let pool = thread_pool(o.threads)?;
    let stop = AtomicBool::new(false);
    // Seconds summed over the timed iterations: photon pass, all maps, volume map, camera pass,
    // volume estimates in the camera pass.
    let mut t = [0.0f64; 5];
    let (mut stored, mut stored_volume) = (0u64, 0u64);
    let mut on_iteration = |s: &Status| {
        // The first iteration warms caches and the allocator; time the rest.
        if s.iteration() > 1 {
            t[0] += s.photon_seconds;
            t[1] += s.map_seconds;
            t[2] += s.volume_map_seconds;
            t[3] += s.camera_seconds;
            t[4] += s.volume_estimate_seconds.unwrap_or(0.0);
            stored += s.photons_stored;
            stored_volume += s.volume_photons_stored;
        }
    };
    let image = pool.install(|| haze::render(&scene, &settings, &mut on_iteration, &stop))?;
    let timed = image.info.iterations.saturating_sub(1);
    if timed == 0 {
        bail!("--iterations must be at least 2 for a benchmark (the first is a warm-up)");
    }
    let [photon_s, map_s, volume_map_s, camera_s, volume_s] = t;
    let per_it = |x: f64| x / timed as f64;
    let [w, h] = scene.camera.resolution;
    let paths = (timed * settings.photons) as f64;
    let pixels = (timed * w as u64 * h as u64) as f64;
    println!("scene: {}", path.display());
    println!(
        "threads: {}, iterations timed: {timed} (after 1 warm-up), photons/iteration: {}, resolution: {w}x{h}",
        pool.current_num_threads(),
        settings.photons
    );
    println!("| pass | per second | seconds per iteration |");
    println!("|---|---|---|");
    println!(
        "| photon pass (trace + map build) | {:.0} light paths/s, {:.0} surface + {:.0} volume photons stored/s | {:.4} |",
        paths / photon_s,
        stored as f64 / photon_s,
        stored_volume as f64 / photon_s,
        per_it(photon_s)
    );
    println!(
        "| … building the surface photon map | {:.0} photons/s | {:.4} |",
        stored as f64 / (map_s - volume_map_s),
        per_it(map_s - volume_map_s)
    );
    let estimate = settings.volume_estimate.name();
    if media {
        println!(
            "| … building the volume photon map ({estimate} estimate) | {:.0} photons/s | {:.4} |",
            stored_volume as f64 / volume_map_s,
            per_it(volume_map_s)
        );
    }
    println!(
        "| camera pass (trace + {}) | {:.0} camera paths/s | {:.4} |",
        if media { format!("surface and {estimate} estimates") } else { "surface estimate".into() },
        pixels / camera_s,
        per_it(camera_s)
    );
    if media {
        println!(
            "| … in {estimate} estimates (thread time / threads) | | {:.4} |",
            per_it(volume_s)
        );
        let share = volume_map_s + volume_s;
        println!(
            "volume estimate ({estimate}: map build + estimates): {:.4} s of {:.4} s per iteration ({:.0} %)",
            per_it(share),
            per_it(photon_s + camera_s),
            100.0 * share / (photon_s + camera_s)
        );
    }
    Ok(())
}

fn converge(args: ConvergeArgs) -> Result<()> {
    use haze::converge::{self, Plan, Reference};
    let scene = load_scene(&args.scene, &args.overrides)?;
    let base = apply(&scene.settings, &args.overrides)?;
    let reference = Reference::load(&args.reference)?;
    let time = args.overrides.time.unwrap_or(60.0);
    if args.runs == 0 {
        bail!("--runs must be at least 1");
    }
    let mut series = Vec::new();
    for name in &args.compare {
        series
            .extend(converge::preset(name, &base).map_err(|e| anyhow::anyhow!("--compare: {e}"))?);
    }
    for spec in &args.series {
        series.push(
            converge::parse_series(spec, &base).map_err(|e| anyhow::anyhow!("--series: {e}"))?,
        );
    }
    if series.is_empty() {
        series.push(converge::Series { label: "scene settings".into(), settings: base.clone() });
    }
    let stem = args.scene.file_stem().unwrap_or("scene".as_ref()).to_string_lossy().to_string();
    let prefix = args.output.clone().unwrap_or_else(|| PathBuf::from(format!("converge-{stem}")));
    if let Some(dir) = prefix.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.is_dir() {
            bail!("--output {}: directory {} does not exist", prefix.display(), dir.display());
        }
    }
    let pool = thread_pool(args.overrides.threads)?;
    let stop = stop_on_ctrl_c();
    let plan = Plan {
        seconds: time,
        runs: args.runs,
        max_iterations: args.overrides.iterations,
        region: args.region,
    };
    let total = series.len() as f64 * args.runs as f64 * time;
    let bar =
        if args.quiet { ProgressBar::hidden() } else { ProgressBar::new((total * 1000.0) as u64) };
    if let Ok(style) = ProgressStyle::with_template("{elapsed_precise} [{bar:30}] ETA {eta} {msg}")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    let labels: Vec<String> = series.iter().map(|s| s.label.clone()).collect();
    let runs = args.runs;
    let mut on_progress = |si: usize, run: u32, seconds: f64| {
        let done = (si as f64 * runs as f64 + run as f64) * time + seconds.min(time);
        bar.set_position((done * 1000.0) as u64);
        bar.set_message(format!("{} (run {}/{runs})", labels[si], run + 1));
    };
    let samples = pool
        .install(|| converge::run(&scene, &series, &reference, &plan, &mut on_progress, &stop))?;
    bar.finish_and_clear();
    let summaries = converge::summarize(&scene, &series, &samples, args.runs);
    let title = args.title.clone().unwrap_or_else(|| {
        let [w, h] = scene.camera.resolution;
        format!("{stem} ({w}x{h}), {} threads", pool.current_num_threads())
    });
    let chart = converge::chart(&title, &summaries);
    let table = converge::markdown(&summaries);
    let with = |ext: &str| PathBuf::from(format!("{}.{ext}", prefix.display()));
    let write = |p: PathBuf, data: String| {
        std::fs::write(&p, data).with_context(|| format!("cannot write {}", p.display()))
    };
    write(with("csv"), converge::csv(&series, &samples))?;
    write(with("md"), table.clone())?;
    chart.write_svg(&with("svg"))?;
    chart.write_png(&with("png"))?;
    println!("{table}");
    println!(
        "reference: {} ({}); {} run(s) of {:.0} s per series, {} threads",
        args.reference.display(),
        reference.description.as_deref().unwrap_or("no haze:reference attribute"),
        args.runs,
        time,
        pool.current_num_threads()
    );
    println!("wrote {}.{{csv,md,svg,png}}", prefix.display());
    if stop.load(Ordering::Relaxed) {
        eprintln!("interrupted: the files hold the checkpoints reached so far");
    }
    Ok(())
}

fn validate(args: ValidateArgs) -> Result<()> {
    use haze::validate::{self, Effort};
    if args.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    if !args.media.join("box.vdb").is_file() {
        bail!(
            "--media {}: box.vdb not found (run from the repository root or pass --media)",
            args.media.display()
        );
    }
    let effort = if args.quick { Effort::QUICK } else { Effort::FULL };
    let pool = thread_pool(args.threads)?;
    let bar = ProgressBar::new(0);
    if let Ok(style) =
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} renders, ETA {eta}")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    let start = Instant::now();
    let rows = pool.install(|| {
        validate::run(&args.media, effort, args.case.as_deref(), |done, total| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        })
    })?;
    bar.finish_and_clear();
    if rows.is_empty() {
        bail!("--case {:?}: no case name contains it", args.case.unwrap_or_default());
    }
    let table = validate::markdown(&rows);
    println!("{table}");
    println!(
        "{} cases, {} seeds each, {} iterations x {} light paths per render; {} threads; {:.0} s",
        rows.len(),
        effort.seeds,
        effort.iterations,
        effort.photons,
        pool.current_num_threads(),
        start.elapsed().as_secs_f64()
    );
    if let Some(p) = &args.markdown {
        std::fs::write(p, &table).with_context(|| format!("cannot write {}", p.display()))?;
    }
    if let Some(p) = &args.csv {
        std::fs::write(p, validate::csv(&rows))
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    let failed = rows.iter().filter(|r| !r.pass()).count();
    if failed > 0 {
        bail!("{failed} of {} cases disagree with their references", rows.len());
    }
    Ok(())
}

fn run() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Render(a) => render(a),
        Command::Bench(a) => bench(a),
        Command::Validate(a) => validate(a),
        Command::Converge(a) => converge(a),
    }
}

fn main() -> ExitCode {
    // vdb-rs 0.6 panics on some corrupt files and obvhs on some degenerate geometry; the library
    // catches those panics and returns an error, so keep the default hook from printing them as if
    // the program had crashed.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let from_vdb_rs = info
            .location()
            .is_some_and(|l| l.file().contains("vdb-rs") || l.file().contains("obvhs"));
        if !from_vdb_rs {
            default_hook(info);
        }
    }));
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
