//! Light paths split by their worth to the image, in media (after adjoint-driven splitting:
//! Vorba & Křivánek, "Adjoint-driven Russian roulette and splitting in light transport
//! simulation", ACM TOG 2016, turned around for light paths).
//!
//! In a dense, bright medium most of a light path's events are where the camera never looks: in
//! `scenes/dense-fog.toml` light random-walks ~1000 steps from a lamp 0.8 m inside fog of optical
//! thickness 120, and the camera sees only the first few centimetres behind the open front. The
//! few paths that reach the front carry the whole image, one firefly each.
//!
//! The **importance** W(x) of a collision at x is what a light path of unit throughput there adds
//! to the image, in expectation, through its photon there and all its later ones. By the symmetry
//! of transport it is proportional to the density of the collisions of eye paths at x — eye
//! random walks from the camera, weighted by their throughput and by σ_s(x) (a collision
//! estimator of the adjoint fluence, times the scattering a light path there would do). A pilot
//! (`integrator/splitting.rs`) walks eye paths through the scene once per render and sums those
//! weights over a grid of cells ([`Importance::from_deposits`]; a cell few walks reached takes
//! the mean of a larger block around it); a second pilot of light paths gives the target: the
//! mean, over light paths, of the value v = β · W(x) of their first collision in a medium (β the
//! throughput there) — what an emitted light path is worth.
//!
//! At every later collision of an iteration's light paths the ratio R = β W(x) / target decides
//! ([`Importance::decide`]): a path worth more than twice the target is split into ⌊R⌋ or ⌈R⌉
//! copies (R in expectation, at most [`MOST_COPIES`] at once and [`MOST_PER_PATH`] in all), each
//! divided by R, so that the light reaching where the camera looks is carried by many light paths
//! of small weight instead of a few of large weight. A copy worth less than half the target plays
//! Russian roulette: it survives with probability max(R, 1/s), s what splitting has divided it by,
//! and is divided by that — never above the throughput of the path it was split from. Both are
//! unbiased for any fixed W — a wrong importance costs time or noise, never the mean — and W and
//! the target come from pilots with their own random streams, the same in every process of a
//! split render, so every iteration stays an ordinary, independent photon-mapping render
//! (docs/theory.md, "Light paths split by importance").
//!
//! Vorba & Křivánek's window also plays roulette with paths never split. That would let a path
//! that survives where the pilot's noisy W is too low arrive where the camera looks weighing more
//! than any unsplit path: haze does not (measured only under a bug since fixed — see
//! docs/theory.md — so that choice is untested). Roulette for copies alone was measured:
//! relative RMSE at 19 s against splitting alone, dense-fog (photons) 45.6 % against 50.4 %,
//! cornell-fog (hybrid) 4.81 % against 5.24 %, cornell-cloud (hybrid) 8.95 % against 9.27 %
//! (`haze converge`, 25 s, 2 runs, 2 cores).

use crate::math::{Rgb, luminance};
use glam::Vec3;

/// Cells along the longest side of the grid.
pub(crate) const CELLS: usize = 32;

/// A copy worth less than this share of the target plays Russian roulette …
const LOW: f32 = 0.5;

/// … and a path worth more than this many targets is split …
const HIGH: f32 = 2.0;

/// … into at most this many copies at one collision …
pub(crate) const MOST_COPIES: u32 = 16;

/// … and most copies a light path makes in all (work stays within paths × bounce limit × this).
pub(crate) const MOST_PER_PATH: u32 = 1024;

/// Deposits a cell needs to stand for itself (see [`Importance::from_deposits`]).
/// 256: with 16 (and roulette, below) on dense-fog the importance of the cells between the lamp
/// and the front varied by 10× from cell to cell.
pub(crate) const FEWEST: u32 = 256;

