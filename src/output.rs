//! Rendered images and their files: OpenEXR (linear RGB, 32-bit float, with the render's metadata
//! in the header) and a tone-mapped sRGB PNG preview.

use crate::error::{Error, Result};
use crate::estimate::kernel::Kernel;
use crate::film::Film;
use std::path::{Path, PathBuf};

/// How an image was made; written into the EXR header as `haze:*` attributes.
#[derive(Clone, Debug)]
pub struct RenderInfo {
    /// Iterations averaged.
    pub iterations: u64,
    /// Light paths traced in total.
    pub light_paths: u64,
    /// Initial surface radius.
    pub initial_radius: f64,
    /// Surface radius of the last iteration.
    pub radius: f64,
    /// Radius reduction α.
    pub alpha: f64,
    /// Initial volume radius.
    pub volume_initial_radius: f64,
    /// Volume radius of the last iteration.
    pub volume_radius: f64,
    /// Radius reduction α of the volume schedule.
    pub volume_alpha: f64,
    /// Dimension of the volume schedule.
    pub volume_dimension: u32,
    /// Volume estimator.
    pub volume_estimate: crate::settings::VolumeEstimate,
    /// Integrator.
    pub integrator: crate::settings::Integrator,
    /// Kernel.
    pub kernel: Kernel,
    /// Seed.
    pub seed: u64,
    /// Seconds spent rendering.
    pub elapsed: f64,
    /// Scene file, if any.
    pub scene: Option<PathBuf>,
    /// Eye-path samples that came out non-finite and were replaced by black (should be 0).
    pub nonfinite_samples: u64,
}

/// A rendered image: linear RGB radiance, row-major, top row first.
#[derive(Clone, Debug)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Pixels.
    pub pixels: Vec<[f32; 3]>,
    /// How it was made.
    pub info: RenderInfo,
}

fn out_err(path: &Path, message: impl ToString) -> Error {
    Error::Output { path: path.to_path_buf(), message: message.to_string() }
}

/// Linear → sRGB transfer, clamped to [0, 1], as an 8-bit value.
fn srgb8(v: f32) -> u8 {
    let v = if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 };
    let s = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

impl Image {
    /// The mean of a film's iterations.
    pub fn from_film(film: &Film, info: RenderInfo) -> Self {
        Self { width: film.width(), height: film.height(), pixels: film.mean(), info }
    }

    /// Mean of every pixel and channel.
    pub fn mean(&self) -> f64 {
        let s: f64 = self.pixels.iter().map(|p| p.iter().map(|&c| c as f64).sum::<f64>()).sum();
        s / (3.0 * self.pixels.len() as f64)
    }

    /// Writes the OpenEXR file and, beside it, the PNG preview (same name, `.png`).
    pub fn write(&self, exr_path: &Path, exposure: f32) -> Result<PathBuf> {
        self.write_exr(exr_path)?;
        let png = exr_path.with_extension("png");
        self.write_png(&png, exposure)?;
        Ok(png)
    }

    /// Writes linear RGB f32 OpenEXR with the metadata as header attributes.
    pub fn write_exr(&self, path: &Path) -> Result<()> {
        use exr::meta::attribute::{AttributeValue, Text};
        use exr::prelude::*;
        let w = self.width as usize;
        let pixels = &self.pixels;
        let channels = SpecificChannels::rgb(|p: Vec2<usize>| {
            let [r, g, b] = pixels[p.y() * w + p.x()];
            (r, g, b)
        });
        let mut attrs = LayerAttributes::named("haze");
        attrs.software_name = Some(Text::from("haze"));
        let info = &self.info;
        let mut put = |k: &str, v: AttributeValue| {
            attrs.other.insert(Text::from(format!("haze:{k}").as_str()), v);
        };
        put("iterations", AttributeValue::Text(Text::from(info.iterations.to_string().as_str())));
        put("lightPaths", AttributeValue::Text(Text::from(info.light_paths.to_string().as_str())));
        put("radius", AttributeValue::F64(info.radius));
        put("initialRadius", AttributeValue::F64(info.initial_radius));
        put("alpha", AttributeValue::F64(info.alpha));
        put("volumeRadius", AttributeValue::F64(info.volume_radius));
        put("volumeInitialRadius", AttributeValue::F64(info.volume_initial_radius));
        put("volumeAlpha", AttributeValue::F64(info.volume_alpha));
        put("volumeDimension", AttributeValue::I32(info.volume_dimension as i32));
        put("volumeEstimate", AttributeValue::Text(Text::from(info.volume_estimate.name())));
        put("kernel", AttributeValue::Text(Text::from(info.kernel.name())));
        put("integrator", AttributeValue::Text(Text::from(info.integrator.name())));
        put("seed", AttributeValue::Text(Text::from(info.seed.to_string().as_str())));
        put("elapsedSeconds", AttributeValue::F64(info.elapsed));
        let scene = info.scene.as_ref().map(|p| p.display().to_string()).unwrap_or_default();
        // EXR text attributes are byte strings; keep the scene path if it is representable.
        if let Some(t) = Text::new_or_none(scene.as_str()) {
            put("scene", AttributeValue::Text(t));
        }
        let layer = Layer::new(
            (self.width as usize, self.height as usize),
            attrs,
            Encoding::SMALL_LOSSLESS,
            channels,
        );
        Image::from_layer(layer).write().to_file(path).map_err(|e| out_err(path, e))
    }

    /// Writes an 8-bit sRGB PNG after scaling by `exposure` and clamping.
    pub fn write_png(&self, path: &Path, exposure: f32) -> Result<()> {
        let file = std::fs::File::create(path).map_err(|e| out_err(path, e))?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = enc.write_header().map_err(|e| out_err(path, e))?;
        let data: Vec<u8> =
            self.pixels.iter().flat_map(|p| p.map(|c| srgb8(c * exposure))).collect();
        writer.write_image_data(&data).map_err(|e| out_err(path, e))?;
        writer.finish().map_err(|e| out_err(path, e))
    }
}
