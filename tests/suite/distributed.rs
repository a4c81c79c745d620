//! Renders split into iteration ranges and merged, and renders stopped and resumed, are
//! bit-identical to one uninterrupted render: for photon mapping and the hybrid (beam and point
//! estimates, homogeneous and VDB media, light paths split by importance) and the path tracer;
//! the original PPM resumes.

use crate::common::{scene_path, temp_dir};
use haze::progress::Silent;
use haze::settings::{Integrator, Progression, VolumeEstimate};
use haze::{Partial, RenderSettings, Scene, Start, render_partial};
use std::process::Command;
use std::sync::atomic::AtomicBool;

fn scene(name: &str) -> Scene {
    let mut s = Scene::load(scene_path(name)).unwrap();
    s.set_resolution([12, 12]).unwrap();
    s
}

fn run(scene: &Scene, settings: &RenderSettings, start: Start, last: u64) -> Partial {
    let settings = RenderSettings { iterations: Some(last), time_limit: None, ..settings.clone() };
    render_partial(scene, &settings, start, &mut Silent, &AtomicBool::new(false)).unwrap()
}

/// Whole render of 1..=6 against three splits merged in scrambled orders and a resume from 4.
fn check_exact(name: &str, settings: &RenderSettings) {
    let scene = scene(name);
    let whole = run(&scene, settings, Start::At(1), 6);
    assert_eq!(whole.info.iterations, 6);
    assert!(whole.image().mean() > 0.0, "{name}: black");
    // Photon films carry the kernel-bias sums, which merge and resume exactly with the rest.
    assert_eq!(whole.film.has_bias(), settings.integrator != Integrator::Path, "{name}");
    for split in [&[(1, 2), (3, 6)][..], &[(1, 1), (2, 3), (4, 6)], &[(1, 5), (6, 6)]] {
        let mut parts: Vec<Partial> =
            split.iter().map(|&(a, b)| run(&scene, settings, Start::At(a), b)).collect();
        parts.reverse();
        let merged = Partial::merge(parts).unwrap();
        assert_eq!(merged.film, whole.film, "{name} {:?}: split {split:?}", settings.integrator);
        assert_eq!(merged.image().pixels, whole.image().pixels);
        assert_eq!((merged.info.first_iteration, merged.info.iterations), (1, 6));
        assert_eq!(merged.info.radius, whole.info.radius);
    }
    let resumed =
        run(&scene, settings, Start::Resume(Box::new(run(&scene, settings, Start::At(1), 4))), 6);
    assert_eq!(resumed.film, whole.film, "{name} {:?}: resume", settings.integrator);
}

fn settings(integrator: Integrator, estimate: VolumeEstimate) -> RenderSettings {
    RenderSettings {
        integrator,
        volume_estimate: estimate,
        photons: 3_000,
        ..RenderSettings::default()
    }
}

/// The combined integrator, whose pilot chooses the light paths per iteration before the first
/// iteration of every part: each part chooses the same.
#[test]
fn ranges_of_the_combined_integrator_merge_and_resume_exactly() {
    let combined =
        RenderSettings { photons: 4_000, ..settings(Integrator::Combined, VolumeEstimate::Beam) };
    check_exact("cornell-fog.toml", &combined);
}

/// Light paths split by importance: the pilots run before the first iteration of every part, from
/// streams of their own, so every part splits the same way (cornell-fog, whose lamp lights the fog
/// unevenly enough that paths split).
#[test]
fn ranges_with_light_paths_split_by_importance_merge_and_resume_exactly() {
    for integrator in [Integrator::PhotonMapping, Integrator::Combined] {
        let split = RenderSettings {
            photon_splitting: haze::settings::PhotonSplitting::Importance,
            ..settings(integrator, VolumeEstimate::Beam)
        };
        check_exact("cornell-fog.toml", &split);
    }
}

#[test]
fn ranges_merge_and_resume_exactly_in_homogeneous_fog() {
    for integrator in [Integrator::Hybrid, Integrator::PhotonMapping] {
        for estimate in [VolumeEstimate::Beam, VolumeEstimate::Point] {
            check_exact("spotlight-fog.toml", &settings(integrator, estimate));
        }
    }
    check_exact("spotlight-fog.toml", &settings(Integrator::Path, VolumeEstimate::Beam));
    check_exact("spotlight-fog.toml", &settings(Integrator::Combined, VolumeEstimate::Beam));
}

#[test]
fn ranges_merge_and_resume_exactly_in_a_vdb_cloud() {
    check_exact("cornell-cloud.toml", &settings(Integrator::Hybrid, VolumeEstimate::Beam));
    check_exact("cornell-cloud.toml", &settings(Integrator::PhotonMapping, VolumeEstimate::Point));
    check_exact("cornell-cloud.toml", &settings(Integrator::Path, VolumeEstimate::Beam));
    check_exact("cornell-cloud.toml", &settings(Integrator::Combined, VolumeEstimate::Beam));
}