/// Each cell's mean deposit over the smallest block of the halving pyramid around it holding
/// [`FEWEST`] deposits or more (the whole grid at the coarsest).
fn pooled(dims: [usize; 3], sums: &[f32], counts: &[u32]) -> Vec<f32> {
    // Level k groups cells by their coordinates shifted right by k.
    let longest = dims.into_iter().max().unwrap_or(1).max(1);
    let levels = (usize::BITS - (longest - 1).leading_zeros()) as usize;
    let index = |c: [usize; 3], k: usize| {
        let d = dims.map(|n| ((n - 1) >> k) + 1);
        ((c[2] >> k) * d[1] + (c[1] >> k)) * d[0] + (c[0] >> k)
    };
    let mut pyramid = Vec::with_capacity(levels + 1);
    for k in 0..=levels {
        let d = dims.map(|n| ((n - 1) >> k) + 1);
        // (sum, deposits, cells) per block.
        let mut level = vec![(0.0f64, 0u64, 0u64); d.iter().product()];
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let i = (z * dims[1] + y) * dims[0] + x;
                    let b = &mut level[index([x, y, z], k)];
                    (b.0, b.1, b.2) = (b.0 + sums[i] as f64, b.1 + counts[i] as u64, b.2 + 1);
                }
            }
        }
        pyramid.push(level);
    }
    let mut w = vec![0.0f32; sums.len()];
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let i = (z * dims[1] + y) * dims[0] + x;
                let (sum, _, cells) = (0..=levels)
                    .map(|k| pyramid[k][index([x, y, z], k)])
                    .find(|b| b.1 >= FEWEST as u64)
                    .unwrap_or(pyramid[levels][0]);
                w[i] = (sum / cells as f64) as f32;
            }
        }
    }
    w
}

/// A grid of importance over the scene's bounds and the target value of a light path.
#[derive(Clone, Debug)]
pub(crate) struct Importance {
    min: Vec3,
    /// Cells per unit length.
    scale: f32,
    dims: [usize; 3],
    w: Vec<f32>,
    target: f32,
}

/// What to do with a light path at a collision.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Fate {
    /// Go on as it is.
    Keep,
    /// Go on divided by the probability it survived with.
    Survive(f32),
    /// End here (its photon here is stored).
    End,
    /// Go on as this many copies, each divided by the factor.
    Split(u32, f32),
}

/// An empty grid over `bounds` of [`CELLS`] cells along its longest side.
pub(crate) fn grid(bounds: (Vec3, Vec3)) -> (Vec3, f32, [usize; 3]) {
    let size = (bounds.1 - bounds.0).max(Vec3::splat(1e-6));
    let scale = CELLS as f32 / size.max_element();
    let dims = (size * scale).ceil().to_array().map(|n| (n as usize).clamp(1, CELLS));
    (bounds.0, scale, dims)
}

/// The index of the cell of `p` in a grid, if inside.
#[inline]
pub(crate) fn cell(min: Vec3, scale: f32, dims: [usize; 3], p: Vec3) -> Option<usize> {
    let c = (p - min) * scale;
    if !c.is_finite() || c.min_element() < 0.0 {
        return None;
    }
    let [x, y, z] = c.to_array().map(|v| v as usize);
    (x < dims[0] && y < dims[1] && z < dims[2]).then(|| (z * dims[1] + y) * dims[0] + x)
}

impl Importance {
    /// The importance from the eye paths' summed `deposits` and their `counts` per cell of the
    /// grid of `bounds`, or `None` if they are all zero. A cell with fewer than [`FEWEST`]
    /// deposits takes the mean of the smallest block of cells around it (halving the grid's
    /// resolution until a block has that many; the whole grid at the end) — where few eye walks
    /// come, one lucky walk would otherwise decide, and a cell none reached would end every path
    /// entering it.
    pub(crate) fn from_deposits(
        bounds: (Vec3, Vec3),
        deposits: Vec<f32>,
        counts: Vec<u32>,
    ) -> Option<Self> {
        let (min, scale, dims) = grid(bounds);
        debug_assert_eq!(deposits.len(), dims.iter().product::<usize>());
        let finite = deposits.iter().all(|w| w.is_finite() && *w >= 0.0);
        if !finite || !deposits.iter().any(|&w| w > 0.0) {
            return None;
        }
        let w = pooled(dims, &deposits, &counts);
        Some(Self { min, scale, dims, w, target: 0.0 })
    }

    /// The importance at `p` (`None` outside the grid).
    #[inline]
    pub(crate) fn at(&self, p: Vec3) -> Option<f32> {
        cell(self.min, self.scale, self.dims, p).map(|i| self.w[i])
    }

    /// The value of a path of throughput `beta` at a collision at `p`: β W(p).
    #[inline]
    pub(crate) fn value(&self, beta: Rgb, p: Vec3) -> f32 {
        self.at(p).map_or(0.0, |w| luminance(beta) * w)
    }

