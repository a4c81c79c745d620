//! Beam queries over volume photons: which photons lie within the query radius of a ray segment.
//! A query costs the cells its segment crosses plus the photons in them — about the photons it
//! finds, not the photons stored.
//!
//! The structure is a dense uniform grid over the photons' bounds, walked along the ray with a
//! 3-D DDA (Amanatides & Woo 1987). Every photon is entered in each cell that its kernel sphere
//! overlaps (at most 27). Cells are numbered x-fastest and their entries stored in that order, so
//! the cells a ray visits lie close together in memory (a hashed grid was 2–3× slower here: every
//! cell visit was a cache miss). A query visits the cells the segment passes through, each for its own interval
//! [t_in, t_out) of the ray, and takes a photon from a cell only if its projection t_p onto the ray
//! falls in that interval. The point of the ray nearest a photon lies in exactly one visited cell,
//! and a photon within the radius overlaps that cell, so every photon is found exactly once without
//! any bookkeeping; the order of the photons found depends only on the ray, so the sums are the
//! same whatever the thread count.
//!
//! Cells are at least twice the radius and hold a few photons on average; buffers are reused
//! between iterations.

use super::VolumePhoton;
use crate::rng::{Purpose, Sampler};
use glam::{IVec3, Vec3, Vec4};
use rayon::prelude::*;

/// Mean photons per cell the cell size aims for when the radius is small.
const PHOTONS_PER_CELL: f32 = 4.0;

/// Most cells in the grid (4 bytes each in the cell table).
const MAX_CELLS: f32 = (1 << 22) as f32;

/// Russian-roulette thinning of dense photon cells, which bounds the cost of a beam query where
/// photons crowd (near a light inside a medium, in a volumetric caustic) without changing the
/// expected estimate.
///
/// A photon whose centre lies in a cell holding n > `budget` photons is kept with probability
/// p = budget / n, and its power is divided by p. The decision uses a random number of its own,
/// keyed by (seed, iteration, photon index), independent of everything else once the photons are
/// placed; so, given the photons, its expected contribution to any query is exactly its
/// contribution without thinning, and the estimate stays unbiased (its variance grows where photons
/// were dropped). A cell then holds about `budget` photons of its own, and a query visits at most
/// the photons entered from 27 such cells per cell.
#[derive(Clone, Copy, Debug)]
pub struct Thinning {
    /// Photons a cell may hold before it is thinned.
    pub budget: u32,
    /// Render seed.
    pub seed: u64,
    /// Iteration (1-based).
    pub iteration: u64,
}

/// The beam-query structure.
#[derive(Default)]
pub struct BeamMap {
    photons: Vec<VolumePhoton>,
    /// Cell entries, grouped by cell: the photon's position (read first) and its index.
    entry_x: Vec<f32>,
    entry_y: Vec<f32>,
    entry_z: Vec<f32>,
    entry_idx: Vec<u32>,
    /// start[c]..start[c + 1] are cell c's entries.
    start: Vec<u32>,
    dims: IVec3,
    cell: f32,
    inv_cell: f32,
    radius: f32,
    lo: Vec3,
    scratch: Vec<(u32, u32)>,
    order: Vec<(u32, u32)>,
}

impl BeamMap {
    /// An empty map.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of photons stored.
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    /// True if empty.
    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    /// Index of cell `c` (which must lie in the grid).
    #[inline]
    fn index(&self, c: IVec3) -> usize {
        (c.x + self.dims.x * (c.y + self.dims.y * c.z)) as usize
    }

    /// Cell coordinates of `p`, clamped to the grid.
    #[inline]
    fn cell_of(&self, p: Vec3) -> IVec3 {
        ((p - self.lo) * self.inv_cell).floor().as_ivec3().clamp(IVec3::ZERO, self.dims - 1)
    }