/// Under environment lights (a map file with the sun in a texel, and a physical sky with its
/// sun): guided photons from the environment's disc, the hybrid and the path tracer.
#[test]
fn ranges_merge_and_resume_exactly_under_a_sky() {
    check_exact("sunset-fog.toml", &settings(Integrator::Hybrid, VolumeEstimate::Beam));
    check_exact("sunset-fog.toml", &settings(Integrator::Path, VolumeEstimate::Beam));
    check_exact("cumulus-sky.toml", &settings(Integrator::Combined, VolumeEstimate::Beam));
}

/// The original PPM's per-pixel statistics depend on every earlier iteration: ranges are
/// refused with a clear message, merging too, but a stopped render resumes exactly.
#[test]
fn the_original_ppm_resumes_but_refuses_ranges() {
    let scene = scene("cornell-box.toml");
    let s = RenderSettings {
        integrator: Integrator::PhotonMapping,
        progression: Progression::Original,
        photons: 2_000,
        ..RenderSettings::default()
    };
    let whole = run(&scene, &s, Start::At(1), 5);
    let resumed = run(&scene, &s, Start::Resume(Box::new(run(&scene, &s, Start::At(1), 2))), 5);
    assert_eq!(resumed.film, whole.film);
    assert_eq!(resumed.image().pixels, whole.image().pixels);
    let settings = RenderSettings { iterations: Some(5), ..s.clone() };
    let e = render_partial(&scene, &settings, Start::At(3), &mut Silent, &AtomicBool::new(false))
        .unwrap_err()
        .to_string();
    assert!(e.contains("original PPM") && e.contains("resume"), "{e}");
    let e = Partial::merge(vec![whole]).unwrap_err();
    assert!(e.contains("cannot be merged"), "{e}");
}

/// Merging names what is wrong: gaps, overlaps, other settings, another scene; a resume from a
/// partial of other settings is refused.
#[test]
fn incompatible_parts_are_refused_with_the_reason() {
    let scene = scene("cornell-box.toml");
    let s = settings(Integrator::Hybrid, VolumeEstimate::Beam);
    let part = |a, b| run(&scene, &s, Start::At(a), b);
    let e = Partial::merge(vec![part(1, 2), part(5, 6)]).unwrap_err();
    assert!(e.contains("iterations 3..4 are missing"), "{e}");
    let e = Partial::merge(vec![part(1, 3), part(3, 4)]).unwrap_err();
    assert!(e.contains("overlap"), "{e}");
    let e = Partial::merge(vec![part(1, 6), part(2, 3), part(5, 6)]).unwrap_err();
    assert!(e.contains("overlap") && !e.contains("missing"), "{e}");
    let other = run(&scene, &RenderSettings { alpha: 0.5, ..s.clone() }, Start::At(3), 4);
    let e = Partial::merge(vec![part(1, 2), other]).unwrap_err();
    assert!(e.contains("render.alpha"), "{e}");
    let fog = self::scene("cornell-fog.toml");
    let e = Partial::merge(vec![part(1, 2), run(&fog, &s, Start::At(3), 4)]).unwrap_err();
    assert!(e.contains("fingerprints differ"), "{e}");
    let settings = RenderSettings { iterations: Some(4), seed: 99, ..s.clone() };
    let e = render_partial(
        &scene,
        &settings,
        Start::Resume(Box::new(part(1, 2))),
        &mut Silent,
        &AtomicBool::new(false),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("cannot resume") && e.contains("render.seed"), "{e}");
}

/// Partial files round-trip exactly; a changed byte or a truncated file is refused.
#[test]
fn partial_files_round_trip_and_refuse_corruption() {
    let scene = scene("cornell-cloud.toml");
    let p = run(&scene, &settings(Integrator::Hybrid, VolumeEstimate::Beam), Start::At(3), 5);
    let dir = temp_dir("partial-files");
    let path = dir.join("p.hpr");
    p.write(&path).unwrap();
    let q = Partial::read(&path).unwrap();
    assert_eq!(q.film, p.film);
    assert_eq!(q.fingerprint, p.fingerprint);
    assert_eq!(q.info.settings.entries(), p.info.settings.entries());
    assert_eq!((q.info.first_iteration, q.info.iterations), (3, 3));
    let bytes = std::fs::read(&path).unwrap();
    for (k, at) in [bytes.len() / 2, bytes.len() - 40, 100].into_iter().enumerate() {
        let mut bad = bytes.clone();
        bad[at] ^= 0x10;
        let f = dir.join(format!("bad{k}.hpr"));
        std::fs::write(&f, &bad).unwrap();
        let e = Partial::read(&f).unwrap_err().to_string();
        assert!(e.contains("corrupt") || e.contains("header"), "byte {at}: {e}");
    }
    let f = dir.join("short.hpr");
    std::fs::write(&f, &bytes[..bytes.len() - 1]).unwrap();
    assert!(Partial::read(&f).unwrap_err().to_string().contains("truncated"));
    // A (sparse) file larger than any partial render can be, or than one of the image size its
    // header states, is refused by its size, unread.
    let f = dir.join("vast.hpr");
    std::fs::File::create(&f).unwrap().set_len((1 << 35) + 1).unwrap();
    let e = Partial::read(&f).unwrap_err().to_string();
    std::fs::remove_file(&f).unwrap();
    assert!(e.contains("vast.hpr") && e.contains("bytes"), "{e}");
    let f = dir.join("long.hpr");
    std::fs::write(&f, &bytes).unwrap();
    std::fs::OpenOptions::new().write(true).open(&f).unwrap().set_len(1 << 34).unwrap();
    let e = Partial::read(&f).unwrap_err().to_string();
    std::fs::remove_file(&f).unwrap();
    assert!(e.contains("long.hpr") && e.contains("size its header states"), "{e}");
}

