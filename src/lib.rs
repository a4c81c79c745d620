//! # haze
//!
//! A progressive photon mapper for participating media, built on probabilistic progressive photon
//! mapping (Knaus & Zwicker, "Progressive Photon Mapping: A Probabilistic Approach", ACM TOG 30(3),
//! 2011): every iteration is an ordinary photon-mapping render whose radius depends only on the
//! iteration number, and the image is the mean of the iterations.
//!
//! The data flow mirrors the modules: a [`scene::Scene`] (loaded from TOML or built with
//! [`scene::SceneBuilder`]) → per iteration a photon pass ([`photon`]) and a photon map → a camera
//! pass ([`integrator::camera`]) with the radiance estimates of [`estimate`] → a [`film::Film`]
//! holding the running mean → an [`output::Image`] written as OpenEXR and PNG.
//!
//! ```no_run
//! use haze::{Scene, render, progress::Status};
//! use std::sync::atomic::AtomicBool;
//!
//! let scene = Scene::load("scenes/cornell-box.toml")?;
//! let mut settings = scene.settings.clone();
//! settings.iterations = Some(16);
//! let stop = AtomicBool::new(false);
//! let mut on_iteration = |s: &Status| eprintln!("iteration {}", s.iteration());
//! let image = render(&scene, &settings, &mut on_iteration, &stop)?;
//! image.write("cornell.exr".as_ref(), 1.0)?;
//! # Ok::<(), haze::Error>(())
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod accel;
mod dda;
pub mod error;
mod estimate;
pub mod film;
mod integrator;
#[cfg(feature = "lab")]
pub mod lab;
mod math;
mod medium;
pub mod output;
mod photon;
pub mod progress;
mod render;
mod rng;
pub mod scene;
pub mod settings;
#[cfg(test)]
mod testing;

pub use error::{Error, Result};
pub use glam;
pub use math::{RAY_EPSILON, Rgb};
pub use output::{Image, RenderInfo};
pub use render::render;
pub use scene::{Scene, SceneBuilder};
pub use settings::{RenderOptions, RenderSettings};

/// The radius schedule of probabilistic progressive photon mapping (Knaus & Zwicker 2011):
/// r_{i+1}^d / r_i^d = (i + α)/(i + 1), evaluated in f64 without stalling.
pub mod schedule {
    pub use crate::estimate::radius::{radius, radius_ratio};
}
