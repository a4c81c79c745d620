//! Photons where the camera looks: emission guided by a pilot pass.
//!
//! Most photons of a scene can be useless to its image: a sun spread over a large ground sends
//! most of its photons onto ground nobody sees, a small lamp in an open scene most of its photons
//! into the sky. Hachisuka & Jensen ("Robust adaptive photon tracing using photon path
//! visibility", ACM TOG 2011) distribute photon paths by their *visibility* — a path is visible
//! if some photon of it contributes to some measurement — with a Markov chain over the paths'
//! random numbers. A chain carries its state from one photon to the next, so iterations would no
//! longer be independent, and the probabilistic schedule, splitting a render into ranges and
//! resuming it all rely on independent iterations. haze uses their visibility with a fixed
//! importance function instead:
//!
//! 1. A **pilot**, before the first iteration: light paths traced as without guiding (random
//!    streams of "iteration 0", so the pilot is a pure function of scene, settings and seed, the
//!    same in every process of a split render), photon maps built at iteration 1's radii (the
//!    largest), and a camera pass that marks every photon an estimate gathers. A path is visible
//!    if one of its photons is marked.
//! 2. For each light, a piecewise-constant density over the pair of uniforms that places its
//!    photons — the position on a directional light's cross-section, the direction of a point,
//!    spot or area light — on a quadtree over [0, 1]² refined where visible paths are (a cell is
//!    split while it holds more than 1 % of the light's visible paths, down to 2⁻¹⁰). A photon
//!    whose uniforms fall where a fraction f of paths is visible contributes c with probability
//!    f: its second moment is f c², and the density that minimises the variance is proportional
//!    to its square root, √f (the target of variance-aware guiding: Rath et al., "Variance-aware
//!    path guiding", ACM TOG 2020). Proportional to f itself — visibility's own distribution —
//!    it starves regions seen rarely but together worth much (the sunlit ground under a cloud,
//!    whose photons light the cloud from below): on vdb-cloud that was worse than no guiding.
//!    Lights are chosen in proportion to power × ∫ √f, the same optimum across lights.
//! 3. Every iteration draws half its light paths as without guiding (light by power, uniforms
//!    uniform) and half from the guide (light and uniforms from these densities), and divides
//!    each path's power by the density of the mixture of the two at what it drew — a defensive
//!    mixture (Hesterberg, "Weighted average importance sampling and defensive mixture
//!    distributions", Technometrics 1995). No region the pilot missed is left without photons,
//!    and no path weighs more than twice its unguided weight, so a guide fitted to a noisy pilot
//!    can at most double the variance (a tenth, as first tried, allowed 100×, and a white
//!    furnace at g = −0.95 came out three times noisier than unguided).
//!
//! Each iteration is then an ordinary photon-mapping render whose light paths are importance
//! sampled with a fixed, everywhere positive density: its expected estimate is exactly the
//! unguided one, and the schedule's convergence argument holds unchanged (docs/theory.md).

use crate::photon::sort::{CountingSort, split};
use crate::scene::light::{Light, LightSampler};
use glam::Vec2;
use rayon::prelude::*;

/// Share of the light paths emitted as without guiding (the defensive mixture). Measured on
/// vdb-cloud (200×125, 40,000 paths, 16 iterations, 12 seeds): per-pixel variance 3.4·10⁻³ with
/// a half, 4.1·10⁻³ with a quarter, against 3.2·10⁻² unguided.
pub(crate) const DEFENSIVE: f32 = 0.5;

/// A quadtree cell is split while it holds more than this share of its light's visible paths …
const SPLIT_SHARE: f32 = 0.01;

/// … and at least this many of them …
const SPLIT_MIN: usize = 8;

/// … down to cells of side 2⁻ᴹᴬˣ_ᴰᴱᴾᵀᴴ.
const MAX_DEPTH: u32 = 10;

/// A node of at least this many pilot points grows its quadrants' subtrees in parallel.
const PARALLEL_POINTS: usize = 1 << 14;

/// Lights among which a fit splits its pilot paths ([`split`]); among more, it sorts them by light
/// ([`CountingSort`]).
const SPLIT_LIGHTS: usize = 64;

/// A node of at least this many pilot points is split into its quadrants in parallel (whatever
/// the subtrees' growth does, so that a tree grown serially is cut the same way).
const PARTITION_PARALLEL: usize = 1 << 15;

/// Which pair of a light's emission uniforms the guide warps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Guided {
    /// Where on the light (a directional light's cross-section, an environment's disc).
    Position,
    /// Which way (point, spot and area lights).
    Direction,
}

