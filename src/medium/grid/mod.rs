//! Density grids from OpenVDB files, copied once into a dense array or 8³ bricks for fast
//! lookups, with a coarse majorant grid for delta tracking.
//!
//! vdb-rs 0.6 reads the file's header and grid descriptors; haze reads the grid's tree itself
//! (`vdbscan.rs`, through `read.rs`), straight from the file. Every known failure mode of vdb-rs
//! is guarded against and reported as an [`Error::Volume`](crate::Error::Volume) naming the file
//! and grid, and never takes the process down:
//!
//! | vdb-rs 0.6 behaviour | haze |
//! |---|---|
//! | half-float grids: it reads a block size where OpenVDB wrote none, and errs or **aborts** | haze's reader decodes full and half floats (zip through flate2, Blosc through c-blosc) |
//! | maps other than (uniform) scale / scale-translate `panic!` | the transform is read by haze; other maps are refused by name |
//! | vector and other non-float grids are read as floats | the grid's tree type must be `Tree_float_5_4_3` |
//! | two grids of the same name: one is silently dropped | the header's grid count must match the distinct names |
//! | root-level tiles are dropped | haze's reader includes them; the voxels read must add up to the file's `file_voxel_count` |
//! | a corrupt count or length makes it allocate up to 10¹⁸ bytes and **abort the process** | haze checks the header and descriptors before vdb-rs reads them, and its own reader checks every count and length against the file and allocates from none |
//! | the whole tree is held in memory while haze copies it | haze's reader hands over one node at a time |
//! | truncated or corrupt files: errors or panics | errors are reported; any panic is caught and reported |
//!
//! The file must be a regular file of at most [`MAX_FILE_BYTES`]; it is read through a buffer,
//! never held in memory whole.
//!
//! Layout, chosen per grid ([`Layout`]): a dense `Vec<f32>` over the bounding box of the active
//! voxels where the box is well filled — the fastest lookup (docs/performance.md) — or 8³-voxel
//! bricks behind a dense table of brick entries, each empty (zero), one constant value (an
//! OpenVDB tile), or 512 stored values, where the box is mostly empty. Dense is chosen unless it
//! would take more than 32 MiB and more than twice the bytes of the bricks, or more than
//! [`MAX_VOXELS`] voxels; bricks are
//! limited to [`MAX_BRICKS`] table entries (a box of 2048³ voxels). Both give the same densities,
//! bit for bit: the interpolation sums the same products in the same order.
//!
//! Loading reads the grid twice (bounds and brick census, then the copy), decoding every block
//! each time, with no per-voxel list in between: the memory it takes is the final copy, the
//! census (a set of brick indices) and a node's worth of buffers.

mod read;

use super::blocks::Blocked;
use glam::{IVec3, Vec3};

/// Largest OpenVDB file accepted (bytes).
pub const MAX_FILE_BYTES: u64 = 4 << 30;

/// Largest dense grid accepted (voxels).
pub const MAX_VOXELS: u64 = 1 << 27;

/// Voxels along each axis of a brick of the sparse layout.
pub const BRICK: i32 = 8;
const BRICK_VOXELS: usize = 512;

/// Up to this many bytes a grid is stored densely whatever its fill (its lookups are faster, and
/// the memory is small): 32 MiB.
const SMALL: u128 = 32 << 20;

/// Largest brick table of the sparse layout (entries of 4 bytes: 64 MiB, a box of 2048³ voxels).
pub const MAX_BRICKS: u64 = 1 << 24;

/// A brick table entry: no value (zero) …
const EMPTY: u32 = u32::MAX;
/// … a constant (the flag, with the index into `constants` below it) …
const CONSTANT: u32 = 1 << 31;
// … or otherwise the index of a stored brick.

/// How a grid's voxels are stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Layout {
    /// Dense where the box is well filled, bricks where it is mostly empty (module docs).
    #[default]
    Auto,
    /// A dense array over the active voxels' bounding box.
    Dense,
    /// 8³-voxel bricks behind a dense table.
    Bricks,
}

/// The stored voxels.
#[derive(Clone, Debug)]
enum Storage {
    /// x fastest over the grid's box.
    Dense(Vec<f32>),
    Bricks(Bricks),
}

