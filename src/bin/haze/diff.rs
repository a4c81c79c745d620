//! `haze diff`: two images compared pixel by pixel (bit for bit, then by size of difference), and
//! with `--tiles N` tile by tile in standard errors from their variance layers.

use anyhow::{Result, bail};
use clap::Args;
use haze::lab::converge::Reference;
use haze::lab::tiles;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Args)]
pub(crate) struct DiffArgs {
    /// An OpenEXR image.
    a: PathBuf,
    /// Another OpenEXR image of the same size.
    b: PathBuf,
    /// Also compare the images tile by tile (tiles of N×N pixels): each tile's mean difference
    /// in standard errors from the two files' `variance` layers, failing beyond the critical
    /// value at `--significance` over all tiles (Šidák). Exit 0 if no tile fails.
    #[arg(long, value_name = "N")]
    tiles: Option<u32>,
    /// Family-wise significance of `--tiles` (the chance that two renders of the same image
    /// fail it).
    #[arg(long, default_value_t = 1e-3, value_name = "ALPHA", requires = "tiles")]
    significance: f64,
}

/// The image and its noise as the per-tile comparison sees them.
fn view<'a>(r: &'a Reference, variance: &'a [[f32; 3]]) -> tiles::NoisyImage<'a> {
    tiles::NoisyImage { width: r.width, height: r.height, pixels: &r.pixels, variance, bias: None }
}

/// Exit 0 if the pixels are bit-identical, 1 if they differ (with how much); with `--tiles`, 0
/// if they are identical or no tile differs significantly, 1 otherwise.
pub(crate) fn run(args: DiffArgs) -> Result<ExitCode> {
    // The lab's reader: the first layer's RGB, with errors naming the file.
    let (ra, rb) = (Reference::load(&args.a)?, Reference::load(&args.b)?);
    let ((wa, ha), (wb, hb)) = ((ra.width, ra.height), (rb.width, rb.height));
    let (a, b) = (&ra.pixels, &rb.pixels);
    if (wa, ha) != (wb, hb) {
        bail!("sizes differ: {wa}x{ha} and {wb}x{hb}");
    }
    let (mut differ, mut max, mut sq) = (0usize, 0f64, 0f64);
    for (p, q) in a.iter().zip(b) {
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
    let Some(tile) = args.tiles else { return Ok(ExitCode::from(1)) };
    let layer = |r: &Reference, path: &PathBuf| -> Result<Vec<[f32; 3]>> {
        match &r.variance_layer {
            Some(v) => Ok(v.clone()),
            None => bail!(
                "{}: no variance layer (haze writes one into every render of two or more \
                 iterations); --tiles needs both images' noise",
                path.display()
            ),
        }
    };
    let (va, vb) = (layer(&ra, &args.a)?, layer(&rb, &args.b)?);
    let (ia, ib) = (view(&ra, &va), view(&rb, &vb));
    let c = tiles::compare(&ia, &ib, tile, args.significance)?;
    println!("{}", c.summary());
    for t in c.failures() {
        println!(
            "  tile at ({}, {}): difference {:+.4e} ± {:.4e}, z {:+.2}",
            t.x0, t.y0, t.difference, t.se, t.z
        );
    }
    Ok(if c.pass() { ExitCode::SUCCESS } else { ExitCode::from(1) })
}
