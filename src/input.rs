//! Reading input files (scenes, meshes, grids) without being made to hang or to exhaust memory.

use crate::error::{Error, Result};
use std::path::Path;

/// Reads the file at `path` whole, refusing anything but a regular file (a FIFO would block, a
/// device such as /dev/zero never end) and files larger than `max` bytes. `what` names the kind
/// of file in messages, e.g. "a scene file".
pub(crate) fn read_bounded(path: &Path, max: u64, what: &str) -> Result<Vec<u8>> {
    use std::io::Read;
    let io = |error: std::io::Error| Error::Io { path: path.to_path_buf(), error };
    let len = check_file(path, max, what)?;
    let file = std::fs::File::open(path).map_err(io)?;
    // A large file (a sparse one can claim terabytes) must not abort the process by its size.
    let mut bytes = Vec::new();
    bytes.try_reserve_exact(len as usize).map_err(|_| {
        refusal(path, format!("is {len} bytes, more than this machine can hold to read {what}"))
    })?;
    file.take(max + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > max {
        return Err(refusal(path, format!("grew past {max} bytes while being read")));
    }
    Ok(bytes)
}

/// Checks that `path` is a regular file of at most `max` bytes (`what` names it in messages) and
/// returns its length.
pub(crate) fn check_file(path: &Path, max: u64, what: &str) -> Result<u64> {
    let io = |error: std::io::Error| Error::Io { path: path.to_path_buf(), error };
    // stat first: opening a FIFO for reading would block until a writer came.
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        let kind = if meta.is_dir() { "a directory" } else { "not a regular file" };
        return Err(refusal(path, format!("is {kind}; {what} must be a regular file")));
    }
    if meta.len() > max {
        return Err(refusal(
            path,
            format!("{} bytes is more than haze reads as {what} ({max} bytes)", meta.len()),
        ));
    }
    Ok(meta.len())
}

fn refusal(path: &Path, message: String) -> Error {
    Error::Io {
        path: path.to_path_buf(),
        error: std::io::Error::new(std::io::ErrorKind::InvalidInput, message),
    }
}

/// Why an OpenEXR file whose header is `meta` is refused for its size, if it is: its layers'
/// pixels summed exceed `max_pixels` (`what` names the file's kind). Checked before any pixel is
/// read, since the exr crate allocates every layer from the declared data windows first.
pub(crate) fn exr_size_refusal(
    meta: &exr::meta::MetaData,
    max_pixels: u64,
    what: &str,
) -> Option<String> {
    let mut total = 0u64;
    for header in meta.headers.iter() {
        let size = header.layer_size;
        let pixels = (size.width() as u64).saturating_mul(size.height() as u64);
        total = total.saturating_add(pixels);
        if total > max_pixels {
            return Some(format!(
                "its header declares a {} × {} image{}, more than haze reads as {what} \
                 ({max_pixels} pixels)",
                size.width(),
                size.height(),
                if meta.headers.len() > 1 { " among its layers" } else { "" },
            ));
        }
    }
    None
}

/// An OpenEXR layer's RGB pixels as the readers here collect them: the width and the pixels,
/// row by row.
pub(crate) type RgbPixels = (usize, Vec<[f32; 3]>);

/// The exr crate's `rgb_channels` storage for a layer of `size`, black.
pub(crate) fn rgb_storage(size: exr::math::Vec2<usize>, _: &exr::image::RgbChannels) -> RgbPixels {
    (size.width(), vec![[0.0f32; 3]; size.width() * size.height()])
}

/// The exr crate's `rgb_channels` setter: one pixel at `pos`.
pub(crate) fn rgb_set(
    (w, px): &mut RgbPixels,
    pos: exr::math::Vec2<usize>,
    (r, g, b): (f32, f32, f32),
) {
    px[pos.y() * *w + pos.x()] = [r, g, b];
}

/// The first RGB layer of an OpenEXR file's `bytes` (`path` names it in errors). The header is
/// read first and an image of more than `max_texels` refused before any pixel buffer is
/// allocated (the reader sizes its buffers from the declared data window); a panic of the exr
/// crate on a corrupt file is an error, not a crash.
pub(crate) fn rgb_exr_from_bytes(
    bytes: &[u8],
    path: &Path,
    max_texels: u64,
    what: &str,
) -> Result<(u32, u32, Vec<[f32; 3]>)> {
    use exr::prelude::*;
    let err = |m: String| crate::error::Error::Image { path: path.to_path_buf(), message: m };
    let cursor = || std::io::Cursor::new(bytes);
    let meta =
        std::panic::catch_unwind(|| exr::meta::MetaData::read_from_buffered(cursor(), false))
            .map_err(|_| err("cannot read as an OpenEXR image: its header is corrupt".into()))?
            .map_err(|e| err(format!("cannot read as an OpenEXR image: {e}")))?;
    if let Some(refusal) = exr_size_refusal(&meta, max_texels, what) {
        return Err(err(refusal));
    }
    let image = std::panic::catch_unwind(|| {
        read()
            .no_deep_data()
            .largest_resolution_level()
            .rgb_channels(rgb_storage, rgb_set)
            .first_valid_layer()
            .all_attributes()
            .from_buffered(cursor())
    })
    .map_err(|_| err("cannot read as an RGB OpenEXR image: the file is corrupt".into()))?
    .map_err(|e| err(format!("cannot read as an RGB OpenEXR image: {e}")))?;
    let layer = image.layer_data;
    let (w, h) = (layer.size.width() as u32, layer.size.height() as u32);
    Ok((w, h, layer.channel_data.pixels.1))
}
