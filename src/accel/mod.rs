//! Ray–scene intersection on an obvhs compressed wide BVH (CWBVH).
//!
//! The accelerator knows only geometry: triangles (with optional per-vertex shading normals) and
//! analytic spheres, each carrying an opaque `tag` that the caller maps back to its own shape.
//! Barycentrics come from `RtTriangle::compute_barycentric` (the orientation obvhs's
//! `RtTriangle::intersect` uses); `Triangle::compute_barycentric` in obvhs 0.4 does not match it.

use glam::{Vec2, Vec3, Vec3A};
use obvhs::{
    Boundable, BvhBuildParams,
    aabb::Aabb,
    cwbvh::{CwBvh, builder::build_cwbvh},
    ray::{Ray, RayHit},
    rt_triangle::RtTriangle,
};
use std::time::Duration;

/// A primitive as handed to [`Accel::build`].
#[derive(Clone, Debug)]
pub enum Primitive {
    /// A triangle; `normals` are per-vertex shading normals (unit length) if the mesh has them.
    Triangle {
        /// Vertex positions.
        p: [Vec3; 3],
        /// Optional per-vertex shading normals.
        normals: Option<[Vec3; 3]>,
        /// Caller's tag (shape index).
        tag: u32,
    },
    /// An analytic sphere (outward normals).
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius (> 0).
        radius: f32,
        /// Caller's tag (shape index).
        tag: u32,
    },
}

impl Primitive {
    fn tag(&self) -> u32 {
        match self {
            Primitive::Triangle { tag, .. } | Primitive::Sphere { tag, .. } => *tag,
        }
    }
}

impl Boundable for Primitive {
    fn aabb(&self) -> Aabb {
        match self {
            Primitive::Triangle { p, .. } => {
                Aabb::from_points(&[p[0].into(), p[1].into(), p[2].into()])
            }
            Primitive::Sphere { center, radius, .. } => Aabb::new(
                Vec3A::from(*center) - Vec3A::splat(*radius),
                Vec3A::from(*center) + Vec3A::splat(*radius),
            ),
        }
    }
}

/// Stored form of a primitive, laid out in BVH order.
enum Stored {
    Triangle(RtTriangle, Option<[Vec3; 3]>),
    Sphere(Vec3, f32),
}

/// A surface intersection.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Position.
    pub p: Vec3,
    /// Geometric normal (unit; for triangles, (p1 − p0) × (p2 − p0); for spheres, outward).
    pub ng: Vec3,
    /// Shading normal (unit), on the same side as `ng`.
    pub ns: Vec3,
    /// The primitive's tag.
    pub tag: u32,
}

/// The geometry accelerator.
pub struct Accel {
    bvh: Option<CwBvh>,
    prims: Vec<Stored>,
    tags: Vec<u32>,
}

impl Accel {
    /// Feeds every primitive (in BVH order) and its tag to `feed`, for a scene's fingerprint.
    pub(crate) fn fingerprint(&self, feed: &mut dyn FnMut(&[u8])) {
        let mut floats = |xs: &[f32]| xs.iter().for_each(|x| feed(&x.to_le_bytes()));
        for p in &self.prims {
            match p {
                Stored::Triangle(t, normals) => {
                    floats(&[
                        t.v0.x, t.v0.y, t.v0.z, t.e1.x, t.e1.y, t.e1.z, t.e2.x, t.e2.y, t.e2.z,
                    ]);
                    if let Some(n) = normals {
                        n.iter().for_each(|v| floats(&v.to_array()));
                    }
                }
                Stored::Sphere(c, r) => floats(&[c.x, c.y, c.z, *r]),
            }
        }
        for t in &self.tags {
            feed(&t.to_le_bytes());
        }
    }
}

/// How far a ray's origin is moved back along the ray before traversal (see [`to_ray`]).
const BACK_OFF: f32 = 2e-4;

