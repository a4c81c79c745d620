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
//! 3. Every iteration draws those uniforms and the light from these densities, mixed with the
//!    unguided ones (a tenth of the mass is spread as without guiding, so no region the pilot
//!    missed is left without photons), and divides the photon's power by their density.
//!
//! Each iteration is then an ordinary photon-mapping render whose light paths are importance
//! sampled with a fixed, everywhere positive density: its expected estimate is exactly the
//! unguided one, its photon weights are bounded (by 10× the unguided ones), and the schedule's
//! convergence argument holds unchanged (docs/theory.md).

use crate::scene::light::{Light, LightSampler};
use glam::Vec2;

/// Share of every distribution kept as without guiding (the defensive mixture).
pub(crate) const DEFENSIVE: f32 = 0.1;

/// A quadtree cell is split while it holds more than this share of its light's visible paths …
const SPLIT_SHARE: f32 = 0.01;

/// … and at least this many of them …
const SPLIT_MIN: usize = 8;

/// … down to cells of side 2⁻ᴹᴬˣ_ᴰᴱᴾᵀᴴ.
const MAX_DEPTH: u32 = 10;

/// Which pair of a light's emission uniforms the guide warps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Guided {
    /// Where on the light (a directional light's cross-section).
    Position,
    /// Which way (point, spot and area lights).
    Direction,
}

