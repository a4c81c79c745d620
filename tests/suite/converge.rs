//! Convergence measurement (`haze converge`), references, and the original-PPM comparison mode.

use crate::analytic::sphere_scene;
use crate::common::{assert_agrees, scene_path, temp_dir};
use haze::lab::converge::{self, Plan, Reference, Series, checkpoints, measure, theory_slope};
use haze::progress::Silent;
use haze::settings::{Integrator, Progression, RenderSettings, VolumeEstimate};
use haze::{Image, Scene};
use std::f64::consts::PI;
use std::process::Command;
use std::sync::atomic::AtomicBool;

fn small_cornell() -> Scene {
    let mut scene = Scene::load(scene_path("cornell-box.toml")).unwrap();
    scene.set_resolution([16, 16]).unwrap();
    scene
}

fn path_settings(seed: u64, iterations: u64) -> RenderSettings {
    RenderSettings {
        iterations: Some(iterations),
        integrator: Integrator::Path,
        seed,
        max_bounces: 8,
        ..RenderSettings::default()
    }
}

fn render(scene: &Scene, s: &RenderSettings) -> Image {
    haze::render(scene, s, &mut Silent, &AtomicBool::new(false)).unwrap()
}

/// A reference written by `write_reference` reads back with its pixels, its variance layer and
/// the integrator and seed that made it.
#[test]
fn reference_files_round_trip() {
    let scene = small_cornell();
    let img = render(&scene, &path_settings(9, 8));
    let dir = temp_dir("reference-round-trip");
    let path = dir.join("ref.exr");
    img.write_reference(&path, 1.0).unwrap();
    let r = Reference::load(&path).unwrap();
    assert_eq!((r.width, r.height), (16, 16));
    assert_eq!(r.pixels, img.pixels);
    assert_eq!(r.variance.as_ref(), img.variance.as_ref());
    assert!(r.variance.unwrap().iter().flatten().any(|v| *v > 0.0));
    assert_eq!(r.made_by, Some((Integrator::Path, 9)));
    assert!(r.description.unwrap().contains("path tracer"), "description");
    // A photon-mapping reference's variance layer is not used: its iterations drift as the
    // radius shrinks, so their spread is not exactly the noise of the mean. The default
    // integrator's reference records the integrator that made it (combined), not `auto`.
    let ppm = render(
        &scene,
        &RenderSettings { photons: 2_000, iterations: Some(3), ..Default::default() },
    );
    let ppm_path = dir.join("ppm.exr");
    ppm.write_reference(&ppm_path, 1.0).unwrap();
    let r = Reference::load(&ppm_path).unwrap();
    assert!(r.variance.is_none() && r.variance_layer.is_some());
    assert_eq!(r.made_by, Some((Integrator::Combined, 0)));
    assert!(r.description.unwrap().contains("combined"));
    // A plain render carries its variance layer too, but no reference attribute.
    let plain = dir.join("plain.exr");
    img.write_exr(&plain).unwrap();
    let p = Reference::load(&plain).unwrap();
    assert_eq!(p.variance_layer.as_ref(), img.variance.as_ref());
    assert!(p.description.is_none());
    assert_eq!(p.pixels, img.pixels);
    // Not a file, or not an EXR, or an EXR whose header declares a vast image (the plain
    // render's data window patched to 10⁶ × 10⁶ pixels: the reader would size its buffers
    // from it and abort): errors naming the file.
    let junk = dir.join("junk.exr");
    std::fs::write(&junk, b"not an exr").unwrap();
    let mut bytes = std::fs::read(&plain).unwrap();
    let key = b"dataWindow\0box2i\0";
    let at = bytes.windows(key.len()).position(|w| w == key).unwrap() + key.len() + 4;
    for corner in [at + 8, at + 12] {
        bytes[corner..corner + 4].copy_from_slice(&999_999i32.to_le_bytes());
    }
    let vast = dir.join("vast.exr");
    std::fs::write(&vast, bytes).unwrap();
    let e = Reference::load(&vast).unwrap_err().to_string();
    assert!(e.contains("1000000 × 1000000"), "{e}");
    for bad in [dir.join("missing.exr"), junk, vast] {
        let e = Reference::load(&bad).unwrap_err().to_string();
        assert!(e.contains(bad.file_name().unwrap().to_str().unwrap()), "{e}");
    }
}

