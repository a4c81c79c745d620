//! The `haze` binary: exit codes and one-line errors.

use crate::common::{scene_path, temp_dir};
use std::process::Command;

fn haze(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_haze")).args(args).output().unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn render_writes_exr_and_png() {
    let dir = temp_dir("cli-render");
    let out = dir.join("cb.exr");
    let scene = scene_path("cornell-box.toml");
    let (ok, err) = haze(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "-n",
        "2",
        "-p",
        "5000",
        "-j",
        "1",
        "-q",
    ]);
    assert!(ok, "{err}");
    assert!(out.exists() && dir.join("cb.png").exists());
    assert!(err.contains("2 iterations"), "{err}");
}

#[test]
fn bad_input_fails_with_a_one_line_reason() {
    let scene = scene_path("cornell-box.toml");
    let scene = scene.to_str().unwrap();
    for (args, needle) in [
        (vec!["render", "no-such-scene.toml"], "no-such-scene.toml"),
        (vec!["render", scene, "--alpha", "1.5"], "--alpha"),
        (vec!["render", scene, "--time", "soon"], "soon"),
        (vec!["render", scene, "--kernel", "gauss"], "gauss"),
        (vec!["render", scene, "-o", "out.tiff"], ".exr"),
        (vec!["render", scene, "--threads", "0"], "--threads"),
    ] {
        let (ok, err) = haze(&args);
        assert!(!ok, "{args:?} succeeded");
        assert!(err.contains(needle), "{args:?}: `{err}` lacks `{needle}`");
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    }
}

#[test]
fn help_explains_the_options() {
    let out = Command::new(env!("CARGO_BIN_EXE_haze")).args(["render", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    for flag in
        ["--iterations", "--time", "--photons", "--alpha", "--radius", "--seed", "--threads"]
    {
        assert!(help.contains(flag), "--help lacks {flag}");
    }
}

#[test]
fn ctrl_c_stops_cleanly_writes_the_image_so_far_and_exits_130() {
    let dir = temp_dir("cli-interrupt");
    let out = dir.join("partial.exr");
    let scene = scene_path("cornell-box.toml");
    let child = Command::new(env!("CARGO_BIN_EXE_haze"))
        .args(["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()])
        .args(["-n", "100000", "-p", "2000", "-q"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until iterations are certainly running (scene loading takes milliseconds).
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let killed = Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    assert!(killed.success());
    let output = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(130), "{err}");
    assert!(err.contains("(interrupted by SIGINT)"), "{err}");
    assert!(out.exists() && dir.join("partial.png").exists());
    let image = exr::prelude::read_first_rgba_layer_from_file(
        &out,
        |_, _| (),
        |_: &mut (), _, _: (f32, f32, f32, f32)| {},
    )
    .unwrap();
    match image
        .layer_data
        .attributes
        .other
        .get(&exr::meta::attribute::Text::from("haze:iterations"))
    {
        Some(exr::meta::attribute::AttributeValue::Text(t)) => {
            let n: u64 = t.to_string().parse().unwrap();
            assert!(n > 0 && n < 100_000, "{n} iterations");
        }
        other => panic!("{other:?}"),
    }
}
