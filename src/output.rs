//! Rendered images and their files: OpenEXR (linear RGB, 32-bit float, with the render's metadata
//! in the header) and a tone-mapped sRGB PNG preview. Every file is written atomically
//! ([`write_atomically`]): a temporary file beside the target, renamed over it when complete.

pub use crate::atomic::{check_writable, write_atomically, write_bytes};
use crate::error::{Error, Result};
use crate::film::Film;
pub use crate::region::{NOISIEST_SHARE, Region};
use crate::settings::{Integrator, RenderSettings};
use std::path::{Path, PathBuf};

/// How an image was made; written into the EXR header as `haze:*` attributes (the settings as
/// `haze:render.KEY`, in the scene file's syntax).
#[derive(Clone, Debug)]
pub struct RenderInfo {
    /// The settings it was rendered with.
    pub settings: RenderSettings,
    /// The first iteration (1 unless the render covered a later range of iterations).
    pub first_iteration: u64,
    /// Iterations averaged (the range `first_iteration ..= first_iteration + iterations − 1`).
    pub iterations: u64,
    /// Light paths traced in total.
    pub light_paths: u64,
    /// Initial surface radius, in scene units.
    pub initial_radius: f64,
    /// Surface radius of the last iteration.
    pub radius: f64,
    /// Initial volume radius, in scene units.
    pub volume_initial_radius: f64,
    /// Volume radius of the last iteration.
    pub volume_radius: f64,
    /// Seconds spent rendering.
    pub elapsed: f64,
    /// Scene file, if any.
    pub scene: Option<PathBuf>,
    /// Eye-path samples that came out non-finite and were replaced by black (should be 0).
    pub nonfinite_samples: u64,
    /// Trackings through VDB media cut at their step cap (2¹⁸ tentative collisions on one
    /// segment) and treated as opaque: a biased darkening, zero in any sensible medium; a
    /// non-zero count means the medium's extinction is too high for its grid (see
    /// docs/scene-format.md).
    pub truncated_trackings: u64,
}

/// The variance of the sum of a pixel's three channels whose per-channel variances are `v`,
/// taken as fully correlated (they come from the same paths): (Σ_c √v_c)².
pub(crate) fn channel_sum_variance(v: [f32; 3]) -> f64 {
    v.iter().map(|&c| (c as f64).sqrt()).sum::<f64>().powi(2)
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
    /// Each pixel's estimated variance of the mean over the iterations (see
    /// [`Film::variance_of_mean`]), written as the EXR layer `variance`; `None` where there is
    /// no estimate (fewer than two iterations, or the original PPM's running statistics).
    pub variance: Option<Vec<[f32; 3]>>,
    /// Each pixel's estimated kernel bias ([`Film::bias`]): photon mapping's images, written as
    /// the EXR layer `bias`; `None` for the path tracer (no kernel, no bias).
    pub bias: Option<Vec<[f32; 3]>>,
    /// The variance of the bias estimate ([`Film::bias_variance`]), the EXR layer
    /// `bias_variance`; `None` where `variance` is.
    pub bias_variance: Option<Vec<[f32; 3]>>,
    /// With `techniques` on (the combined integrator): each technique's weighted contribution,
    /// named, written as the EXR layers `technique_NAME`; they sum to `pixels`.
    pub techniques: Option<Vec<(String, Vec<[f32; 3]>)>>,
    /// How it was made.
    pub info: RenderInfo,
}

fn out_err(path: &Path, message: impl ToString) -> Error {
    Error::Output { path: path.to_path_buf(), message: message.to_string() }
}

