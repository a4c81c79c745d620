//! The `haze` command line: render scenes, benchmark the passes, and the lab's tools (validate
//! against analytic media, chart error against time). The only part of haze that prints or exits.

mod bench;
mod diff;
mod lab;
mod merge;
mod rays;
mod render;
mod scaling;
mod shared;
mod signals;
mod sky;

use anyhow::Result;
use clap::{Parser, Subcommand};
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
    /// Write a daylight sky (Preetham et al. 1999, the scene format's `type = "sky"`) as an
    /// OpenEXR environment map, with the sun in it.
    Sky(sky::SkyArgs),
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
        Command::Sky(a) => sky::run(a),
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