/// A partial file of format 1 (before the kernel-bias sums) is still read: a path-traced
/// partial rewritten as format 1 (version 1, no `bias_sums` key, checksum recomputed) reads back
/// as the same film.
#[test]
fn partial_files_of_format_1_are_still_read() {
    use sha2::Digest;
    let scene = scene("cornell-box.toml");
    let p = run(&scene, &settings(Integrator::Path, VolumeEstimate::Beam), Start::At(1), 3);
    assert!(!p.film.has_bias());
    let dir = temp_dir("partial-v1");
    let path = dir.join("p.hpr");
    p.write(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let u64_at = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
    let header_len = u64_at(12);
    let header = std::str::from_utf8(&bytes[20..20 + header_len]).unwrap();
    let old_header = header.replace("bias_sums = false\n", "");
    assert_ne!(old_header, header, "the format 2 header names `bias_sums`");
    let rest = &bytes[20 + header_len..bytes.len() - 32]; // state length, state, sums
    let state_len = u64_at(20 + header_len);
    let mut digest = sha2::Sha256::new();
    digest.update(old_header.as_bytes());
    digest.update(&rest[8..8 + state_len]);
    digest.update(&rest[8 + state_len..]);
    let mut old = b"HAZEPART".to_vec();
    old.extend_from_slice(&1u32.to_le_bytes());
    old.extend_from_slice(&(old_header.len() as u64).to_le_bytes());
    old.extend_from_slice(old_header.as_bytes());
    old.extend_from_slice(rest);
    old.extend_from_slice(&digest.finalize());
    let v1 = dir.join("v1.hpr");
    std::fs::write(&v1, &old).unwrap();
    let q = Partial::read(&v1).unwrap();
    assert_eq!(q.film, p.film);
}

fn exr_pixels(path: &std::path::Path) -> Vec<[u32; 3]> {
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |size, _| vec![[0u32; 3]; size.width() * size.height()],
        |px: &mut Vec<[u32; 3]>, pos, (r, g, b, _): (f32, f32, f32, f32)| {
            let w = (px.len() as f64).sqrt() as usize;
            px[pos.y() * w + pos.x()] = [r.to_bits(), g.to_bits(), b.to_bits()];
        },
    )
    .unwrap();
    image.layer_data.channel_data.pixels
}

/// The command line: `--iterations A..B` pieces merged by `haze merge`, and a render resumed
/// with `--resume`, give the bits of one render.
#[test]
fn the_command_line_splits_merges_and_resumes_exactly() {
    let dir = temp_dir("cli-merge");
    let scene = scene_path("spotlight-fog.toml");
    let haze = |args: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_haze"))
            .arg("render")
            .arg(&scene)
            .args(["--resolution", "16x16", "-p", "2000", "-q"])
            .args(args)
            .current_dir(&dir)
            .output()
            .unwrap();
        assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    };
    haze(&["-n", "7", "-o", "whole.exr"]);
    haze(&["-n", "1..3", "-o", "a.hpr"]);
    haze(&["--iterations=4..7", "-o", "b.hpr"]);
    haze(&["-n", "1..2", "-o", "c.exr"]);
    assert!(dir.join("c.hpr").exists(), "a range from 1 keeps its partial beside the image");
    let o = Command::new(env!("CARGO_BIN_EXE_haze"))
        .args(["merge", "b.hpr", "a.hpr", "-o", "merged.exr"])
        .current_dir(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && err.contains("iterations 1..7"), "{err}");
    assert_eq!(exr_pixels(&dir.join("merged.exr")), exr_pixels(&dir.join("whole.exr")));
    haze(&["--resume", "a.hpr", "-n", "7", "-o", "resumed.exr"]);
    assert_eq!(exr_pixels(&dir.join("resumed.exr")), exr_pixels(&dir.join("whole.exr")));
    assert!(dir.join("resumed.hpr").exists(), "a resumed render keeps its partial");
}