/// A path's extension, lower case.
fn extension(path: &Path) -> Option<String> {
    path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase)
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
        let noisy = film.iterations() >= 2
            && info.settings.progression == crate::settings::Progression::Probabilistic;
        Self {
            width: film.width(),
            height: film.height(),
            pixels: film.mean(),
            variance: noisy.then(|| film.variance_of_mean()),
            bias: (film.iterations() >= 1).then(|| film.bias()).flatten(),
            bias_variance: noisy.then(|| film.bias_variance()).flatten(),
            techniques: None,
            info,
        }
    }

    /// The image's estimated relative error from its layers: the figure
    /// [`Film::error_estimate`] gives for the film it came from, at `confidence`, over
    /// `region` (or the whole image). `None` without a variance layer (below two iterations).
    pub fn error_estimate(
        &self,
        confidence: f64,
        region: Option<Region>,
    ) -> Option<crate::film::ErrorEstimate> {
        let layers = crate::film::ErrorLayers {
            mean: &self.pixels,
            variance: self.variance.as_deref()?,
            bias: self.bias.as_deref(),
            bias_variance: self.bias_variance.as_deref(),
            iterations: self.info.iterations,
            size: (self.width, self.height),
        };
        layers.estimate(confidence, region)
    }

    /// The estimated kernel bias of the image relative to its mean, over `region` (or the whole
    /// image): Σ b / Σ m over the region's pixels and channels, b the bias layer, with its
    /// standard error from the bias estimate's variance (pixels independent). `None` without a
    /// bias layer or on a black image.
    pub fn relative_bias(&self, region: Option<Region>) -> Option<(f64, Option<f64>)> {
        let bias = self.bias.as_ref()?;
        let (mut sum, mut b, mut var) = (0.0f64, 0.0f64, 0.0f64);
        for i in self.region_pixels(region) {
            sum += self.pixels[i].iter().map(|&c| c as f64).sum::<f64>();
            b += bias[i].iter().map(|&c| c as f64).sum::<f64>();
            if let Some(v) = &self.bias_variance {
                var += channel_sum_variance(v[i]);
            }
        }
        let se = self.bias_variance.as_ref().map(|_| var.sqrt() / sum);
        (sum > 0.0).then(|| (b / sum, se))
    }

    /// The indices of the pixels of `region` (or of the whole image).
    fn region_pixels(&self, region: Option<Region>) -> impl Iterator<Item = usize> + use<> {
        let (w, h) = (self.width, self.height);
        region.unwrap_or(Region::whole(w, h)).indices(w, h)
    }

    /// The estimated noise of the image relative to its mean, over `region` (or the whole
    /// image): √(mean v) / m, with v each pixel's and channel's estimated variance of the mean
    /// and m the mean value — the relative RMSE the noise alone would give, as `haze converge`
    /// measures errors — over the pixels [`Region::counted`] keeps: the 0.1 % noisiest are left
    /// out (docs/error.md). `None` without a variance estimate or on a black image.
    pub fn relative_noise(&self, region: Option<Region>) -> Option<f64> {
        let variance = self.variance.as_ref()?;
        let (mut sum, mut var, mut n) = (0.0f64, 0.0f64, 0.0f64);
        let (w, h) = (self.width, self.height);
        let pixel_variance = |i: usize| variance[i].iter().map(|&c| c as f64).sum::<f64>();
        for i in region.unwrap_or(Region::whole(w, h)).counted(w, h, pixel_variance) {
            sum += self.pixels[i].iter().map(|&c| c as f64).sum::<f64>();
            var += variance[i].iter().map(|&c| c as f64).sum::<f64>();
            n += 3.0;
        }
        (n > 0.0 && sum > 0.0).then(|| (var / n).sqrt() / (sum / n))
    }

    /// Mean of every pixel and channel.
    pub fn mean(&self) -> f64 {
        let s: f64 = self.pixels.iter().map(|p| p.iter().map(|&c| c as f64).sum::<f64>()).sum();
        s / (3.0 * self.pixels.len() as f64)
    }

    /// Writes the image in the format its extension names, and returns the files written:
    /// `.exr` writes the OpenEXR file and, beside it, a PNG preview (same name, `.png`, scaled by
    /// `exposure`); `.png` writes only the preview. Any other extension is refused.
    pub fn write(&self, path: &Path, exposure: f32) -> Result<Vec<PathBuf>> {
        match extension(path).as_deref() {
            Some("exr") => self.write_with_preview(path, exposure, false),
            Some("png") => {
                self.write_png(path, exposure)?;
                Ok(vec![path.to_path_buf()])
            }
            _ => Err(out_err(
                path,
                "unknown image format: name the file .exr (OpenEXR, with a PNG preview beside it) or .png",
            )),
        }
    }

    /// Writes linear RGB f32 OpenEXR with the metadata as header attributes.
    pub fn write_exr(&self, path: &Path) -> Result<()> {
        self.write_exr_with(path, false)
    }

    /// Writes the image as a reference for `haze converge`: the OpenEXR file of
    /// [`Self::write_exr`] (with its `variance` layer, which `haze converge` subtracts from its
    /// squared errors for path-traced references) and the attribute `haze:reference` saying how
    /// it was made. Also writes the PNG preview.
    pub fn write_reference(&self, exr_path: &Path, exposure: f32) -> Result<Vec<PathBuf>> {
        if extension(exr_path).as_deref() != Some("exr") {
            return Err(out_err(exr_path, "a reference is an OpenEXR file: name it .exr"));
        }
        self.write_with_preview(exr_path, exposure, true)
    }

    /// Writes the OpenEXR file (a reference's with `reference`) and its PNG preview beside it.
    /// The OpenEXR file is compressed and written on every thread; the preview is encoded and
    /// written while the OpenEXR file is synced to disk (a wait of milliseconds on one thread);
    /// both are put in place only once both are written and synced, so that a failure of either
    /// leaves both files as they were. Returns the two files' paths.
    fn write_with_preview(
        &self,
        path: &Path,
        exposure: f32,
        reference: bool,
    ) -> Result<Vec<PathBuf>> {
        let mut exr = self.stage_exr(path, reference)?;
        let png_path = preview_path(path);
        let preview = || {
            let mut staged =
                crate::atomic::stage_bytes(&png_path, &self.encode_png(&png_path, exposure)?)?;
            staged.sync()?;
            Ok(staged)
        };
        let (synced, png) = rayon::join(|| exr.sync(), preview);
        synced?;
        crate::atomic::commit(vec![exr, png?])?;
        Ok(vec![path.to_path_buf(), png_path])
    }

    /// How a reference was made, as its `haze:reference` attribute says.
    pub fn reference_description(&self) -> String {
        let i = &self.info;
        let method = match i.settings.integrator {
            Integrator::Path => "path tracer (unbiased)".to_string(),
            // A render records the integrator `auto` stood for; only a hand-made header has it.
            Integrator::Auto => "the default integrator (consistent, not unbiased)".to_string(),
            Integrator::Combined => format!(
                "combined estimator ({} light paths, final radius {:.3e}, volume radius {:.3e}; consistent, not unbiased)",
                i.light_paths, i.radius, i.volume_radius
            ),
            Integrator::PhotonMapping | Integrator::Hybrid => format!(
                "{} ({} volume estimate, {} light paths, final radius {:.3e}, volume radius {:.3e}; consistent, not unbiased)",
                if i.settings.integrator == Integrator::Hybrid {
                    "hybrid"
                } else {
                    "photon mapping"
                },
                i.settings.volume_estimate,
                i.light_paths,
                i.radius,
                i.volume_radius
            ),
        };
        format!(
            "haze reference: {method}, {} iterations, seed {}, {:.0} s",
            i.iterations, i.settings.seed, i.elapsed
        )
    }

    /// The EXR layers beside the image, with the note each carries: the noise estimate, the
    /// kernel bias and its variance, and the combined integrator's technique layers.
    fn extra_layers(&self) -> Vec<(String, &[[f32; 3]], &'static str)> {
        let mut out: Vec<(String, &[[f32; 3]], &'static str)> = Vec::new();
        // Every render carries its noise estimate. Only the path tracer's iterations are
        // identically distributed; photon-mapping iterations drift as the radius shrinks, so
        // their spread also counts that drift (a slight overstatement of the noise), and
        // `haze converge` uses the layer of path-traced references only.
        if let Some(variance) = &self.variance {
            let note = match self.info.settings.integrator {
                Integrator::Path => {
                    "estimated variance of the mean per pixel: the sample variance of the iterations / their count"
                }
                _ => {
                    "estimated variance of the mean per pixel: the sample variance of the iterations / their count (photon mapping: includes the drift of the iterations' means as the radius shrinks)"
                }
            };
            out.push(("variance".into(), variance, note));
        }
        if let Some(bias) = &self.bias {
            out.push(("bias".into(), bias, "estimated kernel bias per pixel (expected value minus limit): the mean of the iterations' 2 (L_r - L_{r/sqrt 2}), docs/theory.md"));
        }
        if let Some(v) = &self.bias_variance {
            out.push(("bias_variance".into(), v, "estimated variance of the bias layer: the sample variance of the iterations' bias estimates / their count"));
        }
        for (name, data) in self.techniques.iter().flatten() {
            out.push((format!("technique_{name}"), data, "one technique's contribution to the image, weighted by multiple importance sampling (the combined integrator): the technique layers sum to the image"));
        }
        out
    }

    fn write_exr_with(&self, path: &Path, reference: bool) -> Result<()> {
        crate::atomic::commit(vec![self.stage_exr(path, reference)?])
    }

    /// The OpenEXR file of [`Self::write_exr_with`], written beside `path` but not yet synced
    /// nor in place ([`crate::atomic::stage`]).
    fn stage_exr(&self, path: &Path, reference: bool) -> Result<crate::atomic::Staged> {
        let image = self.exr_image(reference);
        crate::atomic::stage(path, |w| {
            write_exr_blocks(w, &image.layer_data, &image.attributes).map_err(|e| e.to_string())
        })
    }

    /// The image as the exr crate writes it: its layers, each with its note, the first with the
    /// render's settings and figures (and with `reference`, how the reference was made).
    fn exr_image(&self, reference: bool) -> ExrImage<'_> {
        use exr::meta::attribute::{AttributeValue, Text};
        use exr::prelude::*;
        let w = self.width as usize;
        let size = (self.width as usize, self.height as usize);
        let text = |v: &str| AttributeValue::Text(Text::new_or_none(v).unwrap_or_default());
        let layer = |name: &str, data, note: Option<&str>| -> RgbLayer<'_> {
            let mut attrs = LayerAttributes::named(name);
            if let Some(note) = note {
                attrs.other.insert(Text::from(format!("haze:{name}").as_str()), text(note));
            }
            let channels = SpecificChannels::rgb(Plane { data, width: w });
            Layer::new(size, attrs, ENCODING, channels)
        };
        let mut main = layer("haze", &self.pixels, None);
        let attrs = &mut main.attributes;
        attrs.software_name = Some(Text::from("haze"));
        let info = &self.info;
        let mut put = |k: &str, v: AttributeValue| {
            attrs.other.insert(Text::from(format!("haze:{k}").as_str()), v);
        };
        for (key, value) in info.settings.entries() {
            put(&format!("render.{key}"), text(&value));
        }
        put("iterations", text(&info.iterations.to_string()));
        put("firstIteration", text(&info.first_iteration.to_string()));
        put("lightPaths", text(&info.light_paths.to_string()));
        put("radius", AttributeValue::F64(info.radius));
        put("initialRadius", AttributeValue::F64(info.initial_radius));
        put("volumeRadius", AttributeValue::F64(info.volume_radius));
        put("volumeInitialRadius", AttributeValue::F64(info.volume_initial_radius));
        put("elapsedSeconds", AttributeValue::F64(info.elapsed));
        put("nonfiniteSamples", text(&info.nonfinite_samples.to_string()));
        put("truncatedTrackings", text(&info.truncated_trackings.to_string()));
        let scene = info.scene.as_ref().map(|p| p.display().to_string()).unwrap_or_default();
        // EXR text attributes are byte strings; keep the scene path if it is representable.
        if let Some(t) = Text::new_or_none(scene.as_str()) {
            put("scene", AttributeValue::Text(t));
        }
        if reference {
            put("reference", text(&self.reference_description()));
        }
        let mut layers = vec![main];
        for (name, data, note) in self.extra_layers() {
            layers.push(layer(&name, data, Some(note)));
        }
        let bounds = exr::math::Vec2(size.0, size.1);
        Image::from_layers(ImageAttributes::new(IntegerBounds::from_dimensions(bounds)), layers)
    }

    /// Writes an 8-bit sRGB PNG after scaling by `exposure` and clamping, marked as haze's
    /// (text chunk `Software` = `haze`, which [`is_haze_preview`] looks for).
    pub fn write_png(&self, path: &Path, exposure: f32) -> Result<()> {
        crate::atomic::write_bytes(path, &self.encode_png(path, exposure)?)
    }

    /// The PNG file of [`Self::write_png`], in memory, or the error of `path` not written
    /// because it could not be encoded.
    fn encode_png(&self, path: &Path, exposure: f32) -> Result<Vec<u8>> {
        // In parallel: 3.6 ms on one thread for the cumulus's 640 × 400 pixels.
        use rayon::prelude::*;
        let mut data = vec![0u8; 3 * self.pixels.len()];
        let srgb = |(out, p): (&mut [u8], &[f32; 3])| {
            out.copy_from_slice(&p.map(|c| srgb8(c * exposure)));
        };
        data.par_chunks_mut(3).zip(&self.pixels).with_min_len(1 << 12).for_each(srgb);
        let mut bytes = Vec::new();
        let mut enc = png::Encoder::new(&mut bytes, self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        // The preview is encoded on one thread while the OpenEXR file syncs: the png
        // crate's fast mode (fdeflate) encoded cornell-fog's 384×384 preview in
        // 1.1 ms against 36 ms (its default), 7 % larger (cumulus, noisier: 1.0 against 15 ms,
        // 34 % larger). The pixels are the same.
        enc.set_compression(png::Compression::Fast);
        let failed = |e: png::EncodingError| out_err(path, format!("not written: {e}"));
        enc.add_text_chunk("Software".into(), "haze".into()).map_err(failed)?;
        let mut writer = enc.write_header().map_err(failed)?;
        writer.write_image_data(&data).map_err(failed)?;
        writer.finish().map_err(failed)?;
        Ok(bytes)
    }
}

