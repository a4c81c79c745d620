//! The `haze` command line: render scenes, benchmark the passes, and the lab's tools (validate
//! against analytic media, chart error against time). The only part of haze that prints or exits.

mod bench;
mod diff;
mod lab;
mod merge;
mod rays;
mod render;
mod signals;

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use haze::{RenderOptions, RenderSettings, Scene};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// haze: a progressive photon mapper for participating media.
#[derive(Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene file to OpenEXR (plus a PNG preview beside it); `--iterations A..B`
    /// renders a range of iterations into a partial render, `--resume` continues one.
    Render(render::RenderArgs),
    /// Merge partial renders of one scene (iteration ranges, from any processes or machines)
    /// into the image of the union of their ranges: bit-identical to one render of them all.
    Merge(merge::MergeArgs),
    /// Compare two OpenEXR images pixel by pixel: exit 0 if they are identical bit for bit, 1
    /// with the size of the differences if not.
    Diff(diff::DiffArgs),
    /// Measure the time of each step of an iteration on a scene.
    Bench(bench::BenchArgs),
    /// Chart error against time: render the scene while measuring its error against a reference
    /// image at log-spaced iteration counts, for one or more series of settings; writes CSV,
    /// Markdown and SVG, and prints fitted and theoretical slopes.
    Converge(lab::ConvergeArgs),
    /// Render media with known answers (furnace, Beer–Lambert, half-space, slab, point source,
    /// emitting media)
    /// with every method and report agreement with the analytic references; exits 1 if a case
    /// fails.
    Validate(lab::ValidateArgs),
}

/// The scene's `[render]` settings overridden from the command line, and how to run.
#[derive(Args, Clone)]
#[command(allow_negative_numbers = true)]
pub(crate) struct Overrides {
    #[command(flatten)]
    settings: RenderOptions,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(short = 'j', long, value_name = "T")]
    threads: Option<usize>,
    /// Image size WIDTHxHEIGHT instead of the scene's (the field of view is kept).
    #[arg(long, value_name = "WxH", value_parser = parse_resolution)]
    resolution: Option<[u32; 2]>,
    /// The old bounce limit, replaced by `--max-bounces`: refused with a pointer to it.
    #[arg(long = "max-depth", value_name = "D", hide = true, num_args = 0..=1,
        default_missing_value = "", value_parser = refuse_max_depth)]
    #[allow(dead_code)] // never set: its value parser refuses every use
    max_depth: Option<String>,
}

/// `--max-depth` says what replaced it, as the scene key `max_depth` does.
fn refuse_max_depth(_: &str) -> Result<String, String> {
    Err("--max-depth was replaced by --max-bounces, which limits the scattering events along the \
         whole light-to-camera path (max_depth limited light and eye paths separately); see \
         `haze render --help`"
        .into())
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

/// The command-line flag of a `[render]` key, e.g. `--time` for `time_limit`.
fn flag(key: &str) -> String {
    let cmd = Overrides::augment_args(clap::Command::new("haze"));
    cmd.get_arguments()
        .find(|a| a.get_id() == key)
        .and_then(|a| a.get_long())
        .map_or_else(|| key.replace('_', "-"), str::to_string)
}

impl Overrides {
    /// Loads the scene and applies the resolution override.
    fn load_scene(&self, path: &Path) -> Result<Scene> {
        let mut scene = Scene::load(path)?;
        if let Some(r) = self.resolution {
            scene.set_resolution(r).context("--resolution")?;
        }
        Ok(scene)
    }

    /// `base` with the command-line settings laid over it, validated.
    fn settings(&self, base: &RenderSettings) -> Result<RenderSettings> {
        let s = base.with(&self.settings);
        if let Err(e) = s.validate() {
            bail!("--{} (or the scene's render.{}): {}", flag(e.key), e.key, e.message);
        }
        Ok(s)
    }
}

/// The most worker threads accepted: 8 per core.
/// Seconds between two plain progress lines ([`LogLines`]).
const LOG_EVERY: f64 = 5.0;

/// Progress for a log file: where standard error is not a terminal (the progress bar then draws
/// nothing), a plain line at the first report and then at most one every [`LOG_EVERY`] seconds,
/// as cargo and pbrt print theirs.
pub(crate) struct LogLines {
    enabled: bool,
    last: std::sync::Mutex<Option<std::time::Instant>>,
}

impl LogLines {
    /// Lines unless `quiet`, and only where standard error is not a terminal.
    pub(crate) fn new(quiet: bool) -> Self {
        use std::io::IsTerminal;
        Self { enabled: !quiet && !std::io::stderr().is_terminal(), last: Default::default() }
    }

    /// Prints `line()` (prefixed `progress: `) if it is time for one.
    pub(crate) fn report(&self, line: impl FnOnce() -> String) {
        if !self.enabled {
            return;
        }
        let Ok(mut last) = self.last.lock() else { return };
        if last.is_some_and(|t| t.elapsed().as_secs_f64() < LOG_EVERY) {
            return;
        }
        *last = Some(std::time::Instant::now());
        eprintln!("progress: {}", line());
    }
}

/// Seconds as a log line shows them: `42 s`, `3 min 5 s`, `1 h 2 min`.
pub(crate) fn duration_words(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {} s", s / 60, s % 60),
        _ => format!("{} h {} min", s / 3600, s / 60 % 60),
    }
}

