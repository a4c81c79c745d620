//! `haze diff`: two images compared pixel by pixel (bit for bit, then by size of difference).

use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Args)]
pub(crate) struct DiffArgs {
    /// An OpenEXR image.
    a: PathBuf,
    /// Another OpenEXR image of the same size.
    b: PathBuf,
}

/// The RGB pixels of an EXR file's first layer, row-major, and its size.
fn read(path: &Path) -> Result<(Vec<[f32; 3]>, usize, usize)> {
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |size, _| (vec![[0f32; 3]; size.width() * size.height()], size.width()),
        |(px, w): &mut (Vec<[f32; 3]>, usize), pos, (r, g, b, _): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = [r, g, b];
        },
    )
    .with_context(|| format!("{}: cannot read it as OpenEXR", path.display()))?;
    let (px, w) = image.layer_data.channel_data.pixels;
    let h = px.len() / w.max(1);
    Ok((px, w, h))
}

/// Exit 0 if the pixels are bit-identical, 1 if they differ (with how much).
pub(crate) fn run(args: DiffArgs) -> Result<ExitCode> {
    let (a, wa, ha) = read(&args.a)?;
    let (b, wb, hb) = read(&args.b)?;
    if (wa, ha) != (wb, hb) {
        bail!("sizes differ: {wa}x{ha} and {wb}x{hb}");
    }
    let (mut differ, mut max, mut sq) = (0usize, 0f64, 0f64);
    for (p, q) in a.iter().zip(&b) {
        if p.iter().zip(q).any(|(x, y)| x.to_bits() != y.to_bits()) {
            differ += 1;
        }
        for (x, y) in p.iter().zip(q) {
            let d = (*x as f64 - *y as f64).abs();
            max = max.max(if d.is_nan() { f64::INFINITY } else { d });
            sq += d * d;
        }
    }
    if differ == 0 {
        println!("identical: {wa}x{ha} pixels, bit for bit");
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "{differ} of {} pixels differ: largest difference {max:.3e}, RMS {:.3e}",
        a.len(),
        (sq / (3 * a.len()) as f64).sqrt()
    );
    Ok(ExitCode::from(1))
}
