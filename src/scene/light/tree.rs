//! Choosing the light for next-event estimation by its likely contribution where the light is
//! received (Conty Estevez & Kulla 2018, "Importance sampling of many lights"; pbrt-v4's
//! `BVHLightSampler` follows the same paper).
//!
//! Every light with a position — point, spot, area — is bounded by a [`LightBounds`]: a box
//! around its emitting points, its emitted intensity Φ (W/sr: a point or spot light's intensity,
//! an area light's radiance times its area), and the cone of directions its surface normals (or
//! its beam axis) take, with the angle beyond that cone over which emission falls to zero. The
//! bounds of a group of lights are the union of theirs. At a receiving point p (with a surface
//! normal n, or none in a medium) the **importance** of a group estimates the irradiance it can
//! deliver there, without shadows:
//!
//!   I(p) = Φ · g(θ′) · c(θ_i′) / max(d², R²)
//!
//! with d the distance from p to the box's centre and R the box's half-diagonal; θ′ the smallest
//! angle any emitting point of the box could make between its cone and p (the angle to the cone's
//! axis less the cone's half-angle and the angle θ_b the box subtends from p); g falls from 1 at
//! θ′ = 0 to 0 at the end of the emission falloff (cos θ′ for area lights, whose falloff is a
//! quarter turn); and c the same bound on the receiver's cosine. Where a light cannot reach p at
//! all — p behind a one-sided area light, outside a spot's cone, light from behind a surface — the
//! importance is exactly zero, and anywhere else it is positive, so choosing by importance never
//! misses light (the estimate stays unbiased) and never wastes a shadow ray on a light that
//! cannot contribute.
//!
//! The lights form a binary tree, built top-down by the surface-area-orientation heuristic of the
//! paper; a light is drawn by walking down from the root, choosing each child in proportion to its
//! importance at p, and its probability is the product along its path (each light keeps the bits
//! of its path). A subtree of at most [`EXACT_LEAVES`] lights is weighed by the sum of its lights'
//! own importances instead of its bounds, so a scene of a few lights chooses each in exact
//! proportion to its importance. Above that, a group's bounds can promise light that none of its
//! lights can bring: the walk then ends without a light, and the probabilities sum to less than
//! one — still unbiased (a light that can contribute always has a positive probability), only a
//! wasted sample. Directional lights sit beside the tree with importance E · max(0, n · ω_l) (their
//! irradiance on the receiver): unlike their emitted power, which haze measures over the scene's
//! cross-section, this does not depend on the size of the scene. The root of the tree and the
//! directional lights are chosen among in proportion to their importance. An environment light
//! sits beside them too, with the irradiance it brings the receiver (`environment.rs`).
//!
//! A second traversal serves single scattering along an eye segment in a medium, where the light
//! is chosen for the whole segment before a distance is drawn towards it (equiangular sampling):
//! there a group's importance is Φ times its best cone factor at the segment's ends and nearest
//! point, times ∫ dt / (D² + (t − Δ)²) over the segment — the equiangular integral of the inverse
//! square distance, D the distance of the group's centre from the line (at least R) — times the
//! eye-side transmittance at the nearest point.

use super::{Emitter, Light};
use crate::math::luminance;
use glam::{Quat, Vec3};
use std::f32::consts::{FRAC_PI_2, PI};

/// Where light is received: a point and, at a surface, the normal on the side the light must
/// arrive from (`None` in a medium, which scatters light from every direction).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Receiver {
    /// Position.
    pub p: Vec3,
    /// Unit normal on the receiving side, at a surface.
    pub n: Option<Vec3>,
}

impl Receiver {
    /// A point in a medium.
    pub(crate) fn medium(p: Vec3) -> Self {
        Self { p, n: None }
    }

    /// A point of a surface that receives light from the side `n` points to.
    pub(crate) fn surface(p: Vec3, n: Vec3) -> Self {
        Self { p, n: Some(n) }
    }
}

/// The part o + t d, t0 ≤ t ≤ t1, of an eye ray in a medium (t1 may be infinite), with the
/// transmittance from the ray's origin.
pub(crate) struct Segment<'a> {
    pub o: Vec3,
    pub d: Vec3,
    pub t0: f32,
    pub t1: f32,
    pub tr: &'a dyn Fn(f32) -> f32,
}

