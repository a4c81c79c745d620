//! Beam queries over volume photons: which photons lie within the query radius of a ray segment.
//! A query costs the cells its segment crosses plus the photons in them — about the photons it
//! finds, not the photons stored.
//!
//! The structure is a hashed uniform grid walked along the ray with a 3-D DDA (Amanatides & Woo
//! 1987). Every photon is entered in each cell that its kernel sphere overlaps (at most 8, once per
//! hash bucket). A query visits the cells the segment passes through, each for its own interval
//! [t_in, t_out) of the ray, and takes a photon from a cell only if its projection t_p onto the ray
//! falls in that interval. The point of the ray nearest a photon lies in exactly one visited cell,
//! and a photon within the radius overlaps that cell, so every photon is found exactly once without
//! any bookkeeping; the order of the photons found depends only on the ray, so the sums are the
//! same whatever the thread count.
//!
//! Cells are at least twice the radius and hold a few photons on average; buffers are reused
//! between iterations.

use super::VolumePhoton;
use glam::{IVec3, Vec3};

/// Mean photons per cell the cell size aims for when the radius is small.
const PHOTONS_PER_CELL: f32 = 4.0;

#[inline]
fn hash(c: IVec3) -> usize {
    let h = (c.x as u32).wrapping_mul(73_856_093)
        ^ (c.y as u32).wrapping_mul(19_349_663)
        ^ (c.z as u32).wrapping_mul(83_492_791);
    (h ^ (h >> 15)).wrapping_mul(0x2c1b_3c6d) as usize
}

/// The beam-query structure.
#[derive(Default)]
pub struct BeamMap {
    photons: Vec<VolumePhoton>,
    /// Cell entries, grouped by bucket: the photon's position (read first) and its index.
    entry_pos: Vec<Vec3>,
    entry_idx: Vec<u32>,
    /// start[b]..start[b + 1] are bucket b's entries.
    start: Vec<u32>,
    mask: usize,
    cell: f32,
    inv_cell: f32,
    radius: f32,
    lo: Vec3,
    hi: Vec3,
    scratch: Vec<(u32, u32)>,
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

    #[inline]
    fn bucket(&self, c: IVec3) -> usize {
        hash(c) & self.mask
    }