/// The pair of uniforms guided for `light`.
pub(crate) fn guided(light: &Light) -> Guided {
    match light {
        Light::Directional { .. } | Light::Environment(_) => Guided::Position,
        _ => Guided::Direction,
    }
}

/// A node of a [`QuadTree`]: the masses of its four quadrants (x-half + 2 · y-half) and their
/// nodes (0: a leaf; the root is node 0 and no one's child).
#[derive(Clone, Debug)]
struct Node {
    mass: [f32; 4],
    child: [u32; 4],
}

/// A piecewise-constant density over [0, 1]², uniform within the leaves of a quadtree.
#[derive(Clone, Debug)]
pub(crate) struct QuadTree {
    nodes: Vec<Node>,
}

/// Pilot points — a pair of uniforms and a path's value — being fitted.
type Points<'a> = &'a mut [(Vec2, f32)];

/// The largest f32 below 1.
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

/// What a fit counts: all pilot points, and the sum of their moments.
struct Fit {
    all: f64,
    total: f64,
    /// Nodes of at least this many points grow their subtrees in parallel.
    parallel_from: usize,
}

/// The node of quadrant `q` of node `at`, if it is not a leaf.
fn child(tree: &QuadTree, at: usize, q: usize) -> Option<usize> {
    match tree.nodes[at].child[q] {
        0 => None,
        c => Some(c as usize),
    }
}

impl QuadTree {
    /// The uniform density.
    pub(crate) fn uniform() -> Self {
        Self { nodes: vec![Node { mass: [0.25; 4], child: [0; 4] }] }
    }

    /// The guiding density for the uniformly drawn pilot points `points`, each with the second
    /// moment of its path's contribution to the image, mixed with the uniform density with
    /// weight `defensive`; and ∫ √m(u) du, m being the second moment per unit of [0, 1]² (for the
    /// light's share and the gain, see [`EmissionGuide::from_pilot`]). A leaf of area A whose
    /// points' moments sum to V, of N points in all, estimates m there as V / (N A) (the expected
    /// count N A is steadier than the count itself) and gets the mass √(V / (N A)) · A before
    /// normalisation; a cell is split while it holds more than a share of the total moment
    /// (module docs).
    pub(crate) fn fit(points: &mut [(Vec2, f32)], defensive: f32) -> (Self, f64) {
        Self::fit_with(points, defensive, PARALLEL_POINTS)
    }

    /// [`Self::fit`], growing subtrees of nodes of at least `parallel_from` points in parallel.
    fn fit_with(points: &mut [(Vec2, f32)], defensive: f32, parallel_from: usize) -> (Self, f64) {
        let total = crate::buffers::sum(points.len(), |i| points[i].1 as f64);
        if total <= 0.0 {
            return (Self::uniform(), 0.0);
        }
        let mut tree = Self { nodes: Vec::new() };
        let fit = Fit { all: points.len() as f64, total, parallel_from };
        // Where large nodes' points go when they are split (and back, a level down).
        let mut spare = crate::buffers::filled(points.len(), (Vec2::ZERO, 0.0));
        let integral = tree.grow(points, &mut spare, Vec2::ZERO, 1.0, 0, &fit) as f64;
        // Normalise the √m masses to one and mix in the uniform density.
        let scale = (1.0 - defensive) / integral as f32;
        let mut stack = vec![(0usize, 1.0f32)];
        while let Some((at, size)) = stack.pop() {
            let half = 0.5 * size;
            for q in 0..4 {
                match child(&tree, at, q) {
                    Some(c) => stack.push((c, half)),
                    None => {
                        let m = &mut tree.nodes[at].mass[q];
                        *m = *m * scale + defensive * half * half;
                    }
                }
            }
        }
        tree.sum_masses(0);
        (tree, integral)
    }

    /// Recomputes interior masses as the sums of their children's.
    fn sum_masses(&mut self, at: usize) -> f32 {
        for q in 0..4 {
            if let Some(c) = child(self, at, q) {
                let m = self.sum_masses(c);
                self.nodes[at].mass[q] = m;
            }
        }
        self.nodes[at].mass.iter().sum()
    }