/// A cone of directions: unit axis and half-angle (π: every direction).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Cone {
    axis: Vec3,
    theta: f32,
}

impl Cone {
    const ALL: Cone = Cone { axis: Vec3::Z, theta: PI };

    /// The smallest cone holding both.
    fn union(a: Cone, b: Cone) -> Cone {
        let (a, b) = if b.theta > a.theta { (b, a) } else { (a, b) };
        let between = angle(a.axis, b.axis);
        if (between + b.theta).min(PI) <= a.theta {
            return a;
        }
        let theta = 0.5 * (a.theta + between + b.theta);
        if theta >= PI {
            return Cone::ALL;
        }
        let turn = theta - a.theta;
        let w = a.axis.cross(b.axis);
        if w.length_squared() < 1e-12 {
            // Opposite axes (parallel ones were absorbed above): every direction.
            return Cone::ALL;
        }
        let axis = Quat::from_axis_angle(w.normalize(), turn) * a.axis;
        Cone { axis: axis.normalize(), theta }
    }
}

/// Angle between unit vectors, accurate near 0 and π.
#[inline]
fn angle(a: Vec3, b: Vec3) -> f32 {
    let c = a.dot(b);
    if c > 0.0 {
        2.0 * (0.5 * (a - b).length()).min(1.0).asin()
    } else {
        PI - 2.0 * (0.5 * (a + b).length()).min(1.0).asin()
    }
}

/// What bounds the light of one light or a group of lights (module docs).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LightBounds {
    lo: Vec3,
    hi: Vec3,
    /// Emitted intensity, mean over channels (W/sr): summed over a group.
    phi: f32,
    /// Directions of the normals (area lights) or the beam's axis (spots).
    normals: Cone,
    /// Angle beyond the cone over which emission falls to zero.
    theta_e: f32,
}

impl LightBounds {
    /// The bounds of a light with a position; `None` for a directional light.
    pub(crate) fn of(light: &Light) -> Option<Self> {
        match light {
            Light::Point { position, intensity } => Some(Self {
                lo: *position,
                hi: *position,
                phi: luminance(*intensity),
                normals: Cone::ALL,
                theta_e: FRAC_PI_2,
            }),
            Light::Spot { position, frame, intensity, cos_max, cos_start } => {
                let theta_o = cos_start.clamp(-1.0, 1.0).acos();
                let theta_max = cos_max.clamp(-1.0, 1.0).acos();
                Some(Self {
                    lo: *position,
                    hi: *position,
                    phi: luminance(*intensity),
                    normals: Cone { axis: frame.n, theta: theta_o },
                    theta_e: (theta_max - theta_o).max(0.0),
                })
            }
            Light::Directional { .. } | Light::Environment(_) => None,
            Light::Area { radiance, emitter, .. } => {
                let phi = luminance(*radiance);
                Some(match emitter {
                    Emitter::Triangles { triangles, .. } => {
                        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
                        let mut normals: Option<Cone> = None;
                        let mut area = 0.0;
                        for t in triangles {
                            for v in t {
                                (lo, hi) = (lo.min(*v), hi.max(*v));
                            }
                            let n = (t[1] - t[0]).cross(t[2] - t[0]);
                            let len = n.length();
                            if len > 0.0 {
                                area += 0.5 * len;
                                let cone = Cone { axis: n / len, theta: 0.0 };
                                normals = Some(normals.map_or(cone, |c| Cone::union(c, cone)));
                            }
                        }
                        Self {
                            lo,
                            hi,
                            phi: phi * area,
                            normals: normals.unwrap_or(Cone::ALL),
                            theta_e: FRAC_PI_2,
                        }
                    }
                    // A sphere shows πr² of its area to any point outside it.
                    Emitter::Sphere { center, radius } => Self {
                        lo: *center - Vec3::splat(*radius),
                        hi: *center + Vec3::splat(*radius),
                        phi: phi * PI * radius * radius,
                        normals: Cone::ALL,
                        theta_e: FRAC_PI_2,
                    },
                })
            }
        }
    }

