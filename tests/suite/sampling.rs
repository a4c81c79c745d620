//! Where photons and light samples go changes the noise, never the expected image: photon
//! guiding against unguided emission on the bundled VDB cloud, region by region.

use crate::common::{SIGNIFICANCE, mean_and_se, scene_path};
use haze::progress::Silent;
use haze::settings::{PhotonGuiding, RenderSettings};
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
    let base = RenderSettings {
        iterations: Some(3),
        photons: 8000,
        volume_radius: Some(0.08),
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
    let tests = 16.0;
    let t = StudentsT::new(0.0, 1.0, (seeds - 1) as f64).unwrap();
    let critical = t.inverse_cdf(1.0 - SIGNIFICANCE / tests / 2.0);
    for k in 0..16 {
        let a: Vec<f64> = guided.iter().map(|r| r[k]).collect();
        let b: Vec<f64> = plain.iter().map(|r| r[k]).collect();
        let ((ma, sa), (mb, sb)) = (mean_and_se(&a), mean_and_se(&b));
        let se = (sa * sa + sb * sb).sqrt();
        if se == 0.0 {
            assert_eq!(ma, mb, "region {k}");
            continue;
        }
        let z = (ma - mb) / se;
        assert!(
            z.abs() <= critical,
            "region {k}: guided {ma:.5} ± {sa:.5}, unguided {mb:.5} ± {sb:.5} (t = {z:.2})"
        );
    }
}
