//! The same scene, seed and iteration count give a bit-identical image on 1, 2 and 3 threads.

use crate::common::scene_path;
use haze::progress::Silent;
use haze::settings::VolumeEstimate;
use haze::{Image, RenderSettings as Settings, Scene};
use std::sync::atomic::AtomicBool;

fn render_with(scene: &Scene, threads: usize, seed: u64) -> Image {
    render_settings(scene, &scene.settings, threads, seed)
}

fn render_settings(scene: &Scene, settings: &Settings, threads: usize, seed: u64) -> Image {
    let mut settings = settings.clone();
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

/// Media: the beam estimate through the view bins (pinhole camera outside the fog, and inside it
/// in spotlight-fog) and the grid (segments refracted by the lens), with and without thinning, the
/// point estimate, and the combined integrator (with thinning: its merges find each photon's
/// weight record through the thinned map), merging at the first eye vertex and everywhere, its
/// light paths per iteration chosen by its pilot (from counted work, not from the clock).
#[test]
fn media_images_are_bit_identical_across_thread_counts() {
    for (name, size) in
        [("volumetric-caustic.toml", [200, 113]), ("spotlight-fog.toml", [160, 100])]
    {
        let mut scene = Scene::load(scene_path(name)).unwrap();
        scene.set_resolution(size).unwrap();
        // The hybrid's estimates, then the combined integrator's.
        let beam =
            Settings { integrator: haze::settings::Integrator::Hybrid, ..scene.settings.clone() };
        let mut thinned = beam.clone();
        thinned.beam_cell_budget = Some(4);
        let mut point = beam.clone();
        point.volume_estimate = VolumeEstimate::Point;
        let mut combined = thinned.clone();
        combined.integrator = haze::settings::Integrator::Combined;
        let mut everywhere = combined.clone();
        everywhere.merges = Some(haze::settings::Merges::Everywhere);
        for (label, settings) in [
            ("beam", &beam),
            ("thinned", &thinned),
            ("point", &point),
            ("combined", &combined),
            ("combined, merging everywhere", &everywhere),
        ] {
            let one = render_settings(&scene, settings, 1, 5);
            for threads in [2, 3] {
                let other = render_settings(&scene, settings, threads, 5);
                assert!(
                    one.pixels == other.pixels,
                    "{name} {label}: 1 and {threads} threads differ"
                );
            }
            assert!(one.pixels.iter().all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0)));
        }
    }
}

/// Next-event estimation towards an emitting grid (the campfire): each iteration's pool of
/// emitter points is drawn entry by entry from streams of its own, so the image is the same on any
/// number of threads; and the pool's seed matters.
#[test]
fn emitter_pool_images_are_bit_identical_across_thread_counts() {
    let mut scene = Scene::load(scene_path("campfire.toml")).unwrap();
    scene.set_resolution([100, 75]).unwrap();
    assert!(scene.settings.emission_nee_distance.is_some());
    // The pool is the hybrid's.
    scene.settings.integrator = haze::settings::Integrator::Hybrid;
    let one = render_with(&scene, 1, 5);
    for threads in [2, 3] {
        assert!(one.pixels == render_with(&scene, threads, 5).pixels, "1 and {threads} threads");
    }
    assert!(one.pixels.iter().all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0)));
    assert!(one.pixels != render_with(&scene, 2, 6).pixels, "the seed changes nothing");
}

/// Photon guiding: the pilot's tallies are maxima, which concurrent updates leave the same in any
/// order, so the guide — and every image it shapes — is the same on any number of threads.
#[test]
fn guided_images_are_bit_identical_across_thread_counts() {
    let mut scene = Scene::load(scene_path("vdb-cloud.toml")).unwrap();
    scene.set_resolution([80, 50]).unwrap();
    // Guiding is photon mapping's and the hybrid's.
    let integrator = haze::settings::Integrator::Hybrid;
    let settings = Settings { photons: 30_000, integrator, ..scene.settings.clone() };
    let usage = haze::photon_usage(&scene, &settings, 1, &AtomicBool::new(false)).unwrap().unwrap();
    assert!(usage.guided, "vdb-cloud should be guided: {usage:?}");
    let one = render_settings(&scene, &settings, 1, 5);
    for threads in [2, 3] {
        let other = render_settings(&scene, &settings, threads, 5);
        assert!(one.pixels == other.pixels, "vdb-cloud guided: 1 and {threads} threads differ");
    }
}

/// Light paths split by importance: each path's copies are traced in order within its work item,
/// from streams keyed by the path and the copy, and the pilots sum their grids in a fixed order,
/// so photon mapping and the combined integrator give the same image on any number of threads
/// (dense-fog, where paths split most).
#[test]
fn split_images_are_bit_identical_across_thread_counts() {
    let mut scene = Scene::load(scene_path("dense-fog.toml")).unwrap();
    scene.set_resolution([48, 48]).unwrap();
    for integrator in
        [haze::settings::Integrator::PhotonMapping, haze::settings::Integrator::Combined]
    {
        let settings = Settings {
            integrator,
            iterations: Some(2),
            photons: 60,
            seed: 5,
            photon_splitting: haze::settings::PhotonSplitting::Importance,
            ..scene.settings.clone()
        };
        let render = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                haze::render(&scene, &settings, &mut Silent, &AtomicBool::new(false)).unwrap()
            })
        };
        let one = render(1);
        assert!(one.mean() > 0.0, "{integrator:?}: black");
        for threads in [2, 3] {
            assert!(
                one.pixels == render(threads).pixels,
                "{integrator:?}: 1 and {threads} threads"
            );
        }
    }
}
