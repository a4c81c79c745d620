//! Every bundled scene loads and renders without a NaN or infinite pixel, with its own integrator
//! (the default, `auto`: the combined integrator, or the hybrid where media emit, unless it names
//! one) and with the hybrid's two volume estimators (at reduced resolution and photon counts).

use crate::common::scene_path;
use haze::Scene;
use haze::progress::Silent;
use haze::settings::{Integrator, VolumeEstimate};
use std::sync::atomic::AtomicBool;

#[test]
fn bundled_scenes_render_finite_images() {
    let dir = scene_path("");
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 5, "expected the bundled scenes in {}", dir.display());
    for path in names {
        let mut scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let [w, h] = scene.resolution();
        scene.set_resolution([(w / 8).max(1), (h / 8).max(1)]).unwrap();
        let own = scene.settings.integrator;
        for (integrator, estimate) in [
            (own, scene.settings.volume_estimate),
            (Integrator::Hybrid, VolumeEstimate::Beam),
            (Integrator::Hybrid, VolumeEstimate::Point),
        ] {
            let mut s = scene.settings.clone();
            s.integrator = integrator;
            s.iterations = Some(2);
            s.time_limit = None;
            s.photons = s.photons.min(20_000);
            s.volume_estimate = estimate;
            let image = haze::render(&scene, &s, &mut Silent, &AtomicBool::new(false)).unwrap();
            let what = format!("{} ({integrator}, {estimate})", path.display());
            let bad = image.pixels.iter().flatten().filter(|c| !c.is_finite() || **c < 0.0).count();
            assert_eq!(bad, 0, "{what}: {bad} bad pixel values");
            assert_eq!(image.info.nonfinite_samples, 0, "{what}");
            assert!(image.mean() > 0.0, "{what}: black image");
        }
    }
}
