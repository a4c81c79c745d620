//! `haze bench`: the time of each step of an iteration (photon pass, map builds, camera pass,
//! film) on a scene, as a Markdown table; with `--scaling`, whole runs on 1 and N threads
//! ([`crate::scaling`]). Built with the `profile` feature, it also reports the time spent
//! in volume estimates (`cargo run --release --features profile -- bench SCENE`).

use crate::shared::{Overrides, bench_scene, thread_pool};
use anyhow::{Result, bail};
use clap::Args;
use haze::progress::{Status, StepTimes};
use haze::settings::Integrator;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

#[derive(Args)]
#[command(allow_negative_numbers = true, args_conflicts_with_subcommands = true)]
pub(crate) struct BenchArgs {
    #[command(subcommand)]
    what: Option<What>,
    /// Scene file [default: scenes/cornell-box.toml].
    scene: Option<PathBuf>,
    /// Thread scaling: whole runs (loading, the render and writing the image, as `haze render`
    /// does them, each in a fresh process) on 1 thread and on `--threads` (default: every
    /// core), the time of each phase at both, the serial fraction Amdahl's law gives each, and
    /// the efficiency it predicts at 16 and 64 threads.
    #[arg(long)]
    scaling: bool,
    /// With `--scaling`: rounds (the thread counts alternate within each; each phase's shortest
    /// time counts).
    #[arg(long, value_name = "R", default_value_t = 3, requires = "scaling")]
    rounds: usize,
    /// With `--scaling`: one whole run on T threads, its phase times printed on one line (the
    /// scaling table's runs are each made by this, in a process of their own).
    #[arg(long, value_name = "T", hide = true, requires = "scaling")]
    one_run: Option<usize>,
    #[command(flatten)]
    overrides: Overrides,
}

#[derive(clap::Subcommand)]
enum What {
    /// Ray queries alone: closest-hit and occlusion rays per second for camera, incoherent and
    /// shadow rays, on 1 and 2 threads, beside Embree's with `--embree`.
    Rays(crate::rays::RaysArgs),
    /// How one grid of an OpenVDB file is stored and how fast it is looked up: its size, load
    /// time and ns per random trilinear lookup (one thread), in every layout it fits in.
    Grid(GridArgs),
}

#[derive(Args)]
pub(crate) struct GridArgs {
    /// The OpenVDB file.
    file: PathBuf,
    /// The float grid to measure.
    #[arg(long, default_value = "density")]
    grid: String,
    /// Random lookups per layout.
    #[arg(long, value_name = "N", default_value_t = 20_000_000)]
    lookups: usize,
    /// Rounds (layouts alternate within each round).
    #[arg(long, value_name = "R", default_value_t = 3)]
    rounds: usize,
}

