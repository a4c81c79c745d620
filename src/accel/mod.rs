//! Ray–scene intersection: a four-wide BVH ([`bvh4`]) flattened from an obvhs BVH2, with leaves of
//! four triangles tested at once ([`tri4`]), and closest-hit and any-hit (occlusion) queries.
//!
//! The accelerator knows only geometry: triangles (with optional per-vertex shading normals) and
//! analytic spheres, each carrying an opaque `tag` that the caller maps back to its own shape.
//! Barycentrics come from `RtTriangle::compute_barycentric` (the orientation obvhs's
//! `RtTriangle::intersect` uses); `Triangle::compute_barycentric` in obvhs 0.4 does not match it.

mod bvh4;
mod tri4;

use bvh4::{BoxRay, Bvh4, Visit};
use glam::{Vec2, Vec3, Vec3A};
use obvhs::{
    Boundable, BvhBuildParams, aabb::Aabb, bvh2::builder::build_bvh2, ray::Ray,
    rt_triangle::RtTriangle,
};
use smallvec::SmallVec;
use std::time::Duration;
use tri4::{Ray4, Tri4, sphere_t};

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

/// A triangle as stored: obvhs's intersection layout, and optional per-vertex shading normals.
struct StoredTriangle {
    tri: RtTriangle,
    /// The unit geometric normal, computed once.
    ng: Vec3,
    normals: Option<[Vec3; 3]>,
    tag: u32,
    /// Its place among the triangles given to [`Accel::build`].
    input: u32,
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

/// The geometry accelerator: a BVH4 over blocks of four triangles, and one over spheres.
pub struct Accel {
    /// Triangles, in the order the blocks reference them.
    tris: Vec<StoredTriangle>,
    blocks: Vec<Tri4>,
    tri_bvh: Bvh4,
    /// Spheres: centre, radius, tag, place among the spheres given to [`Accel::build`].
    spheres: Vec<(Vec3, f32, u32, u32)>,
    sphere_bvh: Bvh4,
    /// Traversal stack entries needed by the deeper of the two trees.
    stack: usize,
}

/// What [`Accel::through`] found beyond the pass-through surfaces.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Passage {
    /// Nothing else before the end of the ray.
    Clear,
    /// The nearest other surface.
    Surface(Hit),
    /// Another surface (a shadow ray), or too many pass-through ones.
    Blocked,
}

/// A closest hit found by traversal: the parameter (of the backed-off ray) and what was hit.
#[derive(Clone, Copy)]
enum Found {
    Triangle(usize),
    Sphere(usize),
}

/// Stack entries kept on the call stack; deeper trees use a heap stack.
const INLINE_STACK: usize = 64;

/// Largest leaf of obvhs's BVH2 build: one block of four triangles, tested at once.
const MAX_PRIMS_PER_LEAF: u32 = 4;

impl Primitive {
    /// The primitive's tag.
    pub fn tag(&self) -> u32 {
        match self {
            Primitive::Triangle { tag, .. } | Primitive::Sphere { tag, .. } => *tag,
        }
    }
}

impl Accel {
    /// Feeds every primitive and its tag to `feed`, for a scene's fingerprint: triangles then
    /// spheres, each in the order they were given to [`Accel::build`].
    pub(crate) fn fingerprint(&self, feed: &mut dyn FnMut(&[u8])) {
        let mut floats = |xs: &[f32]| xs.iter().for_each(|x| feed(&x.to_le_bytes()));
        let mut order: Vec<&StoredTriangle> = self.tris.iter().collect();
        order.sort_by_key(|t| t.input);
        for t in &order {
            let (v0, e1, e2) = (t.tri.v0, t.tri.e1, t.tri.e2);
            floats(&[v0.x, v0.y, v0.z, e1.x, e1.y, e1.z, e2.x, e2.y, e2.z]);
            if let Some(n) = t.normals {
                n.iter().for_each(|v| floats(&v.to_array()));
            }
        }
        let mut spheres = self.spheres.clone();
        spheres.sort_by_key(|s| s.3);
        for (c, r, _, _) in &spheres {
            floats(&[c.x, c.y, c.z, *r]);
        }
        for t in &order {
            feed(&t.tag.to_le_bytes());
        }
        for s in &spheres {
            feed(&s.2.to_le_bytes());
        }
    }
}

/// How far a ray's origin is moved back along the ray before traversal (see [`to_ray`]).
const BACK_OFF: f32 = 2e-4;