    /// Appends the node over the square at `origin` of side `size` holding `points` (`spare`, as
    /// long, is room for [`partition`]); returns its √m mass. Each quadrant's subtree grows into a
    /// tree of its own that is then appended, side by side in nodes of at least
    /// `fit.parallel_from` points: the nodes, their order (depth first, quadrants in order) and
    /// every mass are the same either way.
    fn grow(
        &mut self,
        points: &mut [(Vec2, f32)],
        spare: &mut [(Vec2, f32)],
        origin: Vec2,
        size: f32,
        depth: u32,
        fit: &Fit,
    ) -> f32 {
        let at = self.nodes.len();
        self.nodes.push(Node { mass: [0.0; 4], child: [0; 4] });
        let half = 0.5 * size;
        let mid = origin + Vec2::splat(half);
        let quadrant = |p: &(Vec2, f32)| (p.0.x >= mid.x) as usize + 2 * (p.0.y >= mid.y) as usize;
        let (start, points, spare) = partition(points, spare, quadrant);
        let mut quadrants = Vec::with_capacity(4);
        let (mut rest, mut room) = (points, spare);
        for q in 0..4 {
            let n = start[q + 1] - start[q];
            let (mine, tail) = rest.split_at_mut(n);
            let (mine_spare, room_tail) = room.split_at_mut(n);
            (rest, room) = (tail, room_tail);
            let seen = if mine.len() < PARTITION_PARALLEL {
                mine.iter().filter(|p| p.1 > 0.0).count()
            } else {
                mine.par_iter().filter(|p| p.1 > 0.0).count()
            };
            let moment = crate::buffers::sum(mine.len(), |i| mine[i].1 as f64);
            let split = depth + 1 < MAX_DEPTH
                && seen >= SPLIT_MIN
                && moment > SPLIT_SHARE as f64 * fit.total;
            quadrants.push((q, mine, mine_spare, moment, split));
        }
        let corner = |q: usize| origin + Vec2::new((q % 2) as f32, (q / 2) as f32) * half;
        let leaf = |moment: f64| {
            let area = (half * half) as f64;
            ((moment / (fit.all * area)).sqrt() * area) as f32
        };
        // A quadrant's subtree grows into a tree of its own, appended below in quadrant order.
        type Quadrant<'a> = (usize, Points<'a>, Points<'a>, f64, bool);
        let grow = |(q, mine, mine_spare, moment, split): Quadrant| {
            if split {
                let mut sub = Self { nodes: Vec::new() };
                let mass = sub.grow(mine, mine_spare, corner(q), half, depth + 1, fit);
                (q, Some(sub), mass)
            } else {
                (q, None, leaf(moment))
            }
        };
        let points: usize = quadrants.iter().map(|(_, mine, ..)| mine.len()).sum();
        let grown: Vec<(usize, Option<QuadTree>, f32)> = if points < fit.parallel_from {
            quadrants.into_iter().map(grow).collect()
        } else {
            quadrants.into_par_iter().map(grow).collect()
        };
        for (q, sub, mass) in grown {
            if let Some(sub) = sub {
                let offset = self.nodes.len() as u32;
                self.nodes[at].child[q] = offset;
                self.nodes.extend(sub.nodes.into_iter().map(|mut node| {
                    for c in node.child.iter_mut().filter(|c| **c != 0) {
                        *c += offset;
                    }
                    node
                }));
            }
            self.nodes[at].mass[q] = mass;
        }
        self.nodes[at].mass.iter().sum()
    }

    /// Warps a uniform `u` into a point of this density, and returns the point and its density.
    pub(crate) fn warp(&self, u: Vec2) -> (Vec2, f32) {
        let mut u = u.clamp(Vec2::ZERO, Vec2::splat(ONE_BELOW));
        let (mut at, mut origin, mut size, mut prob) = (0usize, Vec2::ZERO, 1.0f32, 1.0f32);
        loop {
            let Node { mass: m, child } = &self.nodes[at];
            let total = m[0] + m[1] + m[2] + m[3];
            let left = m[0] + m[2];
            let px = left / total;
            let ix = if u.x < px {
                u.x /= px;
                0
            } else {
                u.x = (u.x - px) / (1.0 - px);
                1
            };
            let column = if ix == 0 { left } else { m[1] + m[3] };
            let py = m[ix] / column;
            let iy = if u.y < py {
                u.y /= py;
                0
            } else {
                u.y = (u.y - py) / (1.0 - py);
                1
            };
            let q = ix + 2 * iy;
            prob *= m[q] / total;
            u = u.clamp(Vec2::ZERO, Vec2::splat(ONE_BELOW));
            size *= 0.5;
            origin += Vec2::new(ix as f32, iy as f32) * size;
            if child[q] == 0 {
                break;
            }
            at = child[q] as usize;
        }
        (origin + u * size, prob / (size * size))
    }

