//! A four-wide BVH over an obvhs BVH2, and its traversal.
//!
//! obvhs builds the hierarchy (PLOC with reinsertion, leaves collapsed by SAH); this module
//! flattens it into nodes of four children whose boxes are stored as six [`Vec4`]s (min and max
//! per axis, one lane per child), so one node visit tests the ray against four boxes with SSE
//! arithmetic (x86-64's baseline: no `target-cpu`, no runtime dispatch needed). Each BVH4 node
//! takes the two children of a BVH2 node and keeps splitting the child of largest surface area
//! until it has four (Wald et al. 2008, "Getting rid of packets"). Traversal is a stack of (node,
//! entry distance), front-to-back for closest hits, with entries beyond the closest hit so far
//! skipped when popped.
//!
//! Why not obvhs's own CWBVH traversal: it decodes compressed 8-wide nodes with a per-call set-up
//! that dominates small scenes (46 % of a path-traced cornell-fog in `ray_traverse` for 36
//! triangles), it clamps every node's entry distance to 10⁻⁴ (the work-around in [`super`]), and
//! it has no query that stops at the first hit of a kind the caller chooses.

use glam::{Vec3A, Vec4};
use obvhs::bvh2::Bvh2;

/// Marks a child that is a leaf: `LEAF | first << COUNT_BITS | (count − 1)`.
pub(super) const LEAF: u32 = 1 << 31;
const COUNT_BITS: u32 = 4;
/// An unused child slot (its box is empty, so it is never entered).
const EMPTY: u32 = u32::MAX;

/// Largest leaf, in the caller's units (blocks or primitives).
pub(super) const MAX_LEAF: u32 = 1 << COUNT_BITS;

/// Four children: their boxes as min and max per axis (x, y, z), one lane each, and their
/// references (a node index, a leaf, or [`EMPTY`]).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node {
    /// min_x, max_x, min_y, max_y, min_z, max_z.
    bounds: [Vec4; 6],
    child: [u32; 4],
    /// Lanes that hold a child.
    lanes: u32,
}

/// A BVH4 whose leaves are ranges of the caller's items.
#[derive(Debug)]
pub(super) struct Bvh4 {
    nodes: Vec<Node>,
    /// The root when the whole tree is one leaf (fewer items than a leaf holds), else `EMPTY`.
    root_leaf: u32,
    /// Longest path from the root to a leaf, in nodes (bounds the traversal stack).
    depth: usize,
}

impl Default for Bvh4 {
    /// The empty tree: no nodes, no root leaf.
    fn default() -> Self {
        Self { nodes: Vec::new(), root_leaf: EMPTY, depth: 0 }
    }
}

/// A ray prepared for box tests: origin, direction, the inverse direction with zero components
/// replaced by ±10⁻³⁰ (so no box test computes 0 · ∞).
pub(super) struct BoxRay {
    o: [Vec4; 3],
    inv: [Vec4; 3],
}

impl BoxRay {
    pub(super) fn new(o: Vec3A, d: Vec3A) -> Self {
        let inv = |x: f32| {
            let x = if x.abs() < 1e-30 { 1e-30f32.copysign(x) } else { x };
            1.0 / x
        };
        let i = [inv(d.x), inv(d.y), inv(d.z)];
        Self { o: [Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z)], inv: i.map(Vec4::splat) }
    }
}

/// Box-test slack: the far distance is scaled by 1 + 2γ₃ (pbrt-v4's conservative slab test;
/// γₙ = nε/(1 − nε)), so rounding never rejects a box the ray touches.
const FAR_SLACK: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Relative outward padding of every box (a few ulps).
const PAD: f32 = 4.0 * f32::EPSILON;

/// What a leaf visit asks of the traversal.
pub(super) enum Visit {
    /// Go on (a closest hit may have shortened `t_max`).
    Continue,
    /// Stop: the query is answered.
    Stop,
}