/// The ray `o + t d`, 0 < t < `t_max`, as traversed: origin moved back by [`BACK_OFF`] along
/// the ray, accepting BACK_OFF ≤ t' ≤ t_max + BACK_OFF, so t = t' − BACK_OFF; and negative-zero
/// direction components made +0.
///
/// The back-off was a work-around for obvhs 0.4's CWBVH traversal, which clamps every node's
/// entry distance to at least 10⁻⁴, so that a ray from a point less than 10⁻⁴ below a flat face
/// never hit it. haze's own traversal has no such clamp; the ray is kept as it was so that every
/// hit — and every render — is the same bits as before (the triangle test is obvhs's arithmetic
/// on the same ray).
fn to_ray(o: Vec3, d: Vec3, t_max: f32) -> (Vec3A, Vec3A, f32, f32) {
    let d = d + Vec3::ZERO;
    ((o - d * BACK_OFF).into(), d.into(), BACK_OFF, t_max + BACK_OFF)
}

impl Accel {
    /// Builds the BVHs. An empty list gives an accelerator that never hits.
    pub fn build(primitives: &[Primitive]) -> Self {
        let mut tri_prims = Vec::new();
        let mut spheres = Vec::new();
        for p in primitives {
            match p {
                Primitive::Triangle { .. } => tri_prims.push(p.clone()),
                Primitive::Sphere { center, radius, tag } => {
                    spheres.push((*center, *radius, *tag, spheres.len() as u32))
                }
            }
        }
        let params = BvhBuildParams {
            max_prims_per_leaf: MAX_PRIMS_PER_LEAF,
            ..BvhBuildParams::medium_build()
        };
        let build = |prims: &[Primitive]| {
            if prims.is_empty() {
                None
            } else {
                Some(build_bvh2(prims, params, &mut Duration::default()))
            }
        };
        // Triangles: each BVH2 leaf becomes blocks of four, the triangles stored in block order.
        let mut tris = Vec::with_capacity(tri_prims.len());
        let mut blocks = Vec::new();
        let tri_bvh = build(&tri_prims).map_or_else(Bvh4::default, |bvh2| {
            Bvh4::from_bvh2(&bvh2, |items| {
                let first = blocks.len() as u32;
                for chunk in items.chunks(4) {
                    let start = tris.len() as u32;
                    for &i in chunk {
                        let Primitive::Triangle { p, normals, tag } = &tri_prims[i as usize] else {
                            unreachable!("only triangles are in this tree")
                        };
                        let tri = RtTriangle::new(p[0].into(), p[1].into(), p[2].into());
                        let input = i;
                        let ng = Vec3::from(tri.compute_normal()).normalize();
                        tris.push(StoredTriangle { tri, ng, normals: *normals, tag: *tag, input });
                    }
                    let stored = &tris[start as usize..];
                    let refs: Vec<&RtTriangle> = stored.iter().map(|t| &t.tri).collect();
                    let ids: Vec<u32> = (start..start + chunk.len() as u32).collect();
                    blocks.push(Tri4::new(&refs, &ids));
                }
                (first, blocks.len() as u32 - first)
            })
        });
        // Spheres: leaves are ranges of the spheres, stored in leaf order.
        let sphere_prims: Vec<Primitive> = spheres
            .iter()
            .map(|&(center, radius, tag, _)| Primitive::Sphere { center, radius, tag })
            .collect();
        let mut ordered = Vec::with_capacity(spheres.len());
        let sphere_bvh = build(&sphere_prims).map_or_else(Bvh4::default, |bvh2| {
            Bvh4::from_bvh2(&bvh2, |items| {
                let first = ordered.len() as u32;
                ordered.extend(items.iter().map(|&i| spheres[i as usize]));
                (first, items.len() as u32)
            })
        });
        let stack = tri_bvh.stack_size().max(sphere_bvh.stack_size());
        Self { tris, blocks, tri_bvh, spheres: ordered, sphere_bvh, stack }
    }

    /// Runs `f` with a traversal stack large enough for these trees.
    #[inline(always)]
    fn with_stack<R>(&self, f: impl FnOnce(&mut [(u32, f32)]) -> R) -> R {
        // Zeroing the stack costs as much as a node visit: small trees get a small one.
        if self.stack <= 16 {
            f(&mut [(0u32, 0f32); 16])
        } else if self.stack <= INLINE_STACK {
            let mut stack = [(0u32, 0f32); INLINE_STACK];
            f(&mut stack)
        } else {
            f(&mut vec![(0u32, 0f32); self.stack])
        }
    }