    /// The density at `v`.
    pub(crate) fn pdf(&self, v: Vec2) -> f32 {
        let (mut at, mut origin, mut size, mut prob) = (0usize, Vec2::ZERO, 1.0f32, 1.0f32);
        loop {
            let Node { mass: m, child } = &self.nodes[at];
            let total: f32 = m.iter().sum();
            size *= 0.5;
            let ix = (v.x >= origin.x + size) as usize;
            let iy = (v.y >= origin.y + size) as usize;
            let q = ix + 2 * iy;
            prob *= m[q] / total;
            origin += Vec2::new(ix as f32, iy as f32) * size;
            if child[q] == 0 {
                return prob / (size * size);
            }
            at = child[q] as usize;
        }
    }

    /// The number of leaves.
    pub(crate) fn leaves(&self) -> usize {
        self.nodes.iter().map(|n| n.child.iter().filter(|&&c| c == 0).count()).sum()
    }
}

/// A pilot light path: its light, the guided pair of uniforms it drew, and the sum over its
/// photons of the largest squared contribution each made to a pixel it was gathered for (zero:
/// not visible).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PilotPath {
    pub light: u32,
    pub u: Vec2,
    pub value: f32,
}

/// What the pilot found, per light (reported by `haze bench`).
#[derive(Clone, Debug, Default)]
pub(crate) struct LightUse {
    /// Pilot paths from the light.
    pub paths: u64,
    /// Those visible (gathered at least once).
    pub visible: u64,
    /// Leaves of its quadtree (0 without guiding).
    pub cells: usize,
}

impl LightUse {
    /// Counts `other`'s paths and visible paths too (of more pilot paths of the same light).
    pub(crate) fn add(&mut self, other: &LightUse) {
        (self.paths, self.visible) = (self.paths + other.paths, self.visible + other.visible);
    }
}

/// A path whose contribution is below this fraction of the visible paths' mean is not visible:
/// it was gathered, but only with a weight no estimate notices (a photon near the far end of a
/// long, dense eye segment, e^(−50) down).
pub(crate) const NEGLIGIBLE: f64 = 1e-3;

/// The pilot paths with their values replaced by visibility, 1 or 0: gathered with a
/// contribution (the root of the path's sum of its photons' largest squared contributions) of at least [`NEGLIGIBLE`] of
/// the mean over the paths gathered at all. Visibility, not the contribution itself, because a
/// few photons with large contributions — the noise of a single pilot pass — would otherwise
/// shape the whole density.
fn visibility(paths: &[PilotPath]) -> Vec<PilotPath> {
    let root = |p: &PilotPath| if p.value > 0.0 { (p.value as f64).sqrt() } else { 0.0 };
    let sum = crate::buffers::sum(paths.len(), |i| root(&paths[i]));
    let count = paths.par_iter().filter(|p| p.value > 0.0).count();
    let threshold = if count > 0 { NEGLIGIBLE * sum / count as f64 } else { 0.0 };
    paths
        .par_iter()
        .map(|p| {
            let seen = p.value > 0.0 && (p.value as f64).sqrt() >= threshold;
            PilotPath { value: seen as u8 as f32, ..*p }
        })
        .collect()
}

/// Pilot paths, and those with a value above zero, per light of `lights`.
pub(crate) fn light_use(lights: usize, paths: &[PilotPath]) -> Vec<LightUse> {
    let count = |part: &[PilotPath]| {
        let mut usage = vec![LightUse::default(); lights];
        for p in part {
            let u = &mut usage[p.light as usize];
            u.paths += 1;
            u.visible += (p.value > 0.0) as u64;
        }
        usage
    };
    let add = |mut a: Vec<LightUse>, b: Vec<LightUse>| {
        a.iter_mut().zip(&b).for_each(|(a, b)| a.add(b));
        a
    };
    let piece = crate::buffers::piece(paths.len(), 4, 1 << 14);
    let usage = paths.par_chunks(piece).map(count).reduce_with(add);
    usage.unwrap_or_else(|| vec![LightUse::default(); lights])
}

/// Below this estimated gain (the factor by which guiding lowers the second moment of a light
/// path's contribution) the photon pass stays unguided: a guide would also make photons of the
/// paths that matter — often the expensive ones — more numerous.
pub const MIN_GAIN: f64 = 1.25;

/// The guided emission of a photon pass (module docs): a defensive mixture (Hesterberg 1995) of
/// the unguided emission — lights by power, uniforms uniform — with weight [`DEFENSIVE`], and the
/// guided one — lights by `probs`, uniforms by `tables` — with the rest. A light path is drawn
/// from one of the two, and its weight divided by the mixture's density at what was drawn, which
/// is never below [`DEFENSIVE`] times the unguided density: no path weighs more than
/// 1/[`DEFENSIVE`] times its unguided weight, however wrong the guide.
#[derive(Clone, Debug)]
pub(crate) struct EmissionGuide {
    /// Each light's power share (the unguided choice) …
    power: Vec<f32>,
    /// … cumulative.
    power_cdf: Vec<f32>,
    /// The guided probability of each light …
    probs: Vec<f32>,
    /// … cumulative.
    cdf: Vec<f32>,
    /// The guided densities of each light's pair of uniforms.
    tables: Vec<QuadTree>,
}