/// The sparse layout: bricks of [`BRICK`]³ voxels aligned to multiples of [`BRICK`] in index
/// space (as OpenVDB's leaf nodes are), from the grid's origin (a multiple of 64 voxels, so that
/// OpenVDB's larger tiles cover whole blocks of the table).
#[derive(Clone, Debug)]
struct Bricks {
    /// Per brick: [`EMPTY`], [`CONSTANT`] | index into `constants`, or the index of its 512
    /// values in `pool`; stored by blocks of 8³ bricks, so that a block of one tile's bricks is
    /// one entry.
    table: Blocked<u32>,
    constants: Vec<f32>,
    /// Stored bricks' values, x fastest within a brick.
    pool: Vec<f32>,
}

impl Bricks {
    #[inline]
    fn entry(&self, b: IVec3) -> u32 {
        self.table.get(b)
    }

    /// The value at `q` (relative to the grid's origin, inside its box).
    #[inline]
    fn at(&self, q: IVec3) -> f32 {
        let e = self.entry(q >> 3);
        if e == EMPTY {
            0.0
        } else if e & CONSTANT != 0 {
            self.constants[(e & !CONSTANT) as usize]
        } else {
            let l = q & (BRICK - 1);
            self.pool[e as usize * BRICK_VOXELS + (l.x + 8 * (l.y + 8 * l.z)) as usize]
        }
    }
}

/// Voxels per majorant cell along each axis.
pub const MAJORANT_CELL: i32 = 8;

/// A scalar density on a dense voxel grid, with its index-to-world map (scale, then translation).
#[derive(Clone, Debug)]
pub struct DensityGrid {
    /// Index of the first stored voxel.
    pub origin: IVec3,
    /// Voxels stored along each axis.
    pub dims: IVec3,
    /// The voxels, dense or in bricks: shared by the clones of a grid (a grid a scene references
    /// several times is stored once), copied only if one of them is scaled.
    storage: std::sync::Arc<Storage>,
    /// World position of index (0, 0, 0) (voxel centres are at integer indices).
    pub translation: Vec3,
    /// World size of a voxel along each axis.
    pub voxel_size: Vec3,
    /// Largest density of any voxel.
    pub max_density: f32,
    /// Active voxels in the file (tiles counted voxel by voxel).
    pub active_voxels: u64,
    /// The box of the active voxels (first and last index; the layout's box may be larger).
    pub active_box: (IVec3, IVec3),
}