    /// The closest primitive along the traversed ray (o, d) with t_min ≤ t < `t_max`: what it
    /// is and its parameter.
    #[inline(always)]
    fn closest(&self, o: Vec3A, d: Vec3A, t_min: f32, t_max: f32) -> Option<(Found, f32)> {
        let boxes = BoxRay::new(o, d);
        let ray4 = Ray4::new(o, d);
        let mut best: Option<Found> = None;
        let mut t_best = t_max;
        self.with_stack(|stack| {
            self.tri_bvh.traverse(&boxes, t_min, &mut t_best, stack, |first, count, t_max| {
                for b in &self.blocks[first as usize..(first + count) as usize] {
                    let (t, mut mask) = b.intersect(&ray4, t_min, *t_max);
                    while mask != 0 {
                        let lane = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        if t[lane] < *t_max {
                            *t_max = t[lane];
                            best = Some(Found::Triangle(b.prim[lane] as usize));
                        }
                    }
                }
                Visit::Continue
            });
            self.sphere_bvh.traverse(&boxes, t_min, &mut t_best, stack, |first, count, t_max| {
                for i in first as usize..(first + count) as usize {
                    let (c, r, _, _) = self.spheres[i];
                    let t = sphere_t(o, d, t_min, *t_max, c, r);
                    if t < *t_max {
                        *t_max = t;
                        best = Some(Found::Sphere(i));
                    }
                }
                Visit::Continue
            });
        });
        best.map(|f| (f, t_best))
    }

    /// Closest hit along `o + t d` with `0 < t < t_max` (`d` unit length).
    pub fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<Hit> {
        let ray = to_ray(o, d, t_max);
        let (found, t_hit) = self.closest(ray.0, ray.1, ray.2, ray.3)?;
        Some(self.hit(o, d, ray, found, t_hit - BACK_OFF))
    }

    /// True if something blocks `o + t d` for `0 < t < t_max`: an any-hit query that stops at
    /// the first primitive found.
    pub fn occluded(&self, o: Vec3, d: Vec3, t_max: f32) -> bool {
        let (ro, rd, t_min, t_end) = to_ray(o, d, t_max);
        let boxes = BoxRay::new(ro, rd);
        let ray4 = Ray4::new(ro, rd);
        let mut hit = false;
        self.with_stack(|stack| {
            let mut t = t_end;
            self.tri_bvh.traverse(&boxes, t_min, &mut t, stack, |first, count, t_max| {
                for b in &self.blocks[first as usize..(first + count) as usize] {
                    let (ts, mask) = b.intersect(&ray4, t_min, *t_max);
                    // obvhs accepts t < t_max only.
                    if mask & ts.cmplt(glam::Vec4::splat(*t_max)).bitmask() != 0 {
                        hit = true;
                        return Visit::Stop;
                    }
                }
                Visit::Continue
            });
            if hit {
                return;
            }
            let mut t = t_end;
            self.sphere_bvh.traverse(&boxes, t_min, &mut t, stack, |first, count, t_max| {
                for i in first as usize..(first + count) as usize {
                    let (c, r, _, _) = self.spheres[i];
                    if sphere_t(ro, rd, t_min, *t_max, c, r) < *t_max {
                        hit = true;
                        return Visit::Stop;
                    }
                }
                Visit::Continue
            });
        });
        hit
    }

