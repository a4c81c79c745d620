//! `haze bench SCENE --scaling`: whole runs on 1 thread and on N, phase by phase, with the serial
//! fraction of each by Amdahl's law and the efficiency it predicts on larger machines.
//!
//! Amdahl's law for a phase that takes T₁ on one thread and T_N on N: if a fraction s of its work
//! cannot run in parallel, T_N = T₁ (s + (1 − s)/N), so s = (N T_N/T₁ − 1)/(N − 1), and on M
//! threads its efficiency T₁/(M T_M) is 1/(1 + s (M − 1)). Measured on few threads, s also holds
//! whatever else keeps threads from speeding up — waiting on another thread's last work item,
//! contention for memory or shared cache lines — so the prediction is a bound of what the code
//! allows, not a promise for a machine with other caches and memory.

use crate::shared::{Overrides, bench_scene, thread_pool};
use anyhow::{Result, bail};
use haze::progress::Status;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

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
    "writing EXR and PNG",
    "whole run",
];

/// Seconds of each phase of one whole run, in the order of [`PHASES`].
type Times = [f64; PHASES.len()];

/// One whole run on `threads` threads: load, render, write (to a temporary file, removed).
fn run_once(path: &Path, overrides: &Overrides, threads: usize) -> Result<Times> {
    let pool = thread_pool(Some(threads))?;
    let whole = Instant::now();
    let (scene, settings) = bench_scene(&pool, path, overrides)?;
    let load = whole.elapsed().as_secs_f64();
    let mut steps = [0.0f64; 6];
    let mut on_iteration = |s: &Status| {
        let t = &s.times;
        let each = [t.pilot, t.photon_trace, t.surface_map, t.volume_map, t.camera, t.film];
        for (sum, x) in steps.iter_mut().zip(each) {
            *sum += x;
        }
    };
    let stop = AtomicBool::new(false);
    let clock = Instant::now();
    let image = pool.install(|| haze::render(&scene, &settings, &mut on_iteration, &stop))?;
    let render = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    let out = std::env::temp_dir().join(format!("haze-scaling-{}.exr", std::process::id()));
    let written = pool.install(|| image.write(&out, 1.0))?;
    for f in written {
        let _ = std::fs::remove_file(f);
    }
    let write = clock.elapsed().as_secs_f64();
    let setup = (render - steps.iter().sum::<f64>()).max(0.0);
    let [pilot, trace, surface, volume, camera, film] = steps;
    let whole = whole.elapsed().as_secs_f64();
    Ok([load, setup, pilot, trace, surface, volume, camera, film, write, whole])
}

/// Amdahl's serial fraction from one phase's times on 1 and `n` threads.
fn serial_fraction(t1: f64, tn: f64, n: usize) -> f64 {
    (n as f64 * tn / t1 - 1.0) / (n as f64 - 1.0)
}

/// Efficiency on `m` threads of a phase with serial fraction `s` (clamped to 0..=1).
fn efficiency(s: f64, m: usize) -> f64 {
    1.0 / (1.0 + s.clamp(0.0, 1.0) * (m as f64 - 1.0))
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
    let (mut one, mut many) = ([f64::INFINITY; PHASES.len()], [f64::INFINITY; PHASES.len()]);
    for round in 1..=rounds {
        for (threads, best) in [(1, &mut one), (n, &mut many)] {
            eprintln!("round {round}/{rounds}: {threads} thread(s)");
            let t = run_once(path, overrides, threads)?;
            for (b, x) in best.iter_mut().zip(t) {
                *b = b.min(x);
            }
        }
    }
    println!("scene: {}", path.display());
    println!(
        "whole runs on 1 and {n} threads, shortest of {rounds} rounds per phase; {} cores here",
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    println!();
    println!(
        "| phase | 1 thread (s) | {n} threads (s) | speed-up | serial fraction | its serial time / run | efficiency at 16 | at 64 | |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let whole = one[PHASES.len() - 1];
    for (i, name) in PHASES.iter().enumerate() {
        let (t1, tn) = (one[i], many[i]);
        if t1 <= 0.0 {
            println!("| {name} | — | — | | | | | | |");
            continue;
        }
        let s = serial_fraction(t1, tn, n);
        let share = s.max(0.0) * t1 / whole;
        let flag = if s > FLAG_FRACTION && t1 / whole >= FLAG_SHARE && i + 1 < PHASES.len() {
            "does not scale"
        } else {
            ""
        };
        println!(
            "| {name} | {t1:.4} | {tn:.4} | {:.2}× | {:.1} % | {:.2} % | {:.0} % | {:.0} % | {flag} |",
            t1 / tn,
            100.0 * s,
            100.0 * share,
            100.0 * efficiency(s, 16),
            100.0 * efficiency(s, 64),
        );
    }
    println!();
    println!(
        "serial fraction s = (N·T_N/T_1 − 1)/(N − 1), efficiency at M threads 1/(1 + s(M − 1)); \
         \"its serial time / run\": s·T_1 of the phase over the whole run's T_1 (they add up to \
         about the whole run's serial fraction). Measured on few threads, s also counts waiting \
         and contention, not only serial code."
    );
    Ok(())
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
}