    /// Rebuilds the grid over `photons` for queries of radius `radius`.
    pub fn build(&mut self, photons: &[VolumePhoton], radius: f32) {
        self.photons.clear();
        self.photons.extend_from_slice(photons);
        self.entry_pos.clear();
        self.entry_idx.clear();
        self.radius = radius;
        if photons.is_empty() {
            return;
        }
        let (lo, hi) = photons
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.p), hi.max(p.p))
            });
        self.lo = lo - Vec3::splat(radius);
        self.hi = hi + Vec3::splat(radius);
        let extent = (self.hi - self.lo).max(Vec3::splat(1e-6));
        // The photons' typical spacing, from the volume holding the central 90% of them along
        // each axis (a few stray photons far away must not make every cell huge).
        let mut coord: Vec<f32> = Vec::with_capacity(photons.len());
        let mut core = Vec3::ZERO;
        for axis in 0..3 {
            coord.clear();
            coord.extend(photons.iter().map(|p| p.p[axis]));
            let n = coord.len();
            let a = *coord.select_nth_unstable_by(n / 20, f32::total_cmp).1;
            let b = *coord
                .select_nth_unstable_by(n - 1 - n / 20, f32::total_cmp)
                .1;
            core[axis] = (b - a).max(radius).max(1e-6 * extent.max_element());
        }
        let volume = core.x * core.y * core.z / 0.9f32.powi(3);
        let spacing = (PHOTONS_PER_CELL * volume / photons.len() as f32).cbrt();
        // At least twice the radius, and no more than about 2^20 cells per axis.
        self.cell = spacing
            .max(2.0 * radius)
            .max(extent.max_element() / 1_000_000.0);
        self.inv_cell = 1.0 / self.cell;
        // Enter each photon in every bucket its (slightly grown) sphere overlaps, once per bucket.
        let grow = radius * 1.001 + 1e-6 * extent.max_element();
        let mut pairs = std::mem::take(&mut self.scratch);
        pairs.clear();
        let mut est = photons.len() * 2;
        est = est.next_power_of_two().max(16);
        self.mask = est - 1;
        for (i, ph) in photons.iter().enumerate() {
            let a = ((ph.p - Vec3::splat(grow)) * self.inv_cell)
                .floor()
                .as_ivec3();
            let b = ((ph.p + Vec3::splat(grow)) * self.inv_cell)
                .floor()
                .as_ivec3();
            let mut seen = [usize::MAX; 27];
            let mut n = 0;
            for z in a.z..=b.z {
                for y in a.y..=b.y {
                    for x in a.x..=b.x {
                        let k = self.bucket(IVec3::new(x, y, z));
                        if !seen[..n].contains(&k) {
                            seen[n] = k;
                            n += 1;
                            pairs.push((k as u32, i as u32));
                        }
                    }
                }
            }
        }
        // Counting sort of the entries by bucket (stable: photon order within a bucket).
        self.start.clear();
        self.start.resize(self.mask + 2, 0);
        for &(k, _) in &pairs {
            self.start[k as usize + 1] += 1;
        }
        for k in 0..=self.mask {
            self.start[k + 1] += self.start[k];
        }
        self.entry_pos.resize(pairs.len(), Vec3::ZERO);
        self.entry_idx.resize(pairs.len(), 0);
        let mut cursor = self.start[..=self.mask].to_vec();
        for &(k, i) in &pairs {
            let slot = cursor[k as usize] as usize;
            cursor[k as usize] += 1;
            self.entry_pos[slot] = photons[i as usize].p;
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
        // Clip the segment to the grid's bounds.
        let inv = |x: f32| if x.abs() < 1e-30 { 1e30 } else { 1.0 / x };
        let inv_d = Vec3::new(inv(d.x), inv(d.y), inv(d.z));
        let t1 = (self.lo - o) * inv_d;
        let t2 = (self.hi - o) * inv_d;
        let t_start = t1.min(t2).max_element().max(0.0);
        let t_end = t1.max(t2).min_element().min(t_max);
        if t_start >= t_end || t_start.is_nan() {
            return;
        }
        let r2 = self.radius * self.radius;
        let p0 = o + d * t_start;
        let mut cell = (p0 * self.inv_cell).floor().as_ivec3();
        let step = IVec3::new(
            if d.x >= 0.0 { 1 } else { -1 },
            if d.y >= 0.0 { 1 } else { -1 },
            if d.z >= 0.0 { 1 } else { -1 },
        );
        let delta = (Vec3::splat(self.cell) * inv_d).abs();
        let boundary = |c: i32, s: i32, axis: usize| -> f32 {
            let edge = (c + if s > 0 { 1 } else { 0 }) as f32 * self.cell;
            let t = (edge - o[axis]) * inv_d[axis];
            if d[axis].abs() < 1e-30 {
                f32::INFINITY
            } else {
                t
            }
        };
        let mut next = Vec3::new(
            boundary(cell.x, step.x, 0),
            boundary(cell.y, step.y, 1),
            boundary(cell.z, step.z, 2),
        );
        let mut t_in = t_start;
        loop {
            let t_out = next.min_element().min(t_end);
            let b = self.bucket(cell);
            let (s, e) = (self.start[b] as usize, self.start[b + 1] as usize);
            for (q, &i) in self.entry_pos[s..e].iter().zip(&self.entry_idx[s..e]) {
                let v = *q - o;
                let t = v.dot(d);
                let d2 = v.length_squared() - t * t;
                if d2 < r2 && t >= t_in && t < t_out && t > 0.0 {
                    f(&self.photons[i as usize], t, d2.max(0.0));
                }
            }
            if t_out >= t_end {
                break;
            }
            // Step along the axis whose boundary comes first.
            if next.x <= next.y && next.x <= next.z {
                cell.x += step.x;
                next.x += delta.x;
            } else if next.y <= next.z {
                cell.y += step.y;
                next.y += delta.y;
            } else {
                cell.z += step.z;
                next.z += delta.z;
            }
            t_in = t_out;
        }
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
            map.build(&photons, r);
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
