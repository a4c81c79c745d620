//! Where photons and light samples go changes the noise, never the expected image: photon
//! guiding against unguided emission on the bundled VDB cloud, and light paths split by
//! importance against unsplit ones in the dense fog box, region by region.

use crate::common::{SIGNIFICANCE, mean_and_se, scene_path};
use haze::progress::Silent;
use haze::progress::Status;
use haze::settings::{Integrator, PhotonGuiding, PhotonSplitting, RenderSettings};
use haze::{Image, Scene};
use statrs::distribution::{ContinuousCDF, StudentsT};
use std::sync::atomic::AtomicBool;

/// Means of an n × n grid of image regions, row-major.
fn regions(img: &Image, n: usize) -> Vec<f64> {
    let (w, h) = (img.width as usize, img.height as usize);
    let mut sums = vec![(0.0f64, 0usize); n * n];
    for y in 0..h {
        for x in 0..w {
            let k = (y * n / h) * n + x * n / w;
            let p = img.pixels[y * w + x];
            sums[k].0 += (p[0] + p[1] + p[2]) as f64 / 3.0;
            sums[k].1 += 1;
        }
    }
    sums.into_iter().map(|(s, c)| s / c as f64).collect()
}

/// The sun and the spot light of vdb-cloud, most of the sun's photons falling on ground nobody
/// sees: with guiding on, the pilot must find that and guide the photon pass, and the guided
/// image must agree with the unguided one. Each iteration of either is an unbiased estimate of
/// the same kernel-smoothed image (importance sampling with the exact density; docs/theory.md),
/// so the expected images are equal, radius bias included: a two-sample Welch t-test per region
/// of a 4 × 4 grid over 10 seeds each, at the suite's significance shared over the 16 regions
/// (Bonferroni), no bias allowance.
#[test]
fn photon_guiding_changes_the_noise_not_the_image() {
    let mut scene = Scene::load(scene_path("vdb-cloud.toml")).unwrap();
    scene.set_resolution([48, 30]).unwrap();
    // Guiding is photon mapping's and the hybrid's.
    let base = RenderSettings {
        iterations: Some(3),
        photons: 8000,
        volume_radius: Some(0.08),
        integrator: Integrator::Hybrid,
        ..scene.settings.clone()
    };
    let stop = AtomicBool::new(false);
    let usage = haze::photon_usage(&scene, &base, 1, &stop).unwrap().unwrap();
    assert!(usage.guided, "the pilot should find the sun's photons mostly wasted: {usage:?}");
    let seeds = 10u64;
    let run = |guiding| -> Vec<Vec<f64>> {
        (0..seeds)
            .map(|seed| {
                let s =
                    RenderSettings { seed: 100 + seed, photon_guiding: guiding, ..base.clone() };
                regions(&haze::render(&scene, &s, &mut Silent, &stop).unwrap(), 4)
            })
            .collect()
    };
    let (guided, plain) = (run(PhotonGuiding::Visibility), run(PhotonGuiding::Off));
    assert_regions_agree("guided", &guided, "unguided", &plain);
}

/// Two samples of region means (per seed, then per region) agree: a two-sample Welch t-test per
/// region at the suite's significance shared over the regions (Bonferroni), no bias allowance.
fn assert_regions_agree(a_name: &str, a: &[Vec<f64>], b_name: &str, b: &[Vec<f64>]) {
    let (seeds, regions) = (a.len(), a[0].len());
    let tests = regions as f64;
    let t = StudentsT::new(0.0, 1.0, (seeds - 1) as f64).unwrap();
    let critical = t.inverse_cdf(1.0 - SIGNIFICANCE / tests / 2.0);
    for k in 0..regions {
        let ((ma, sa), (mb, sb)) = (
            mean_and_se(&a.iter().map(|r| r[k]).collect::<Vec<_>>()),
            mean_and_se(&b.iter().map(|r| r[k]).collect::<Vec<_>>()),
        );
        let se = (sa * sa + sb * sb).sqrt();
        if se == 0.0 {
            assert_eq!(ma, mb, "region {k}");
            continue;
        }
        let z = (ma - mb) / se;
        assert!(
            z.abs() <= critical,
            "region {k}: {a_name} {ma:.5} ± {sa:.5}, {b_name} {mb:.5} ± {sb:.5} (t = {z:.2})"
        );
    }
}

/// Light paths split by importance (docs/theory.md, "Light paths split by importance") in the
/// fog box of dense-fog thinned to σ_t = 10 (optical thickness 20 across the room, albedo 0.995:
/// light random-walks from the lamp to the front the camera sees, and enough arrives that 12
/// seeds of 64 iterations measure it to ~2 % per region): the split render must store more
/// photons than the unsplit one (the copies), and its expected image is the unsplit one's at the
/// same radius — each copy is divided by the expected number of copies — so the region means
/// agree by the Welch t-test of `photon_guiding_changes_the_noise_not_the_image` (2 × 2 regions
/// over the fog's face). Two mistakes it caught: copies left at the whole path's throughput
/// (×800), and a path that ended going on again after its copies (+18 %).
#[test]
fn photon_splitting_changes_the_noise_not_the_image() {
    let text = std::fs::read_to_string(scene_path("dense-fog.toml")).unwrap();
    let text = text.replace("sigma_a = 0.06\nsigma_s = 59.94", "sigma_a = 0.05\nsigma_s = 9.95");
    let mut scene =
        Scene::from_toml(&text, std::path::Path::new("fog-box.toml"), &scene_path("")).unwrap();
    scene.set_resolution([32, 32]).unwrap();
    let base = RenderSettings {
        iterations: Some(64),
        photons: 100,
        volume_radius: Some(0.08),
        max_bounces: 2000,
        // The hybrid's light paths, at the count given (the combined integrator's pilot would
        // choose a count of its own for each run).
        integrator: Integrator::Hybrid,
        ..scene.settings.clone()
    };
    let stop = AtomicBool::new(false);
    let seeds = 12u64;
    let run = |splitting| -> (Vec<Vec<f64>>, u64) {
        let mut stored = 0u64;
        let images = (0..seeds)
            .map(|seed| {
                let s = RenderSettings {
                    seed: 200 + seed,
                    photon_splitting: splitting,
                    ..base.clone()
                };
                let mut count = |st: &Status| stored += st.volume_photons_stored;
                regions(&haze::render(&scene, &s, &mut count, &stop).unwrap(), 2)
            })
            .collect();
        (images, stored)
    };
    let ((split, with), (plain, without)) =
        (run(PhotonSplitting::Importance), run(PhotonSplitting::Off));
    // That the rule ran: millions of photons, so a few percent of noise at most (measured: 1.35×
    // with roulette for copies, 2× without).
    assert!(5 * with > 6 * without, "splitting stored {with} volume photons, unsplit {without}");
    assert_regions_agree("split", &split, "unsplit", &plain);
}