/// An obvhs ray for `o + t d`, 0 < t < `t_max`, whose parameter is shifted by [`BACK_OFF`]:
/// the returned ray starts at o − `BACK_OFF`·d and accepts BACK_OFF ≤ t' ≤ t_max + BACK_OFF, so
/// t = t' − BACK_OFF.
///
/// - obvhs 0.4's CWBVH traversal clamps every node's entry distance to at least 10⁻⁴
///   (`cwbvh::node::EPSILON`, whatever the ray's own `tmin`), so a node whose box the ray leaves
///   within 10⁻⁴ of its origin is skipped: a ray from a point less than 10⁻⁴ below a flat face
///   never hit it (a shadow ray from a collision just inside a medium escaped through its
///   boundary, darkening the singly scattered light of a half-space by 0.03 %). Starting the
///   traversal 2·10⁻⁴ behind the origin puts every hit with t > 0 beyond that clamp.
/// - Negative-zero direction components become +0: obvhs 0.4 inverts a zero component to ±1/ε
///   by its sign bit but picks the slab order by `d < 0`, so a −0 component makes every node test
///   miss (a ray straight down −z hit nothing before this).
fn to_ray(o: Vec3, d: Vec3, t_max: f32) -> Ray {
    let d = d + Vec3::ZERO;
    Ray::new((o - d * BACK_OFF).into(), d.into(), BACK_OFF, t_max + BACK_OFF)
}

impl Accel {
    /// Builds the BVH. An empty list gives an accelerator that never hits.
    pub fn build(primitives: &[Primitive]) -> Self {
        if primitives.is_empty() {
            return Self { bvh: None, prims: Vec::new(), tags: Vec::new() };
        }
        let bvh = build_cwbvh(primitives, BvhBuildParams::medium_build(), &mut Duration::default());
        let order: Vec<&Primitive> =
            bvh.primitive_indices.iter().map(|&i| &primitives[i as usize]).collect();
        let prims = order
            .iter()
            .map(|p| match p {
                Primitive::Triangle { p, normals, .. } => Stored::Triangle(
                    RtTriangle::new(p[0].into(), p[1].into(), p[2].into()),
                    *normals,
                ),
                Primitive::Sphere { center, radius, .. } => Stored::Sphere(*center, *radius),
            })
            .collect();
        let tags = order.iter().map(|p| p.tag()).collect();
        Self { bvh: Some(bvh), prims, tags }
    }

    #[inline]
    fn intersect_prim(&self, ray: &Ray, id: usize) -> f32 {
        match &self.prims[id] {
            Stored::Triangle(tri, _) => tri.intersect(ray),
            Stored::Sphere(c, r) => sphere_t(ray, *c, *r),
        }
    }

    /// Closest hit along `o + t d` with `0 < t < t_max` (`d` unit length).
    pub fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        let ray = to_ray(o, d, t_max);
        let mut hit = RayHit::none();
        if !bvh.ray_traverse(ray, &mut hit, |r, id| self.intersect_prim(r, id)) {
            return None;
        }
        let id = hit.primitive_id as usize;
        let t = hit.t - BACK_OFF;
        let p = o + d * t;
        let (ng, ns) = match &self.prims[id] {
            Stored::Triangle(tri, normals) => {
                let ng = Vec3::from(tri.compute_normal()).normalize();
                let ns = match normals {
                    Some(n) => {
                        let b: Vec2 = tri.compute_barycentric(&ray);
                        let s = (n[0] * (1.0 - b.x - b.y) + n[1] * b.x + n[2] * b.y)
                            .normalize_or_zero();
                        if s == Vec3::ZERO {
                            ng
                        } else if s.dot(ng) < 0.0 {
                            -s
                        } else {
                            s
                        }
                    }
                    None => ng,
                };
                (ng, ns)
            }
            Stored::Sphere(c, _) => {
                let n = (p - *c).normalize();
                (n, n)
            }
        };
        Some(Hit { t, p, ng, ns, tag: self.tags[id] })
    }

    /// True if nothing blocks `o + t d` for `0 < t < t_max`.
    #[cfg(test)]
    pub fn unoccluded(&self, o: Vec3, d: Vec3, t_max: f32) -> bool {
        match &self.bvh {
            None => true,
            Some(bvh) => {
                bvh.ray_traverse_miss(to_ray(o, d, t_max), |r, id| self.intersect_prim(r, id))
            }
        }
    }
}

