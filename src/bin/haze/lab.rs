//! The lab's commands: `haze converge` (error against time) and `haze validate` (analytic media).

use crate::shared::{Overrides, check_output_dir, thread_pool};
use crate::signals::Interrupt;
use anyhow::{Result, bail};
use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Args)]
pub(crate) struct ValidateArgs {
    /// A short run (fewer seeds, iterations and photons).
    #[arg(long)]
    quick: bool,
    /// The power cases instead: single scattering, the albedo-0.99 half-space and a dense slab,
    /// each at the effort that detects a small bias (what CI runs; docs/validation.md).
    #[arg(long)]
    power: bool,
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

#[derive(Args)]
#[command(allow_negative_numbers = true)]
pub(crate) struct ConvergeArgs {
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
    /// progression, integrator, merges (the combined integrator's, first and everywhere) or
    /// photon-budget (the combined integrator's pilot against the count as given) (repeatable).
    #[arg(long, value_name = "NAME")]
    compare: Vec<String>,
    /// A series LABEL:KEY=VALUE,… with keys of the scene's [render] table, e.g.
    /// "alpha 0.5:alpha=0.5" (repeatable).
    #[arg(long, value_name = "SPEC")]
    series: Vec<String>,
    /// Measure over the pixels X0,Y0,X1,Y1 only (X1, Y1 exclusive).
    #[arg(long, value_name = "X0,Y0,X1,Y1")]
    region: Option<haze::lab::converge::Region>,
    /// Output prefix: writes PREFIX.csv, PREFIX.svg, PREFIX.md and PREFIX-estimate.svg (the
    /// renders' estimated error against the measured) [default: converge-SCENE-NAME].
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

pub(crate) fn converge(args: ConvergeArgs) -> Result<ExitCode> {
    use haze::lab::converge::{self, Plan, Reference};
    let scene = args.overrides.load_scene(&args.scene)?;
    let base = args.overrides.settings(&scene.settings)?;
    let reference = Reference::load(&args.reference)?;
    let time = args.overrides.settings.time_limit.unwrap_or(60.0);
    if args.runs == 0 {
        bail!("--runs must be at least 1");
    }
    let series = series_of(&args, &base)?;
    let stem = args.scene.file_stem().unwrap_or("scene".as_ref()).to_string_lossy().to_string();
    let prefix = args.output.clone().unwrap_or_else(|| PathBuf::from(format!("converge-{stem}")));
    check_output_dir("--output", &prefix)?;
    let pool = thread_pool(args.overrides.threads)?;
    let interrupt = Interrupt::install()?;
    interrupt.arm();
    let stop = interrupt.flag();
    let plan = Plan {
        seconds: time,
        runs: args.runs,
        max_iterations: args.overrides.settings.iterations,
        region: args.region,
    };
    let total = series.len() as f64 * args.runs as f64 * time;
    let bar = crate::shared::bar(
        args.quiet,
        (total * 1000.0) as u64,
        "{elapsed_precise} [{bar:30}] ETA {eta} {msg}",
    );
    let labels: Vec<String> = series.iter().map(|s| s.label.clone()).collect();
    let runs = args.runs;
    let log = crate::shared::LogLines::new(args.quiet);
    let mut on_progress = |si: usize, run: u32, seconds: f64| {
        let done = (si as f64 * runs as f64 + run as f64) * time + seconds.min(time);
        bar.set_position((done * 1000.0) as u64);
        bar.set_message(format!("{} (run {}/{runs})", labels[si], run + 1));
        log.report(|| {
            format!(
                "series {} of {} ({}), run {}/{runs}: {} of {} rendered, ETA {}",
                si + 1,
                labels.len(),
                labels[si],
                run + 1,
                crate::shared::duration_words(done),
                crate::shared::duration_words(total),
                crate::shared::duration_words(total - done)
            )
        });
    };
    let samples =
        pool.install(|| converge::run(&scene, &series, &reference, &plan, &mut on_progress, stop))?;
    bar.finish_and_clear();
    let summaries = converge::summarize(&scene, &series, &samples, args.runs);
    let title = args.title.clone().unwrap_or_else(|| {
        let [w, h] = scene.resolution();
        format!("{stem} ({w}x{h}), {} threads", pool.current_num_threads())
    });
    let wrote = write_converge(&prefix, &title, &series, &samples, &summaries, &interrupt)?;
    println!(
        "reference: {} ({}); {} run(s) of {:.0} s per series, {} threads",
        args.reference.display(),
        reference.description.as_deref().unwrap_or("no haze:reference attribute"),
        args.runs,
        time,
        pool.current_num_threads()
    );
    println!("{wrote}");
    if let Some(code) = interrupt.exit_code() {
        eprintln!(
            "interrupted by {}: the files hold the checkpoints reached so far",
            interrupt.name().unwrap_or("a signal")
        );
        return Ok(code);
    }
    Ok(ExitCode::SUCCESS)
}

pub(crate) fn validate(args: ValidateArgs) -> Result<ExitCode> {
    use haze::lab::validate::{self, Effort};
    check_validate_args(&args)?;
    let effort = if args.quick { Effort::QUICK } else { Effort::FULL };
    let pool = thread_pool(args.threads)?;
    let bar =
        crate::shared::bar(false, 0, "{elapsed_precise} [{bar:30}] {pos}/{len} renders, ETA {eta}");
    let start = Instant::now();
    let log = crate::shared::LogLines::new(false);
    let rows = pool.install(|| {
        let progress = |done, total| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
            log.report(|| {
                let elapsed = start.elapsed().as_secs_f64();
                let eta = if done > 0 {
                    format!(
                        ", ETA {}",
                        crate::shared::duration_words(
                            elapsed / done as f64 * (total - done) as f64
                        )
                    )
                } else {
                    String::new()
                };
                format!("{done}/{total} renders{eta}")
            });
        };
        if args.power {
            validate::run_power(&args.media, args.case.as_deref(), progress)
        } else {
            validate::run(&args.media, effort, args.case.as_deref(), progress)
        }
    })?;
    bar.finish_and_clear();
    if rows.is_empty() {
        bail!("--case {:?}: no case name contains it", args.case.unwrap_or_default());
    }
    let table = validate::markdown(&rows);
    println!("{table}");
    println!("{}", validate::summary(&rows));
    println!("{}", validate_footer(&args, rows.len(), effort, pool.current_num_threads(), start));
    if let Some(p) = &args.markdown {
        haze::output::write_bytes(p, table.as_bytes())?;
    }
    if let Some(p) = &args.csv {
        haze::output::write_bytes(p, validate::csv(&rows).as_bytes())?;
    }
    let failed = rows.iter().filter(|r| !r.pass()).count();
    if failed > 0 {
        bail!("{failed} of {} cases disagree with their references", rows.len());
    }
    Ok(ExitCode::SUCCESS)
}

/// Refuses `haze validate` arguments that cannot work, before any render.
fn check_validate_args(args: &ValidateArgs) -> Result<()> {
    if let Some(p) = &args.markdown {
        check_output_dir("--markdown", p)?;
    }
    if let Some(p) = &args.csv {
        check_output_dir("--csv", p)?;
    }
    if !args.media.join("box.vdb").is_file() {
        bail!(
            "--media {}: box.vdb not found (run from the repository root or pass --media)",
            args.media.display()
        );
    }
    if args.power && args.quick {
        bail!("--power and --quick: the power cases run at their own effort; give one of them");
    }
    Ok(())
}

/// What follows `haze validate`'s table: how much was run, and what a quick run can see.
fn validate_footer(
    args: &ValidateArgs,
    rows: usize,
    effort: haze::lab::validate::Effort,
    threads: usize,
    start: Instant,
) -> String {
    let mut lines = Vec::new();
    if args.quick {
        lines.push(
            "--quick is a smoke test: with so few seeds and iterations the t-test sees only large \
             errors, and photon estimates at their large early radii lean on their bias bounds; \
             docs/validation.md has the full run (haze validate without --quick)."
                .to_string(),
        );
    }
    if args.power {
        lines.push(format!(
            "{} rows of the power cases, each at its own effort (docs/validation.md); {} threads; {:.0} s",
            rows,
            threads,
            start.elapsed().as_secs_f64()
        ));
    } else {
        lines.push(format!(
            "{} rows, {} seeds each, {} iterations x {} light paths per render; {} threads; {:.0} s",
            rows,
            effort.seeds,
            effort.iterations,
            effort.photons,
            threads,
            start.elapsed().as_secs_f64()
        ));
    }
    lines.join("\n")
}

/// Writes `haze converge`'s files beside `prefix` (CSV, Markdown table, SVG chart and, where the
/// renders estimated their error, a chart of the estimates) and prints the table; returns the
/// line that names what was written.
fn write_converge(
    prefix: &std::path::Path,
    title: &str,
    series: &[haze::lab::converge::Series],
    samples: &[haze::lab::converge::Sample],
    summaries: &[haze::lab::converge::Summary],
    interrupt: &Interrupt,
) -> Result<String> {
    use haze::lab::converge;
    let chart = converge::chart(title, summaries);
    let table = converge::markdown(summaries);
    let estimate_chart = converge::estimate_chart(&format!("{title}: estimated error"), summaries);
    let with = |ext: &str| PathBuf::from(format!("{}.{ext}", prefix.display()));
    interrupt.writing(|| -> Result<()> {
        let write = |p: PathBuf, data: String| haze::output::write_bytes(&p, data.as_bytes());
        write(with("csv"), converge::csv(series, samples))?;
        write(with("md"), table.clone())?;
        chart.write_svg(&with("svg"))?;
        if let Some(c) = &estimate_chart {
            c.write_svg(&PathBuf::from(format!("{}-estimate.svg", prefix.display())))?;
        }
        Ok(())
    })?;
    println!("{table}");
    match estimate_chart {
        Some(_) => Ok(format!("wrote {0}.{{csv,md,svg}} and {0}-estimate.svg", prefix.display())),
        None => Ok(format!("wrote {}.{{csv,md,svg}}", prefix.display())),
    }
}

/// The series `haze converge` compares: its presets (`--compare`), then its `--series`, or the
/// scene's own settings alone.
fn series_of(
    args: &ConvergeArgs,
    base: &haze::RenderSettings,
) -> Result<Vec<haze::lab::converge::Series>> {
    use haze::lab::converge;
    let mut series = Vec::new();
    for name in &args.compare {
        series.extend(converge::preset(name, base).map_err(|e| anyhow::anyhow!("--compare: {e}"))?);
    }
    for spec in &args.series {
        series.push(
            converge::parse_series(spec, base).map_err(|e| anyhow::anyhow!("--series: {e}"))?,
        );
    }
    if series.is_empty() {
        series.push(converge::Series { label: "scene settings".into(), settings: base.clone() });
    }
    Ok(series)
}