/// How the OpenEXR layers are stored: run-length encoded scan lines. A render's float noise
/// leaves little for any lossless compression: four layers of cornell-fog (384 × 384, 4
/// iterations) took 178 ms to write as ZIP16 (zlib over 16 lines, 7.02 MB) on one thread and 12
/// ms as RLE (7.11 MB, 1.4 % larger); vdb-cloud 184 and 17 ms (6.23 and 6.39 MB, 2.6 %), the
/// cumulus 159 and 17 ms (5.20 and 5.37 MB, 3.2 %). Every OpenEXR reader reads both.
const ENCODING: exr::image::Encoding = exr::image::Encoding {
    compression: exr::compression::Compression::RLE,
    blocks: exr::image::Blocks::ScanLines,
    line_order: exr::meta::attribute::LineOrder::Increasing,
};

/// The channels of an OpenEXR layer: an RGB plane …
type RgbChannels<'a> = exr::image::SpecificChannels<Plane<'a>, exr::image::RgbChannels>;

/// … a layer …
type RgbLayer<'a> = exr::image::Layer<RgbChannels<'a>>;

/// … and the image of [`Image::exr_image`].
type ExrImage<'a> = exr::image::Image<exr::image::Layers<RgbChannels<'a>>>;

/// Writes an OpenEXR file of `layers` to `out`, its blocks' bytes gathered and compressed in
/// parallel on the render's threads and written in order: the same bytes as the exr crate's own
/// writer on one thread (tested), which gathers every block's bytes on the calling thread, and in
/// parallel compresses them on a pool it builds anew for every file (the cumulus's four layers,
/// run-length encoded: 17 ms on one thread, 43 ms on that pool of two). The blocks go in
/// [`EXR_BATCHES`] batches, each written while the next is compressed, so that the writing (a
/// copy of the file into the system's cache: 4–6 ms on one thread for the cumulus's 5.4 MB) does
/// not wait for the last block; the writing thread joins the compression once it has written its
/// batch. The compressed blocks of two batches are held at a time.
fn write_exr_blocks<'l, L: exr::image::write::layers::WritableLayers<'l>>(
    out: impl std::io::Write + std::io::Seek + Send,
    layers: &'l L,
    attributes: &exr::meta::header::ImageAttributes,
) -> exr::error::UnitResult {
    use exr::block::chunk::Chunk;
    use exr::block::writer::ChunksWriter;
    use exr::image::write::layers::LayersWriter;
    use rayon::prelude::*;
    let headers = layers.infer_headers(attributes);
    let writer = layers.create_writer(&headers);
    exr::block::write(out, headers, true, |meta, chunks| {
        let blocks: Vec<_> = meta.enumerate_ordered_header_block_indices().collect();
        let compress = |batch: &[(usize, exr::block::BlockIndex)]| {
            let one = |&(at, index): &(usize, exr::block::BlockIndex)| {
                let data = writer.extract_uncompressed_block(&meta.headers, index);
                let block = exr::block::UncompressedBlock { index, data };
                block.compress_to_chunk(&meta.headers).map(|chunk| (at, chunk))
            };
            let mut out = Vec::with_capacity(batch.len());
            batch.par_iter().with_min_len(8).map(one).collect_into_vec(&mut out);
            out
        };
        let mut write = |batch: Vec<exr::error::Result<(usize, Chunk)>>| -> exr::error::UnitResult {
            for block in batch {
                let (at, chunk) = block?;
                chunks.write_chunk(at, chunk)?;
            }
            Ok(())
        };
        let mut batches = blocks.chunks(blocks.len().div_ceil(EXR_BATCHES).max(1));
        let mut ready = batches.next().map(compress).unwrap_or_default();
        for next in batches {
            let (written, compressed) = rayon::join(|| write(ready), || compress(next));
            written?;
            ready = compressed;
        }
        write(ready)
    })
}