/// The pair of uniforms guided for `light`.
pub(crate) fn guided(light: &Light) -> Guided {
    match light {
        Light::Directional { .. } => Guided::Position,
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

/// The largest f32 below 1.
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

/// What a fit counts: all pilot points, and the sum of their moments.
struct Fit {
    all: f64,
    total: f64,
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
        let total: f64 = points.iter().map(|p| p.1 as f64).sum();
        if total <= 0.0 {
            return (Self::uniform(), 0.0);
        }
        let mut tree = Self { nodes: Vec::new() };
        let fit = Fit { all: points.len() as f64, total };
        let integral = tree.grow(points, Vec2::ZERO, 1.0, 0, &fit) as f64;
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

    /// Appends the node over the square at `origin` of side `size` holding `points`; returns its
    /// √m mass.
    fn grow(
        &mut self,
        points: &mut [(Vec2, f32)],
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
        points.sort_unstable_by_key(quadrant);
        let mut rest = points;
        for q in 0..4 {
            let n = rest.iter().take_while(|p| quadrant(p) == q).count();
            let (mine, tail) = rest.split_at_mut(n);
            rest = tail;
            let seen = mine.iter().filter(|p| p.1 > 0.0).count();
            let moment: f64 = mine.iter().map(|p| p.1 as f64).sum();
            let corner = origin + Vec2::new((q % 2) as f32, (q / 2) as f32) * half;
            let split = depth + 1 < MAX_DEPTH
                && seen >= SPLIT_MIN
                && moment > SPLIT_SHARE as f64 * fit.total;
            let mass = if split {
                let c = self.nodes.len() as u32;
                self.nodes[at].child[q] = c;
                self.grow(mine, corner, half, depth + 1, fit)
            } else {
                let area = (half * half) as f64;
                ((moment / (fit.all * area)).sqrt() * area) as f32
            };
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
/// photons of their squared contributions to the pixels they were gathered for (zero: not
/// visible).
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

/// A path whose contribution is below this fraction of the visible paths' mean is not visible:
/// it was gathered, but only with a weight no estimate notices (a photon near the far end of a
/// long, dense eye segment, e^(−50) down).
pub(crate) const NEGLIGIBLE: f64 = 1e-3;

/// The pilot paths with their values replaced by visibility, 1 or 0: gathered with a
/// contribution (the root of the sum of squares the tallies hold) of at least [`NEGLIGIBLE`] of
/// the mean over the paths gathered at all. Visibility, not the contribution itself, because a
/// few photons with large contributions — the noise of a single pilot pass — would otherwise
/// shape the whole density.
fn visibility(paths: &[PilotPath]) -> Vec<PilotPath> {
    let (sum, count) = paths
        .iter()
        .filter(|p| p.value > 0.0)
        .fold((0.0f64, 0usize), |(s, c), p| (s + (p.value as f64).sqrt(), c + 1));
    let threshold = if count > 0 { NEGLIGIBLE * sum / count as f64 } else { 0.0 };
    paths
        .iter()
        .map(|p| {
            let seen = p.value > 0.0 && (p.value as f64).sqrt() >= threshold;
            PilotPath { value: seen as u8 as f32, ..*p }
        })
        .collect()
}

/// Below this estimated gain (the factor by which guiding lowers the second moment of a light
/// path's contribution) the photon pass stays unguided: a guide would also make photons of the
/// paths that matter — often the expensive ones — more numerous.
pub const MIN_GAIN: f64 = 1.25;

/// The guided emission of a photon pass (module docs).
#[derive(Clone, Debug)]
pub(crate) struct EmissionGuide {
    /// Probability of each light.
    probs: Vec<f32>,
    /// Cumulative.
    cdf: Vec<f32>,
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
    /// (Cauchy–Schwarz). It is judged by what the image's variance follows, the sum C² of the
    /// squares of a path's contributions to the pixels (`value`): the gain is the unguided second
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
        let mut usage = vec![LightUse::default(); n];
        for p in seen {
            usage[p.light as usize].paths += 1;
            usage[p.light as usize].visible += (p.value > 0.0) as u64;
        }
        let even: Vec<PilotPath> = seen.iter().step_by(2).copied().collect();
        let Some(trial) = Self::fit(sampler, &even) else { return (None, usage, 1.0) };
        let (mut unguided, mut guided) = (0.0f64, 0.0f64);
        for p in paths.iter().skip(1).step_by(2).filter(|p| p.value > 0.0) {
            let l = p.light as usize;
            let weight = sampler.emission_prob(l) as f64
                / (trial.probs[l] as f64 * trial.tables[l].pdf(p.u) as f64);
            unguided += p.value as f64;
            guided += p.value as f64 * weight;
        }
        let gain = if guided > 0.0 { unguided / guided } else { 1.0 };
        if gain.is_nan() || gain < MIN_GAIN {
            return (None, usage, gain);
        }
        let guide = Self::fit(sampler, seen);
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
        let mut points: Vec<Vec<(Vec2, f32)>> = vec![Vec::new(); n];
        for p in paths {
            points[p.light as usize].push((p.u, p.value));
        }
        let (tables, integrals): (Vec<QuadTree>, Vec<f64>) =
            points.iter_mut().map(|v| QuadTree::fit(v, DEFENSIVE)).unzip();
        let power = |l: usize| sampler.emission_prob(l) as f64;
        let useful: Vec<f64> = (0..n).map(|l| power(l) * integrals[l]).collect();
        let total: f64 = useful.iter().sum();
        if total.is_nan() || total <= 0.0 {
            return None;
        }
        let probs: Vec<f32> = (0..n)
            .map(|l| {
                ((1.0 - DEFENSIVE as f64) * useful[l] / total + DEFENSIVE as f64 * power(l)) as f32
            })
            .collect();
        let mut sum = 0.0;
        let cdf = probs
            .iter()
            .map(|p| {
                sum += p;
                sum
            })
            .collect();
        Some(Self { probs, cdf, tables })
    }

    /// A light to emit from: its index and probability.
    pub(crate) fn pick(&self, u: f32) -> (usize, f32) {
        let total = *self.cdf.last().unwrap_or(&1.0);
        let target = u * total;
        let i = self.cdf.partition_point(|&c| c <= target).min(self.cdf.len() - 1);
        (i, self.probs[i] / total)
    }

    /// Warps light `light`'s guided uniforms `u`: the new pair and its density.
    pub(crate) fn warp(&self, light: usize, u: Vec2) -> (Vec2, f32) {
        self.tables[light].warp(u)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, Sampler};
    use crate::testing::{ChiSquare, Domain, Sample};

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
        let (tree, integral) = QuadTree::fit(&mut points, DEFENSIVE);
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
                assert!(tree.pdf(v) >= DEFENSIVE * 0.999);
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
        let (tree, integral) = QuadTree::fit(&mut [(Vec2::ONE * 0.5, 0.0)], DEFENSIVE);
        assert_eq!(integral, 0.0);
        let (v, pdf) = tree.warp(Vec2::new(0.3, 0.8));
        assert!((v - Vec2::new(0.3, 0.8)).length() < 1e-6 && (pdf - 1.0).abs() < 1e-6);
    }
}