impl Bvh4 {
    /// Flattens `bvh2`. `leaf` stores the items of a BVH2 leaf (their indices into the caller's
    /// primitives) and returns where they went: (first, count) in the caller's units, count ≤
    /// [`MAX_LEAF`].
    pub(super) fn from_bvh2(bvh2: &Bvh2, mut leaf: impl FnMut(&[u32]) -> (u32, u32)) -> Self {
        let mut out = Self { nodes: Vec::new(), root_leaf: EMPTY, depth: 0 };
        let Some(root) = bvh2.nodes.first() else { return out };
        let items = |n: &obvhs::bvh2::node::Bvh2Node| {
            let first = n.first_index as usize;
            &bvh2.primitive_indices[first..first + n.prim_count as usize]
        };
        if root.is_leaf() {
            let (first, count) = leaf(items(root));
            out.root_leaf = encode_leaf(first, count);
            return out;
        }
        out.flatten(bvh2, &mut leaf, &items);
        out
    }

    /// Appends the nodes of the BVH2's inner nodes from the root down, iteratively (a
    /// degenerate input — thousands of coincident triangles — can make the tree as deep as it
    /// is large), and records the depth.
    fn flatten<'a>(
        &mut self,
        bvh2: &'a Bvh2,
        leaf: &mut impl FnMut(&[u32]) -> (u32, u32),
        items: &impl Fn(&'a obvhs::bvh2::node::Bvh2Node) -> &'a [u32],
    ) {
        let empty = Vec4::splat(f32::INFINITY);
        let blank = Node {
            bounds: [empty, -empty, empty, -empty, empty, -empty],
            child: [EMPTY; 4],
            lanes: 0,
        };
        self.nodes.push(blank);
        // (BVH2 inner node, its BVH4 node, that node's level)
        let mut work = vec![(0usize, 0usize, 1usize)];
        while let Some((at, me, level)) = work.pop() {
            self.depth = self.depth.max(level);
            // Open the largest inner child until there are four.
            let first = bvh2.nodes[at].first_index as usize;
            let mut open = vec![first, first + 1];
            while open.len() < 4 {
                let widest = open
                    .iter()
                    .enumerate()
                    .filter(|&(_, &n)| !bvh2.nodes[n].is_leaf())
                    .max_by(|a, b| {
                        let area = |n: usize| bvh2.nodes[n].aabb().half_area();
                        area(*a.1).total_cmp(&area(*b.1))
                    })
                    .map(|(k, _)| k);
                let Some(k) = widest else { break };
                let n = open.swap_remove(k);
                let c = bvh2.nodes[n].first_index as usize;
                open.extend([c, c + 1]);
            }
            for (lane, &n) in open.iter().enumerate() {
                let node = &bvh2.nodes[n];
                let b = node.aabb();
                let child = if node.is_leaf() {
                    let (first, count) = leaf(items(node));
                    encode_leaf(first, count)
                } else {
                    let index = self.nodes.len();
                    self.nodes.push(blank);
                    work.push((n, index, level + 1));
                    index as u32
                };
                let slot = &mut self.nodes[me];
                for (axis, (lo, hi)) in [(b.min.x, b.max.x), (b.min.y, b.max.y), (b.min.z, b.max.z)]
                    .into_iter()
                    .enumerate()
                {
                    // Padded outwards: the triangles tested are rebuilt from rounded edges (and a
                    // sphere's box c ± r is rounded), so they may poke out of the exact box by an
                    // ulp; and a ray lying in a face of the box must still enter it.
                    let pad = PAD * lo.abs().max(hi.abs()) + f32::MIN_POSITIVE;
                    slot.bounds[2 * axis][lane] = lo - pad;
                    slot.bounds[2 * axis + 1][lane] = hi + pad;
                }
                slot.child[lane] = child;
                slot.lanes |= 1 << lane;
            }
        }
    }

    /// Entries the traversal stack can hold at most: three per level (the fourth child is
    /// visited at once) plus one.
    pub(super) fn stack_size(&self) -> usize {
        3 * self.depth + 1
    }

