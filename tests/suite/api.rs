//! The library as a user meets it: scenes built in code are checked exactly as scene files are
//! (the same keys and messages, without a file), materials and media are found by name or id,
//! and a grid medium takes one call.

use haze::glam::Vec3;
use haze::progress::Silent;
use haze::scene::{
    CameraDesc, LightDesc, Material, MaterialId, MediumDesc, SceneBuilder, ShapeDesc,
};
use haze::settings::Integrator;
use haze::{Error, RenderSettings, Scene};
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// The error a scene with this camera gives, built in code.
fn camera_error(camera: CameraDesc) -> Error {
    let mut b = SceneBuilder::new(camera);
    b.material("grey", Material::diffuse(0.5)).unwrap();
    b.shape(ShapeDesc::rectangle(1.0, 1.0).material("grey")).unwrap();
    b.build().err().expect("the camera was accepted")
}

/// A scene file with this `[camera]` table.
fn camera_file_error(camera: &str) -> Error {
    let text = format!(
        "[camera]\n{camera}\nresolution = [8, 8]\n\n[materials.grey]\ntype = \"diffuse\"\nalbedo = 0.5\n\n[[shapes]]\ntype = \"rectangle\"\nmaterial = \"grey\"\n"
    );
    Scene::from_toml(&text, Path::new("cam.toml"), Path::new(".")).err().expect("accepted")
}

#[test]
fn code_built_cameras_are_checked_like_scene_files() {
    let cases = [
        (
            CameraDesc::perspective([0.0, 1.0, 2.0], [0.0, 1.0, 2.0], 40.0),
            "type = \"perspective\"\nposition = [0, 1, 2]\nlook_at = [0, 1, 2]\nfov = 40",
            "camera.look_at",
        ),
        (
            CameraDesc::perspective([0.0, 3.0, 0.0], [0.0, 0.0, 0.0], 40.0),
            "type = \"perspective\"\nposition = [0, 3, 0]\nlook_at = [0, 0, 0]\nfov = 40",
            "camera.up",
        ),
        (
            CameraDesc::perspective([0.0, 1.0, 2.0], [0.0, 0.0, 0.0], -10.0),
            "type = \"perspective\"\nposition = [0, 1, 2]\nlook_at = [0, 0, 0]\nfov = -10",
            "camera.fov",
        ),
        (
            CameraDesc::perspective([0.0, 1.0, 2.0], [0.0, 0.0, 0.0], f32::NAN),
            "type = \"perspective\"\nposition = [0, 1, 2]\nlook_at = [0, 0, 0]\nfov = nan",
            "camera.fov",
        ),
        (
            CameraDesc::orthographic([0.0, 1.0, 2.0], [0.0, 0.0, 0.0], 0.0),
            "type = \"orthographic\"\nposition = [0, 1, 2]\nlook_at = [0, 0, 0]\nheight = 0",
            "camera.height",
        ),
    ];
    for (desc, table, key) in cases {
        let desc = desc.resolution(8, 8);
        let (code, file) = (camera_error(desc).to_string(), camera_file_error(table).to_string());
        // In code: the key and the reason, nothing before them.
        assert!(code.starts_with(&format!("{key}: ")), "code: `{code}`");
        // From a file: the same, after the file and the line.
        assert_eq!(file, format!("cam.toml:1: {code}"), "file vs code for {key}");
    }
}

#[test]
fn materials_and_media_go_by_name_or_id() {
    let camera = CameraDesc::perspective([0.0, 1.0, 3.0], [0.0, 0.5, 0.0], 40.0).resolution(8, 6);
    let mut b = SceneBuilder::new(camera);
    let grey: MaterialId = b.material("grey", Material::diffuse([0.5, 0.4, 0.3])).unwrap();
    b.material("air", Material::Interface).unwrap();
    let fog = b.medium("fog", MediumDesc::homogeneous(0.1, 0.5).g(0.2)).unwrap();
    b.shape(ShapeDesc::rectangle(4.0, 4.0).material(grey).rotate([-90.0, 0.0, 0.0])).unwrap();
    b.shape(ShapeDesc::cuboid([1.0, 1.0, 1.0]).material("air").interior(fog)).unwrap();
    let err = b.shape(ShapeDesc::sphere(Vec3::ZERO, 1.0).material("gold")).unwrap_err();
    assert_eq!(
        err.to_string(),
        "shapes[2].material: undefined material `gold` (defined: `grey`, `air`)"
    );
    let err = b.shape(ShapeDesc::sphere(Vec3::ZERO, 1.0)).unwrap_err().to_string();
    assert!(err.starts_with("shapes[2].material: "), "{err}");
    let err = b.light(LightDesc::point([0.0, 2.0, 0.0], 10.0).medium("smoke")).unwrap_err();
    assert!(err.to_string().starts_with("lights[0].medium: undefined medium `smoke`"), "{err}");
    let err =
        b.light(LightDesc::spot([0.0, 2.0, 0.0], [0.0, 0.0, 0.0], 10.0, 30.0).falloff_start(40.0));
    assert!(err.unwrap_err().to_string().contains("falloff_start"));
    b.light(LightDesc::spot([0.0, 2.0, 0.0], [0.0, 0.0, 0.0], 10.0, 30.0).falloff_start(20.0))
        .unwrap();
    let scene = b.build().unwrap();
    assert_eq!((scene.shape_count(), scene.light_count()), (2, 1));
    assert_eq!(scene.medium_names(), ["fog"]);
}

