//! # haze
//!
//! A progressive photon mapper for participating media, built on probabilistic progressive photon
//! mapping (Knaus & Zwicker, "Progressive Photon Mapping: A Probabilistic Approach", ACM TOG 30(3),
//! 2011): every iteration is an ordinary photon-mapping render whose radius depends only on the
//! iteration number, and the image is the mean of the iterations.
//!
//! A [`Scene`] comes from a TOML scene file ([`Scene::load`]; the format is `docs/scene-format.md`)
//! or from a [`SceneBuilder`] fed with descriptions that read like the file
//! ([`scene::describe`]). [`render`] takes the scene and [`RenderSettings`] (every setting and its
//! meaning: [`settings`]) and returns an [`Image`], reporting every iteration to a
//! [`progress::Progress`] callback; the library never prints. The `lab` module (feature `lab`, on
//! by default) holds the analytic references and the tools that check and measure the renderer.
//!
//! Relative file paths (an OpenVDB grid, an OBJ mesh) resolve against the scene file's directory
//! in a scene file, and against the working directory in a scene built in code; error messages
//! about such files say which.
//!
//! Rendering a scene file (paths are relative to the working directory):
//!
//! ```no_run
//! use haze::{Scene, render, progress::Status};
//! use std::sync::atomic::AtomicBool;
//!
//! let scene = Scene::load("scenes/cornell-box.toml")?;
//! let settings = haze::RenderSettings { iterations: Some(16), ..scene.settings.clone() };
//! let stop = AtomicBool::new(false); // raise it from another thread to stop early
//! let mut on_iteration = |s: &Status| eprintln!("iteration {}", s.iteration());
//! let image = render(&scene, &settings, &mut on_iteration, &stop)?;
//! image.write("cornell.exr".as_ref(), 1.0)?; // OpenEXR, and a PNG preview beside it
//! # Ok::<(), haze::Error>(())
//! ```
//!
//! A smoke box built in code: a cloud from an OpenVDB grid in a pass-through box over a floor,
//! under the sun.
//!
//! ```
//! use haze::scene::{CameraDesc, LightDesc, Material, MediumDesc, SceneBuilder, ShapeDesc};
//! use haze::{RenderSettings, progress::Silent};
//! use std::sync::atomic::AtomicBool;
//!
//! # let cloud = concat!(env!("CARGO_MANIFEST_DIR"), "/media/cloud.vdb");
//! let camera = CameraDesc::perspective([0.0, 0.5, 4.0], [0.0, 0.0, 0.0], 35.0).resolution(48, 32);
//! let mut b = SceneBuilder::new(camera);
//! b.material("air", Material::Interface)?;
//! b.material("floor", Material::diffuse(0.6))?;
//! // One call reads the grid: density × 4, albedo 0.9, extinction 3 per unit density.
//! b.medium("smoke", MediumDesc::vdb(cloud).density_scale(4.0).albedo_extinction(0.9, 3.0).g(0.3))?;
//! b.shape(ShapeDesc::cuboid([2.0, 2.0, 2.0]).material("air").interior("smoke"))?;
//! b.shape(ShapeDesc::rectangle(8.0, 8.0).material("floor").rotate([-90.0, 0.0, 0.0]).translate([0.0, -1.0, 0.0]))?;
//! b.light(LightDesc::directional([0.3, -1.0, 0.2], 2.0))?;
//! let scene = b.build()?;
//! let settings = RenderSettings { iterations: Some(2), photons: 20_000, ..RenderSettings::default() };
//! let image = haze::render(&scene, &settings, &mut Silent, &AtomicBool::new(false))?;
//! assert!(image.mean() > 0.0);
//! # Ok::<(), haze::Error>(())
//! ```
#![deny(unsafe_code)]
#![warn(missing_docs)]

mod accel;
mod atomic;
mod buffers;
mod choices;
mod dda;
pub mod error;
mod estimate;
pub mod film;
pub mod gridbench;
mod input;
mod integrator;
#[cfg(feature = "lab")]
pub mod lab;
mod math;
mod medium;
pub mod output;
pub mod partial;
mod photon;
mod plan;
pub mod progress;
#[cfg(feature = "python")]
mod python;
pub mod raybench;
mod region;
mod render;
mod rng;
pub mod scene;
pub mod settings;
#[cfg(test)]
mod testing;
mod work;