    /// The surface hit of `found` at parameter `t` along `o + t d` (the traversed ray `ray`).
    fn hit(
        &self,
        o: Vec3,
        d: Vec3,
        (ro, rd, t_min, t_end): (Vec3A, Vec3A, f32, f32),
        found: Found,
        t: f32,
    ) -> Hit {
        let p = o + d * t;
        match found {
            Found::Triangle(id) => {
                let StoredTriangle { tri, ng, normals, tag, .. } = &self.tris[id];
                let ng = *ng;
                let ns = match normals {
                    Some(n) => {
                        let ray = Ray::new(ro, rd, t_min, t_end);
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
                Hit { t, p, ng, ns, tag: *tag }
            }
            Found::Sphere(i) => {
                let (c, _, tag, _) = self.spheres[i];
                let n = (p - c).normalize();
                Hit { t, p, ng: n, ns: n, tag }
            }
        }
    }

    /// The tag of what `found` refers to.
    fn tag(&self, found: Found) -> u32 {
        match found {
            Found::Triangle(id) => self.tris[id].tag,
            Found::Sphere(i) => self.spheres[i].2,
        }
    }

    /// Follows `o + t d`, 0 < t < `t_max`, through the surfaces whose tag `through` marks
    /// (pass-through interfaces), in one traversal. With `stop`, the query is a shadow ray: it
    /// ends at the first other surface found (`Blocked`, without looking for the nearest);
    /// without, it finds the nearest other surface (`Surface`). `crossings` receives the
    /// pass-through surfaces before it (or before `t_max`), nearest first; a surface met twice
    /// within `merge` of itself (a ray through the shared edge of two of its triangles) counts
    /// once. More than `max` crossings block the ray.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn through(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        through: &[bool],
        stop: bool,
        merge: f32,
        max: usize,
        crossings: &mut SmallVec<[Hit; 4]>,
    ) -> Passage {
        crossings.clear();
        let ray = to_ray(o, d, t_max);
        let (ro, rd, t_min, t_end) = ray;
        let boxes = BoxRay::new(ro, rd);
        let ray4 = Ray4::new(ro, rd);
        let mut found: SmallVec<[(f32, Found); 8]> = SmallVec::new();
        let mut opaque: Option<Found> = None;
        let mut t_best = t_end;
        let mut visit = |t: f32, f: Found, t_max: &mut f32| -> Visit {
            if through.get(self.tag(f) as usize).copied().unwrap_or(false) {
                found.push((t, f));
                return Visit::Continue;
            }
            opaque = Some(f);
            *t_max = t;
            if stop { Visit::Stop } else { Visit::Continue }
        };
        self.with_stack(|stack| {
            let mut done = false;
            self.tri_bvh.traverse(&boxes, t_min, &mut t_best, stack, |first, count, t_max| {
                for b in &self.blocks[first as usize..(first + count) as usize] {
                    let (t, mut mask) = b.intersect(&ray4, t_min, *t_max);
                    while mask != 0 {
                        let lane = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        if t[lane] < *t_max {
                            if let Visit::Stop =
                                visit(t[lane], Found::Triangle(b.prim[lane] as usize), t_max)
                            {
                                done = true;
                                return Visit::Stop;
                            }
                        }
                    }
                }
                Visit::Continue
            });
            if done {
                return;
            }
            self.sphere_bvh.traverse(&boxes, t_min, &mut t_best, stack, |first, count, t_max| {
                for i in first as usize..(first + count) as usize {
                    let (c, r, _, _) = self.spheres[i];
                    // A ray crosses a pass-through sphere twice: both roots count.
                    let near = sphere_t(ro, rd, t_min, *t_max, c, r);
                    let far =
                        if near < *t_max { sphere_t(ro, rd, near, *t_max, c, r) } else { near };
                    for t in [near, far] {
                        if t < *t_max {
                            if let Visit::Stop = visit(t, Found::Sphere(i), t_max) {
                                return Visit::Stop;
                            }
                        }
                    }
                }
                Visit::Continue
            });
        });
        if stop && opaque.is_some() {
            return Passage::Blocked;
        }
        found.retain(|e| e.0 < t_best);
        found.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut last: Option<(f32, u32)> = None;
        for (t, f) in found {
            let tag = self.tag(f);
            if matches!(last, Some((lt, ltag)) if ltag == tag && t - lt <= merge) {
                continue;
            }
            last = Some((t, tag));
            if crossings.len() == max {
                return Passage::Blocked;
            }
            crossings.push(self.hit(o, d, ray, f, t - BACK_OFF));
        }
        match opaque {
            Some(f) => Passage::Surface(self.hit(o, d, ray, f, t_best - BACK_OFF)),
            None => Passage::Clear,
        }
    }

    /// The triangles (three vertices each, as the intersection test sees them) and spheres
    /// (centre, radius), in the order they were given to [`Accel::build`].
    pub(crate) fn primitives(&self) -> (Vec<[Vec3; 3]>, Vec<(Vec3, f32)>) {
        let mut tris: Vec<&StoredTriangle> = self.tris.iter().collect();
        tris.sort_by_key(|t| t.input);
        let tris = tris
            .iter()
            .map(|t| {
                let (v0, e1, e2) =
                    (Vec3::from(t.tri.v0), Vec3::from(t.tri.e1), Vec3::from(t.tri.e2));
                [v0, v0 - e1, v0 + e2]
            })
            .collect();
        let mut spheres = self.spheres.clone();
        spheres.sort_by_key(|s| s.3);
        (tris, spheres.iter().map(|s| (s.0, s.1)).collect())
    }

    /// True if nothing blocks `o + t d` for `0 < t < t_max`.
    #[cfg(test)]
    pub fn unoccluded(&self, o: Vec3, d: Vec3, t_max: f32) -> bool {
        !self.occluded(o, d, t_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sample_uniform_sphere;
    use crate::rng::{Purpose, Sampler};

    /// Closest t (of the backed-off ray) over every primitive, tested one by one with the
    /// scalar arithmetic the BVH's blocks replicate.
    fn brute_force(prims: &[Primitive], o: Vec3, d: Vec3, t_max: f32) -> Option<f32> {
        let (ro, rd, t_min, t_end) = to_ray(o, d, t_max);
        let ray = Ray::new(ro, rd, t_min, t_end);
        let mut best = t_end;
        for p in prims {
            let t = match p {
                Primitive::Triangle { p, .. } => {
                    RtTriangle::new(p[0].into(), p[1].into(), p[2].into()).intersect(&ray)
                }
                Primitive::Sphere { center, radius, .. } => {
                    sphere_t(ro, rd, t_min, best, *center, *radius)
                }
            };
            if t < best {
                best = t;
            }
        }
        (best < t_end).then_some(best - BACK_OFF)
    }

    /// A soup of small random triangles (some degenerate, some large) and spheres.
    fn soup(s: &mut Sampler, triangles: usize, spheres: usize) -> Vec<Primitive> {
        let v = |s: &mut Sampler, scale: f32| {
            Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * scale
        };
        let mut prims: Vec<Primitive> = (0..triangles)
            .map(|i| {
                let c = v(s, 10.0);
                let size = if i % 97 == 0 { 6.0 } else { 0.4 };
                let (a, b) = (v(s, size), v(s, size));
                // Every 50th degenerate: its three vertices on a line.
                let b = if i % 50 == 0 { a * 2.0 } else { b };
                Primitive::Triangle { p: [c, c + a, c + b], normals: None, tag: i as u32 }
            })
            .collect();
        prims.extend((0..spheres).map(|i| Primitive::Sphere {
            center: v(s, 10.0),
            radius: 0.2 + 0.5 * s.next_f32(),
            tag: (triangles + i) as u32,
        }));
        prims
    }

    /// The BVH4 traversal finds what testing every primitive finds: the same closest distance,
    /// bit for bit (its blocks compute obvhs's triangle test lane by lane), and the same answer
    /// to occlusion — for random rays, bounded and not, through a random soup.
    #[test]
    fn traversal_agrees_with_testing_every_primitive() {
        let mut s = Sampler::new(1, Purpose::Other, 0, 0);
        for (triangles, spheres) in [(3000, 20), (3, 0), (0, 5), (1, 1), (700, 0)] {
            let prims = soup(&mut s, triangles, spheres);
            let accel = Accel::build(&prims);
            let mut hits = 0;
            for k in 0..20_000 {
                let o = Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * 12.0 - 1.0;
                let d = sample_uniform_sphere(s.next_2d());
                let t_max = if k % 2 == 0 { f32::INFINITY } else { 8.0 * s.next_f32() };
                let want = brute_force(&prims, o, d, t_max);
                let got = accel.intersect(o, d, t_max).map(|h| h.t);
                assert_eq!(
                    got.map(f32::to_bits),
                    want.map(f32::to_bits),
                    "{triangles} triangles, {spheres} spheres, ray {k}: {got:?} vs {want:?}"
                );
                assert_eq!(accel.occluded(o, d, t_max), want.is_some(), "ray {k}");
                hits += want.is_some() as usize;
            }
            if triangles + spheres > 100 {
                assert!(hits > 1000, "the rays should hit something: {hits}");
            }
        }
    }

    /// Thousands of copies of one triangle make a deep tree: the traversal stack must hold it (more
    /// copies overflow the stack of obvhs's own recursive validation, which runs in test builds).
    #[test]
    fn coincident_triangles_are_traversed() {
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let prims: Vec<Primitive> =
            (0..3_000).map(|i| Primitive::Triangle { p: t, normals: None, tag: i }).collect();
        let accel = Accel::build(&prims);
        let h = accel.intersect(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z, f32::INFINITY).unwrap();
        assert!((h.t - 1.0).abs() < 1e-5);
        assert!(accel.occluded(Vec3::new(0.2, 0.2, -1.0), Vec3::Z, 2.0));
        assert!(!accel.occluded(Vec3::new(1.2, 0.2, -1.0), Vec3::Z, 2.0));
    }

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