/// Subtracting the reference's variance makes the squared error unbiased: for two independent
/// path-traced images a and b with variance estimates v_a and v_b, each pixel's
/// q = Σ_c (a − b)² − v_b − v_a has expectation zero (pixels are independent: t-test).
#[test]
fn reference_variance_correction_is_unbiased() {
    let scene = small_cornell();
    let a = render(&scene, &path_settings(21, 64));
    let b = render(&scene, &path_settings(22, 256));
    let (va, vb) = (a.variance.as_ref().unwrap(), b.variance.as_ref().unwrap());
    let q: Vec<f64> = (0..a.pixels.len())
        .map(|i| {
            (0..3)
                .map(|c| {
                    (a.pixels[i][c] as f64 - b.pixels[i][c] as f64).powi(2)
                        - vb[i][c] as f64
                        - va[i][c] as f64
                })
                .sum()
        })
        .collect();
    assert_agrees("corrected squared error minus own variance", &q, 0.0, 0.0);
}

/// A run measures every series and run at exactly the checkpoints, with non-decreasing times,
/// and the summary averages the runs point by point.
#[test]
fn runs_are_measured_at_the_checkpoints() {
    let scene = small_cornell();
    let reference = Reference::from_image(&render(&scene, &path_settings(1, 64)));
    let series = vec![
        Series { label: "path".into(), settings: path_settings(5, 1) },
        Series {
            label: "ppm".into(),
            settings: RenderSettings { photons: 2_000, seed: 5, ..RenderSettings::default() },
        },
    ];
    let plan = Plan { seconds: 1e6, runs: 2, max_iterations: Some(20), region: None };
    let mut calls = 0;
    let samples = converge::run(
        &scene,
        &series,
        &reference,
        &plan,
        &mut |_, _, _| calls += 1,
        &AtomicBool::new(false),
    )
    .unwrap();
    assert_eq!(calls, 2 * 2 * 20);
    for si in 0..2 {
        for run in 0..2 {
            let mine: Vec<_> = samples.iter().filter(|s| s.series == si && s.run == run).collect();
            let its: Vec<u64> = mine.iter().map(|s| s.iterations).collect();
            assert_eq!(its, checkpoints(20));
            assert!(mine.windows(2).all(|w| w[0].seconds <= w[1].seconds));
            assert!(mine.iter().all(|s| s.error.mse.is_finite() && s.error.rel_mse >= 0.0));
        }
    }
    let summaries = converge::summarize(&scene, &series, &samples, 2);
    assert_eq!(summaries[0].points.len(), checkpoints(20).len());
    let p = &summaries[0].points[3];
    let at: Vec<f64> = samples
        .iter()
        .filter(|s| s.series == 0 && s.iterations == p.iterations)
        .map(|s| s.error.mse)
        .collect();
    assert!((p.error.mse - (at[0] + at[1]) / 2.0).abs() <= 1e-12 * p.error.mse.max(1e-30));
    let csv = converge::csv(&series, &samples);
    assert_eq!(csv.lines().count(), 1 + samples.len());
    assert!(converge::markdown(&summaries).contains("| path |"));
    // A region restricts the measurement; one outside the image is an error.
    let region = Some(converge::Region { x0: 0, y0: 0, x1: 4, y1: 4 });
    let e = measure(&reference.pixels, &reference, region);
    assert_eq!(e.rmse(), 0.0);
    let outside = Plan { region: Some(converge::Region { x0: 0, y0: 0, x1: 99, y1: 4 }), ..plan };
    let err = converge::run(
        &scene,
        &series,
        &reference,
        &outside,
        &mut |_, _, _| {},
        &AtomicBool::new(false),
    )
    .unwrap_err();
    assert!(err.to_string().contains("outside"), "{err}");
}