/// The batches [`write_exr_blocks`] compresses and writes an OpenEXR file's blocks in.
const EXR_BATCHES: usize = 16;

/// One RGB plane of an image, as the OpenEXR writer reads it.
struct Plane<'a> {
    data: &'a [[f32; 3]],
    width: usize,
}

impl exr::image::write::channels::GetPixel for Plane<'_> {
    type Pixel = (f32, f32, f32);
    fn get_pixel(&self, p: exr::math::Vec2<usize>) -> (f32, f32, f32) {
        let [r, g, b] = self.data[p.y() * self.width + p.x()];
        (r, g, b)
    }
}

/// The PNG preview written beside an OpenEXR file by [`Image::write`]: the same name, `.png`.
pub fn preview_path(exr: &Path) -> PathBuf {
    exr.with_extension("png")
}

/// True if `path` is a PNG file haze wrote (it carries the text chunk `Software` = `haze`).
/// Used to refuse overwriting an unrelated PNG that happens to sit beside an EXR output.
pub fn is_haze_preview(path: &Path) -> bool {
    let Ok(file) = std::fs::File::open(path) else { return false };
    let Ok(reader) = png::Decoder::new(std::io::BufReader::new(file)).read_info() else {
        return false;
    };
    let info = reader.info();
    info.uncompressed_latin1_text.iter().any(|t| t.keyword == "Software" && t.text == "haze")
}

