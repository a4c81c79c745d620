//! `haze bench SCENE --scaling`: whole runs on 1 thread and on N, phase by phase, with the serial
//! fraction of each by Amdahl's law and the efficiency it predicts on larger machines.
//!
//! Amdahl's law for a phase that takes T₁ on one thread and T_N on N: if a fraction s of its work
//! cannot run in parallel, T_N = T₁ (s + (1 − s)/N), so s = (N T_N/T₁ − 1)/(N − 1), and on M
//! threads its efficiency T₁/(M T_M) is 1/(1 + s (M − 1)). Measured on few threads, s also holds
//! whatever else keeps threads from speeding up — waiting on another thread's last work item,
//! contention for memory or shared cache lines — so the prediction is a bound of what the code
//! allows, not a promise for a machine with other caches and memory.
//!
//! Every run is a process of its own (this command started again with a hidden `--one-run T`),
//! as every `haze render` is: in one process, later runs took memory the earlier ones had touched
//! and freed, and missed what a fresh process pays — the first touch of every page, and the
//! kernel's announcements to every processor of the process when a mapping changes (a film whose
//! pages were first read as the shared zero page cost cumulus's photon mapping 7 % of its
//! 2-thread run, and nothing an in-process run could see).

use crate::shared::{Overrides, bench_scene, thread_pool};
use anyhow::{Context, Result, bail};
use haze::progress::{Status, Stopwatch};
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// A phase whose serial fraction exceeds this is flagged …
const FLAG_FRACTION: f64 = 0.05;
/// … where it takes at least this share of the run on one thread.
const FLAG_SHARE: f64 = 0.002;

/// The phases of a run, in order.
const PHASES: [&str; 10] = [
    "loading the scene (grids, majorants, BVH)",
    "the rest: setup, the image from the film",
    "guiding pilot (once)",
    "photon trace",
    "surface photon map",
    "volume photon map",
    "camera pass",
    "adding to the film",
    "writing EXR and PNG (and the last line's figures)",
    "whole run",
];

/// Seconds of each phase of one whole run, in the order of [`PHASES`].
type Times = [f64; PHASES.len()];

/// One whole run's wall-clock and processor seconds per phase.
#[derive(Clone, Copy)]
struct Run {
    wall: Times,
    processor: Times,
}

/// What a `--one-run` process's line of times starts with.
const ONE_RUN: &str = "haze-scaling-run";

/// `haze bench SCENE --scaling --one-run T`: one whole run on `threads` threads, its times printed
/// on one line for [`fresh_run`].
pub(crate) fn one_run(path: &Path, overrides: &Overrides, threads: usize) -> Result<()> {
    let run = run_once(path, overrides, threads)?;
    let times: Vec<String> = run.wall.iter().chain(&run.processor).map(f64::to_string).collect();
    println!("{ONE_RUN} {}", times.join(" "));
    Ok(())
}