    fn union(&self, b: &LightBounds) -> LightBounds {
        LightBounds {
            lo: self.lo.min(b.lo),
            hi: self.hi.max(b.hi),
            phi: self.phi + b.phi,
            normals: Cone::union(self.normals, b.normals),
            theta_e: self.theta_e.max(b.theta_e),
        }
    }

    fn centre(&self) -> Vec3 {
        0.5 * (self.lo + self.hi)
    }

    fn half_diagonal(&self) -> f32 {
        0.5 * (self.hi - self.lo).length()
    }

    /// The angle the bounding sphere of the box subtends from a point at distance `dist` from
    /// its centre (π from inside).
    fn subtended(&self, dist: f32) -> f32 {
        let r = self.half_diagonal();
        if dist > r { (r / dist).asin() } else { PI }
    }

    /// The emission factor g(θ′) towards a point in direction `to` (unit, from the centre) seen
    /// under the half-angle `theta_b`: 1 inside the cone grown by θ_b, falling to 0 over the
    /// falloff angle, 0 beyond.
    fn cone_factor(&self, to: Vec3, theta_b: f32) -> f32 {
        if self.normals.theta >= PI {
            return 1.0;
        }
        let theta = (angle(self.normals.axis, to) - self.normals.theta - theta_b).max(0.0);
        if theta > self.theta_e {
            0.0
        } else if theta <= 0.0 {
            1.0
        } else {
            (theta * (FRAC_PI_2 / self.theta_e)).cos().max(0.0)
        }
    }

    /// The importance at a receiver (module docs).
    pub(crate) fn importance(&self, r: &Receiver) -> f32 {
        let v = r.p - self.centre();
        let dist2 = v.length_squared();
        let dist = dist2.sqrt();
        let to = if dist > 0.0 { v / dist } else { self.normals.axis };
        let theta_b = self.subtended(dist);
        let g = self.cone_factor(to, theta_b);
        if g <= 0.0 {
            return 0.0;
        }
        let c = match r.n {
            Some(n) => {
                let theta_i = (angle(n, -to) - theta_b).max(0.0);
                if theta_i >= FRAC_PI_2 { 0.0 } else { theta_i.cos() }
            }
            None => 1.0,
        };
        let r2 = self.half_diagonal().powi(2);
        self.phi * g * c / dist2.max(r2).max(1e-12)
    }

    /// The importance for a segment (module docs).
    fn segment_importance(&self, seg: &Segment) -> f32 {
        let c = self.centre();
        let delta = (c - seg.o).dot(seg.d);
        let dist = (c - (seg.o + seg.d * delta)).length().max(self.half_diagonal()).max(1e-6);
        let theta_a = ((seg.t0 - delta) / dist).atan();
        let theta_b = if seg.t1.is_finite() { ((seg.t1 - delta) / dist).atan() } else { FRAC_PI_2 };
        if theta_b.is_nan() || theta_b <= theta_a {
            return 0.0;
        }
        let nearest = delta.clamp(seg.t0, seg.t1);
        let g = [seg.t0, nearest, seg.t1]
            .into_iter()
            .filter(|t| t.is_finite())
            .map(|t| {
                let v = seg.o + seg.d * t - c;
                let len = v.length();
                let to = if len > 0.0 { v / len } else { self.normals.axis };
                self.cone_factor(to, self.subtended(len))
            })
            .fold(0.0, f32::max);
        self.phi * g * (theta_b - theta_a) / dist * (seg.tr)(nearest)
    }