/// Nearest ray–sphere intersection in (tmin, tmax], or +∞.
fn sphere_t(ray: &Ray, c: Vec3, r: f32) -> f32 {
    let o = Vec3::from(ray.origin) - c;
    let d = Vec3::from(ray.direction);
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
        if t > ray.tmin && t <= ray.tmax {
            return t;
        }
    }
    f32::INFINITY
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn barycentric_shading_normals_interpolate() {
        let tri = Primitive::Triangle {
            p: [Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: Some([Vec3::Z, Vec3::X, Vec3::Y]),
            tag: 4,
        };
        let accel = Accel::build(&[tri]);
        // A hit at vertex 1's corner should get (almost) vertex 1's normal.
        let h = accel.intersect(Vec3::new(0.98, 0.01, 1.0), -Vec3::Z, f32::INFINITY).unwrap();
        assert_eq!(h.tag, 4);
        assert!(h.ns.dot(Vec3::new(1.0, 0.0, 0.05).normalize()) > 0.99, "{:?}", h.ns);
        let h = accel.intersect(Vec3::new(0.01, 0.98, 1.0), -Vec3::Z, f32::INFINITY).unwrap();
        assert!(h.ns.dot(Vec3::new(0.0, 1.0, 0.05).normalize()) > 0.99, "{:?}", h.ns);
        assert!((h.t - 1.0).abs() < 1e-6);
    }

    #[test]
    fn axis_aligned_rays_with_negative_zero_components_hit() {
        let tri = Primitive::Triangle { p: [Vec3::ZERO, Vec3::X, Vec3::Y], normals: None, tag: 0 };
        let accel = Accel::build(&[tri]);
        let down = -Vec3::Z; // (−0, −0, −1)
        assert!(accel.intersect(Vec3::new(0.2, 0.2, 1.0), down, f32::INFINITY).is_some());
        assert!(!accel.unoccluded(Vec3::new(0.2, 0.2, 1.0), down, 2.0));
    }

    /// obvhs skips nodes the ray leaves within 10⁻⁴ of its origin; the traversal must still find
    /// a flat face a hair away, from either side, and report the distance from the true origin.
    #[test]
    fn faces_closer_than_the_traversal_epsilon_are_hit() {
        let tris = [
            Primitive::Triangle {
                p: [
                    Vec3::new(-5.0, 0.0, -1.0),
                    Vec3::new(5.0, 0.0, -1.0),
                    Vec3::new(5.0, 0.0, 1.0),
                ],
                normals: None,
                tag: 0,
            },
            Primitive::Triangle {
                p: [
                    Vec3::new(-5.0, 0.0, -1.0),
                    Vec3::new(5.0, 0.0, 1.0),
                    Vec3::new(-5.0, 0.0, 1.0),
                ],
                normals: None,
                tag: 0,
            },
        ];
        let accel = Accel::build(&tris);
        for gap in [1e-6f32, 3e-5, 7.5e-5, 2e-4, 1e-3] {
            for (x, z) in [(0.3f32, 0.2f32), (-2.7, -0.48), (4.1, 0.9)] {
                let below = Vec3::new(x, -gap, z);
                let h = accel.intersect(below, Vec3::Y, f32::INFINITY).expect("hit from below");
                assert!((h.t - gap).abs() < 1e-6 + 1e-3 * gap, "gap {gap}: t = {}", h.t);
                assert!(h.p.y.abs() < 1e-6, "gap {gap}: p = {}", h.p);
                assert!(accel.intersect(Vec3::new(x, gap, z), -Vec3::Y, 1.0).is_some());
                assert!(!accel.unoccluded(below, Vec3::Y, 1.0), "gap {gap}");
                // Nothing behind the origin counts, nor beyond t_max.
                assert!(accel.intersect(below, -Vec3::Y, f32::INFINITY).is_none());
                assert!(accel.intersect(below, Vec3::Y, 0.5 * gap).is_none());
            }
        }
    }

    #[test]
    fn sphere_hits_from_outside_and_inside() {
        let s = Primitive::Sphere { center: Vec3::new(0.0, 0.0, 5.0), radius: 1.0, tag: 0 };
        let accel = Accel::build(&[s]);
        let h = accel.intersect(Vec3::ZERO, Vec3::Z, f32::INFINITY).unwrap();
        assert!((h.t - 4.0).abs() < 1e-5 && h.ng.z < -0.99);
        let h = accel.intersect(Vec3::new(0.0, 0.0, 5.0), Vec3::Z, f32::INFINITY).unwrap();
        assert!((h.t - 1.0).abs() < 1e-5 && h.ng.z > 0.99);
        assert!(accel.unoccluded(Vec3::ZERO, Vec3::Z, 3.9));
        assert!(!accel.unoccluded(Vec3::ZERO, Vec3::Z, 4.1));
    }
}