/// One whole run on `threads` threads in a process of its own (this command again, with
/// `--one-run`), and the wall-clock seconds of that process from start to exit.
fn fresh_run(threads: usize) -> Result<(Run, f64)> {
    let exe = std::env::current_exe().context("cannot find this program to run it again")?;
    let clock = Stopwatch::start();
    let out = std::process::Command::new(exe)
        .args(std::env::args_os().skip(1))
        .args(["--one-run", &threads.to_string()])
        .output()
        .context("cannot start a run in a process of its own")?;
    let process = clock.lap().0;
    if !out.status.success() {
        // The run's own message (a scene that does not load, say), as `haze render` gives it.
        let said = String::from_utf8_lossy(&out.stderr);
        let said = said.trim().strip_prefix("error: ").unwrap_or(said.trim());
        bail!("a run on {threads} thread(s) failed ({}): {said}", out.status);
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let times: Vec<f64> = text
        .lines()
        .find_map(|l| l.strip_prefix(ONE_RUN))
        .map(|l| l.split_whitespace().filter_map(|t| t.parse().ok()).collect())
        .unwrap_or_default();
    if times.len() != 2 * PHASES.len() {
        bail!("a run on {threads} thread(s) printed no times");
    }
    let mut run = Run { wall: [0.0; PHASES.len()], processor: [0.0; PHASES.len()] };
    run.wall.copy_from_slice(&times[..PHASES.len()]);
    run.processor.copy_from_slice(&times[PHASES.len()..]);
    Ok((run, process))
}

/// One whole run on `threads` threads: load, render, write (to a temporary file, removed).
fn run_once(path: &Path, overrides: &Overrides, threads: usize) -> Result<Run> {
    let pool = thread_pool(Some(threads))?;
    let whole = Stopwatch::start();
    let (scene, settings) = bench_scene(&pool, path, overrides)?;
    let load = whole.lap();
    // Per step, wall-clock and processor seconds summed over the iterations.
    let mut steps = [(0.0f64, 0.0f64); 6];
    let mut on_iteration = |s: &Status| {
        let (t, p) = (&s.times, &s.times.processor);
        let each = [
            (t.pilot, p.pilot),
            (t.photon_trace, p.photon_trace),
            (t.surface_map, p.surface_map),
            (t.volume_map, p.volume_map),
            (t.camera, p.camera),
            (t.film, p.film),
        ];
        for (sum, (wall, processor)) in steps.iter_mut().zip(each) {
            *sum = (sum.0 + wall, sum.1 + processor);
        }
    };
    let stop = AtomicBool::new(false);
    let clock = Stopwatch::start();
    let image = pool.install(|| haze::render(&scene, &settings, &mut on_iteration, &stop))?;
    let render = clock.lap();
    let clock = Stopwatch::start();
    let out = std::env::temp_dir().join(format!("haze-scaling-{}.exr", std::process::id()));
    // As `haze render` ends: the files written while the last line's figures are worked out.
    let (written, _) = pool.install(|| {
        rayon::join(|| image.write(&out, 1.0), || crate::render::Figures::of(&image, &settings))
    });
    let written = written?;
    for f in written {
        let _ = std::fs::remove_file(f);
    }
    let (write, whole) = (clock.lap(), whole.lap());
    // Wall-clock times (`pick` the first of each pair) or processor times (the second).
    let phases = |pick: fn((f64, f64)) -> f64| -> Times {
        let steps = steps.map(pick);
        let setup = (pick(render) - steps.iter().sum::<f64>()).max(0.0);
        let [pilot, trace, surface, volume, camera, film] = steps;
        [pick(load), setup, pilot, trace, surface, volume, camera, film, pick(write), pick(whole)]
    };
    Ok(Run { wall: phases(|t| t.0), processor: phases(|t| t.1) })
}

/// Amdahl's serial fraction from one phase's times on 1 and `n` threads.
fn serial_fraction(t1: f64, tn: f64, n: usize) -> f64 {
    (n as f64 * tn / t1 - 1.0) / (n as f64 - 1.0)
}

/// Efficiency on `m` threads of a phase with serial fraction `s` (clamped to 0..=1).
fn efficiency(s: f64, m: usize) -> f64 {
    1.0 / (1.0 + s.clamp(0.0, 1.0) * (m as f64 - 1.0))
}

/// One phase's times on 1 and `n` threads, wall clock and processor, and what they say.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Phase {
    /// The part of Amdahl's serial fraction s that is waiting: the serial fraction the `n`-thread run's idle
    /// processor time stands for, had the work been that of one thread. Threads that wait for a
    /// serial part or for another's last work item leave their processors idle.
    waiting: f64,
    /// The part of s that is work grown on `n` threads (contention for memory or shared
    /// cache lines, work repeated per thread): the serial fraction the growth of processor time
    /// stands for, had no thread waited.
    more_work: f64,
    /// The `n`-thread run's processor time over `n` × its wall-clock time: 1 where every thread
    /// was busy throughout.
    busy: f64,
}

impl Phase {
    /// From wall-clock `t1`, `tn` seconds on 1 and `n` threads and the `n`-thread run's
    /// processor seconds `pn`; `None` where that is zero (no process clock, or a phase too short
    /// to see). With s = [`serial_fraction`]`(t1, tn, n)` the fractions satisfy
    /// 1 + (n − 1)·s = (1 + (n − 1)·more_work)·(1 + (n − 1)·waiting): for small fractions,
    /// s ≈ waiting + more_work. `more_work` counts processor time
    /// against the one-thread run's wall-clock time, so a one-thread run that left its processor
    /// idle (reading a file) lowers it.
    fn new(t1: f64, tn: f64, pn: f64, n: usize) -> Option<Phase> {
        if pn <= 0.0 || tn <= 0.0 || t1 <= 0.0 {
            return None;
        }
        let m = n as f64 - 1.0;
        let busy = pn / (n as f64 * tn);
        Some(Phase { waiting: (1.0 / busy - 1.0) / m, more_work: (pn / t1 - 1.0) / m, busy })
    }
}