    /// Visits the leaves that `ray` may hit within (`t_min`, `*t_max`), nearest box first;
    /// `visit(first, count, t_max)` tests a leaf's items, may shorten `t_max` (a closest hit), and
    /// may stop the traversal. `stack` needs [`Self::stack_size`] entries.
    #[inline(always)]
    pub(super) fn traverse(
        &self,
        ray: &BoxRay,
        t_min: f32,
        t_max: &mut f32,
        stack: &mut [(u32, f32)],
        mut visit: impl FnMut(u32, u32, &mut f32) -> Visit,
    ) {
        if self.root_leaf != EMPTY {
            let (first, count) = decode_leaf(self.root_leaf);
            visit(first, count, t_max);
            return;
        }
        if self.nodes.is_empty() {
            return;
        }
        let mut top = 0usize;
        let mut current = 0u32;
        loop {
            if current & LEAF == 0 {
                let node = &self.nodes[current as usize];
                let (near, mask) = hit_children(node, ray, t_min, *t_max);
                // Children in order of entry distance: the nearest next, the rest pushed.
                let mut order = [(0u32, 0f32); 4];
                let mut n = 0;
                let mut bits = mask;
                while bits != 0 {
                    let lane = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let mut k = n;
                    let entry = (node.child[lane], near[lane]);
                    while k > 0 && order[k - 1].1 < entry.1 {
                        order[k] = order[k - 1];
                        k -= 1;
                    }
                    order[k] = entry;
                    n += 1;
                }
                if n > 0 {
                    for &(c, _) in &order[..n] {
                        if c & LEAF == 0 {
                            prefetch(&self.nodes[c as usize]);
                        }
                    }
                    // order is far to near: push all but the nearest.
                    for &e in &order[..n - 1] {
                        stack[top] = e;
                        top += 1;
                    }
                    current = order[n - 1].0;
                    continue;
                }
            } else {
                let (first, count) = decode_leaf(current);
                if let Visit::Stop = visit(first, count, t_max) {
                    return;
                }
            }
            // Pop the nearest entry that can still beat the closest hit.
            loop {
                if top == 0 {
                    return;
                }
                top -= 1;
                let (node, near) = stack[top];
                if near <= *t_max * FAR_SLACK {
                    current = node;
                    break;
                }
            }
        }
    }
}

/// The ray's entry distance into each child's box, and the mask of children it enters within
/// (`t_min`, `t_max`). Both slab distances per axis, ordered by min and max (no per-ray choice of
/// plane to index with).
#[inline(always)]
fn hit_children(node: &Node, ray: &BoxRay, t_min: f32, t_max: f32) -> (Vec4, u32) {
    let [lx, hx, ly, hy, lz, hz] = &node.bounds;
    let (ax, bx) = ((*lx - ray.o[0]) * ray.inv[0], (*hx - ray.o[0]) * ray.inv[0]);
    let (ay, by) = ((*ly - ray.o[1]) * ray.inv[1], (*hy - ray.o[1]) * ray.inv[1]);
    let (az, bz) = ((*lz - ray.o[2]) * ray.inv[2], (*hz - ray.o[2]) * ray.inv[2]);
    let near = ax.min(bx).max(ay.min(by)).max(az.min(bz).max(Vec4::splat(t_min)));
    let far = ax.max(bx).min(ay.max(by)).min(az.max(bz).min(Vec4::splat(t_max))) * FAR_SLACK;
    (near, near.cmple(far).bitmask() & node.lanes)
}

fn encode_leaf(first: u32, count: u32) -> u32 {
    debug_assert!((1..=MAX_LEAF).contains(&count) && first < (1 << (31 - COUNT_BITS)));
    LEAF | first << COUNT_BITS | (count - 1)
}

fn decode_leaf(c: u32) -> (u32, u32) {
    ((c & !LEAF) >> COUNT_BITS, (c & (MAX_LEAF - 1)) + 1)
}

/// Asks the processor to start loading `node` (both of its cache lines) into the cache: a child
/// the ray enters is read soon, and on large meshes every node visit is otherwise a wait for
/// memory.
#[inline(always)]
fn prefetch(node: &Node) {
    prefetch_bytes(node, 2);
}

/// Prefetches the first `lines` cache lines of `value` (see [`prefetch`]).
#[inline(always)]
#[allow(unsafe_code)]
pub(super) fn prefetch_bytes<T>(value: &T, lines: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let p = value as *const T as *const i8;
        for k in 0..lines.min(std::mem::size_of::<T>().div_ceil(64)) {
            // SAFETY: a prefetch is only a hint: it never faults, reads nothing into the program
            // and writes nothing. The address stays inside `value` (k · 64 < its size), so the
            // pointer arithmetic is in bounds of one live object.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.add(64 * k)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (value, lines);
}