    /// Rebuilds the grid over `photons` for queries of radius `radius`, storing each photon with
    /// its power replaced by `weight(photon)` (the beam estimate stores β·σ_s(x_p) here, so that
    /// σ_s is looked up once per photon rather than once per ray that finds it).
    pub fn build(
        &mut self,
        photons: &[VolumePhoton],
        radius: f32,
        thinning: Option<Thinning>,
        weight: impl Fn(&VolumePhoton) -> crate::math::Rgb,
    ) {
        self.photons.clear();
        self.entry_x.clear();
        self.entry_y.clear();
        self.entry_z.clear();
        self.entry_idx.clear();
        self.radius = radius;
        if photons.is_empty() {
            return;
        }
        let (lo, hi) = photons
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p.p), hi.max(p.p)));
        self.lo = lo - Vec3::splat(radius);
        let extent = (hi + Vec3::splat(radius) - self.lo).max(Vec3::splat(1e-6));
        // The photons' typical spacing, from the volume holding the central 90% of them along
        // each axis (a few stray photons far away must not make every cell huge).
        let mut coord: Vec<f32> = Vec::with_capacity(photons.len());
        let mut core = Vec3::ZERO;
        for axis in 0..3 {
            coord.clear();
            coord.extend(photons.iter().map(|p| p.p[axis]));
            let n = coord.len();
            let a = *coord.select_nth_unstable_by(n / 20, f32::total_cmp).1;
            let b = *coord.select_nth_unstable_by(n - 1 - n / 20, f32::total_cmp).1;
            core[axis] = (b - a).max(radius).max(1e-6 * extent.max_element());
        }
        let volume = core.x * core.y * core.z / 0.9f32.powi(3);
        let spacing = (PHOTONS_PER_CELL * volume / photons.len() as f32).cbrt();
        // At least twice the radius, and no more than MAX_CELLS cells in all.
        let cap = (extent.x * extent.y * extent.z / MAX_CELLS).cbrt();
        self.cell = spacing.max(2.0 * radius).max(cap) * 1.0001;
        self.inv_cell = 1.0 / self.cell;
        self.dims = (extent * self.inv_cell).ceil().as_ivec3().max(IVec3::ONE);
        let cells = (self.dims.x * self.dims.y * self.dims.z) as usize;
        // Enter each photon in every cell its (slightly grown) sphere overlaps.
        let grow = radius * 1.001 + 1e-6 * extent.max_element();
        let mut pairs = std::mem::take(&mut self.scratch);
        pairs.clear();
        // Keep the photons in the order of the cells their centres lie in, so that the photons a
        // cell refers to sit together in memory. (cell, index) keys are unique: the order does
        // not depend on the thread count.
        let mut order = std::mem::take(&mut self.order);
        order.clear();
        order.extend(
            photons
                .iter()
                .enumerate()
                .map(|(i, p)| (self.index(self.cell_of(p.p)) as u32, i as u32)),
        );
        order.par_sort_unstable();
        // `order` is sorted by cell: each run of equal keys is one cell's photons.
        for run in order.chunk_by(|a, b| a.0 == b.0) {
            let keep = thinning.map_or(1.0, |t| (t.budget as f64 / run.len() as f64).min(1.0));
            for &(_, i) in run {
                let p = &photons[i as usize];
                if let Some(t) = thinning.filter(|_| keep < 1.0) {
                    let mut u = Sampler::new(t.seed, Purpose::Thinning, t.iteration, i as u64);
                    if u.next_f32() as f64 >= keep {
                        continue;
                    }
                }
                let beta = weight(p) * (1.0 / keep) as f32;
                self.photons.push(VolumePhoton { beta, ..*p });
            }
        }
        self.order = order;
        let photons = &self.photons;
        for (i, ph) in photons.iter().enumerate() {
            let a = self.cell_of(ph.p - Vec3::splat(grow));
            let b = self.cell_of(ph.p + Vec3::splat(grow));
            for z in a.z..=b.z {
                for y in a.y..=b.y {
                    for x in a.x..=b.x {
                        pairs.push((self.index(IVec3::new(x, y, z)) as u32, i as u32));
                    }
                }
            }
        }
        // Counting sort of the entries by cell (stable: photon order within a cell).
        super::bucket_starts(pairs.iter().map(|&(k, _)| k), cells, &mut self.start);
        for v in [&mut self.entry_x, &mut self.entry_y, &mut self.entry_z] {
            v.resize(pairs.len(), 0.0);
        }
        self.entry_idx.resize(pairs.len(), 0);
        let mut cursor = self.start[..cells].to_vec();
        for &(k, i) in &pairs {
            let slot = cursor[k as usize] as usize;
            cursor[k as usize] += 1;
            let p = photons[i as usize].p;
            (self.entry_x[slot], self.entry_y[slot], self.entry_z[slot]) = (p.x, p.y, p.z);
            self.entry_idx[slot] = i;
        }
        self.scratch = pairs;
    }

    /// Calls `f(photon, t_p, d²)` for every photon whose projection onto the ray o + t d (d unit)
    /// falls at 0 < t_p < `t_max` within the build radius of the ray; d² is its squared distance
    /// to the ray.
    pub fn query(&self, o: Vec3, d: Vec3, t_max: f32, mut f: impl FnMut(&VolumePhoton, f32, f32)) {
        if self.photons.is_empty() {
            return;
        }
        let r2 = self.radius * self.radius;
        let r2v = Vec4::splat(r2);
        let (ox, oy, oz) = (Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z));
        let (dx, dy, dz) = (Vec4::splat(d.x), Vec4::splat(d.y), Vec4::splat(d.z));
        // Walk the cells in grid coordinates, where cell k spans [k, k + 1).
        let og = (o - self.lo) * self.inv_cell;
        let dg = d * self.inv_cell;
        crate::dda::walk(og, dg, t_max, self.dims, |cell, t_in, t_out| {
            let b = self.index(cell);
            let (s, e) = (self.start[b] as usize, self.start[b + 1] as usize);
            // Four entries at a time (SSE through glam's Vec4), the rare hits one by one.
            let (xs, ys, zs) = (&self.entry_x[s..e], &self.entry_y[s..e], &self.entry_z[s..e]);
            let mut j = 0;
            while j + 4 <= xs.len() {
                let vx = Vec4::from_slice(&xs[j..j + 4]) - ox;
                let vy = Vec4::from_slice(&ys[j..j + 4]) - oy;
                let vz = Vec4::from_slice(&zs[j..j + 4]) - oz;
                let t = vx * dx + vy * dy + vz * dz;
                let d2 = vx * vx + vy * vy + vz * vz - t * t;
                let inside = d2.cmplt(r2v)
                    & t.cmpge(Vec4::splat(t_in.max(0.0)))
                    & t.cmplt(Vec4::splat(t_out));
                let mut mask = inside.bitmask();
                while mask != 0 {
                    let k = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    let (tk, dk) = (t[k], d2[k]);
                    if tk > 0.0 {
                        f(&self.photons[self.entry_idx[s + j + k] as usize], tk, dk.max(0.0));
                    }
                }
                j += 4;
            }
            for k in j..xs.len() {
                let v = Vec3::new(xs[k], ys[k], zs[k]) - o;
                let t = v.dot(d);
                let d2 = v.length_squared() - t * t;
                if d2 < r2 && t >= t_in && t < t_out && t > 0.0 {
                    f(&self.photons[self.entry_idx[s + k] as usize], t, d2.max(0.0));
                }
            }
            true
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, Sampler};

    #[test]
    fn beam_query_finds_exactly_the_photons_near_the_segment() {
        let mut s = Sampler::new(3, Purpose::Other, 0, 0);
        let photons: Vec<VolumePhoton> = (0..20_000)
            .map(|i| VolumePhoton {
                p: Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * 2.0 - 1.0,
                medium: i % 3,
                ..Default::default()
            })
            .collect();
        let mut map = BeamMap::new();
        for r in [0.003f32, 0.01, 0.05, 0.2] {
            map.build(&photons, r, None, |p| p.beta);
            for q in 0..60 {
                let o = Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * 3.0 - 1.5;
                let d = match q {
                    0 => Vec3::Z,
                    1 => -Vec3::X,
                    2 => Vec3::new(1.0, 1.0, 0.0).normalize(),
                    _ => crate::math::sample_uniform_sphere(s.next_2d()),
                };
                let t_max = if q % 5 == 0 { f32::INFINITY } else { 1.5 };
                let mut found = Vec::new();
                map.query(o, d, t_max, |ph, _, _| found.push(ph.p));
                let want: Vec<Vec3> = photons
                    .iter()
                    .filter(|ph| {
                        let v = ph.p - o;
                        let t = v.dot(d);
                        t > 0.0 && t < t_max && v.length_squared() - t * t < r * r
                    })
                    .map(|ph| ph.p)
                    .collect();
                assert_eq!(found.len(), want.len(), "r = {r}, query {q}");
                for p in &want {
                    assert!(found.contains(p), "r = {r}, query {q}: missed {p}");
                }
            }
        }
    }
}