#[cfg(test)]
mod noisiest_tests {
    use super::*;

    /// The pixels the noise figures count: all of them below 1,000 pixels; from 1,000 on, all
    /// but the 0.1 % with the largest variance — exactly those, whatever their order.
    #[test]
    fn the_noisiest_thousandth_of_the_pixels_is_left_out() {
        let (w, h) = (50u32, 40u32);
        // Pixels 17 and 1,500 are the noisiest; the rest rise slowly with their index.
        let var = |i: usize| match i {
            17 => 1e9,
            1500 => 1e6,
            _ => i as f64,
        };
        let kept: Vec<usize> = Region::whole(w, h).counted(w, h, var).collect();
        assert_eq!(kept.len(), 1998);
        assert!(!kept.contains(&17) && !kept.contains(&1500) && kept.contains(&1999));
        assert!(kept.windows(2).all(|p| p[0] < p[1]), "kept in pixel order");
        let small = Region { x0: 0, y0: 0, x1: 30, y1: 30 };
        assert_eq!(small.counted(w, h, var).count(), 900);
    }
}

#[cfg(test)]
mod error_tests {
    use super::*;

    /// An image's error estimate from its layers is its film's, with and without bias sums and
    /// over a region.
    #[test]
    fn an_images_error_estimate_is_its_films() {
        let (w, h) = (40u32, 30u32);
        for with_bias in [false, true] {
            let mut film = if with_bias { Film::with_bias(w, h) } else { Film::new(w, h) };
            for k in 0..5u32 {
                let value = |i: usize, c: usize| {
                    let x =
                        (i as u32).wrapping_mul(2_654_435_761).wrapping_add(k * 97 + c as u32 * 13);
                    glam::Vec3::splat(0.5 + (x % 1000) as f32 / 1000.0)
                };
                let image: Vec<_> = (0..(w * h) as usize).map(|i| value(i, 0)).collect();
                let bias: Vec<_> = (0..(w * h) as usize).map(|i| value(i, 1) * 0.01).collect();
                film.add_with_bias(&image, &bias);
            }
            let info = RenderInfo {
                settings: RenderSettings { target_confidence: 0.9, ..RenderSettings::default() },
                first_iteration: 1,
                iterations: film.iterations(),
                light_paths: 0,
                initial_radius: 0.0,
                radius: 0.0,
                volume_initial_radius: 0.0,
                volume_radius: 0.0,
                elapsed: 0.0,
                scene: None,
                nonfinite_samples: 0,
                truncated_trackings: 0,
            };
            let image = Image::from_film(&film, info);
            let region = Some(Region { x0: 3, y0: 4, x1: 20, y1: 25 });
            for r in [None, region] {
                let (a, b) =
                    (image.error_estimate(0.9, r).unwrap(), film.error_estimate(0.9, r).unwrap());
                assert_eq!((a.relative_rmse, a.upper), (b.relative_rmse, b.upper));
            }
        }
    }
}

