//! A hashed uniform grid over photon positions for fixed-radius queries, rebuilt every iteration
//! into buffers it keeps, so memory does not grow over a render.
//!
//! The cell size is twice the query radius, so a query ball overlaps at most 2 × 2 × 2 cells.
//! Cells are hashed into a table of 2ⁿ ≥ 2·(photon count) buckets; photons are counting-sorted
//! by bucket, which keeps the build O(N) and deterministic (stable in photon order).

use super::Located;
use super::sort::CountingSort;
use glam::{IVec3, Vec3};
use rayon::prelude::*;

/// The photon grid.
pub struct PhotonGrid<P> {
    /// The radius the grid was built for: its gathers' radius.
    radius: f32,
    inv_cell: f32,
    mask: usize,
    /// start[b]..start[b + 1] indexes `photons` for bucket b.
    start: Vec<u32>,
    photons: Vec<P>,
    keys: Vec<u32>,
    /// With tracking on, the index in the built list of the photon in each slot.
    origin: Vec<u32>,
    track: bool,
    sort: CountingSort,
}

impl<P> Default for PhotonGrid<P> {
    fn default() -> Self {
        Self {
            radius: 0.0,
            inv_cell: 1.0,
            mask: 0,
            start: Vec::new(),
            photons: Vec::new(),
            keys: Vec::new(),
            origin: Vec::new(),
            track: false,
            sort: CountingSort::default(),
        }
    }
}

#[inline]
fn hash(c: IVec3) -> usize {
    let h = (c.x as u32).wrapping_mul(73_856_093)
        ^ (c.y as u32).wrapping_mul(19_349_663)
        ^ (c.z as u32).wrapping_mul(83_492_791);
    // One more mixing round: the raw xor of products clusters on regular grids.
    (h ^ (h >> 15)).wrapping_mul(0x2c1b_3c6d) as usize
}

impl<P: Located + Copy + Default + Send + Sync> PhotonGrid<P> {
    /// An empty grid.
    #[cfg(test)]
    pub fn new() -> Self {
        Self::default()
    }

    /// Rebuilds the grid over `photons` for queries of radius `radius`.
    pub fn build(&mut self, photons: &[P], radius: f32) {
        self.radius = radius;
        let cell = (2.0 * radius).max(1e-20);
        self.inv_cell = 1.0 / cell;
        let buckets = (2 * photons.len()).next_power_of_two().max(16);
        self.mask = buckets - 1;
        let mut keys = std::mem::take(&mut self.keys);
        let key = |ph: &P| self.bucket(self.cell_of(ph.position())) as u32;
        crate::buffers::collect(&mut keys, photons.par_iter().map(key));
        // `origin[slot]` is the photon that goes to the slot (kept only with tracking on).
        let mut origin = std::mem::take(&mut self.origin);
        self.sort.sort(&keys, buckets, &mut self.start, &mut origin);
        crate::buffers::collect(&mut self.photons, origin.par_iter().map(|&i| photons[i as usize]));
        if !self.track {
            origin.clear();
        }
        (self.keys, self.origin) = (keys, origin);
    }

    /// Keep, from the next build on, which photon of the built list each slot holds
    /// ([`Self::origin`]); off by default.
    pub fn set_tracking(&mut self, on: bool) {
        self.track = on;
    }

    /// The photons held (slots 0..len).
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    /// The index in the built list of the photon in `slot` (with tracking on).
    pub fn origin(&self, slot: usize) -> usize {
        self.origin[slot] as usize
    }

    #[inline]
    fn cell_of(&self, p: Vec3) -> IVec3 {
        (p * self.inv_cell).floor().as_ivec3()
    }

    #[inline]
    fn bucket(&self, c: IVec3) -> usize {
        hash(c) & self.mask
    }

    /// The radius the grid was last built for.
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// Calls `f(photon, squared distance)` for every photon within `radius` of `p`. `radius`
    /// must not exceed the radius the grid was built for.
    #[inline]
    pub fn query(&self, p: Vec3, radius: f32, mut f: impl FnMut(&P, f32)) {
        self.query_slots(p, radius, |ph, _, d2| f(ph, d2));
    }

    /// [`Self::query`], also passing each photon's slot.
    #[inline]
    pub fn query_slots(&self, p: Vec3, radius: f32, mut f: impl FnMut(&P, usize, f32)) {
        debug_assert!(radius <= self.radius, "query radius {radius} > built {}", self.radius);
        if self.photons.is_empty() {
            return;
        }
        let r2 = radius * radius;
        // Lower corner of the 2×2×2 block of cells touching the ball.
        let lo = ((p - Vec3::splat(radius)) * self.inv_cell).floor().as_ivec3();
        let hi = ((p + Vec3::splat(radius)) * self.inv_cell).floor().as_ivec3();
        let mut seen = [usize::MAX; 8];
        let mut n_seen = 0;
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    let b = self.bucket(IVec3::new(x, y, z));
                    // Two cells may hash to one bucket: visit each bucket once.
                    if seen[..n_seen].contains(&b) {
                        continue;
                    }
                    if n_seen < seen.len() {
                        seen[n_seen] = b;
                        n_seen += 1;
                    }
                    let (s, e) = (self.start[b] as usize, self.start[b + 1] as usize);
                    crate::work::found((e - s) as u64);
                    for (k, ph) in self.photons[s..e].iter().enumerate() {
                        let d2 = (ph.position() - p).length_squared();
                        if d2 < r2 {
                            f(ph, s + k, d2);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::Photon;
    use crate::rng::{Purpose, Sampler};

    #[test]
    fn query_finds_exactly_the_photons_in_the_ball() {
        let mut s = Sampler::new(1, Purpose::Other, 0, 0);
        let photons: Vec<Photon> = (0..5000)
            .map(|_| Photon {
                p: Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * 4.0 - 2.0,
                ..Default::default()
            })
            .collect();
        let mut grid = PhotonGrid::new();
        for r in [0.05f32, 0.2, 0.7] {
            grid.build(&photons, r);
            for q in 0..50 {
                let c = photons[q * 7].p + Vec3::new(0.01, -0.02, 0.03);
                let mut found = 0;
                grid.query(c, r, |_, _| found += 1);
                let want = photons.iter().filter(|ph| (ph.p - c).length_squared() < r * r).count();
                assert_eq!(found, want, "r={r} q={q}");
            }
        }
    }
}
