//! Integrators: the progressive photon mapping loop (`ppm`) with its camera pass (`camera`), and
//! the reference path tracer (`path`).

pub mod camera;
pub mod original;
pub mod path;
pub mod ppm;

use crate::math::Rgb;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Fills `image` (row-major, `width` pixels a row) with `radiance(x, y)` in parallel over rows.
/// Non-finite samples become black and are counted in `nonfinite`. Returns `false` if `stop` was
/// raised before every row was done.
pub(crate) fn render_rows(
    image: &mut [Rgb],
    width: usize,
    stop: &AtomicBool,
    nonfinite: &AtomicU64,
    radiance: impl Fn(u32, u32) -> Rgb + Sync,
) -> bool {
    image.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        if stop.load(Ordering::Relaxed) {
            return;
        }
        for (x, px) in row.iter_mut().enumerate() {
            let l = radiance(x as u32, y as u32);
            *px = if l.is_finite() {
                l
            } else {
                nonfinite.fetch_add(1, Ordering::Relaxed);
                Rgb::ZERO
            };
        }
    });
    !stop.load(Ordering::Relaxed)
}
