//! Beam queries over volume photons: a bounding-volume hierarchy over the photons' kernel spheres,
//! so that a query along a ray segment costs about the photons it finds, not the photons stored.
//!
//! The hierarchy is a linear BVH (Lauterbach et al. 2009): photons are sorted along a 63-bit Morton
//! curve (ties broken by photon index, so the order — and every sum over it — is the same whatever
//! the thread count), cut into leaves of [`LEAF`] consecutive photons, and a complete binary tree
//! of boxes (each leaf's box grown by the query radius) is built bottom-up over the leaves. Nodes
//! live in one array in heap order: node k has children 2k and 2k + 1; leaves start at index P,
//! the leaf count rounded up to a power of two. Buffers are reused between iterations.

use super::VolumePhoton;
use glam::Vec3;
use rayon::prelude::*;

/// Photons per leaf.
pub const LEAF: usize = 8;

#[derive(Clone, Copy, Debug)]
struct Bounds {
    min: Vec3,
    max: Vec3,
}

const EMPTY: Bounds = Bounds { min: Vec3::INFINITY, max: Vec3::NEG_INFINITY };

impl Bounds {
    #[inline]
    fn union(self, o: Bounds) -> Bounds {
        Bounds { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    /// Does the segment o + t d, t ∈ (0, t_max), meet the box? (`inv_d` = 1/d, finite.)
    #[inline]
    fn hit(&self, o: Vec3, inv_d: Vec3, t_max: f32) -> bool {
        let t1 = (self.min - o) * inv_d;
        let t2 = (self.max - o) * inv_d;
        let t_near = t1.min(t2).max_element().max(0.0);
        let t_far = t1.max(t2).min_element().min(t_max);
        t_near <= t_far
    }
}

/// Spreads the low 21 bits of `v` to every third bit.
fn spread(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | (x << 32)) & 0x1f_0000_0000_ffff;
    x = (x | (x << 16)) & 0x1f_0000_ff00_00ff;
    x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
    x = (x | (x << 2)) & 0x1249_2492_4924_9249;
    x
}

/// The beam-query structure.
#[derive(Default)]
pub struct BeamMap {
    photons: Vec<VolumePhoton>,
    /// Photon positions alone, in the same order: the traversal reads only these until a photon
    /// is within the radius, a third of the memory traffic of whole photons.
    positions: Vec<Vec3>,
    nodes: Vec<Bounds>,
    first_leaf: usize,
    radius: f32,
    keys: Vec<(u64, u32)>,
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

    /// Rebuilds the hierarchy over `photons` for queries of radius `radius`.
    pub fn build(&mut self, photons: &[VolumePhoton], radius: f32) {
        self.radius = radius;
        self.photons.clear();
        self.positions.clear();
        self.nodes.clear();
        self.first_leaf = 0;
        if photons.is_empty() {
            return;
        }
        let (lo, hi) = photons.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.p), hi.max(p.p))
        });
        let scale = Vec3::splat(((1u64 << 21) - 1) as f32) / (hi - lo).max(Vec3::splat(1e-30));
        let mut keys = std::mem::take(&mut self.keys);
        photons
            .par_iter()
            .enumerate()
            .map(|(i, p)| {
                let q = ((p.p - lo) * scale).as_uvec3();
                let code = spread(q.x as u64) | (spread(q.y as u64) << 1) | (spread(q.z as u64) << 2);
                (code, i as u32)
            })
            .collect_into_vec(&mut keys);
        // Keys are unique (index breaks ties), so the order is deterministic.
        keys.par_sort_unstable();
        self.photons.extend(keys.iter().map(|&(_, i)| photons[i as usize]));
        self.positions.extend(self.photons.iter().map(|p| p.p));
        self.keys = keys;

        let leaves = self.photons.len().div_ceil(LEAF);
        let p = leaves.next_power_of_two();
        self.first_leaf = p;
        self.nodes.resize(2 * p, EMPTY);
        let grow = Vec3::splat(radius * 1.0001);
        let positions = &self.positions;
        self.nodes[p..p + leaves].par_iter_mut().enumerate().for_each(|(l, node)| {
            let chunk = &positions[l * LEAF..((l + 1) * LEAF).min(positions.len())];
            let (lo, hi) = chunk.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &q| {
                (lo.min(q), hi.max(q))
            });
            *node = Bounds { min: lo - grow, max: hi + grow };
        });
        for k in (1..p).rev() {
            self.nodes[k] = self.nodes[2 * k].union(self.nodes[2 * k + 1]);
        }
    }

    /// Calls `f(photon, t_p, d²)` for every photon whose projection onto the ray o + t d (d unit)
    /// falls at 0 < t_p < `t_max` within the build radius of the ray; d² is its squared
    /// distance to the ray.
    #[inline]
    pub fn query(&self, o: Vec3, d: Vec3, t_max: f32, mut f: impl FnMut(&VolumePhoton, f32, f32)) {
        if self.photons.is_empty() {
            return;
        }
        let inv = |x: f32| if x.abs() < 1e-30 { 1e30 } else { 1.0 / x };
        let inv_d = Vec3::new(inv(d.x), inv(d.y), inv(d.z));
        let r2 = self.radius * self.radius;
        let mut stack = [0u32; 64];
        let mut top = 1;
        stack[0] = 1;
        while top > 0 {
            top -= 1;
            let k = stack[top] as usize;
            let node = &self.nodes[k];
            if node.min.x > node.max.x || !node.hit(o, inv_d, t_max) {
                continue;
            }
            if k >= self.first_leaf {
                let l = k - self.first_leaf;
                let start = l * LEAF;
                let end = (start + LEAF).min(self.positions.len());
                for (i, &q) in self.positions[start..end].iter().enumerate() {
                    let v = q - o;
                    let t = v.dot(d);
                    let d2 = v.length_squared() - t * t;
                    if d2 < r2 && t > 0.0 && t < t_max {
                        f(&self.photons[start + i], t, d2.max(0.0));
                    }
                }
            } else {
                stack[top] = 2 * k as u32;
                stack[top + 1] = 2 * k as u32 + 1;
                top += 2;
            }
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
        for r in [0.01f32, 0.05, 0.2] {
            map.build(&photons, r);
            for q in 0..40 {
                let o = Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * 3.0 - 1.5;
                let d = crate::math::sample_uniform_sphere(s.next_2d());
                let d = if q == 0 { Vec3::Z } else { d };
                let t_max = if q % 5 == 0 { f32::INFINITY } else { 1.5 };
                let mut found = 0;
                map.query(o, d, t_max, |_, _, _| found += 1);
                let want = photons
                    .iter()
                    .filter(|ph| {
                        let v = ph.p - o;
                        let t = v.dot(d);
                        t > 0.0 && t < t_max && v.length_squared() - t * t < r * r
                    })
                    .count();
                assert_eq!(found, want, "r = {r}, query {q}");
            }
        }
    }
}