impl EmissionGuide {
    /// The guide learnt from the pilot paths `paths` (drawn with `sampler`'s power distribution
    /// and unguided uniforms), if it gains at least [`MIN_GAIN`]; what the pilot found per
    /// light; and the estimated gain.
    ///
    /// The guide is fitted to the paths' visibility V ∈ {0, 1} ([`visibility`]): with f_l(u) a
    /// light's visible fraction and P_l its power share, the tables q_l ∝ √f_l and the light
    /// choice p_l ∝ P_l ∫ √f_l minimise the second moment of a guided path's visibility weight
    /// (Cauchy–Schwarz). It is judged by what the image's variance follows, the squares C² of a
    /// path's contributions to the pixels (`value`: over its photons, the sum of each one's
    /// largest squared contribution to a pixel): the gain is the unguided second
    /// moment over the guided one, E[C²] / E[C² P_l / (p_l q_l(u))] over pilot paths — estimated
    /// on the odd-numbered paths for a guide fitted to the even ones, so that a guide fitted to a
    /// few lucky paths (in a rare-event scene) cannot claim a gain it would not have. The guide
    /// used is then fitted to all of them.
    pub(crate) fn from_pilot(
        sampler: &LightSampler,
        paths: &[PilotPath],
    ) -> (Option<Self>, Vec<LightUse>, f64) {
        let n = sampler.len();
        let seen = &visibility(paths);
        let mut usage = light_use(n, seen);
        let even: Vec<PilotPath> = seen.par_iter().step_by(2).copied().collect();
        // The guide from every path is fitted beside the trial (each fit is parallel only in its
        // larger nodes), and dropped if the trial says guiding does not pay.
        let (trial, guide) = rayon::join(|| Self::fit(sampler, &even), || Self::fit(sampler, seen));
        let Some(trial) = trial else { return (None, usage, 1.0) };
        // Over the odd-numbered paths, those gathered (the others add nothing).
        let odd = |k: usize| Some(&paths[2 * k + 1]).filter(|p| p.value > 0.0);
        let unguided =
            crate::buffers::sum(paths.len() / 2, |k| odd(k).map_or(0.0, |p| p.value as f64));
        let guided = crate::buffers::sum(paths.len() / 2, |k| {
            odd(k).map_or(0.0, |p| {
                let l = p.light as usize;
                p.value as f64 * (sampler.emission_prob(l) as f64 / trial.density(l, p.u) as f64)
            })
        });
        let gain = if guided > 0.0 { unguided / guided } else { 1.0 };
        if gain.is_nan() || gain < MIN_GAIN {
            return (None, usage, gain);
        }
        if let Some(g) = &guide {
            for (u, t) in usage.iter_mut().zip(&g.tables) {
                u.cells = t.leaves();
            }
        }
        (guide, usage, gain)
    }

    /// The tables and light choice fitted to `paths`; `None` if none of them was visible.
    fn fit(sampler: &LightSampler, paths: &[PilotPath]) -> Option<Self> {
        let n = sampler.len();
        // Each light's points, in path order, one light after another: split among a few lights
        // (a piece of a split holds a part per light), sorted by light among many.
        let point = |p: &PilotPath| (p.u, p.value);
        let (mut points, start) = if n <= SPLIT_LIGHTS {
            let mut points = crate::buffers::filled(paths.len(), (Vec2::ZERO, 0.0));
            let start = split(paths, &mut points, n, |p| p.light as usize, point);
            (points, start)
        } else {
            let keys: Vec<u32> = paths.par_iter().map(|p| p.light).collect();
            let (mut start, mut order) = (Vec::new(), Vec::new());
            CountingSort::default().sort(&keys, n, &mut start, &mut order);
            let points = order.par_iter().map(|&i| point(&paths[i as usize])).collect();
            (points, start.iter().map(|&s| s as usize).collect())
        };
        let mut per_light = Vec::with_capacity(n);
        let mut rest = &mut points[..];
        for l in 0..n {
            let (mine, tail) = rest.split_at_mut(start[l + 1] - start[l]);
            per_light.push(mine);
            rest = tail;
        }
        let (tables, integrals): (Vec<QuadTree>, Vec<f64>) =
            per_light.into_par_iter().map(|v| QuadTree::fit(v, 0.0)).unzip();
        let power: Vec<f32> = (0..n).map(|l| sampler.emission_prob(l)).collect();
        let useful: Vec<f64> = (0..n).map(|l| power[l] as f64 * integrals[l]).collect();
        let total: f64 = useful.iter().sum();
        if total.is_nan() || total <= 0.0 {
            return None;
        }
        let probs: Vec<f32> = useful.iter().map(|u| (u / total) as f32).collect();
        Some(Self { power_cdf: cumulative(&power), power, cdf: cumulative(&probs), probs, tables })
    }