    fn surface_area(&self) -> f32 {
        let e = self.hi - self.lo;
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// The orientation measure M_Ω of the paper (its eq. 1): the solid angle of the normal
    /// cone, with the falloff band weighted by a cosine.
    fn orientation_measure(&self) -> f32 {
        let theta_o = self.normals.theta;
        let theta_w = (theta_o + self.theta_e).min(PI);
        let (sin_o, cos_o) = theta_o.sin_cos();
        2.0 * PI * (1.0 - cos_o)
            + FRAC_PI_2
                * (2.0 * theta_w * sin_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_o
                    + cos_o)
    }

    /// The heuristic cost of a group (surface area × orientation × power), with a small floor
    /// on the area so that groups of point lights still compare by power and orientation.
    fn cost(&self, scale: f32) -> f32 {
        self.phi * self.orientation_measure() * (self.surface_area() + 1e-6 * scale * scale)
    }
}

/// A tree node: its bounds, and either the light it holds or its second child (the first
/// follows it).
#[derive(Clone, Debug)]
struct Node {
    bounds: LightBounds,
    leaf: bool,
    /// Leaf: the light's index in the scene. Interior: the second child's node index.
    index: u32,
    /// One past the last node of its subtree (which starts at the node itself).
    end: u32,
    /// Lights in its subtree.
    leaves: u32,
}

/// The importance-driven light choice of next-event estimation (module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct LightTree {
    nodes: Vec<Node>,
    /// Per light of the scene: its path from the root (bit k set: the second child at depth k)
    /// and its depth, for lights in the tree.
    trails: Vec<Option<(u64, u32)>>,
    /// Lights at infinity (directional and environment lights), with their index.
    directional: Vec<(u32, Infinite)>,
    lights: usize,
}

/// Splits by the heuristic stop at this depth; below it lights are halved by count, so that no
/// path is longer than the 64 bits of a trail (2⁶⁴⁻⁴⁰ lights would be needed to exceed it).
const HEURISTIC_DEPTH: u32 = 40;

/// Buckets per axis for the split heuristic.
const BUCKETS: usize = 12;

/// A subtree of at most this many lights is judged by the sum of its lights' own importances
/// rather than by its bounds: exact for scenes of a few lights (every light gets the share of
/// its own importance, and a walk never ends in a subtree whose bounds promised light that none
/// of its lights can bring), and cheap.
const EXACT_LEAVES: u32 = 8;

