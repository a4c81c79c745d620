//! The same scene, seed and iteration count give a bit-identical image on 1 and 2 threads.

use crate::common::scene_path;
use haze::progress::Silent;
use haze::{Image, Scene};
use std::sync::atomic::AtomicBool;

fn render_with(scene: &Scene, threads: usize, seed: u64) -> Image {
    let mut settings = scene.settings.clone();
    settings.iterations = Some(3);
    settings.photons = 30_000;
    settings.seed = seed;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| haze::render(scene, &settings, &mut Silent, &AtomicBool::new(false)).unwrap())
}

#[test]
fn image_is_bit_identical_across_thread_counts() {
    for name in ["cornell-box.toml", "glass-caustic.toml"] {
        let scene = Scene::load(scene_path(name)).unwrap();
        let one = render_with(&scene, 1, 5);
        let two = render_with(&scene, 2, 5);
        assert!(one.pixels == two.pixels, "{name}: 1 and 2 threads differ");
        assert!(one.pixels.iter().all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0)));
        assert_eq!(one.info.nonfinite_samples, 0);
        let other_seed = render_with(&scene, 2, 6);
        assert!(one.pixels != other_seed.pixels, "{name}: the seed changes nothing");
    }
}