fn max_threads() -> usize {
    8 * std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// The worker pool of every command, `--threads` checked against [`max_threads`].
fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        let max = max_threads();
        if t == 0 || t > max {
            bail!(
                "--threads {t}: must lie in 1..={max} (8 per core on this machine; more only adds overhead)"
            );
        }
        b = b.num_threads(t);
    }
    b.build().context("cannot start worker threads")
}

/// Refuses, before any work, an output path that cannot be written.
fn check_output_dir(what: &str, path: &Path) -> Result<()> {
    haze::output::check_writable(path).with_context(|| what.to_string())
}

/// The command line with `--iterations A..B` (or `-n A..B`, `-nA..B`, `--iterations=A..B`) rewritten as
/// `--iterations B --first-iteration A`: a range of iterations is the last index plus where the
/// range starts.
fn expand_ranges(args: impl Iterator<Item = std::ffi::OsString>) -> Vec<std::ffi::OsString> {
    let mut out = Vec::new();
    let mut after_flag = false;
    for arg in args {
        let text = arg.to_str().map(str::to_string);
        let (flag, value) = match text.as_deref() {
            Some(t) if after_flag => (None, Some(t.to_string())),
            Some(t) if t.starts_with("--iterations=") => {
                (Some("--iterations"), Some(t["--iterations=".len()..].to_string()))
            }
            Some(t) if t.starts_with("-n") && t.len() > 2 && !t.starts_with("-n=") => {
                (Some("-n"), Some(t[2..].to_string()))
            }
            Some(t) if t.starts_with("-n=") => (Some("-n"), Some(t[3..].to_string())),
            _ => (None, None),
        };
        after_flag = matches!(text.as_deref(), Some("-n" | "--iterations"));
        match value.as_deref().and_then(|v| v.split_once("..")) {
            Some((a, b)) => {
                if let Some(f) = flag {
                    out.push(f.into());
                }
                out.push(b.into());
                out.push("--first-iteration".into());
                out.push(a.into());
            }
            None => out.push(arg),
        }
    }
    out
}

fn run() -> Result<ExitCode> {
    let cli = Cli::parse_from(expand_ranges(std::env::args_os()));
    match cli.command {
        Command::Render(a) => render::run(a),
        Command::Merge(a) => merge::run(a),
        Command::Diff(a) => diff::run(a),
        Command::Bench(a) => bench::run(a).map(|()| ExitCode::SUCCESS),
        Command::Validate(a) => lab::validate(a),
        Command::Converge(a) => lab::converge(a),
    }
}

fn main() -> ExitCode {
    // vdb-rs 0.6 panics on some corrupt files and obvhs on some degenerate geometry; the library
    // catches those panics and returns an error, so keep the default hook from printing them as if
    // the program had crashed.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let from_dependency = info
            .location()
            .is_some_and(|l| l.file().contains("vdb-rs") || l.file().contains("obvhs"));
        if !from_dependency {
            default_hook(info);
        }
    }));
    match run() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// The output path for a scene: `-o` or the scene's file name with `extension`.
fn default_output(scene: &Path, output: Option<PathBuf>, extension: &str) -> PathBuf {
    output.unwrap_or_else(|| {
        PathBuf::from(scene.file_stem().unwrap_or("render".as_ref())).with_extension(extension)
    })
}

#[cfg(test)]
mod tests {
    use super::expand_ranges;

    fn expand(args: &[&str]) -> Vec<String> {
        expand_ranges(args.iter().map(|a| a.into()))
            .into_iter()
            .map(|a| a.into_string().unwrap())
            .collect()
    }

    #[test]
    fn iteration_ranges_become_a_last_index_and_a_first() {
        let range = ["--first-iteration", "3"];
        for form in
            [&["-n", "3..9"][..], &["--iterations", "3..9"], &["--iterations=3..9"], &["-n3..9"]]
        {
            let mut args = vec!["haze", "render", "../s.toml"];
            args.extend_from_slice(form);
            let out = expand(&args);
            assert_eq!(&out[..3], ["haze", "render", "../s.toml"], "{form:?}");
            assert_eq!(out[4], "9", "{form:?}: {out:?}");
            assert_eq!(&out[5..], range, "{form:?}: {out:?}");
        }
        assert_eq!(
            expand(&["haze", "render", "a..b.toml", "-n", "7"]),
            ["haze", "render", "a..b.toml", "-n", "7"]
        );
    }
}
