//! The Rust side of the Python overhead benchmark (`benches/python_overhead.py`): renders a
//! scene through the library API, `haze::render` on a pool of N threads, R times in one
//! process, and prints each render's wall time in seconds (scene loading excluded), one per line.
//!
//! ```sh
//! cargo bench --bench api_render -- SCENE ITERATIONS THREADS ROUNDS [KEY=VALUE,...]
//! ```

use haze::progress::Silent;
use haze::{RenderOptions, Scene};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // `cargo bench` adds `--bench`; the other arguments are ours.
    let args: Vec<String> = std::env::args().skip(1).filter(|a| a != "--bench").collect();
    let [scene, iterations, threads, rounds, rest @ ..] = args.as_slice() else {
        return Err("usage: api_render SCENE ITERATIONS THREADS ROUNDS [KEY=VALUE,...]".into());
    };
    let scene = Scene::load(scene)?;
    let mut options = RenderOptions::parse_assignments(rest.first().map_or("", |s| s.as_str()))?;
    options.iterations = Some(iterations.parse()?);
    let settings = scene.settings.with(&options);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads.parse()?).build()?;
    for _ in 0..rounds.parse::<u32>()? {
        let start = Instant::now();
        let image =
            pool.install(|| haze::render(&scene, &settings, &mut Silent, &AtomicBool::new(false)))?;
        println!("{:.6} {:.6}", start.elapsed().as_secs_f64(), image.info.elapsed);
        assert_eq!(image.info.iterations, settings.iterations.unwrap_or(0));
    }
    Ok(())
}
