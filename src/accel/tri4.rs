//! Four triangles tested against a ray at once.
//!
//! The arithmetic is obvhs's `RtTriangle::intersect` (Möller–Trumbore in the layout of Madmann91's
//! `bvh`: e₁ = v₀ − v₁, e₂ = v₂ − v₀, n = e₁ × e₂), operation for operation, one triangle per SSE
//! lane: every lane computes exactly the IEEE results the scalar version computes, so hits —
//! and renders — are the same bits as with obvhs's traversal.

use glam::{Vec3A, Vec4};
use obvhs::rt_triangle::RtTriangle;

/// Four triangles, one per lane: v₀, e₁ and e₂ as x, y, z vectors (n = e₁ × e₂ is recomputed
/// per test: three cache lines a block instead of four).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(super) struct Tri4 {
    v0: [Vec4; 3],
    e1: [Vec4; 3],
    e2: [Vec4; 3],
    /// The index of each lane's triangle (in the accelerator's primitive order).
    pub prim: [u32; 4],
    /// Lanes that hold a triangle.
    lanes: u32,
}

/// A ray's origin and direction, each component in every lane.
pub(super) struct Ray4 {
    o: [Vec4; 3],
    d: [Vec4; 3],
}

impl Ray4 {
    pub(super) fn new(o: Vec3A, d: Vec3A) -> Self {
        Self {
            o: [Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z)],
            d: [Vec4::splat(d.x), Vec4::splat(d.y), Vec4::splat(d.z)],
        }
    }
}

impl Tri4 {
    /// Up to four triangles `tris` (with their primitive indices `prims`).
    pub(super) fn new(tris: &[&RtTriangle], prims: &[u32]) -> Self {
        let mut b = Self {
            v0: [Vec4::ZERO; 3],
            e1: [Vec4::ZERO; 3],
            e2: [Vec4::ZERO; 3],
            prim: [0; 4],
            lanes: 0,
        };
        for (lane, (t, &p)) in tris.iter().zip(prims).enumerate().take(4) {
            for axis in 0..3 {
                b.v0[axis][lane] = t.v0[axis];
                b.e1[axis][lane] = t.e1[axis];
                b.e2[axis][lane] = t.e2[axis];
            }
            b.prim[lane] = p;
            b.lanes |= 1 << lane;
        }
        b
    }

    /// Each lane's hit distance, and the mask of lanes hit with `t_min` ≤ t ≤ `t_max`.
    #[inline(always)]
    pub(super) fn intersect(&self, r: &Ray4, t_min: f32, t_max: f32) -> (Vec4, u32) {
        // dot as glam's Vec3A computes it: (x·x' + y·y') + z·z'.
        let dot = |a: &[Vec4; 3], b: &[Vec4; 3]| (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2];
        // n = e₁ × e₂, as obvhs stores it (glam's cross, the same operations lane by lane).
        let (e1, e2) = (&self.e1, &self.e2);
        let ng = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let c = [self.v0[0] - r.o[0], self.v0[1] - r.o[1], self.v0[2] - r.o[2]];
        let d = &r.d;
        // r = d × c, as glam's cross: x = a.y·b.z − a.z·b.y, …
        let rr = [d[1] * c[2] - d[2] * c[1], d[2] * c[0] - d[0] * c[2], d[0] * c[1] - d[1] * c[0]];
        let inv_det = Vec4::ONE / dot(&ng, d);
        let u = dot(&rr, &self.e2) * inv_det;
        let v = dot(&rr, &self.e1) * inv_det;
        let w = (Vec4::ONE - u) - v;
        // A lane misses if the sign bit of u, v or w is set (−0 included, as in obvhs) …
        let negative = u.is_negative_bitmask() | v.is_negative_bitmask() | w.is_negative_bitmask();
        // … or if the determinant's inverse is zero.
        let valid = inv_det.cmpne(Vec4::ZERO).bitmask() & !negative & self.lanes;
        let t = dot(&ng, &c) * inv_det;
        let inside = t.cmpge(Vec4::splat(t_min)).bitmask() & t.cmple(Vec4::splat(t_max)).bitmask();
        (t, valid & inside)
    }
}

/// Nearest ray–sphere intersection in (`t_min`, `t_max`], or +∞.
pub(super) fn sphere_t(o: Vec3A, d: Vec3A, t_min: f32, t_max: f32, c: glam::Vec3, r: f32) -> f32 {
    let o = glam::Vec3::from(o) - c;
    let d = glam::Vec3::from(d);
    let b = o.dot(d);
    // Numerically stable discriminant (Hearn & Baker / Ray Tracing Gems ch. 7).
    let f = o - b * d;
    let disc = r * r - f.length_squared();
    if disc < 0.0 {
        return f32::INFINITY;
    }
    let cq = o.length_squared() - r * r;
    let q = -b - b.signum() * disc.sqrt();
    let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (cq / q, q) };
    let (t0, t1) = if t0 < t1 { (t0, t1) } else { (t1, t0) };
    for t in [t0, t1] {
        if t > t_min && t <= t_max {
            return t;
        }
    }
    f32::INFINITY
}