/// `haze bench grid`: a Markdown table, one row per layout and round.
fn grid(args: GridArgs) -> Result<()> {
    use haze::scene::GridLayout;
    // The lookup points are held in memory (12 bytes each).
    const MAX_LOOKUPS: usize = 1 << 27;
    if !(1..=MAX_LOOKUPS).contains(&args.lookups) || !(1..=1000).contains(&args.rounds) {
        bail!("--lookups must lie in 1..={MAX_LOOKUPS} and --rounds in 1..=1000");
    }
    println!(
        "{} grid `{}`, {} lookups per row, 1 thread",
        args.file.display(),
        args.grid,
        args.lookups
    );
    println!();
    println!(
        "| round | layout | box (voxels) | active voxels | MB | load s | ns/lookup | checksum |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let auto = haze::gridbench::measure_grid(&args.file, &args.grid, GridLayout::Auto, 1, 1)?;
    println!("(auto chooses {:?})", auto.layout);
    for round in 1..=args.rounds {
        for layout in [GridLayout::Dense, GridLayout::Bricks] {
            match haze::gridbench::measure_grid(&args.file, &args.grid, layout, args.lookups, 1) {
                Ok(m) => {
                    let [x, y, z] = m.dims;
                    println!(
                        "| {round} | {:?} | {x}×{y}×{z} | {} | {:.2} | {:.3} | {:.1} | {:.6e} |",
                        m.layout,
                        m.active_voxels,
                        m.bytes as f64 / 1e6,
                        m.load_seconds,
                        m.ns_per_lookup,
                        m.checksum
                    );
                }
                Err(e) => println!("| {round} | {layout:?} | — | — | — | — | — | {e} |"),
            }
        }
    }
    Ok(())
}

/// Step times summed over iterations, and the photons stored.
#[derive(Default)]
struct Totals {
    times: StepTimes,
    volume_estimates: f64,
    stored: u64,
    stored_volume: u64,
}

impl Totals {
    fn add(&mut self, s: &Status) {
        let (t, u) = (&mut self.times, &s.times);
        t.photon_trace += u.photon_trace;
        t.surface_map += u.surface_map;
        t.volume_map += u.volume_map;
        t.camera += u.camera;
        t.film += u.film;
        self.volume_estimates += u.volume_estimates.unwrap_or(0.0);
        self.stored += s.photons_stored;
        self.stored_volume += s.volume_photons_stored;
    }
}

pub(crate) fn run(args: BenchArgs) -> Result<()> {
    match args.what {
        Some(What::Rays(rays)) => return crate::rays::run(rays),
        Some(What::Grid(g)) => return grid(g),
        None => {}
    }
    let path = args.scene.unwrap_or_else(|| PathBuf::from("scenes/cornell-box.toml"));
    if args.scaling {
        return match args.one_run {
            Some(threads) => crate::scaling::one_run(&path, &args.overrides, threads),
            None => crate::scaling::run(&path, &args.overrides, args.rounds),
        };
    }
    let pool = thread_pool(args.overrides.threads)?;
    let (scene, settings) = bench_scene(&pool, &path, &args.overrides)?;
    let mut totals = Totals::default();
    let mut first_pilot = 0.0;
    let mut on_iteration = |s: &Status| {
        // The first iteration warms caches and the allocator (and runs the guiding pilot); time
        // the rest.
        if s.iteration() > 1 {
            totals.add(s);
        } else {
            first_pilot = s.times.pilot;
        }
    };
    let stop = AtomicBool::new(false);
    let image = pool.install(|| haze::render(&scene, &settings, &mut on_iteration, &stop))?;
    let timed = image.info.iterations.saturating_sub(1);
    if timed == 0 {
        bail!("--iterations must be at least 2 for a benchmark (the first is a warm-up)");
    }
    report(&path, &scene, &settings, pool.current_num_threads(), timed, &totals);
    if let Some(b) = pool.install(|| haze::light_path_budget(&scene, &settings, &stop))? {
        report_budget(&b, settings.photons);
    }
    if settings.integrator.uses_photons() {
        let usage = pool.install(|| haze::photon_usage(&scene, &settings, 2, &stop))?;
        if let Some(u) = usage {
            report_usage(&scene, &settings, &u, first_pilot);
        }
    }
    Ok(())
}

/// Prints the combined integrator's light paths per iteration and what its pilot measured.
fn report_budget(b: &haze::Budget, asked: u64) {
    println!(
        "point–point merges: {}",
        if b.point_merges { "weighed" } else { "off (the beam alone merges in media)" }
    );
    let Some(p) = &b.pilot else {
        println!("light paths per iteration: {} (fixed)", b.paths);
        return;
    };
    println!(
        "light paths per iteration: {} of the {asked} asked for, chosen by the pilot ({:.3} s, once per render; {} of {} pixels per pilot iteration)",
        b.paths, p.seconds, p.pixels.0, p.pixels.1
    );
    if b.split {
        println!(
            "light paths split by importance (photon_splitting = \"auto\": they ran long); the pilot measured them split"
        );
    }
    println!(
        "| light paths | pilot iterations | variance per iteration (merges' part) | mean ± standard error | light rays | light steps | stored | eye rays | eye steps | photons found | modelled ms | measured ms (photons + camera) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let scale = p.pixels.1 as f64 / p.pixels.0 as f64;
    for m in &p.measured {
        let (variance, mean) = if m.iterations > 1 {
            let v = format!("{:.4e} ({:.4e})", m.variance, m.merge_variance);
            (v, format!("{:.4e} ± {:.2e}", m.mean[0], m.mean[1]))
        } else {
            ("—".to_string(), "—".to_string())
        };
        println!(
            "| {} | {} | {variance} | {mean} | {:.0} | {:.0} | {:.0} | {:.0} | {:.0} | {:.0} | {:.2} | {:.2} + {:.2} |",
            m.paths,
            m.iterations,
            m.light[0],
            m.light[1],
            m.stored,
            m.eye[0],
            m.eye[1],
            m.eye[2],
            m.cost * 1e-6,
            m.seconds[0] * 1e3,
            m.seconds[1] * scale * 1e3,
        );
    }
    let ranked: Vec<String> = p.ranked.iter().map(|(n, r)| format!("{n}: {r:.3}")).collect();
    println!("predicted variance × cost per iteration, relative: {}", ranked.join(", "));
    if let Some(m) = p.measured.first() {
        println!(
            "past the eye's first merge: second moment {:.4e}, modelled {:.2} ms of the eye's work",
            m.deep_moment,
            m.deep_cost * 1e-6
        );
    }
    println!(
        "the eye's vertices past its first merge take {:.2} of an iteration's modelled cost{}",
        p.deep_share,
        if b.ends_at_merge {
            ": eye paths end at their first merge (merges = \"last\")"
        } else {
            ""
        }
    );
    let each: Vec<String> = p.continuation.iter().map(|(q, r)| format!("{q}: {r:.3}")).collect();
    println!(
        "eye paths go on past their first merge with chance {} (relative variance × cost: {})",
        b.continues,
        each.join(", ")
    );
}

/// Prints what one iteration's photons were used for, and what the guiding pilot found.
fn report_usage(
    scene: &haze::Scene,
    settings: &haze::RenderSettings,
    u: &haze::PhotonUsage,
    pilot_seconds: f64,
) {
    let share = |a: u64, b: u64| if b == 0 { 0.0 } else { 100.0 * a as f64 / b as f64 };
    let [s, v] = u.stored;
    let how = match (settings.photon_guiding, u.guided) {
        (haze::settings::PhotonGuiding::Off, _) => "guiding off".to_string(),
        (_, true) => format!("guided by the pilot, estimated gain {:.1}x", u.gain),
        (_, false) => format!(
            "unguided: the pilot's estimated gain {:.2}x is below {}x",
            u.gain,
            haze::PILOT_MIN_GAIN
        ),
    };
    println!(
        "photons gathered by one camera pass ({how}): {:.1} % of {s} surface photons, {:.1} % of {v} volume photons ({} kept by thinning)",
        share(u.gathered[0], s),
        share(u.gathered[1], v),
        u.kept[1],
    );
    if !u.pilot.is_empty() {
        println!("guiding pilot: {pilot_seconds:.3} s, once per render");
        for (i, (paths, visible, cells)) in u.pilot.iter().enumerate() {
            println!(
                "  light {i} ({}): {paths} pilot paths, {:.1} % visible, {cells} cells",
                scene.light_label(i),
                share(*visible, *paths)
            );
        }
    }
}

/// Prints the table of step times per iteration over `timed` iterations.
fn report(
    path: &std::path::Path,
    scene: &haze::Scene,
    settings: &haze::RenderSettings,
    threads: usize,
    timed: u64,
    totals: &Totals,
) {
    let media = scene.has_media() && settings.integrator.uses_photons();
    let t = &totals.times;
    let per_it = |x: f64| x / timed as f64;
    let [w, h] = scene.resolution();
    let paths = (timed * settings.photons) as f64;
    let pixels = (timed * w as u64 * h as u64) as f64;
    let photon_pass = t.photon_trace + t.surface_map + t.volume_map;
    println!("scene: {}", path.display());
    println!(
        "threads: {}, iterations timed: {timed} (after 1 warm-up), photons/iteration: {}, resolution: {w}x{h}",
        threads, settings.photons
    );
    println!("| step | per second | seconds per iteration |");
    println!("|---|---|---|");
    if settings.integrator.uses_photons() {
        println!(
            "| photon pass (trace + map builds) | {:.0} light paths/s, {:.0} surface + {:.0} volume photons stored/s | {:.4} |",
            paths / photon_pass,
            totals.stored as f64 / photon_pass,
            totals.stored_volume as f64 / photon_pass,
            per_it(photon_pass)
        );
        println!(
            "| … building the surface photon map | {:.0} photons/s | {:.4} |",
            totals.stored as f64 / t.surface_map,
            per_it(t.surface_map)
        );
    }
    let estimate = settings.volume_estimate;
    if media {
        println!(
            "| … building the volume photon map ({estimate} estimate) | {:.0} photons/s | {:.4} |",
            totals.stored_volume as f64 / t.volume_map,
            per_it(t.volume_map)
        );
    }
    let what = match (settings.integrator, media) {
        (Integrator::Path, _) => "path tracing".to_string(),
        (Integrator::Combined, _) => {
            "eye paths with next-event estimation and surface, point and beam merges".to_string()
        }
        (_, true) => format!("trace + surface and {estimate} estimates"),
        (_, false) => "trace + surface estimate".to_string(),
    };
    println!(
        "| camera pass ({what}) | {:.0} camera paths/s | {:.4} |",
        pixels / t.camera,
        per_it(t.camera)
    );
    println!("| adding the image to the film | | {:.4} |", per_it(t.film));
    if media && cfg!(feature = "profile") {
        println!(
            "| … in {estimate} estimates (thread time / threads) | | {:.4} |",
            per_it(totals.volume_estimates)
        );
        let share = t.volume_map + totals.volume_estimates;
        println!(
            "volume estimate ({estimate}: map build + estimates): {:.4} s of {:.4} s per iteration ({:.0} %)",
            per_it(share),
            per_it(t.total()),
            100.0 * share / t.total()
        );
    } else if media {
        println!(
            "(build with `--features profile` to also measure the time spent in {estimate} estimates)"
        );
    }
}