/// Seconds the host took from this machine's processors so far (`steal` in /proc/stat), where
/// the system says.
fn stolen_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/stat").ok()?;
    let cpu = stat.lines().next()?.strip_prefix("cpu ")?;
    let steal: f64 = cpu.split_whitespace().nth(7)?.parse().ok()?;
    Some(steal / 100.0) // USER_HZ, 100 on every Linux that haze runs on
}

/// Prints the scaling table of `path`.
pub(crate) fn run(path: &Path, overrides: &Overrides, rounds: usize) -> Result<()> {
    let n = overrides
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    if n < 2 {
        bail!(
            "--scaling needs at least 2 threads to compare with 1 (--threads, or a machine with 2 cores)"
        );
    }
    if !(1..=100).contains(&rounds) {
        bail!("--rounds must lie in 1..=100");
    }
    // Each phase's shortest wall-clock time over the rounds, with that run's processor time.
    let empty = Run { wall: [f64::INFINITY; PHASES.len()], processor: [0.0; PHASES.len()] };
    let (mut one, mut many) = (empty, empty);
    // The shortest process, start to exit, on 1 and on `n` threads.
    let mut process = [f64::INFINITY; 2];
    let mut stolen = 0.0;
    // The steal during the fastest `n`-thread whole run, the one the table's last row reports.
    let mut stolen_from_best = None;
    for round in 1..=rounds {
        for (k, (threads, best)) in [(1, &mut one), (n, &mut many)].into_iter().enumerate() {
            eprintln!("round {round}/{rounds}: {threads} thread(s)");
            let before = stolen_seconds();
            let (t, p) = fresh_run(threads)?;
            process[k] = process[k].min(p);
            let steal = before.zip(stolen_seconds()).map(|(a, b)| b - a);
            stolen += steal.unwrap_or(0.0);
            if threads == n && t.wall[PHASES.len() - 1] < best.wall[PHASES.len() - 1] {
                stolen_from_best = steal;
            }
            for i in 0..PHASES.len() {
                if t.wall[i] < best.wall[i] {
                    (best.wall[i], best.processor[i]) = (t.wall[i], t.processor[i]);
                }
            }
        }
    }
    print_table(path, n, rounds, &one, &many, process);
    println!();
    println!(
        "serial fraction s = (N·T_N/T_1 − 1)/(N − 1), efficiency at M threads 1/(1 + s(M − 1)); \
         \"its serial time / run\": s·T_1 of the phase over the whole run's T_1 (they add up to \
         about the whole run's serial fraction). Measured on few threads, s also counts waiting \
         and contention, not only serial code; the processor clock tells them apart: \"busy\" is \
         the N-thread run's processor time over N × its wall-clock time, \"waiting\" the serial \
         fraction its idle processors stand for, \"more work\" the one its processor time grown \
         over the 1-thread run's wall-clock time stands for (contention, work repeated per \
         thread; below zero where the 1-thread run left its processor idle, reading or writing \
         files). The clock counts every thread of the process (the one that frees a render's \
         buffers too), so \"busy\" can pass 100 % in a phase that writes."
    );
    if stolen > 0.0 {
        println!(
            "The host took {stolen:.2} s of processor time from this machine during these runs \
             (steal in /proc/stat): wall-clock times and \"waiting\" include it."
        );
    }
    let last = PHASES.len() - 1;
    if let (Some(steal), Some(p)) =
        (stolen_from_best, Phase::new(one.wall[last], many.wall[last], many.processor[last], n))
    {
        // The host's steal was idle time to the process, but not haze's waiting.
        let idle = (n as f64 * many.wall[last] - many.processor[last] - steal).max(0.0);
        let waiting = idle / (many.processor[last] + steal) / (n as f64 - 1.0);
        println!(
            "The whole {n}-thread run of the table (the fastest) lost {steal:.2} s to the host (in \
             steps of 0.01 s); its waiting without that time: {:.1} % (with it: {:.1} %).",
            100.0 * waiting,
            100.0 * p.waiting
        );
    }
    Ok(())
}