    /// A light to emit from, and whether its uniforms are to be guided: from the unguided
    /// emission with probability [`DEFENSIVE`], else from the guided one. `u` is uniform.
    pub(crate) fn pick(&self, u: f32) -> (usize, bool) {
        if u < DEFENSIVE {
            (pick(&self.power_cdf, u / DEFENSIVE), false)
        } else {
            (pick(&self.cdf, (u - DEFENSIVE) / (1.0 - DEFENSIVE)), true)
        }
    }

    /// Light `light`'s pair of uniforms from the uniform `u` — warped if it was picked to be
    /// guided — and the mixture's density of the light and that pair.
    pub(crate) fn place(&self, light: usize, u: Vec2, guided: bool) -> (Vec2, f32) {
        let v = if guided { self.tables[light].warp(u).0 } else { u };
        (v, self.density(light, v))
    }

    /// The mixture's density of light `light` with the pair of uniforms `v`.
    pub(crate) fn density(&self, light: usize, v: Vec2) -> f32 {
        DEFENSIVE * self.power[light]
            + (1.0 - DEFENSIVE) * self.probs[light] * self.tables[light].pdf(v)
    }
}

/// Puts the points of a node in the order of their `quadrant` (0 to 3): returns where each
/// quadrant's points start (and the end), the slice that holds them so ordered — `points` or
/// `spare` — and the other one, free. Nodes of [`PARTITION_PARALLEL`] points or more are split in
/// parallel and stably into `spare` ([`split`]: the root holds every pilot path of its light, and
/// a serial sort of them was most of a fit's time); smaller ones are sorted in place on the
/// calling thread. Either way the order depends only on the points, not on the threads.
fn partition<'a>(
    points: Points<'a>,
    spare: Points<'a>,
    quadrant: impl Fn(&(Vec2, f32)) -> usize + Sync,
) -> ([usize; 5], Points<'a>, Points<'a>) {
    let n = points.len();
    if n < PARTITION_PARALLEL {
        points.sort_unstable_by_key(&quadrant);
        let first = |q: usize| points.partition_point(|p| quadrant(p) < q);
        return ([0, first(1), first(2), first(3), n], points, spare);
    }
    let start = split(points, spare, 4, quadrant, |p| *p);
    ([start[0], start[1], start[2], start[3], start[4]], spare, points)
}

/// Running sums of `probs`.
fn cumulative(probs: &[f32]) -> Vec<f32> {
    let mut sum = 0.0;
    probs
        .iter()
        .map(|p| {
            sum += p;
            sum
        })
        .collect()
}