#[cfg(test)]
mod file_tests {
    use super::*;
    use crate::film::Film;
    use crate::settings::RenderSettings;

    /// How a render of `iterations` iterations with the default settings was made.
    fn info(iterations: u64) -> RenderInfo {
        RenderInfo {
            settings: RenderSettings::default(),
            first_iteration: 1,
            iterations,
            light_paths: 1000,
            initial_radius: 0.1,
            radius: 0.05,
            volume_initial_radius: 0.2,
            volume_radius: 0.1,
            elapsed: 1.5,
            scene: None,
            nonfinite_samples: 0,
            truncated_trackings: 0,
        }
    }

    /// The PNG preview holds exactly the sRGB bytes of the scaled and clamped pixels (fast
    /// compression is lossless), and the mark `is_haze_preview` looks for; smooth and noisy
    /// pixels, and pixels beyond 1 and below 0.
    #[test]
    fn the_preview_holds_the_pixels_it_was_given() {
        let (w, h) = (64u32, 48u32);
        let mut film = Film::new(w, h);
        let pixel = |i: usize| {
            let noise = (i as u32).wrapping_mul(2_654_435_761) % 1000;
            let ramp = (i % w as usize) as f32 / w as f32;
            glam::Vec3::new(ramp, noise as f32 / 500.0, 0.3 - ramp)
        };
        film.add(&(0..(w * h) as usize).map(pixel).collect::<Vec<_>>());
        let image = Image::from_film(&film, info(1));
        let exposure = 1.5;
        let dir = crate::testing::temp_dir("preview");
        let path = dir.join("p.png");
        image.write_png(&path, exposure).unwrap();
        assert!(is_haze_preview(&path));
        let file = std::io::BufReader::new(std::fs::File::open(&path).unwrap());
        let mut reader = png::Decoder::new(file).read_info().unwrap();
        let mut got = vec![0; reader.output_buffer_size().unwrap()];
        let frame = reader.next_frame(&mut got).unwrap();
        assert_eq!((frame.width, frame.height, frame.color_type), (w, h, png::ColorType::Rgb));
        let want: Vec<u8> =
            image.pixels.iter().flat_map(|p| p.map(|c| srgb8(c * exposure))).collect();
        assert!(want.contains(&255) && want.contains(&0));
        assert!(got[..frame.buffer_size()] == want[..], "the preview's pixels differ");
    }