/// The table of [`run`]: one row per phase, and one for the `process`es from start to exit (on 1
/// and on `n` threads).
fn print_table(path: &Path, n: usize, rounds: usize, one: &Run, many: &Run, process: [f64; 2]) {
    println!("scene: {}", path.display());
    println!(
        "whole runs on 1 and {n} threads, shortest of {rounds} rounds per phase; {} cores here",
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    println!();
    println!(
        "| phase | 1 thread (s) | {n} threads (s) | speed-up | serial fraction | its serial time / run | efficiency at 16 | at 64 | busy | waiting | more work | |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let whole = one.wall[PHASES.len() - 1];
    for (i, name) in PHASES.iter().enumerate() {
        let (t1, tn) = (one.wall[i], many.wall[i]);
        if t1 <= 0.0 {
            println!("| {name} | — | — | | | | | | | | | |");
            continue;
        }
        let s = serial_fraction(t1, tn, n);
        let share = s.max(0.0) * t1 / whole;
        let flag = if s > FLAG_FRACTION && t1 / whole >= FLAG_SHARE && i + 1 < PHASES.len() {
            "does not scale"
        } else {
            ""
        };
        let split = match Phase::new(t1, tn, many.processor[i], n) {
            Some(p) => format!(
                "{:.1} % | {:.1} % | {:.1} %",
                100.0 * p.busy,
                100.0 * p.waiting,
                100.0 * p.more_work
            ),
            None => "— | — | —".to_string(),
        };
        println!(
            "| {name} | {t1:.4} | {tn:.4} | {:.2}× | {:.1} % | {:.2} % | {:.0} % | {:.0} % | {split} | {flag} |",
            t1 / tn,
            100.0 * s,
            100.0 * share,
            100.0 * efficiency(s, 16),
            100.0 * efficiency(s, 64),
        );
    }
    // The process from start to exit: the whole run with starting the program and handing its
    // memory back to the system (timed from outside, so wall-clock only).
    let [t1, tn] = process;
    let s = serial_fraction(t1, tn, n);
    println!(
        "| whole process, start to exit (wall clock only) | {t1:.4} | {tn:.4} | {:.2}× | {:.1} % | | {:.0} % | {:.0} % | | | | |",
        t1 / tn,
        100.0 * s,
        100.0 * efficiency(s, 16),
        100.0 * efficiency(s, 64),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn amdahl_round_trips() {
        for s in [0.0, 0.01, 0.2, 1.0] {
            for n in [2, 8, 16] {
                let tn = s + (1.0 - s) / n as f64;
                assert!((serial_fraction(1.0, tn, n) - s).abs() < 1e-12);
                assert!((efficiency(s, n) - 1.0 / (n as f64 * tn)).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn waiting_and_more_work_make_up_the_serial_fraction() {
        // A phase of 1 s on one thread whose N-thread run did 1.1 s of processor work with its
        // threads busy 80 % of the time: T_N = 1.1/(0.8 N).
        for n in [2, 4, 16] {
            let tn = 1.1 / (0.8 * n as f64);
            let p = Phase::new(1.0, tn, 1.1, n).unwrap();
            let m = n as f64 - 1.0;
            let product = (1.0 + m * p.more_work) * (1.0 + m * p.waiting);
            assert!((product - (1.0 + m * serial_fraction(1.0, tn, n))).abs() < 1e-12);
            assert!((p.busy - 0.8).abs() < 1e-12);
            assert!((p.more_work - 0.1 / m).abs() < 1e-12);
            assert!((p.waiting - 0.25 / m).abs() < 1e-12);
        }
        // Every thread busy and no work added: no serial fraction at all.
        let p = Phase::new(1.0, 0.5, 1.0, 2).unwrap();
        let s = serial_fraction(1.0, 0.5, 2);
        assert!(s.abs() < 1e-12 && p.waiting.abs() < 1e-12 && p.more_work.abs() < 1e-12);
        // No process clock: nothing to split.
        assert_eq!(Phase::new(1.0, 0.5, 0.0, 2), None);
    }
}
