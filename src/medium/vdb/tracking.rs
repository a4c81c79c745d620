//! A grid medium described to the tracker ([`super::super::tracker`]): its majorant segments
//! along a ray (a DDA over majorant cells, dense pieces bisected under tighter bounds; module
//! docs of `vdb`), and its extinction, colour and emission at a point.

use super::super::grid::MAJORANT_CELL;
use super::super::tracker::{Constant, Tracked};
use super::VdbMedium;
use crate::math::Rgb;
use glam::Vec3;
use std::sync::atomic::Ordering;

/// Largest number of bisections of one cell's piece of a ray.
const MAX_SPLITS: u32 = 64;

impl Tracked for VdbMedium {
    fn constant(&self) -> Option<Constant> {
        None
    }

    /// The majorant cells the ray crosses, in order, each a piece at its majorant — bisected
    /// where more than `split_steps` tentative collisions at `rate` are expected and a tighter
    /// bound on the piece ([`VdbMedium::density_bounds`], with an extinction grid also
    /// [`VdbMedium::colour_bounds`]) can cut the count.
    fn majorants(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        rate: f32,
        mut f: impl FnMut(f32, f32, f32) -> bool,
    ) {
        // The ray in index space (for bounds of the density on pieces of it), and in coarse-cell
        // coordinates, where cell k spans [k, k + 1).
        let (oq, dq) = (self.to_index.transform_point3(o), self.to_index.transform_vector3(d));
        let scale = 1.0 / MAJORANT_CELL as f32;
        let (oc, dc) = ((oq - self.lo) * scale, dq * scale);
        crate::dda::walk(oc, dc, t_max, self.cells, |cell, a, b| {
            // The extinction field's bound in the cell, if any.
            let tint = self.extinction_majorant.as_ref().map_or(1.0, |e| e.get(cell));
            let mu = self.majorant.get(cell) * self.sigma_t * tint;
            if mu <= 0.0 {
                return true;
            }
            if mu * rate * (b - a) <= self.split_steps {
                return f(mu, a, b);
            }
            // Many tentative collisions expected in this cell: its majorant may dwarf the
            // density along the ray (a dense voxel beside empty ones). Bisect the piece while
            // a tighter bound on it (`density_bounds`) can cut the expected count, and track
            // each part at its own rate, in order along the ray.
            let mut pieces: smallvec::SmallVec<[(f32, f32, u32); 32]> =
                smallvec::smallvec![(a, b, 0)];
            while let Some((a, b, depth)) = pieces.pop() {
                let (lo, hi) = self.density_bounds(oq + dq * a, oq + dq * b);
                // With an extinction grid, the colour's bounds on the piece too: where it
                // varies (at the edge of a tint grid) a tight density bound alone leaves the
                // tracked channel's σ_t far below the rate, and the walk would crawl.
                let (lo_c, hi_c) = if self.extinction_grid.is_some() {
                    let (c0, c1) = self.colour_bounds(o + d * a, o + d * b);
                    (c0, c1.min(tint))
                } else {
                    (tint, tint)
                };
                let (lo, hi) = (lo * lo_c, hi * hi_c);
                let mu = hi * self.sigma_t;
                if mu <= 0.0 {
                    continue;
                }
                let m = 0.5 * (a + b);
                if mu * rate * (b - a) > self.split_steps
                    && hi > 2.0 * lo
                    && depth < MAX_SPLITS
                    && a < m
                    && m < b
                {
                    pieces.push((m, b, depth + 1));
                    pieces.push((a, m, depth + 1));
                    continue;
                }
                if !f(mu, a, b) {
                    return false;
                }
            }
            true
        });
    }

    #[inline]
    fn sigma_t(&self, p: Vec3) -> f32 {
        self.sigma_t * self.density(p)
    }

    /// With a tint or an extinction grid (spectral tracking needed).
    #[inline]
    fn coloured(&self) -> bool {
        self.tint.is_some() || self.extinction_grid.is_some()
    }

    #[inline]
    fn tint(&self, p: Vec3) -> Rgb {
        self.tint_at(p)
    }

    #[inline]
    fn emission_at(&self, p: Vec3) -> (Rgb, Rgb, Rgb) {
        let e = self.extinction_colour(p);
        let tint = self.tint.unwrap_or(Rgb::ONE) * e;
        (tint, self.absorption_share_at(p, e), self.le(p))
    }

    fn emits(&self) -> bool {
        self.emits()
    }

    fn cut(&self) {
        self.truncated.0.fetch_add(1, Ordering::Relaxed);
    }
}

impl VdbMedium {
    /// Lower and upper bounds of the (scaled) density on the index-space segment from `q0` to
    /// `q1` ([`DensityGrid::bounds`]).
    pub(super) fn density_bounds(&self, q0: Vec3, q1: Vec3) -> (f32, f32) {
        self.grid.bounds(q0, q1)
    }

    /// Lower and upper bounds of the largest channel of the (normalised) extinction colour on
    /// the scene segment from `p0` to `p1`: each channel's grid bounded on the segment in its own
    /// index space; (1, 1) without an extinction grid. The largest channel is at least the
    /// largest of the channels' lower bounds.
    pub(super) fn colour_bounds(&self, p0: Vec3, p1: Vec3) -> (f32, f32) {
        let Some(field) = &self.extinction_grid else { return (1.0, 1.0) };
        let (mut lo, mut hi) = (0.0f32, 0.0f32);
        for c in 0..3 {
            let to = field.to_index[c];
            let (l, h) = field.grids[c].bounds(to.transform_point3(p0), to.transform_point3(p1));
            (lo, hi) = (lo.max(l), hi.max(h));
        }
        (lo * field.scale, hi * field.scale)
    }

    /// The part [t0, t1] of o + t d, 0 ≤ t ≤ `t_max`, inside the grid's majorant cells (the
    /// density is zero elsewhere); `None` if the ray misses them.
    pub fn extent(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32)> {
        // In index space, where the cells cover [lo, lo + cells · MAJORANT_CELL]; t is unchanged
        // by the affine map.
        let oi = self.to_index.transform_point3(o);
        let di = self.to_index.transform_vector3(d);
        let hi = self.lo + (self.cells * MAJORANT_CELL).as_vec3();
        let (mut t0, mut t1) = (0.0f32, t_max);
        for a in 0..3 {
            if di[a] == 0.0 {
                if oi[a] < self.lo[a] || oi[a] > hi[a] {
                    return None;
                }
                continue;
            }
            let (u, v) = ((self.lo[a] - oi[a]) / di[a], (hi[a] - oi[a]) / di[a]);
            t0 = t0.max(u.min(v));
            t1 = t1.min(u.max(v));
        }
        (t0 < t1).then_some((t0, t1))
    }
}
