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
        (vec!["render", scene, "-o", "out.png"], ".exr"),
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
