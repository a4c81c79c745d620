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

    /// Multiplies every value by `k`.
    pub(crate) fn scale_values(&mut self, k: f32) {
        if k == 1.0 {
            return;
        }
        let values = match std::sync::Arc::make_mut(&mut self.storage) {
            Storage::Dense(d) => d.as_mut_slice(),
            Storage::Bricks(b) => {
                b.constants.iter_mut().for_each(|c| *c *= k);
                b.pool.as_mut_slice()
            }
        };
        // Each value on its own: the same products in any order (cumulus: 3.7 ms on one thread).
        use rayon::prelude::*;
        values.par_iter_mut().with_min_len(1 << 14).for_each(|v| *v *= k);
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
mod tests {
    use super::super::vdbscan::Input;
    use super::*;
    use std::path::Path;

    /// A corrupt file with two root nodes at one origin, a 128³ tile of 1 in the first and a leaf
    /// with a voxel of 2 at the origin in the second (tests/fuzz-corpus/vdb/tile-overlap.vdb:
    /// pyopenvdb wrote the tile at the origin and the voxel at (4096, 0, 0), then the second root
    /// node's origin was patched to (0, 0, 0)): the bricks layout stores it as the dense one does,
    /// the voxel over the tile, instead of indexing its pool with the tile's table entry.
    #[test]
    fn a_voxel_in_a_tile_is_stored_alike_in_both_layouts() {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-corpus/vdb/tile-overlap.vdb");
        let dense = DensityGrid::load_with(&path, "density", Layout::Dense).unwrap();
        let bricks = DensityGrid::load_with(&path, "density", Layout::Bricks).unwrap();
        assert!(matches!(*bricks.storage, Storage::Bricks(_)));
        for (i, v) in [(IVec3::ZERO, 2.0), (IVec3::new(1, 0, 0), 1.0), (IVec3::splat(127), 1.0)] {
            assert_eq!((dense.voxel(i), bricks.voxel(i)), (v, v), "voxel {i}");
        }
        assert_eq!(bricks.voxel(IVec3::splat(128)), 0.0);
    }

    /// The libm-free floor is `f32::floor`, bit for bit but for the sign of a zero: at and
    /// around integers, over the range a grid index takes, at the limits of exactness and
    /// beyond, and for non-finite values.
    #[test]
    fn floor_without_libm_is_floor() {
        let mut xs = vec![0.0f32, -0.0, 0.5, -0.5, 1.0, -1.0, 8_388_607.5, -8_388_607.5];
        xs.extend([8_388_608.0, -8_388_608.0, 3e9, -3e9, f32::MAX, f32::MIN]);
        xs.extend([f32::INFINITY, f32::NEG_INFINITY, f32::MIN_POSITIVE, -f32::MIN_POSITIVE]);
        for k in -3000..3000 {
            let x = k as f32 * 0.37;
            // The floats beside x and below k (x ≠ 0: one step of the bit pattern away from 0).
            let (up, down) = (
                |v: f32| f32::from_bits(v.to_bits() + 1),
                |v: f32| f32::from_bits(v.to_bits() - 1),
            );
            let kf = k as f32;
            xs.extend([x, kf]);
            if x != 0.0 {
                xs.extend([up(x), down(x), down(kf)]);
            }
        }
        for x in xs {
            let (got, want) = (floor(Vec3::splat(x)).x, x.floor());
            assert!(got == want && (got != 0.0 || want == 0.0), "floor({x}) = {got}, not {want}");
        }
        assert!(floor(Vec3::splat(f32::NAN)).x.is_nan());
    }

    use crate::testing::temp_dir;
    use std::path::PathBuf;

    fn media(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("media").join(name)
    }

    #[test]
    fn good_grids_load_with_their_values() {
        let b = DensityGrid::load(&media("box.vdb"), "density").unwrap();
        assert_eq!(b.dims, IVec3::splat(16));
        let (lo, hi) = b.active_box;
        assert_eq!((lo, hi), (IVec3::ZERO, IVec3::splat(15)));
        assert_eq!(b.active_voxels, 16 * 16 * 16);
        assert_eq!(b.max_density, 1.0);
        assert_eq!(b.voxel(IVec3::new(3, 15, 7)), 1.0);
        assert!((b.voxel_size - Vec3::splat(1.0 / 16.0)).abs().max_element() < 1e-7);
        assert_eq!(b.translation, Vec3::ZERO);

        let g = DensityGrid::load(&media("gradient.vdb"), "density").unwrap();
        assert_eq!(g.dims, IVec3::new(32, 16, 16));
        for i in 0..32 {
            assert_eq!(g.voxel(IVec3::new(i, 3, 5)), (i as f32 + 0.5) / 32.0);
        }
        // Trilinear interpolation between voxel centres; zero outside.
        let q = Vec3::new(10.25, 3.0, 5.0);
        assert!((g.density_index(q) - (10.25 + 0.5) / 32.0).abs() < 1e-6);
        assert_eq!(g.voxel(IVec3::new(40, 0, 0)), 0.0);

        let h = DensityGrid::load(&media("holes.vdb"), "density").unwrap();
        assert_eq!(h.voxel(IVec3::new(5, 5, 5)), 8.0);
        assert_eq!(h.voxel(IVec3::new(21, 30, 30)), 40.0);
        assert_eq!(h.voxel(IVec3::new(25, 25, 25)), 0.0);
        assert_eq!(h.max_density, 40.0);

        let c = DensityGrid::load(&media("cloud.vdb"), "density").unwrap();
        assert!(c.max_density > 0.5 && c.max_density <= 1.0);
        assert!((c.translation - Vec3::splat(-1.0)).abs().max_element() < 1e-6);
    }

    fn expect_error(path: &Path, grid: &str, needles: &[&str]) {
        let msg = match DensityGrid::load(path, grid) {
            Ok(_) => panic!("{} loaded", path.display()),
            Err(e) => e.to_string(),
        };
        assert!(msg.contains(&path.display().to_string()), "`{msg}` does not name the file");
        for n in needles {
            assert!(msg.contains(n), "`{msg}` does not mention `{n}`");
        }
    }

    /// Every voxel of `half` is that of `full` rounded to a 16-bit float (OpenVDB and the `half`
    /// crate both round to nearest even), in the same box and transform.
    fn assert_half_of(half: &DensityGrid, full: &DensityGrid) {
        assert_voxels_of(half, full, |v| half::f16::from_f32(v).to_f32());
    }

    /// `got` has `want`'s box, placement and active voxels, and every voxel of the box is
    /// `round` of `want`'s, bit for bit.
    fn assert_voxels_of(got: &DensityGrid, want: &DensityGrid, round: fn(f32) -> f32) {
        assert_eq!((got.origin, got.dims), (want.origin, want.dims));
        assert_eq!((got.translation, got.voxel_size), (want.translation, want.voxel_size));
        assert_eq!(got.active_voxels, want.active_voxels);
        let (lo, hi) = want.active_box;
        let mut nonzero = 0;
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    let p = IVec3::new(x, y, z);
                    let want = round(want.voxel(p));
                    assert_eq!(got.voxel(p).to_bits(), want.to_bits(), "voxel {p}");
                    nonzero += (want > 0.0) as usize;
                }
            }
        }
        assert!(nonzero > 500, "{nonzero} voxels compared");
    }

    /// The components of a 3-vector grid (`albedo[k]` of media/vector.vdb, as Houdini and
    /// Blender write colour) read as the float grids they were made from (albedo.vdb's
    /// `albedo.r`, `.g`, `.b`): every voxel bit for bit in full floats, rounded to half in
    /// half/vector.vdb (6 bytes a value). A decoder that took the wrong component or stride fails
    /// it; vector grids without a component and components of float grids are refused by name.
    #[test]
    fn vector_grids_read_component_by_component() {
        for (k, channel) in ["albedo.r", "albedo.g", "albedo.b"].iter().enumerate() {
            let float = DensityGrid::load(&media("albedo.vdb"), channel).unwrap();
            let name = format!("albedo[{k}]");
            let full = DensityGrid::load(&media("vector.vdb"), &name).unwrap();
            assert_eq!(full.active_voxels, 4096);
            assert_voxels_of(&full, &float, |v| v);
            let half = DensityGrid::load(&media("half/vector.vdb"), &name).unwrap();
            assert_half_of(&half, &float);
        }
        expect_error(&media("vector.vdb"), "albedo", &["vector grid", "`albedo[0]`"]);
        expect_error(&media("vector.vdb"), "density[1]", &["not a vector grid"]);
        expect_error(&media("vector.vdb"), "albedo[3]", &["no grid named `albedo[3]`"]);
        expect_error(&media("bad/vector.vdb"), "density", &["vector grid"]);
    }

    #[test]
    fn half_float_grids_are_their_full_float_sources_rounded() {
        // vdb-rs 0.6 fails on every one of these (it reads a block size where OpenVDB wrote
        // none); haze decodes them itself.
        let cloud = DensityGrid::load(&media("cloud.vdb"), "density").unwrap();
        for codec in ["zip", "blosc", "none"] {
            let h = DensityGrid::load(&media(&format!("half/cloud-{codec}.vdb")), "density");
            assert_half_of(&h.unwrap(), &cloud);
        }
        // Tiles (a 128³ internal-node tile and leaf-level tiles) stored as half floats.
        for layout in [Layout::Dense, Layout::Bricks] {
            let full = DensityGrid::load_with(&media("tiles.vdb"), "density", layout).unwrap();
            let h = DensityGrid::load_with(&media("half/tiles-blosc.vdb"), "density", layout);
            let h = h.unwrap();
            assert_eq!(h.layout(), layout);
            assert_half_of(&h, &full);
        }
        // pyopenvdb's saveFloatAsHalf with the library's default codec.
        let cube = DensityGrid::load(&media("half/cube.vdb"), "density").unwrap();
        assert_eq!((cube.active_voxels, cube.max_density), (512, 0.5));
        assert_eq!(cube.voxel(IVec3::new(7, 0, 3)), 0.5);
    }

    /// haze's reader against vdb-rs 0.6 as an oracle, on every full-float grid of every bundled
    /// file (zip and Blosc, leaves and tiles at both internal levels): the same active voxels
    /// and tiles with the same values, bit for bit — and the same from a file as from its bytes
    /// in memory. A decoder that misplaced or misread one value would fail it.
    #[test]
    fn the_reader_reads_every_value_as_vdb_rs_does() {
        let mut grids = 0;
        for file in ["albedo", "box", "cloud", "cumulus", "fire", "gradient", "holes", "tiles"] {
            let path = media(&format!("{file}.vdb"));
            let bytes = std::fs::read(&path).unwrap();
            let mut vdb = vdb_rs::VdbReader::new(std::io::Cursor::new(&bytes[..])).unwrap();
            let mut names = vdb.available_grids();
            names.sort();
            for name in names {
                if vdb.grid_descriptors[&name].grid_type != "Tree_float_5_4_3" {
                    continue;
                }
                grids += 1;
                let grid = vdb.read_grid::<f32>(&name).unwrap();
                let mut oracle: Vec<([i32; 3], i32, u32)> = grid
                    .iter()
                    .map(|(p, v, level)| {
                        ([p.x as i32, p.y as i32, p.z as i32], level.scale() as i32, v.to_bits())
                    })
                    .collect();
                oracle.sort();
                for input in [Input::File(&path), Input::Memory(&bytes)] {
                    let mut ours = Vec::new();
                    let mut push =
                        |p: [i32; 3], edge: i32, v: f32| ours.push((p, edge, v.to_bits()));
                    super::super::vdbscan::for_each_value(input, &name, 0, &mut push).unwrap();
                    ours.sort();
                    assert_eq!(ours.len(), oracle.len(), "{file}.vdb `{name}`");
                    assert!(ours == oracle, "{file}.vdb `{name}`: values differ");
                }
            }
        }
        assert!(grids >= 10, "only {grids} grids compared");
    }

    #[test]
    fn files_vdb_rs_would_crash_on_or_misread_are_clear_errors() {
        expect_error(&media("bad/vector.vdb"), "density", &["is a vector grid"]);
        expect_error(&media("bad/affine.vdb"), "density", &["AffineMap"]);
        expect_error(&media("bad/duplicate.vdb"), "density", &["share the name"]);
        // One active root-level tile (4096³ voxels, which vdb-rs drops): read, and too large.
        expect_error(&media("bad/root-tile.vdb"), "density", &["4096×4096×4096 voxels"]);
        expect_error(
            &media("bad/far-apart.vdb"),
            "density",
            &["dense copy", "2048³ voxels for bricks"],
        );
        expect_error(&media("box.vdb"), "smoke", &["no grid named `smoke`", "density"]);
        expect_error(&media("no-such-file.vdb"), "density", &["No such file"]);

        let dir = temp_dir("vdb");
        for file in ["half/cloud-blosc.vdb", "half/cloud-zip.vdb"] {
            let good = std::fs::read(media(file)).unwrap();
            for cut in [200, good.len() / 3, good.len() - 100] {
                let p = dir.join(format!("truncated-half-{cut}.vdb"));
                std::fs::write(&p, &good[..cut]).unwrap();
                expect_error(&p, "density", &["corrupt file at byte"]);
            }
        }
        let good = std::fs::read(media("cloud.vdb")).unwrap();
        for cut in [12, 200, good.len() / 3, good.len() - 100] {
            let p = dir.join(format!("truncated-{cut}.vdb"));
            std::fs::write(&p, &good[..cut]).unwrap();
            expect_error(&p, "density", &[]);
        }
        let mut corrupt = good.clone();
        for (i, b) in corrupt.iter_mut().enumerate().skip(400).step_by(97) {
            *b ^= (i as u8).wrapping_mul(31) | 1;
        }
        let p = dir.join("corrupt.vdb");
        std::fs::write(&p, &corrupt).unwrap();
        // Flipped bytes may or may not be detectable; the load must simply not crash the process.
        let _ = DensityGrid::load(&p, "density");
        let p = dir.join("text.vdb");
        std::fs::write(&p, "not a volume at all").unwrap();
        expect_error(&p, "density", &["not an OpenVDB file"]);
        expect_error(&dir, "density", &["is a directory"]);
        expect_error(Path::new("/dev/zero"), "density", &["not a regular file"]);
    }

    /// The one-byte corruptions of issue 13 (media/README.md) on which vdb-rs 0.6 asked for
    /// 10¹⁷–10¹⁸ bytes and the process aborted.
    #[test]
    fn corrupt_counts_are_refused_before_anything_is_allocated() {
        // Compressed blocks' lengths of 2⁵⁹ and 6·10¹⁸ bytes: refused before they are read (or
        // allocated).
        let holes = "corrupt file at byte 0x230d: a compressed block of 576460752303423504 bytes";
        expect_error(&media("bad/holes-0x230c.vdb"), "density", &[holes]);
        let cloud = "corrupt file at byte 0x3b3d7: a compressed block of 6845471433603155626 bytes";
        expect_error(&media("bad/cloud-0x3b3d6.vdb"), "density", &[cloud]);
        expect_error(&media("bad/box-0xec.vdb"), "density", &["corrupt file at byte", "remain"]);
        // Found by the `vdb` fuzz target: a Blosc header claiming more compressed bytes than its
        // block holds made c-blosc read past the buffer (AddressSanitizer: heap-buffer-overflow).
        expect_error(&media("bad/blosc-cbytes.vdb"), "density", &["Blosc block of 118 bytes"]);
    }

    /// Every byte of box.vdb set to 0x00, 0xff and flipped in turn: each load returns (a grid or
    /// an error). An abort — what vdb-rs 0.6 does on a bad count — would take the test process
    /// down with it, so this test cannot pass by accident.
    #[test]
    fn single_byte_mutations_of_a_grid_never_abort() {
        // A full-float grid and a half-float one (both read by haze's reader).
        for file in ["box.vdb", "half/cube.vdb"] {
            mutate_every_byte(&media(file));
        }
    }

    fn mutate_every_byte(path: &Path) {
        let good = std::fs::read(path).unwrap();
        let dir = temp_dir("vdb-mutations");
        let p = dir.join("m.vdb");
        let (mut ok, mut refused) = (0, 0);
        for i in 0..good.len() {
            for v in [0x00, 0xff, good[i] ^ 0x08] {
                if v == good[i] {
                    continue;
                }
                let mut m = good.clone();
                m[i] = v;
                std::fs::write(&p, &m).unwrap();
                match DensityGrid::load(&p, "density") {
                    Ok(_) => ok += 1,
                    Err(_) => refused += 1,
                }
            }
        }
        assert!(refused > 0 && ok + refused > 2 * good.len(), "{ok} loaded, {refused} refused");
    }
}

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
