//! `haze bench rays`: closest-hit and occlusion queries per second on a scene's geometry, for
//! camera, incoherent and shadow rays, on 1 and 2 threads — and, given the Embree harness
//! (`benches/embree/build.sh`), the same rays through Embree in the same run, as a ratio.

use anyhow::{Context, Result, bail};
use clap::Args;
use haze::raybench::{self, QueryRay, RaySet};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args)]
pub(crate) struct RaysArgs {
    /// Scene file [default: scenes/cornell-box.toml].
    scene: Option<PathBuf>,
    /// Rays per set.
    #[arg(long, value_name = "N", default_value_t = 1 << 20)]
    rays: usize,
    /// Seconds per measurement (whole passes over the set are repeated until they have passed).
    #[arg(long, value_name = "S", default_value_t = 1.0)]
    seconds: f64,
    /// Thread counts to measure.
    #[arg(long, value_name = "T,…", value_delimiter = ',', default_values_t = [1, 2])]
    threads: Vec<usize>,
    /// The Embree harness (built by benches/embree/build.sh as target/embree-rays): traces the
    /// same geometry and rays beside haze's and adds its rates and the ratio.
    #[arg(long, value_name = "PATH")]
    embree: Option<PathBuf>,
    /// Seed of the ray sets.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// Rays per second and the rays of one pass that hit, per (set, query, threads).
type Rates = BTreeMap<(String, &'static str, usize), (f64, usize)>;

pub(crate) fn run(args: RaysArgs) -> Result<()> {
    let path = args.scene.unwrap_or_else(|| PathBuf::from("scenes/cornell-box.toml"));
    // Three sets of this many rays are held in memory (28 bytes a ray).
    const MAX_RAYS: usize = 1 << 24;
    let seconds_ok = args.seconds > 0.0 && args.seconds <= 600.0;
    if !((1..=MAX_RAYS).contains(&args.rays) && seconds_ok) {
        bail!("--rays must lie in 1..={MAX_RAYS} and --seconds in (0, 600]");
    }
    if let Some(&t) = args.threads.iter().find(|&&t| t == 0 || t > crate::shared::max_threads()) {
        bail!("--threads {t}: each count must lie in 1..={}", crate::shared::max_threads());
    }
    let scene = haze::Scene::load(&path)?;
    let sets = raybench::ray_sets(&scene, args.rays, args.seed);
    let (tris, spheres) = raybench::geometry(&scene);
    let mut haze = Rates::new();
    for set in &sets {
        for query in ["closest", "occlusion"] {
            for &threads in &args.threads {
                let (rate, hits) = measure(&scene, set, query, threads, args.seconds);
                haze.insert((set.name.to_string(), query, threads), (rate, hits));
            }
        }
    }
    let embree = match &args.embree {
        Some(harness) => Some(run_embree(harness, &scene, &sets, args.seconds, &args.threads)?),
        None => None,
    };
    println!("scene: {} ({} triangles, {} spheres)", path.display(), tris.len(), spheres.len());
    println!(
        "{} rays per set; rays per second over whole passes of at least {} s; {} cores",
        args.rays,
        args.seconds,
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    if embree.is_some() {
        println!(
            "| rays | query | threads | haze rays/s | Embree rays/s | haze ÷ Embree | hits haze / Embree |"
        );
        println!("|---|---|---|---|---|---|---|");
    } else {
        println!("| rays | query | threads | haze rays/s | hits |");
        println!("|---|---|---|---|---|");
    }
    for ((set, query, threads), (rate, hits)) in &haze {
        let n = sets.iter().find(|s| s.name == set).map_or(0, |s| s.rays.len());
        match embree.as_ref().and_then(|e| e.get(&(set.clone(), *query, *threads))) {
            Some((e_rate, e_hits)) => println!(
                "| {set} | {query} | {threads} | {:.2} M | {:.2} M | {:.2} | {hits} / {e_hits} of {n} |",
                rate / 1e6,
                e_rate / 1e6,
                rate / e_rate
            ),
            None if embree.is_some() => println!(
                "| {set} | {query} | {threads} | {:.2} M | — | — | {hits} of {n} |",
                rate / 1e6
            ),
            None => {
                println!("| {set} | {query} | {threads} | {:.2} M | {hits} of {n} |", rate / 1e6)
            }
        }
    }
    Ok(())
}

/// Rays per second of `query` over `set` on `threads` threads (each thread takes a contiguous
/// share of every pass, as the Embree harness does), and the rays of one pass that hit.
fn measure(
    scene: &haze::Scene,
    set: &RaySet,
    query: &str,
    threads: usize,
    seconds: f64,
) -> (f64, usize) {
    let count = |rays: &[QueryRay]| match query {
        "closest" => raybench::closest_hits(scene, rays),
        _ => raybench::occlusions(scene, rays),
    };
    let pass = || -> usize {
        let n = set.rays.len();
        std::thread::scope(|s| {
            let parts: Vec<_> = (0..threads)
                .map(|k| {
                    let part = &set.rays[n * k / threads..n * (k + 1) / threads];
                    s.spawn(move || count(part))
                })
                .collect();
            parts.into_iter().map(|p| p.join().unwrap_or(0)).sum()
        })
    };
    if set.rays.is_empty() {
        return (0.0, 0);
    }
    let hits = pass(); // warm-up
    let start = Instant::now();
    let mut rays = 0usize;
    while start.elapsed().as_secs_f64() < seconds {
        pass();
        rays += set.rays.len();
    }
    (rays as f64 / start.elapsed().as_secs_f64(), hits)
}

/// Writes the geometry and rays for the Embree harness, runs it, and reads its rates.
fn run_embree(
    harness: &std::path::Path,
    scene: &haze::Scene,
    sets: &[RaySet],
    seconds: f64,
    threads: &[usize],
) -> Result<Rates> {
    let file = std::env::temp_dir().join(format!("haze-rays-{}.bin", std::process::id()));
    raybench::export(&file, scene, sets)?;
    let out = std::process::Command::new(harness)
        .arg(&file)
        .arg(seconds.to_string())
        .output()
        .with_context(|| format!("cannot run the Embree harness {}", harness.display()));
    let _ = std::fs::remove_file(&file);
    let out = out?;
    if !out.status.success() {
        bail!(
            "the Embree harness {} failed: {}",
            harness.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let mut rates = Rates::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        if let [set, query, t, rate, hits] = f[..] {
            let query = if query == "closest" { "closest" } else { "occlusion" };
            let t: usize = t.parse().unwrap_or(0);
            if threads.contains(&t) {
                rates.insert(
                    (set.to_string(), query, t),
                    (rate.parse().unwrap_or(0.0), hits.parse().unwrap_or(0)),
                );
            }
        }
    }
    Ok(rates)
}
