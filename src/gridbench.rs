//! Measuring how grids are stored (`haze bench grid`): one float grid of an OpenVDB file loaded
//! in a layout, its size, and the time of random trilinear lookups inside its active box — the
//! lookup every tracking step makes.

use crate::error::Result;
use crate::medium::grid::{DensityGrid, Layout};
use crate::rng::{Purpose, Sampler};
use glam::Vec3;
use std::path::Path;
use std::time::Instant;

/// One grid in one layout, measured.
#[derive(Clone, Debug)]
pub struct GridMeasure {
    /// The layout it was stored in.
    pub layout: Layout,
    /// The box the layout covers, in voxels.
    pub dims: [i32; 3],
    /// Active voxels in the file.
    pub active_voxels: u64,
    /// Bytes of the stored values.
    pub bytes: usize,
    /// Seconds to load the grid (read, parse, copy).
    pub load_seconds: f64,
    /// Nanoseconds per trilinear lookup (one thread).
    pub ns_per_lookup: f64,
    /// The sum of the looked-up densities (f64): equal across layouts for the same points.
    pub checksum: f64,
}

/// Loads grid `name` of `path` in `layout` and times `lookups` trilinear lookups at points
/// uniform in its active box (plus one voxel around it), drawn from `seed`; `Err` if the grid
/// cannot be loaded in that layout.
pub fn measure_grid(
    path: &Path,
    name: &str,
    layout: Layout,
    lookups: usize,
    seed: u64,
) -> Result<GridMeasure> {
    let clock = Instant::now();
    let grid = DensityGrid::load_with(path, name, layout)?;
    let load_seconds = clock.elapsed().as_secs_f64();
    let mut s = Sampler::new(seed, Purpose::Camera, 0, 0);
    let (a, b) = grid.active_box;
    let (lo, size) = ((a - 1).as_vec3(), (b - a + 3).as_vec3());
    let points: Vec<Vec3> = (0..lookups)
        .map(|_| lo + size * Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()))
        .collect();
    let clock = Instant::now();
    let mut checksum = 0.0f64;
    for q in &points {
        checksum += std::hint::black_box(grid.density_index(*q)) as f64;
    }
    let ns_per_lookup = clock.elapsed().as_secs_f64() * 1e9 / lookups.max(1) as f64;
    Ok(GridMeasure {
        layout: grid.layout(),
        dims: grid.dims.to_array(),
        active_voxels: grid.active_voxels,
        bytes: grid.stored_bytes(),
        load_seconds,
        ns_per_lookup,
        checksum,
    })
}
