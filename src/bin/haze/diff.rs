//! `haze diff`: two images compared pixel by pixel (bit for bit, then by size of difference).

use anyhow::{Result, bail};
use clap::Args;
use haze::lab::converge::Reference;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Args)]
pub(crate) struct DiffArgs {
    /// An OpenEXR image.
    a: PathBuf,
    /// Another OpenEXR image of the same size.
    b: PathBuf,
}

/// Exit 0 if the pixels are bit-identical, 1 if they differ (with how much).
pub(crate) fn run(args: DiffArgs) -> Result<ExitCode> {
    // The lab's reader: the first layer's RGB, with errors naming the file.
    let (a, b) = (Reference::load(&args.a)?, Reference::load(&args.b)?);
    let ((wa, ha), (wb, hb)) = ((a.width, a.height), (b.width, b.height));
    let (a, b) = (a.pixels, b.pixels);
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