/// A grid medium is one call; the render of a small smoke box in code comes out finite and lit.
#[test]
fn a_vdb_smoke_scene_builds_and_renders_in_code() {
    let cloud = Path::new(env!("CARGO_MANIFEST_DIR")).join("media/cloud.vdb");
    let camera = CameraDesc::perspective([0.0, 0.5, 4.0], [0.0, 0.0, 0.0], 35.0).resolution(24, 16);
    let mut b = SceneBuilder::new(camera);
    b.material("air", Material::Interface).unwrap();
    b.material("floor", Material::diffuse(0.6)).unwrap();
    let smoke = MediumDesc::vdb(&cloud).density_scale(4.0).albedo_extinction(0.9, 3.0).g(0.3);
    b.medium("smoke", smoke).unwrap();
    b.shape(ShapeDesc::cuboid([2.0, 2.0, 2.0]).material("air").interior("smoke")).unwrap();
    let floor = ShapeDesc::rectangle(8.0, 8.0).material("floor").rotate([-90.0, 0.0, 0.0]);
    b.shape(floor.translate([0.0, -1.0, 0.0])).unwrap();
    b.light(LightDesc::directional([0.3, -1.0, 0.2], 2.0)).unwrap();
    let scene = b.build().unwrap();
    let settings = RenderSettings { iterations: Some(2), photons: 5_000, ..scene.settings.clone() };
    let image = haze::render(&scene, &settings, &mut Silent, &AtomicBool::new(false)).unwrap();
    assert!(image.pixels.iter().flatten().all(|c| c.is_finite() && *c >= 0.0));
    assert!(image.mean() > 0.0);
    // A missing grid names the medium, the key and the file.
    let mut b = SceneBuilder::new(CameraDesc::perspective([0.0, 0.0, 3.0], Vec3::ZERO, 40.0));
    let err = b.medium("smoke", MediumDesc::vdb("no/such.vdb")).unwrap_err().to_string();
    assert!(err.starts_with("media.smoke.file: ") && err.contains("no/such.vdb"), "{err}");
}

/// The README's runnable code-built scene needs nothing of this repository (issue 38: it read
/// `CARGO_MANIFEST_DIR/media/cloud.vdb`, which in a user's crate is the user's): no manifest
/// directory, no path into `media/` or `scenes/`, its grid made in code. The doctest runs it;
/// CI builds and runs it as a user would, pasted into a crate outside the repository and run
/// from elsewhere (`tests/readme-snippet.sh` in `.ci/run`: a nested cargo build of about two
/// minutes, too long for the suite).
#[test]
fn the_readmes_code_built_scene_needs_nothing_of_the_repository() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let block = readme
        .split("```rust\n")
        .nth(1)
        .and_then(|b| b.split("```").next())
        .expect("the README's runnable rust block");
    assert!(block.contains("fn main") && block.contains("VoxelGrid::from_fn"), "{block}");
    for dependency in ["CARGO_MANIFEST_DIR", "media/", "scenes/", ".vdb", "include_"] {
        assert!(!block.contains(dependency), "the snippet uses `{dependency}`:\n{block}");
    }
    let ci = std::fs::read_to_string(root.join(".ci/run")).unwrap();
    assert!(ci.contains("tests/readme-snippet.sh"), ".ci/run does not build the snippet");
}

/// The default integrator (`auto`) is the combined integrator, or the hybrid where media emit,
/// and a render records the one that made it, not `auto`: the image's header and summary name
/// it. A choice made is kept.
#[test]
fn a_render_records_the_integrator_the_default_stood_for() {
    let scene = |medium: MediumDesc| {
        let camera = CameraDesc::perspective([0.0, 0.5, 4.0], [0.0, 0.0, 0.0], 35.0);
        let mut b = SceneBuilder::new(camera.resolution(12, 8));
        b.material("air", Material::Interface).unwrap();
        b.material("floor", Material::diffuse(0.6)).unwrap();
        b.medium("fog", medium).unwrap();
        b.shape(ShapeDesc::cuboid([1.0, 1.0, 1.0]).material("air").interior("fog")).unwrap();
        let floor = ShapeDesc::rectangle(8.0, 8.0).material("floor").rotate([-90.0, 0.0, 0.0]);
        b.shape(floor.translate([0.0, -1.0, 0.0])).unwrap();
        b.light(LightDesc::point([0.0, 2.0, 0.0], 20.0)).unwrap();
        b.build().unwrap()
    };
    let fog = MediumDesc::homogeneous(0.2, 0.5);
    let rendered = |scene: &Scene, integrator: Integrator| {
        let settings = RenderSettings {
            iterations: Some(1),
            photons: 500,
            integrator,
            ..scene.settings.clone()
        };
        let image = haze::render(scene, &settings, &mut Silent, &AtomicBool::new(false)).unwrap();
        image.info.settings.integrator
    };
    let (plain, glowing) = (scene(fog.clone()), scene(fog.emission(1.0)));
    assert_eq!(plain.settings.integrator, Integrator::Auto);
    assert_eq!(rendered(&plain, Integrator::Auto), Integrator::Combined);
    assert_eq!(rendered(&glowing, Integrator::Auto), Integrator::Hybrid);
    assert_eq!(rendered(&glowing, Integrator::Combined), Integrator::Combined);
    assert_eq!(rendered(&plain, Integrator::Path), Integrator::Path);
}
