//! What the commands share: the render-setting overrides of the command line, the worker pool,
//! output checks and plain progress lines for logs.

use anyhow::{Context, Result, bail};
use clap::Args;
use haze::{RenderOptions, RenderSettings, Scene};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};

/// The scene's `[render]` settings overridden from the command line, and how to run.
#[derive(Args, Clone)]
#[command(allow_negative_numbers = true)]
pub(crate) struct Overrides {
    #[command(flatten)]
    pub(crate) settings: RenderOptions,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(short = 'j', long, value_name = "T")]
    pub(crate) threads: Option<usize>,
    /// Image size WIDTHxHEIGHT instead of the scene's (the field of view is kept).
    #[arg(long, value_name = "WxH", value_parser = parse_resolution)]
    pub(crate) resolution: Option<[u32; 2]>,
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
    pub(crate) fn load_scene(&self, path: &Path) -> Result<Scene> {
        let mut scene = Scene::load(path)?;
        if let Some(r) = self.resolution {
            scene.set_resolution(r).context("--resolution")?;
        }
        Ok(scene)
    }

    /// `base` with the command-line settings laid over it, validated.
    pub(crate) fn settings(&self, base: &RenderSettings) -> Result<RenderSettings> {
        let s = base.with(&self.settings);
        if let Err(e) = s.validate() {
            bail!("--{} (or the scene's render.{}): {}", flag(e.key), e.key, e.message);
        }
        Ok(s)
    }
}

/// The scene at `path`, loaded on `pool`'s threads, and its settings under the command line's,
/// with 8 iterations unless it says otherwise and the integrator `auto` stands for in it: what
/// every kind of scene benchmark renders.
pub(crate) fn bench_scene(
    pool: &rayon::ThreadPool,
    path: &Path,
    overrides: &Overrides,
) -> Result<(Scene, RenderSettings)> {
    let scene = pool.install(|| overrides.load_scene(path))?;
    let mut o = overrides.clone();
    o.settings.iterations = o.settings.iterations.or(Some(8));
    let settings = o.settings(&scene.settings)?.resolved(scene.has_emissive_media());
    Ok((scene, settings))
}

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

pub(crate) use haze::max_threads;

/// The worker pool of every command, `--threads` checked against [`max_threads`].
pub(crate) fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
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
pub(crate) fn check_output_dir(what: &str, path: &Path) -> Result<()> {
    haze::output::check_writable(path).with_context(|| what.to_string())
}

/// The output path for a scene: `-o` or the scene's file name with `extension`.
pub(crate) fn default_output(scene: &Path, output: Option<PathBuf>, extension: &str) -> PathBuf {
    output.unwrap_or_else(|| {
        PathBuf::from(scene.file_stem().unwrap_or("render".as_ref())).with_extension(extension)
    })
}

/// A progress bar of `len` steps drawn by `template` (hidden if `quiet`).
pub(crate) fn bar(quiet: bool, len: u64, template: &str) -> ProgressBar {
    let bar = if quiet { ProgressBar::hidden() } else { ProgressBar::new(len) };
    if let Ok(style) = ProgressStyle::with_template(template) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}