/// The index that uniform `u` selects from the running sums `cdf` (normalised by their total).
fn pick(cdf: &[f32], u: f32) -> usize {
    let target = u * cdf.last().copied().unwrap_or(1.0);
    cdf.partition_point(|&c| c <= target).min(cdf.len() - 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, Sampler};
    use crate::testing::{ChiSquare, Domain, Sample};

    /// Subtrees grown side by side are the subtrees grown one after another: the same nodes in
    /// the same order with the same masses, bit for bit, so that the guide (and the image) does
    /// not depend on the number of threads.
    #[test]
    fn quadtree_grown_in_parallel_is_the_serial_one() {
        let mut s = Sampler::new(5, Purpose::Other, 0, 0);
        let points: Vec<(Vec2, f32)> = (0..100_000)
            .map(|_| {
                let u = s.next_2d();
                let near = (u - Vec2::new(0.3, 0.7)).length() < 0.1 || u.x > 0.9;
                (u, if near { s.next_f32() * 4.0 } else { (s.next_f32() < 0.01) as u8 as f32 })
            })
            .collect();
        let (serial, a) = QuadTree::fit_with(&mut points.clone(), 0.1, usize::MAX);
        assert!(serial.leaves() > 50, "{} leaves", serial.leaves());
        for from in [1, 64, PARALLEL_POINTS] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
            let (parallel, b) = pool.install(|| QuadTree::fit_with(&mut points.clone(), 0.1, from));
            let bits = |t: &QuadTree| -> Vec<([u32; 4], [u32; 4])> {
                t.nodes.iter().map(|n| (n.mass.map(f32::to_bits), n.child)).collect()
            };
            assert_eq!(bits(&parallel), bits(&serial), "parallel from {from} points");
            assert_eq!(a.to_bits(), b.to_bits());
        }
    }

    /// A node's points put in quadrant order: a permutation of them, grouped by quadrant at the
    /// starts returned, and — for nodes split in parallel — each quadrant's points in their
    /// order before, the same on 1 and 4 threads.
    #[test]
    fn partition_groups_points_by_quadrant() {
        let mut s = Sampler::new(9, Purpose::Other, 0, 0);
        for n in [0, 7, 1000, PARTITION_PARALLEL, 3 * PARTITION_PARALLEL + 5] {
            let points: Vec<(Vec2, f32)> = (0..n).map(|i| (s.next_2d(), i as f32)).collect();
            let quadrant = |p: &(Vec2, f32)| (p.0.x >= 0.3) as usize + 2 * (p.0.y >= 0.6) as usize;
            let on = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let (mut v, mut spare) = (points.clone(), points.clone());
                let (start, v) = pool.install(|| {
                    let (start, v, _) = partition(&mut v, &mut spare, quadrant);
                    (start, v.to_vec())
                });
                (v, start)
            };
            let (v, start) = on(1);
            assert_eq!((start[0], start[4]), (0, n));
            for q in 0..4 {
                assert!(v[start[q]..start[q + 1]].iter().all(|p| quadrant(p) == q), "{n}: {q}");
            }
            // The values are the points' indices: a permutation, in order within a quadrant
            // where the split is stable.
            let mut seen: Vec<usize> = v.iter().map(|p| p.1 as usize).collect();
            if n >= PARTITION_PARALLEL {
                for q in 0..4 {
                    assert!(seen[start[q]..start[q + 1]].is_sorted(), "{n} points, quadrant {q}");
                }
                let (w, start4) = on(4);
                assert_eq!(start4, start);
                assert!(w.iter().zip(&v).all(|(a, b)| a.1 == b.1), "{n} points, 4 threads");
            }
            seen.sort_unstable();
            assert!(seen.iter().enumerate().all(|(i, &k)| i == k), "{n}: not a permutation");
        }
    }

    /// A quadtree fitted to points crowding in a small square: its warp follows its density
    /// (chi-square), the density integrates to one, is at least the defensive share everywhere,
    /// and puts most of the mass where the points are.
    #[test]
    fn quadtree_warp_follows_its_density() {
        let mut s = Sampler::new(3, Purpose::Other, 0, 0);
        // Uniform pilot points, visible inside a small square and rarely elsewhere.
        let mut points: Vec<(Vec2, f32)> = (0..200_000)
            .map(|_| {
                let u = s.next_2d();
                let inside = (0.6..0.65).contains(&u.x) && (0.2..0.25).contains(&u.y);
                (u, (inside || s.next_f32() < 1e-3) as u8 as f32)
            })
            .collect();
        let (tree, integral) = QuadTree::fit(&mut points, 0.1);
        // ∫ √f: √1 over the square's area plus √0.001 over the rest, roughly.
        let want = 0.0025 + (1e-3f64).sqrt() * 0.9975;
        assert!((integral / want - 1.0).abs() < 0.2, "∫√f = {integral} vs ~{want}");
        assert!(tree.leaves() > 20, "refined: {} leaves", tree.leaves());
        // Midpoint integration on a fine grid.
        let n = 512;
        let (mut integral, mut inside) = (0.0f64, 0.0f64);
        for i in 0..n {
            for j in 0..n {
                let v = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let p = tree.pdf(v) as f64 / (n * n) as f64;
                assert!(tree.pdf(v) >= 0.1 * 0.999);
                integral += p;
                if (0.6..0.65).contains(&v.x) && (0.2..0.25).contains(&v.y) {
                    inside += p;
                }
            }
        }
        assert!((integral - 1.0).abs() < 1e-3, "integral {integral}");
        // The √f target gives the square 0.0025 / (0.0025 + 0.0316) of the guided mass.
        assert!(inside > 0.05 && inside < 0.2, "mass where the visible points crowd: {inside}");
        ChiSquare::new("quadtree warp", Domain::Square, 1).run(
            |s| {
                let (v, pdf) = tree.warp(s.next_2d());
                assert!((pdf / tree.pdf(v) - 1.0).abs() < 1e-3, "{pdf} vs {}", tree.pdf(v));
                Some(Sample::Point(v.as_dvec2()))
            },
            |d| tree.pdf(d.point().as_vec2()) as f64,
        );
    }

    #[test]
    fn no_visible_points_is_uniform() {
        let (tree, integral) = QuadTree::fit(&mut [(Vec2::ONE * 0.5, 0.0)], 0.1);
        assert_eq!(integral, 0.0);
        let (v, pdf) = tree.warp(Vec2::new(0.3, 0.8));
        assert!((v - Vec2::new(0.3, 0.8)).length() < 1e-6 && (pdf - 1.0).abs() < 1e-6);
    }

    /// A fit gathers each light's pilot points in path order, by a split among a few lights and
    /// by a sort among many: each light's table is the quadtree fitted to its own points, bit
    /// for bit.
    #[test]
    fn each_light_is_fitted_to_its_own_points() {
        use glam::Vec3;
        let mut s = Sampler::new(6, Purpose::Other, 0, 0);
        for lights in [3, SPLIT_LIGHTS + 6] {
            let point = |k: usize| Light::Point {
                position: Vec3::new(k as f32, 0.0, 0.0),
                intensity: Vec3::splat(1.0 + k as f32),
            };
            let sampler = LightSampler::new(&(0..lights).map(point).collect::<Vec<_>>(), 0);
            let paths: Vec<PilotPath> = (0..60_000)
                .map(|_| {
                    let light =
                        ((s.next_f32().powi(2) * lights as f32) as u32).min(lights as u32 - 1);
                    let u = s.next_2d();
                    let seen = u.x < 0.3 && u.y > 0.5 || s.next_f32() < 0.02;
                    PilotPath { light, u, value: seen as u8 as f32 }
                })
                .collect();
            let guide = EmissionGuide::fit(&sampler, &paths).unwrap();
            let bits = |t: &QuadTree| -> Vec<([u32; 4], [u32; 4])> {
                t.nodes.iter().map(|n| (n.mass.map(f32::to_bits), n.child)).collect()
            };
            for l in 0..lights {
                let mut mine: Vec<(Vec2, f32)> = paths
                    .iter()
                    .filter(|p| p.light as usize == l)
                    .map(|p| (p.u, p.value))
                    .collect();
                let (want, _) = QuadTree::fit(&mut mine, 0.0);
                assert_eq!(bits(&guide.tables[l]), bits(&want), "{lights} lights: light {l}");
            }
        }
    }

    /// The emission mixture of two lights fitted to a pilot in which only one corner of light 1's
    /// square is visible: its density integrates to one over lights and squares, is at least half
    /// the unguided density everywhere (no weight above 2×), and `pick` + `place` draw from it
    /// (chi-square over the two squares laid side by side).
    #[test]
    fn emission_mixture_draws_from_its_density() {
        use glam::Vec3;
        let light = |x: f32, w: f32| Light::Point {
            position: Vec3::new(x, 0.0, 0.0),
            intensity: Vec3::splat(w),
        };
        let sampler = LightSampler::new(&[light(0.0, 1.0), light(1.0, 3.0)], 0);
        let mut s = Sampler::new(4, Purpose::Other, 0, 0);
        let paths: Vec<PilotPath> = (0..40_000)
            .map(|i| {
                let (l, u) = (i % 2, s.next_2d());
                let seen = l == 1 && u.x < 0.2 && u.y < 0.3 || s.next_f32() < 0.01;
                PilotPath { light: l as u32, u, value: seen as u8 as f32 }
            })
            .collect();
        let guide = EmissionGuide::fit(&sampler, &visibility(&paths)).unwrap();
        let n = 256;
        let mut total = 0.0f64;
        for l in 0..2 {
            for i in 0..n * n {
                let v = Vec2::new((i % n) as f32 + 0.5, (i / n) as f32 + 0.5) / n as f32;
                let d = guide.density(l, v);
                assert!(d >= DEFENSIVE * sampler.emission_prob(l) * 0.999, "light {l} at {v}: {d}");
                total += d as f64 / (n * n) as f64;
            }
        }
        assert!((total - 1.0).abs() < 1e-3, "∑∫ density = {total}");
        ChiSquare::new("emission mixture", Domain::Square, 1).run(
            |s| {
                let (l, guided) = guide.pick(s.next_f32());
                let (v, _) = guide.place(l, s.next_2d(), guided);
                Some(Sample::Point(glam::DVec2::new((l as f64 + v.x as f64) / 2.0, v.y as f64)))
            },
            |d| {
                let p = d.point();
                let l = (p.x * 2.0).floor().min(1.0) as usize;
                let v = Vec2::new((p.x * 2.0 - l as f64) as f32, p.y as f32);
                2.0 * guide.density(l, v) as f64
            },
        );
    }
}