impl LightTree {
    pub(crate) fn new(lights: &[Light]) -> Self {
        let mut tree =
            Self { trails: vec![None; lights.len()], lights: lights.len(), ..Self::default() };
        let mut bounded = Vec::new();
        for (i, light) in lights.iter().enumerate() {
            match (LightBounds::of(light), light) {
                (Some(b), _) if b.phi > 0.0 && b.phi.is_finite() => bounded.push((i as u32, b)),
                (None, Light::Directional { direction, irradiance, .. }) => {
                    let e = luminance(*irradiance);
                    if e > 0.0 && e.is_finite() {
                        tree.directional.push((i as u32, Infinite::Parallel(e, *direction)));
                    }
                }
                (None, Light::Environment(env)) if env.importance.at(None) > 0.0 => {
                    let importance = Box::new(env.importance.clone());
                    tree.directional.push((i as u32, Infinite::Environment(importance)));
                }
                _ => {}
            }
        }
        if !bounded.is_empty() {
            let (lo, hi) =
                bounded.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (_, b)| {
                    (lo.min(b.lo), hi.max(b.hi))
                });
            let scale = (hi - lo).max_element().max(1e-3);
            tree.build(&mut bounded, 0, 0, scale);
        }
        tree
    }

    /// Appends the subtree over `items` (its path from the root is `trail`, `depth` bits long)
    /// and returns its bounds.
    fn build(
        &mut self,
        items: &mut [(u32, LightBounds)],
        trail: u64,
        depth: u32,
        scale: f32,
    ) -> LightBounds {
        let at = self.nodes.len();
        if let [(light, bounds)] = items {
            let end = at as u32 + 1;
            self.nodes.push(Node { bounds: *bounds, leaf: true, index: *light, end, leaves: 1 });
            self.trails[*light as usize] = Some((trail, depth));
            return *bounds;
        }
        let leaves = items.len() as u32;
        let placeholder = Node { bounds: items[0].1, leaf: false, index: 0, end: 0, leaves };
        self.nodes.push(placeholder);
        let mid = if depth < HEURISTIC_DEPTH { split(items, scale) } else { None };
        let mid = mid.unwrap_or_else(|| {
            items.sort_by_key(|(i, _)| *i);
            items.len() / 2
        });
        let (first, second) = items.split_at_mut(mid);
        let a = self.build(first, trail, depth + 1, scale);
        let second_at = self.nodes.len() as u32;
        let b = self.build(second, trail | (1 << depth), depth + 1, scale);
        let bounds = a.union(&b);
        let end = self.nodes.len() as u32;
        self.nodes[at] = Node { bounds, leaf: false, index: second_at, end, leaves };
        bounds
    }

    /// The importance of node `at` by `importance` of bounds: the sum over its lights for small
    /// subtrees, its bounds' otherwise.
    #[inline]
    fn weigh(&self, at: usize, importance: &impl Fn(&LightBounds) -> f32) -> f32 {
        let node = &self.nodes[at];
        if node.leaves == 1 || node.leaves > EXACT_LEAVES {
            return importance(&node.bounds);
        }
        self.nodes[at..node.end as usize]
            .iter()
            .filter(|n| n.leaf)
            .map(|n| importance(&n.bounds))
            .sum()
    }

    /// Draws a light for the receiver `r` from a uniform `u`: its index and probability, or `None`
    /// if no light can contribute there. With a single light in the scene that light, always, with
    /// probability 1.
    pub(crate) fn pick(&self, r: &Receiver, u: f32) -> Option<(usize, f32)> {
        if self.lights == 1 {
            return Some((0, 1.0));
        }
        let importance = |b: &LightBounds| b.importance(r);
        let root = if self.nodes.is_empty() { 0.0 } else { self.weigh(0, &importance) };
        let total = root + self.directional.iter().map(|l| directional(l, r)).sum::<f32>();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let mut x = u * total;
        let mut last = None;
        for l in &self.directional {
            let imp = directional(l, r);
            if imp > 0.0 {
                if x < imp {
                    return Some((l.0 as usize, imp / total));
                }
                last = Some((l.0 as usize, imp / total));
                x -= imp;
            }
        }
        if root <= 0.0 {
            return last;
        }
        let u = (x / root).clamp(0.0, ONE_BELOW);
        self.descend(u, root / total, importance)
    }

    /// The probability that [`Self::pick`] returns light `i` at `r`.
    pub(crate) fn prob(&self, r: &Receiver, i: usize) -> f32 {
        if self.lights == 1 {
            return if i == 0 { 1.0 } else { 0.0 };
        }
        let importance = |b: &LightBounds| b.importance(r);
        let root = if self.nodes.is_empty() { 0.0 } else { self.weigh(0, &importance) };
        let mut mine = None;
        let mut total = root;
        for l in &self.directional {
            let imp = directional(l, r);
            total += imp;
            if l.0 as usize == i {
                mine = Some(imp);
            }
        }
        if !(total > 0.0 && total.is_finite()) {
            return 0.0;
        }
        match mine {
            Some(imp) => imp / total,
            None => self.trail_prob(i, root / total, importance),
        }
    }

    /// Draws a light with a position for single scattering along `seg`: its index and
    /// probability, or `None` if there is none or none can contribute. With a single such light,
    /// that light with probability 1.
    pub(crate) fn pick_along(&self, seg: &Segment, u: f32) -> Option<(usize, f32)> {
        match self.nodes.len() {
            0 => None,
            1 => Some((self.nodes[0].index as usize, 1.0)),
            _ => self.descend(u, 1.0, |b| b.segment_importance(seg)),
        }
    }

    /// The probability that [`Self::pick_along`] returns light `i` for `seg`.
    pub(crate) fn prob_along(&self, seg: &Segment, i: usize) -> f32 {
        match self.nodes.len() {
            0 => 0.0,
            1 => {
                if self.nodes[0].index as usize == i {
                    1.0
                } else {
                    0.0
                }
            }
            _ => self.trail_prob(i, 1.0, |b| b.segment_importance(seg)),
        }
    }

    /// Walks from the root to a leaf, choosing children in proportion to `importance`.
    fn descend(
        &self,
        mut u: f32,
        mut p: f32,
        importance: impl Fn(&LightBounds) -> f32,
    ) -> Option<(usize, f32)> {
        let mut at = 0usize;
        loop {
            let node = &self.nodes[at];
            if node.leaf {
                return Some((node.index as usize, p));
            }
            let (a, b) = (at + 1, node.index as usize);
            let (ia, ib) = (self.weigh(a, &importance), self.weigh(b, &importance));
            let sum = ia + ib;
            if !(sum > 0.0 && sum.is_finite()) {
                return None;
            }
            let pa = ia / sum;
            if u < pa {
                u = (u / pa).min(ONE_BELOW);
                p *= pa;
                at = a;
            } else {
                u = ((u - pa) / (1.0 - pa)).clamp(0.0, ONE_BELOW);
                p *= ib / sum;
                at = b;
            }
        }
    }

    /// The probability of reaching light `i`'s leaf from the root (reached with `p`).
    fn trail_prob(&self, i: usize, mut p: f32, importance: impl Fn(&LightBounds) -> f32) -> f32 {
        let Some(Some((trail, depth))) = self.trails.get(i) else { return 0.0 };
        let mut at = 0usize;
        for k in 0..*depth {
            let node = &self.nodes[at];
            let (a, b) = (at + 1, node.index as usize);
            let (ia, ib) = (self.weigh(a, &importance), self.weigh(b, &importance));
            let sum = ia + ib;
            if !(sum > 0.0 && sum.is_finite()) {
                return 0.0;
            }
            if trail >> k & 1 == 0 {
                p *= ia / sum;
                at = a;
            } else {
                p *= ib / sum;
                at = b;
            }
        }
        p
    }
}