pub use error::{Error, Result};

/// Entry points for the fuzz targets (`fuzz/`) and the suite's corpus replay: each parser on
/// bytes in memory, as the loaders run it on a file's contents. Not a stable API.
#[doc(hidden)]
pub mod fuzzing {
    use std::path::Path;

    /// The scene parser and builder on scene text (file references resolve against a directory
    /// that does not exist, so they fail as missing files).
    pub fn scene(text: &str) -> crate::Result<()> {
        crate::Scene::from_toml(text, Path::new("fuzz.toml"), Path::new("/nonexistent")).map(|_| ())
    }

    /// The scene parser and builder on scene text whose files resolve against the repository's
    /// `media/` directory, so that grid keys (`extinction_grid`, `albedo_grid`,
    /// `emission_grid`, `temperature`) reach the grids they name.
    pub fn scene_with_media(text: &str) -> crate::Result<()> {
        let media = Path::new(env!("CARGO_MANIFEST_DIR")).join("media");
        crate::Scene::from_toml(text, &media.join("fuzz.toml"), &media).map(|_| ())
    }

    /// The partial-render reader (header, sums, checksum) on a file's bytes.
    pub fn partial(bytes: &[u8]) -> crate::Result<()> {
        crate::Partial::from_bytes(bytes, Path::new("fuzz.hpr")).map(|_| ())
    }

    /// The OBJ loader on a file's bytes, then the PLY loader on the same bytes.
    pub fn obj(bytes: &[u8]) -> crate::Result<()> {
        let ply = crate::scene::shape::ply_from_bytes(bytes, Path::new("fuzz.ply"));
        crate::scene::shape::obj_from_bytes(bytes, Path::new("fuzz.obj")).and(ply).map(|_| ())
    }

    /// The environment-map loader (OpenEXR header check, the exr crate, texel checks) on a
    /// file's bytes.
    pub fn envmap(bytes: &[u8]) -> crate::Result<()> {
        crate::scene::EnvMap::from_bytes(bytes, Path::new("fuzz.exr")).map(|_| ())
    }

    /// The OpenVDB loader (header check, vdb-rs on the header, haze's tree reader, checks, the
    /// copy) on a file's bytes: grid `density`, then component 1 of a vector grid `albedo`.
    pub fn vdb(bytes: &[u8]) -> crate::Result<()> {
        use crate::medium::grid::{DensityGrid, Layout};
        let path = Path::new("fuzz.vdb");
        let density = DensityGrid::from_bytes(bytes, path, "density");
        // The bricks layout too, which the automatic choice leaves to large sparse grids.
        let bricks = DensityGrid::from_bytes_with(bytes, path, "density", Layout::Bricks);
        DensityGrid::from_bytes(bytes, path, "albedo[1]")?;
        density.and(bricks).map(|_| ())
    }
}
/// The README's examples, compiled (and the runnable ones run) by `cargo test --doc`.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeExamples;

pub use glam;
pub use integrator::combined::budget::{Budget, Measured, Pilot};
pub use math::{RAY_EPSILON, Rgb};
pub use output::{Image, RenderInfo};
pub use partial::Partial;
pub use photon::guide::MIN_GAIN as PILOT_MIN_GAIN;
pub use plan::MIN_RADIUS_FRACTION;
pub use render::{
    MIN_TARGET_ITERATIONS, PILOT_PATHS, PhotonUsage, Start, light_path_budget, max_threads,
    memory_estimate, photon_usage, render, render_partial,
};
pub use scene::{Scene, SceneBuilder};
pub use settings::{RenderOptions, RenderSettings};

/// The radius schedule of probabilistic progressive photon mapping (Knaus & Zwicker 2011):
/// r_{i+1}^d / r_i^d = (i + α)/(i + 1), evaluated in f64 without stalling.
pub mod schedule {
    pub use crate::estimate::radius::{radius, radius_ratio};
}