impl DensityGrid {
    /// A dense grid from values made in code: `dims` voxels (x fastest), voxel (0, 0, 0)'s centre
    /// at `translation`, voxels of `voxel_size`. Every value must be finite and non-negative,
    /// and the grid within [`MAX_VOXELS`]; the message says what is wrong.
    pub(crate) fn from_dense(
        dims: IVec3,
        values: Vec<f32>,
        voxel_size: Vec3,
        translation: Vec3,
    ) -> std::result::Result<DensityGrid, String> {
        let n = dims.as_i64vec3();
        if dims.cmple(IVec3::ZERO).any() || n.element_product() as u64 > MAX_VOXELS {
            return Err(format!(
                "{}×{}×{} voxels: each axis needs at least one, and at most {MAX_VOXELS} in all",
                dims.x, dims.y, dims.z
            ));
        }
        if values.len() as i64 != n.element_product() {
            return Err(format!(
                "{} values for {}×{}×{} voxels",
                values.len(),
                dims.x,
                dims.y,
                dims.z
            ));
        }
        if !(voxel_size.is_finite() && voxel_size.min_element() > 0.0 && translation.is_finite()) {
            return Err(format!("a box of voxels {voxel_size} at {translation}: not a box"));
        }
        if let Some(k) = values.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
            let i = k as i32;
            let at = IVec3::new(i % dims.x, i / dims.x % dims.y, i / dims.x / dims.y);
            return Err(format!(
                "the value at voxel {at} is {}; densities must be finite and non-negative",
                values[k]
            ));
        }
        let max = values.iter().fold(0.0f32, |a, &v| a.max(v));
        if max <= 0.0 {
            return Err("every value is zero: the medium would be empty".into());
        }
        Ok(DensityGrid {
            origin: IVec3::ZERO,
            dims,
            active_voxels: values.len() as u64,
            storage: std::sync::Arc::new(Storage::Dense(values)),
            translation,
            voxel_size,
            max_density: max,
            active_box: (IVec3::ZERO, dims - IVec3::ONE),
        })
    }

    /// The layout the voxels are stored in ([`Layout::Dense`] or [`Layout::Bricks`]).
    pub fn layout(&self) -> Layout {
        match *self.storage {
            Storage::Dense(_) => Layout::Dense,
            Storage::Bricks(_) => Layout::Bricks,
        }
    }

    /// Identifies the stored voxels: equal for clones that share them.
    pub(crate) fn storage_id(&self) -> usize {
        std::sync::Arc::as_ptr(&self.storage) as usize
    }

    /// Bytes of the stored voxels (the dense array, or the brick table, constants and bricks).
    pub fn stored_bytes(&self) -> usize {
        match &*self.storage {
            Storage::Dense(d) => 4 * d.len(),
            Storage::Bricks(b) => b.table.bytes() + 4 * (b.constants.len() + b.pool.len()),
        }
    }

    /// Multiplies every value by `k`: in place where the grid's storage is its own, else into a
    /// copy of its own, made and scaled in one parallel pass (a grid read once per scene shares
    /// its storage with the scene's list of loaded grids; copying it first, then scaling, was a
    /// serial copy and a second pass: cumulus, 4 ms of its 27 ms loading on either thread count).
    pub(crate) fn scale_values(&mut self, k: f32) {
        use rayon::prelude::*;
        if k == 1.0 {
            return;
        }
        // Each value on its own: the same products in any order.
        const PIECE: usize = 1 << 14;
        let scaled = |v: &[f32]| -> Vec<f32> {
            let mut out = Vec::with_capacity(v.len());
            v.par_iter().with_min_len(PIECE).map(|x| x * k).collect_into_vec(&mut out);
            out
        };
        match std::sync::Arc::get_mut(&mut self.storage) {
            Some(Storage::Dense(d)) => d.par_iter_mut().with_min_len(PIECE).for_each(|v| *v *= k),
            Some(Storage::Bricks(b)) => {
                b.constants.iter_mut().for_each(|c| *c *= k);
                b.pool.par_iter_mut().with_min_len(PIECE).for_each(|v| *v *= k);
            }
            None => {
                let copy = match &*self.storage {
                    Storage::Dense(d) => Storage::Dense(scaled(d)),
                    Storage::Bricks(b) => Storage::Bricks(Bricks {
                        table: b.table.clone(),
                        constants: b.constants.iter().map(|c| c * k).collect(),
                        pool: scaled(&b.pool),
                    }),
                };
                self.storage = std::sync::Arc::new(copy);
            }
        }
        self.max_density *= k;
    }

    /// Feeds the stored values to `feed` (a dense grid: every value in order).
    pub(crate) fn feed_values(&self, feed: &mut dyn FnMut(&[u8])) {
        let values = |v: &[f32], feed: &mut dyn FnMut(&[u8])| {
            v.iter().for_each(|d| feed(&d.to_le_bytes()));
        };
        match &*self.storage {
            Storage::Dense(d) => values(d, feed),
            Storage::Bricks(b) => {
                b.table.for_each_cell(|e| feed(&e.to_le_bytes()));
                values(&b.constants, feed);
                values(&b.pool, feed);
            }
        }
    }

    /// The largest value of any voxel of each majorant cell's interpolation range: cell k (x
    /// fastest, `cells` along each axis) covers voxels lo + k·[`MAJORANT_CELL`] + [0,
    /// MAJORANT_CELL]³. The same in both layouts (bricks skip the cells whose bricks are all
    /// empty or constant). Built in parallel by blocks of 8³ cells, a block of equal values
    /// stored as one ([`Blocked`]).
    pub(crate) fn majorants(&self, lo: IVec3, cells: IVec3) -> Blocked<f32> {
        use rayon::prelude::*;
        let m = MAJORANT_CELL;
        // Largest value of each stored brick (sparse layout; constant bricks are their value).
        let pool_max: Vec<f32> = match &*self.storage {
            Storage::Dense(_) => Vec::new(),
            Storage::Bricks(b) => b
                .pool
                .par_chunks(BRICK_VOXELS)
                .map(|brick| brick.iter().fold(0.0f32, |a, v| a.max(*v)))
                .collect(),
        };
        let brick_max = |b: &Bricks, e: u32| {
            if e == EMPTY {
                0.0
            } else if e & CONSTANT != 0 {
                b.constants[(e & !CONSTANT) as usize]
            } else {
                pool_max[e as usize]
            }
        };
        Blocked::from_fn(cells, |cell| {
            let base = lo + cell * m;
            // Bricks skip the cells they know to be empty, and need no voxel lookups where every
            // brick the cell's range touches is constant (a tile).
            let mut bound = f32::INFINITY;
            if let Storage::Bricks(b) = &*self.storage {
                bound = 0.0;
                let mut constant = true;
                // The bricks the range [base, base + m] touches, within the table.
                let first: IVec3 = ((base - self.origin) >> 3i32).max(IVec3::ZERO);
                let last: IVec3 =
                    ((base + IVec3::splat(m) - self.origin) >> 3i32).min(b.table.count() - 1);
                for z in first.z..=last.z {
                    for y in first.y..=last.y {
                        for x in first.x..=last.x {
                            let e = b.entry(IVec3::new(x, y, z));
                            bound = bound.max(brick_max(b, e));
                            constant &= e == EMPTY || e & CONSTANT != 0;
                        }
                    }
                }
                if constant {
                    // Every voxel of those bricks holds its brick's value (and voxels outside
                    // the table are zero): the bound is the largest value.
                    return bound;
                }
            }
            if bound > 0.0 { self.box_max(base, base + IVec3::splat(m)) } else { 0.0 }
        })
    }

    /// The largest value of the voxels of the index-space box `lo..=hi` (at least 0; voxels
    /// outside the grid's box are zero): [`Self::voxel`]'s largest over the box, read row by
    /// row from the storage rather than voxel by voxel.
    fn box_max(&self, lo: IVec3, hi: IVec3) -> f32 {
        let (a, b) = ((lo - self.origin).max(IVec3::ZERO), (hi - self.origin).min(self.dims - 1));
        let mut v = 0.0f32;
        if a.cmpgt(b).any() {
            return v;
        }
        // The largest of `v` and `values[at(y, z) + x]` over the box `a..=b`.
        let rows =
            |mut v: f32, values: &[f32], (a, b): (IVec3, IVec3), at: &dyn Fn(i32, i32) -> usize| {
                for z in a.z..=b.z {
                    for y in a.y..=b.y {
                        let row = at(y, z);
                        let run = &values[row + a.x as usize..=row + b.x as usize];
                        v = run.iter().fold(v, |m, &x| m.max(x));
                    }
                }
                v
            };
        match &*self.storage {
            Storage::Dense(data) => {
                let d = self.dims;
                v = rows(v, data, (a, b), &|y, z| (d.x * (y + d.y * z)) as usize);
            }
            Storage::Bricks(bricks) => {
                for kz in a.z >> 3..=b.z >> 3 {
                    for ky in a.y >> 3..=b.y >> 3 {
                        for kx in a.x >> 3..=b.x >> 3 {
                            let k = IVec3::new(kx, ky, kz);
                            let e = bricks.entry(k);
                            if e == EMPTY {
                                continue;
                            }
                            if e & CONSTANT != 0 {
                                v = v.max(bricks.constants[(e & !CONSTANT) as usize]);
                                continue;
                            }
                            // The box's part in this brick, in the brick's own coordinates.
                            let first = k * BRICK;
                            let part = (a.max(first) - first, b.min(first + BRICK - 1) - first);
                            let pool = &bricks.pool[e as usize * BRICK_VOXELS..][..BRICK_VOXELS];
                            v = rows(v, pool, part, &|y, z| (8 * (y + 8 * z)) as usize);
                        }
                    }
                }
            }
        }
        v
    }

    /// Lower and upper bounds of the (scaled) values on the index-space segment from `q0` to
    /// `q1`. Within one interpolation cell (between eight voxel centres) the density is
    /// multilinear, so its extremes over the box spanned by the segment are at the box's corners;
    /// across cells, every voxel of the cells the box touches bounds it. The upper bound is
    /// raised by a few ulps for the rounding of trilinear lookups.
    pub(crate) fn bounds(&self, q0: Vec3, q1: Vec3) -> (f32, f32) {
        let (mn, mx) = (q0.min(q1), q0.max(q1));
        let (i0, i1) = (mn.floor().as_ivec3(), mx.floor().as_ivec3());
        let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
        if i0 == i1 {
            for k in 0..8 {
                let pick = |bit: i32, a: f32, b: f32| if k & bit == 0 { a } else { b };
                let q = Vec3::new(pick(1, mn.x, mx.x), pick(2, mn.y, mx.y), pick(4, mn.z, mx.z));
                let v = self.density_index(q);
                (lo, hi) = (lo.min(v), hi.max(v));
            }
        } else if (i1 - i0 + IVec3::splat(2)).as_i64vec3().element_product() > 4096 {
            // A long piece of a ray in a fine grid: the grid's own bounds (valid, loose).
            return (0.0, self.max_density * (1.0 + 1e-5));
        } else {
            for z in i0.z..=i1.z + 1 {
                for y in i0.y..=i1.y + 1 {
                    for x in i0.x..=i1.x + 1 {
                        let v = self.voxel(IVec3::new(x, y, z));
                        (lo, hi) = (lo.min(v), hi.max(v));
                    }
                }
            }
        }
        (lo, hi * (1.0 + 1e-5))
    }

    /// Density at index `i` (zero outside the stored box).
    #[inline]
    pub fn voxel(&self, i: IVec3) -> f32 {
        let q = i - self.origin;
        if q.cmplt(IVec3::ZERO).any() || q.cmpge(self.dims).any() {
            return 0.0;
        }
        match &*self.storage {
            Storage::Dense(data) => data[(q.x + self.dims.x * (q.y + self.dims.y * q.z)) as usize],
            Storage::Bricks(b) => b.at(q),
        }
    }

    /// Trilinearly interpolated density at continuous index-space position `q` (voxel centres at
    /// integers).
    #[inline]
    pub fn density_index(&self, q: Vec3) -> f32 {
        let f = floor(q);
        let i = f.as_ivec3();
        let t = q - f;
        let weights = [
            (1.0 - t.x) * (1.0 - t.y) * (1.0 - t.z),
            t.x * (1.0 - t.y) * (1.0 - t.z),
            (1.0 - t.x) * t.y * (1.0 - t.z),
            t.x * t.y * (1.0 - t.z),
            (1.0 - t.x) * (1.0 - t.y) * t.z,
            t.x * (1.0 - t.y) * t.z,
            (1.0 - t.x) * t.y * t.z,
            t.x * t.y * t.z,
        ];
        let lo = i - self.origin;
        let inside = lo.cmpge(IVec3::ZERO).all() && (lo + IVec3::ONE).cmplt(self.dims).all();
        match &*self.storage {
            Storage::Dense(data) if inside => {
                // All eight corners inside the box (most lookups): one index, no per-corner
                // checks. The same products summed in the same order as below, so the same bits.
                let (sy, sz) = (self.dims.x as usize, (self.dims.x * self.dims.y) as usize);
                let base = lo.x as usize + sy * lo.y as usize + sz * lo.z as usize;
                return corner_sum(&weights, &data[base..=base + sz + sy + 1], [sy, sz]);
            }
            Storage::Bricks(b) if inside && (lo >> 3) == ((lo + IVec3::ONE) >> 3) => {
                // All eight corners in one brick: one table entry.
                let e = b.entry(lo >> 3);
                if e == EMPTY {
                    return 0.0;
                }
                if e & CONSTANT != 0 {
                    // The dense sum with the same value at every corner.
                    let c = b.constants[(e & !CONSTANT) as usize];
                    return weights.iter().filter(|w| **w > 0.0).fold(0.0, |d, w| d + w * c);
                }
                let l = lo & (BRICK - 1);
                let base = e as usize * BRICK_VOXELS + (l.x + 8 * (l.y + 8 * l.z)) as usize;
                return corner_sum(&weights, &b.pool[base..=base + 64 + 8 + 1], [8, 64]);
            }
            _ => {}
        }
        let offsets = [
            IVec3::new(0, 0, 0),
            IVec3::new(1, 0, 0),
            IVec3::new(0, 1, 0),
            IVec3::new(1, 1, 0),
            IVec3::new(0, 0, 1),
            IVec3::new(1, 0, 1),
            IVec3::new(0, 1, 1),
            IVec3::new(1, 1, 1),
        ];
        let mut d = 0.0;
        for (w, k) in weights.into_iter().zip(offsets) {
            if w > 0.0 {
                d += w * self.voxel(i + k);
            }
        }
        d
    }
}