/// The largest f32 below 1.
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

/// A light at infinity, for its importance.
#[derive(Clone, Debug)]
enum Infinite {
    /// A directional light: its importance without the receiver's cosine, direction of travel.
    Parallel(f32, Vec3),
    /// An environment light's irradiance by normal.
    Environment(Box<super::environment::EnvImportance>),
}

/// A light at infinity's importance at `r`: its irradiance on the receiver.
#[inline]
fn directional((_, light): &(u32, Infinite), r: &Receiver) -> f32 {
    match (light, r.n) {
        (Infinite::Parallel(e, direction), Some(n)) => e * n.dot(-*direction).max(0.0),
        (Infinite::Parallel(e, _), None) => *e,
        (Infinite::Environment(env), n) => env.at(n),
    }
}

/// Where to split `items` (at least two) by the surface-area-orientation heuristic, reordering
/// them so that the split is a prefix; `None` if no split separates them.
fn split(items: &mut [(u32, LightBounds)], scale: f32) -> Option<usize> {
    let (lo, hi) = items.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (_, b)| {
        (lo.min(b.centre()), hi.max(b.centre()))
    });
    let extent = hi - lo;
    let bucket = |b: &LightBounds, axis: usize| {
        let f = (b.centre()[axis] - lo[axis]) / extent[axis];
        ((f * BUCKETS as f32) as usize).min(BUCKETS - 1)
    };
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in 0..3 {
        if extent[axis].is_nan() || extent[axis] <= 0.0 {
            continue;
        }
        let mut groups: [Option<LightBounds>; BUCKETS] = [None; BUCKETS];
        for (_, b) in items.iter() {
            let k = bucket(b, axis);
            groups[k] = Some(groups[k].map_or(*b, |g| g.union(b)));
        }
        // Thin axes are penalised: splitting across them separates little.
        let regular = extent.max_element() / extent[axis];
        for cut in 1..BUCKETS {
            let side = |range: std::ops::Range<usize>| {
                groups[range]
                    .iter()
                    .flatten()
                    .fold(None, |acc: Option<LightBounds>, g| Some(acc.map_or(*g, |a| a.union(g))))
            };
            let (Some(a), Some(b)) = (side(0..cut), side(cut..BUCKETS)) else { continue };
            let cost = regular * (a.cost(scale) + b.cost(scale));
            if best.is_none_or(|(c, ..)| cost < c) {
                best = Some((cost, axis, cut));
            }
        }
    }
    let (_, axis, cut) = best?;
    items.sort_by_key(|(i, b)| (bucket(b, axis) >= cut, *i));
    let mid = items.iter().filter(|(_, b)| bucket(b, axis) < cut).count();
    (mid > 0 && mid < items.len()).then_some(mid)
}