    /// Sets the target value (the mean value of a light path at its first collision); returns
    /// `None` unless it is positive and finite.
    pub(crate) fn with_target(mut self, target: f64) -> Option<Self> {
        (target > 0.0 && target.is_finite()).then(|| {
            self.target = target as f32;
            self
        })
    }

    /// The fate of a path of throughput `beta` at a collision at `p`, with `copies` made so far,
    /// `split` what splitting has divided it by so far (1 for a path never split), and the uniform
    /// `u`. Outside the grid a path goes on as it is; a path never split is never ended (see the
    /// module's doc).
    pub(crate) fn decide(&self, beta: Rgb, p: Vec3, copies: u32, split: f32, u: f32) -> Fate {
        let Some(w) = self.at(p) else { return Fate::Keep };
        let r = luminance(beta) * w / self.target;
        if !r.is_finite() {
            return Fate::Keep;
        }
        if r < LOW && split > 1.0 {
            // Never above the unsplit path's throughput: survive with at least 1 / split.
            let q = r.max(1.0 / split);
            return if u < q { Fate::Survive(q) } else { Fate::End };
        }
        let room = MOST_PER_PATH.saturating_sub(copies).min(MOST_COPIES - 1) + 1;
        if r <= HIGH || room < 2 {
            return Fate::Keep;
        }
        if r >= room as f32 {
            // The cap: exactly `room` copies, each divided by their number.
            return Fate::Split(room, room as f32);
        }
        // ⌊R⌋ copies, one more with probability frac(R): R in expectation, each divided by R.
        let n = r as u32 + u32::from(u < r.fract());
        Fate::Split(n, r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(w: f32, target: f64) -> Importance {
        let bounds = (Vec3::ZERO, Vec3::ONE);
        let (_, _, dims) = grid(bounds);
        let cells = dims.iter().product();
        Importance::from_deposits(bounds, vec![w; cells], vec![FEWEST; cells])
            .unwrap()
            .with_target(target)
            .unwrap()
    }

    /// Every fate keeps the expected throughput: Σ copies × (1 / factor) over the uniform is 1.
    /// A decision that divided by the wrong number (say ⌊R⌋ where it drew ⌈R⌉) fails it.
    #[test]
    fn every_fate_keeps_the_expected_throughput() {
        let imp = unit(1.0, 1.0);
        let p = Vec3::splat(0.5);
        for value in [0.001, 0.03, 0.2, 0.49, 0.7, 1.9, 2.5, 7.3, 15.9, 40.0, 3000.0] {
            for (copies, split) in [(0, 1.0), (0, 100.0), (1000, 4.0), (1020, 1.0), (1024, 30.0)] {
                let n = 100_000;
                let mut mean = 0.0f64;
                for k in 0..n {
                    let u = (k as f32 + 0.5) / n as f32;
                    mean += match imp.decide(Rgb::splat(value), p, copies, split, u) {
                        Fate::Keep => 1.0,
                        Fate::Survive(q) => {
                            assert!(q * split >= 1.0 - 1e-6, "above the unsplit throughput");
                            1.0 / q as f64
                        }
                        Fate::End => 0.0,
                        Fate::Split(c, f) => {
                            assert!(c <= MOST_COPIES && copies + c - 1 <= MOST_PER_PATH);
                            c as f64 / f as f64
                        }
                    };
                }
                mean /= n as f64;
                assert!((mean - 1.0).abs() < 1e-3, "value {value}, copies {copies}: {mean}");
            }
        }
    }

    /// Outside the grid, or where the target makes no sense, a path goes on untouched.
    #[test]
    fn outside_the_grid_paths_go_on() {
        let imp = unit(1.0, 1.0);
        assert_eq!(imp.decide(Rgb::splat(100.0), Vec3::splat(2.0), 0, 1.0, 0.5), Fate::Keep);
        assert_eq!(imp.decide(Rgb::splat(100.0), Vec3::splat(-0.1), 0, 1.0, 0.5), Fate::Keep);
        // A path never split goes on however little it is worth: no roulette.
        assert_eq!(imp.decide(Rgb::splat(0.001), Vec3::splat(0.5), 0, 1.0, 0.99), Fate::Keep);
        assert!(unit(1.0, 1.0).clone().with_target(0.0).is_none());
        let cells = 32 * 32 * 32;
        let none =
            Importance::from_deposits((Vec3::ZERO, Vec3::ONE), vec![0.0; cells], vec![0; cells]);
        assert!(none.is_none());
    }
}