/// Σ w_k · values[corner k] over the eight corners of an interpolation cell whose corner (0, 0, 0)
/// is `values[0]`, with strides `[y, z]`, skipping zero weights: the sum every layout computes, in
/// the same order, so that they agree bit for bit.
#[inline(always)]
fn corner_sum(weights: &[f32; 8], values: &[f32], [sy, sz]: [usize; 2]) -> f32 {
    let corners = [0, 1, sy, sy + 1, sz, sz + 1, sz + sy, sz + sy + 1];
    let mut d = 0.0;
    for (w, c) in weights.iter().zip(corners) {
        if *w > 0.0 {
            d += w * values[c];
        }
    }
    d
}

/// `v.floor()` without a call into libm (x86-64's baseline has no rounding instruction, and the
/// call was 2.6 % of a vdb-cloud render): truncation towards zero, one down for negative
/// non-integers. Exact for |x| < 2²³; larger values (and NaN, ±∞) are integral already and are
/// returned as they are. −0 becomes +0, which no caller can tell apart.
#[inline(always)]
fn floor(v: Vec3) -> Vec3 {
    let f = |x: f32| {
        if x.abs() < 8_388_608.0 {
            let t = x as i32 as f32;
            if t > x { t - 1.0 } else { t }
        } else {
            x
        }
    };
    Vec3::new(f(v.x), f(v.y), f(v.z))
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod layout_tests {
    use super::*;
    use crate::rng::{Purpose, Sampler};
    use std::path::Path;

    fn media(name: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("media").join(name)
    }

    /// Every bundled grid (and one of OpenVDB tiles) reads the same in both layouts: every voxel
    /// of the box and a margin around it, trilinear lookups at 100,000 random points bit for bit,
    /// and the majorant cells of the medium built on it (both equal to the cells' largest voxels
    /// found voxel by voxel); and the automatic choice is dense for
    /// the small bundled grids, bricks for the tiles file, whose box is 256³ but holds 65 tiles
    /// and 20 voxels.
    #[test]
    fn dense_and_brick_layouts_read_the_same_values() {
        let files = [
            ("cloud.vdb", "density"),
            ("box.vdb", "density"),
            ("gradient.vdb", "density"),
            ("holes.vdb", "density"),
            ("fire.vdb", "density"),
            ("fire.vdb", "temperature"),
            ("tiles.vdb", "density"),
        ];
        for (file, name) in files {
            let dense = DensityGrid::load_with(&media(file), name, Layout::Dense).unwrap();
            let bricks = DensityGrid::load_with(&media(file), name, Layout::Bricks).unwrap();
            let auto = DensityGrid::load(&media(file), name).unwrap();
            let want = if file == "tiles.vdb" { Layout::Bricks } else { Layout::Dense };
            assert_eq!(auto.layout(), want, "{file} {name}");
            assert_eq!((dense.layout(), bricks.layout()), (Layout::Dense, Layout::Bricks));
            assert_eq!(dense.active_voxels, bricks.active_voxels);
            assert_eq!(dense.max_density, bricks.max_density);
            let (lo, hi) = dense.active_box;
            let step = if file == "tiles.vdb" { 3 } else { 1 };
            for z in (lo.z - 2..=hi.z + 2).step_by(step) {
                for y in (lo.y - 2..=hi.y + 2).step_by(step) {
                    for x in lo.x - 2..=hi.x + 2 {
                        let i = IVec3::new(x, y, z);
                        assert_eq!(
                            dense.voxel(i).to_bits(),
                            bricks.voxel(i).to_bits(),
                            "{file} {i}"
                        );
                    }
                }
            }
            let mut s = Sampler::new(5, Purpose::Camera, 0, 0);
            let (a, size) = ((lo - 2).as_vec3(), (hi - lo + 4).as_vec3());
            for _ in 0..100_000 {
                let q = a + size * Vec3::new(s.next_f32(), s.next_f32(), s.next_f32());
                let (d, b) = (dense.density_index(q), bricks.density_index(q));
                assert_eq!(d.to_bits(), b.to_bits(), "{file} {name} at {q}: {d} vs {b}");
            }
            let cells = (dense.dims + 2 + MAJORANT_CELL - 1) / MAJORANT_CELL;
            let start = dense.origin - 1;
            let want = majorants_voxel_by_voxel(&dense, start, cells);
            assert_eq!(dense.majorants(start, cells), want, "{file}");
            assert_eq!(bricks.majorants(start, cells), want, "{file}");
        }
    }

    /// The majorants as their definition reads: each cell's range, voxel by voxel.
    fn majorants_voxel_by_voxel(g: &DensityGrid, lo: IVec3, cells: IVec3) -> Blocked<f32> {
        Blocked::from_fn(cells, |cell| {
            let base = lo + cell * MAJORANT_CELL;
            let mut v = 0.0f32;
            for z in 0..=MAJORANT_CELL {
                for y in 0..=MAJORANT_CELL {
                    for x in 0..=MAJORANT_CELL {
                        v = v.max(g.voxel(base + IVec3::new(x, y, z)));
                    }
                }
            }
            v
        })
    }

    /// One constant 2048³ region stored as OpenVDB tiles (a 9 KB file, tests/fuzz-corpus/cli):
    /// its brick table and its majorants hold a few uniform blocks, not an entry per brick and a
    /// value per cell (issue 37: 64 MB each, and 59 s to find majorants voxel by voxel).
    #[test]
    fn a_constant_region_of_tiles_costs_a_few_values() {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-corpus/cli/tiles-2048.vdb");
        let g = DensityGrid::load(&path, "density").unwrap();
        assert_eq!((g.layout(), g.active_voxels), (Layout::Bricks, 1 << 33));
        assert!(g.stored_bytes() < 1 << 20, "{} bytes", g.stored_bytes());
        for (q, v) in
            [([0, 0, 0], 1.0), ([2047, 1000, 3], 1.0), ([2048, 0, 0], 0.0), ([-1, 5, 5], 0.0)]
        {
            assert_eq!(g.voxel(IVec3::from(q)), v, "{q:?}");
        }
        let cells = IVec3::splat((2048 + 2 + MAJORANT_CELL - 1) / MAJORANT_CELL);
        let m = g.majorants(IVec3::splat(-1), cells);
        assert!(m.bytes() < 1 << 20, "majorants: {} bytes", m.bytes());
        assert_eq!(
            (m.get(IVec3::ZERO), m.get(IVec3::splat(100)), m.get(cells - 1)),
            (1.0, 1.0, 1.0)
        );
    }

    /// Tiles are stored as one value per brick: the tiles file's bricks take a few hundred KB
    /// where its dense box would take 64 MiB, and the holes grid's bricks less than half its
    /// dense array.
    #[test]
    fn bricks_store_sparse_grids_in_proportion_to_what_they_hold() {
        let tiles = DensityGrid::load_with(&media("tiles.vdb"), "density", Layout::Bricks).unwrap();
        assert_eq!(tiles.active_voxels, 32 * 32 * 32 + 128 * 128 * 128 + 20);
        assert!(tiles.stored_bytes() < 300_000, "{} bytes", tiles.stored_bytes());
        assert_eq!(tiles.voxel(IVec3::new(5, 30, 17)), 2.0);
        assert_eq!(tiles.voxel(IVec3::new(200, 129, 255)), 0.5);
        assert_eq!(tiles.voxel(IVec3::new(45, 4, 4)), 3.0);
        assert_eq!(tiles.voxel(IVec3::new(45, 5, 4)), 0.0);
        assert_eq!(tiles.voxel(IVec3::new(100, 100, 100)), 0.0);
        let dense = DensityGrid::load_with(&media("holes.vdb"), "density", Layout::Dense).unwrap();
        let bricks =
            DensityGrid::load_with(&media("holes.vdb"), "density", Layout::Bricks).unwrap();
        assert!(2 * bricks.stored_bytes() < dense.stored_bytes());
    }
}