    /// An image whose preview cannot be written leaves both of the files it would replace as
    /// they were (the OpenEXR file is put in place only with its preview), and no temporary file.
    #[test]
    fn a_preview_that_cannot_be_written_leaves_both_files_as_they_were() {
        let (w, h) = (16u32, 8u32);
        let image = |v: f32| {
            let mut film = Film::new(w, h);
            film.add(&vec![glam::Vec3::splat(v); (w * h) as usize]);
            film.add(&vec![glam::Vec3::splat(v * 0.5); (w * h) as usize]);
            Image::from_film(&film, info(2))
        };
        let dir = crate::testing::temp_dir("preview-fails");
        let exr = dir.join("x.exr");
        assert_eq!(image(0.25).write(&exr, 1.0).unwrap(), [exr.clone(), dir.join("x.png")]);
        let before = std::fs::read(&exr).unwrap();
        // The preview's place taken by a directory.
        std::fs::remove_file(dir.join("x.png")).unwrap();
        std::fs::create_dir(dir.join("x.png")).unwrap();
        let e = image(0.75).write(&exr, 1.0).unwrap_err().to_string();
        assert!(e.contains("x.png") && e.contains("is a directory"), "{e}");
        assert!(std::fs::read(&exr).unwrap() == before, "the OpenEXR file changed");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2, "a temporary file was left");
    }

    /// The OpenEXR file's bytes, blocks compressed in parallel, are the exr crate's own writer's
    /// on one thread, whatever the thread count: four layers of noisy pixels, zeros among them.
    #[test]
    fn exr_blocks_written_in_parallel_are_the_exr_crates_own() {
        use exr::prelude::WritableImage;
        let (w, h) = (37u32, 29u32);
        let mut film = Film::with_bias(w, h);
        for k in 0..3u32 {
            let value = |i: usize| {
                let x = (i as u32).wrapping_mul(2_654_435_761).wrapping_add(k * 977);
                let v = if i % 7 == 0 { 0.0 } else { (x % 1000) as f32 / 100.0 };
                glam::Vec3::new(v, v * 0.5, 1.0 / (1.0 + v))
            };
            let image: Vec<_> = (0..(w * h) as usize).map(value).collect();
            let bias: Vec<_> = image.iter().map(|v| *v * 0.01).collect();
            film.add_with_bias(&image, &bias);
        }
        let image = Image::from_film(&film, info(3));
        let exr = image.exr_image(true);
        assert_eq!(exr.layer_data.len(), 4);
        let mut theirs = std::io::Cursor::new(Vec::new());
        exr.write().non_parallel().to_buffered(&mut theirs).unwrap();
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let mut ours = std::io::Cursor::new(Vec::new());
            pool.install(|| write_exr_blocks(&mut ours, &exr.layer_data, &exr.attributes)).unwrap();
            assert!(ours.get_ref() == theirs.get_ref(), "{threads} threads: other bytes");
        }
    }
}