/// A series that would repeat the reference's samples (same integrator and seed) is refused, and
/// so is a reference of another size.
#[test]
fn clashing_seeds_and_sizes_are_refused() {
    let scene = small_cornell();
    let reference = Reference::from_image(&render(&scene, &path_settings(3, 4)));
    let plan = Plan { seconds: 1.0, runs: 2, max_iterations: Some(2), region: None };
    let clash = vec![Series { label: "p".into(), settings: path_settings(2, 1) }];
    let stop = AtomicBool::new(false);
    let err = converge::run(&scene, &clash, &reference, &plan, &mut |_, _, _| {}, &stop)
        .unwrap_err()
        .to_string();
    assert!(err.contains("seed 3"), "{err}");
    let mut big = small_cornell();
    big.set_resolution([20, 16]).unwrap();
    let ok = vec![Series { label: "p".into(), settings: path_settings(10, 1) }];
    let err = converge::run(&big, &ok, &reference, &plan, &mut |_, _, _| {}, &stop)
        .unwrap_err()
        .to_string();
    assert!(err.contains("16x16") && err.contains("20x16"), "{err}");
}

/// The slopes theory gives (../DESIGN.md §3): surface α = 2/3 → −1/3; the beam estimate on the
/// 3-D schedule with α = 1/2 → −1/3, on the 2-D schedule → −1/4; the point estimate at its
/// optimum α = 4/7 → −2/7 (the combined integrator, which weighs both, the beam's); the path tracer −1/2.
#[test]
fn theory_slopes() {
    let surface = small_cornell();
    let fog = Scene::load(scene_path("cornell-fog.toml")).unwrap();
    let hybrid = Integrator::Hybrid;
    let base = RenderSettings {
        alpha: 2.0 / 3.0,
        volume_alpha: 0.5,
        integrator: hybrid,
        ..RenderSettings::default()
    };
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
    assert!(close(theory_slope(&surface, &base), -1.0 / 3.0));
    assert!(close(theory_slope(&fog, &base), -1.0 / 3.0));
    let d2 = RenderSettings { volume_dimension: 2, ..base.clone() };
    assert!(close(theory_slope(&fog, &d2), -0.25));
    let point = RenderSettings {
        volume_estimate: VolumeEstimate::Point,
        volume_alpha: 4.0 / 7.0,
        ..base.clone()
    };
    assert!(close(theory_slope(&fog, &point), -2.0 / 7.0));
    // The combined integrator weighs both merges whatever the volume estimate says: the beam's
    // rate (the point estimate's at α = 1/2 would be −1/4).
    let combined = RenderSettings {
        integrator: Integrator::Combined,
        volume_estimate: VolumeEstimate::Point,
        ..base.clone()
    };
    assert!(close(theory_slope(&fog, &combined), -1.0 / 3.0));
    let path = RenderSettings { integrator: Integrator::Path, ..base };
    assert!(close(theory_slope(&fog, &path), -0.5));
}

/// The original PPM (per-pixel statistics) on the closed diffuse sphere around a point light,
/// where radiance is uniform and the disc kernel on the sphere has no bias: the image mean must
/// equal ρ/π · (1 − ρ^D)/(1 − ρ) (t-test over seeds). Its radius shrinks per pixel.
#[test]
fn original_ppm_matches_the_analytic_sphere() {
    let scene = sphere_scene(0.5, 4.0 * std::f32::consts::PI);
    let depth = 12;
    let rho = 0.5f64;
    let reference = rho / PI * (1.0 - rho.powi(depth)) / (1.0 - rho);
    let means: Vec<f64> = (0..10)
        .map(|seed| {
            let s = RenderSettings {
                iterations: Some(6),
                photons: 20_000,
                radius: Some(0.08),
                max_bounces: depth as u32,
                seed,
                progression: Progression::Original,
                integrator: Integrator::PhotonMapping,
                ..RenderSettings::default()
            };
            let img = render(&scene, &s);
            assert!(img.info.radius < 0.08 && img.info.radius > 0.0, "{}", img.info.radius);
            assert_eq!(img.info.nonfinite_samples, 0);
            img.mean()
        })
        .collect();
    assert_agrees("original PPM, sphere ρ = 0.5", &means, reference, 0.0);
}

/// The original PPM refuses scenes with media, the path tracer and the hybrid.
#[test]
fn original_ppm_is_for_surfaces_only() {
    let fog = Scene::load(scene_path("cornell-fog.toml")).unwrap();
    let s = RenderSettings {
        progression: Progression::Original,
        integrator: Integrator::PhotonMapping,
        ..RenderSettings::default()
    };
    let err = haze::render(&fog, &s, &mut Silent, &AtomicBool::new(false)).unwrap_err();
    assert!(err.to_string().contains("media"), "{err}");
    for integrator in [Integrator::Path, Integrator::Hybrid] {
        let p = RenderSettings { integrator, ..s.clone() };
        assert!(p.validate().unwrap_err().key == "progression");
    }
}

fn haze(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_haze")).args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `haze render --reference` then `haze converge` end to end: CSV, Markdown, SVG and PNG are
/// written; bad input fails with a reason.
#[test]
fn converge_command_end_to_end() {
    let dir = temp_dir("converge-cli");
    let scene = scene_path("cornell-box.toml");
    let scene = scene.to_str().unwrap();
    let reference = dir.join("ref.exr");
    let reference = reference.to_str().unwrap();
    let (ok, _, err) = haze(&[
        "render",
        scene,
        "--resolution",
        "12x12",
        "--integrator",
        "path",
        "-n",
        "16",
        "--seed",
        "100",
        "--reference",
        "-q",
        "-o",
        reference,
    ]);
    assert!(ok, "{err}");
    let prefix = dir.join("cv");
    let prefix = prefix.to_str().unwrap();
    let common = [
        "converge",
        scene,
        "--reference",
        reference,
        "--resolution",
        "12x12",
        "-p",
        "2000",
        "-n",
        "8",
        "-t",
        "60s",
    ];
    let mut args = common.to_vec();
    args.extend([
        "--compare",
        "progression",
        "--series",
        "path:integrator=path",
        "-o",
        prefix,
        "-q",
    ]);
    let (ok, out, err) = haze(&args);
    assert!(ok, "{err}");
    assert!(out.contains("| original PPM |") && out.contains("| path |"), "{out}");
    assert!(out.contains("path tracer"), "reference description missing: {out}");
    for ext in ["csv", "md", "svg"] {
        assert!(dir.join(format!("cv.{ext}")).is_file(), "cv.{ext} missing");
    }
    let csv = std::fs::read_to_string(dir.join("cv.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 3 * checkpoints(8).len());
    for (extra, needle) in [
        (vec!["--series", "bad"], "LABEL:KEY=VALUE"),
        (vec!["--series", "x:alpha=2"], "alpha"),
        (vec!["--series", "x:colour=red"], "colour"),
        (vec!["--compare", "everything"], "everything"),
        (vec!["--region", "1,2,3"], "region"),
        (vec!["--runs", "0"], "--runs"),
        (vec!["--series", "x:integrator=path,seed=100"], "seed 100"),
    ] {
        let mut a = common.to_vec();
        a.extend(extra.iter().copied());
        let (ok, _, err) = haze(&a);
        assert!(!ok, "{extra:?} succeeded");
        assert!(err.contains(needle), "{extra:?}: `{err}` lacks `{needle}`");
        assert!(!err.contains("panicked"), "{err}");
    }
    let (ok, _, err) = haze(&["converge", scene, "--reference", "nope.exr"]);
    assert!(!ok && err.contains("nope.exr"), "{err}");
    let (ok, _, err) = haze(&["converge", scene, "--reference", reference]);
    assert!(!ok && err.contains("12x12"), "size mismatch: {err}");
}
