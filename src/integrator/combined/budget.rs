//! How many light paths the combined integrator traces per iteration: a pilot that renders,
//! before the first iteration, a few iterations with the scene's count and two with an eighth
//! of it, predicts the variance and the cost of an iteration with 1, 1/2, 1/4 and 1/8 of the
//! count (and, where it may, of none), and picks the count whose variance times cost is the
//! smallest — the one that reaches a given error soonest (docs/theory.md, "How many light
//! paths").
//!
//! At the scene's count N it measures, over a sparse set of pixels, the variance V of an
//! iteration and the variance V_M of the merges' part of it. The merges' part is a mean over the
//! N light paths, so with N/d of them (the weights held as they are) its variance is d V_M and
//! the iteration's V + (d − 1) V_M. The cost of an iteration is the work counted while rendering
//! ([`crate::work`]: rays, tentative collisions in grids, photons found, photons stored), a line
//! in the light paths through the costs measured at N and N/8. The variance at fewer light
//! paths is predicted rather than measured: measured from a few iterations it comes out low,
//! because what the photons add is heavy-tailed and rare large values are what a few iterations
//! miss (fog-forward at N/8: 4,391 from the pilot's 8 iterations, 7,240 from 200).
//!
//! It also weighs no light paths at all — the eye's techniques alone, a path tracer with
//! next-event estimation — measuring that variance directly (no merge's part to scale), but
//! only where the eye's techniques can carry all the light: where no photon of the pilot's
//! iterations at the scene's count has an empty light side (a photon only a merge can find:
//! light from a point or spot light by way of a mirror or glass), and where merges are made at
//! the eye's first vertex only (deeper merges enter the photons' light side).
//!
//! The same measurements set how the eye goes on past its first merge: by Russian roulette with
//! a chance below 1 where what its deeper vertices add is worth less than their work
//! ([`continuation`]), or not at all where those vertices take most of an iteration and the
//! settings leave the merges open ([`LAST_DEEP_SHARE`]). The second moment of the deeper part
//! is measured at the scene's count and used for every count, where with fewer light paths the
//! weights move some light towards the eye's techniques: the roulette's cost at n/8 is
//! somewhat under-predicted.
//!
//! Every input is a function of the scene, the settings and the seed, so the choice is the same
//! on every machine, thread count and split of the render into processes; the clock is read
//! only to report.

use crate::math::Rgb;
use crate::rng::{Purpose, Sampler};
use crate::settings::Technique;
use crate::work::Work;
use std::time::Instant;

/// Pilot iterations with the scene's count, for the variances and the cost …
pub(crate) const PILOT_ITERATIONS: u64 = 8;

/// … and with an eighth of it, for the cost alone (counted work varies little from one
/// iteration to the next).
pub(crate) const COST_ITERATIONS: u64 = 2;

/// The pilot's iterations take the radii of this iteration and the next ones: the radii whose
/// merges are as noisy as the mean iteration's of a render of about 1,200 iterations (the
/// variance of a merge grows as 1/r^d, and the mean over iterations 1 … n of r_i^{−d} is about
/// r_{n/2.3}^{−d} for the schedules' α), a few seconds at the time-to-error settings. A fixed
/// index keeps the choice the same for every range of a render split over processes.
pub(crate) const PILOT_ITERATION: u64 = 512;

/// About this many pixels, one in each cell of a grid over the image, are rendered by each
/// pilot iteration.
const PILOT_PIXELS: u32 = 2048;

/// The divisors of the scene's light paths per iteration that the pilot chooses among.
pub(crate) const DIVISORS: [u64; 4] = [1, 2, 4, 8];

/// Nanoseconds of 2-core time per unit of counted work, fitted to the measured times of the
/// photon and camera passes of the bundled scenes (docs/performance.md, "How many light paths").
/// Only their ratios matter.
const NS_PER_RAY: f64 = 150.0;
const NS_PER_STEP: f64 = 25.0;
const NS_PER_FOUND: f64 = 15.0;
const NS_PER_STORED: f64 = 40.0;

/// The merging techniques, whose part of an iteration is a mean over its light paths.
pub(super) const MERGES: [Technique; 3] = [Technique::Surface, Technique::Point, Technique::Beam];

/// Mixed into the seed for the pilot's random streams, so that its iterations are not the
/// render's.
pub(super) const PILOT_SEED: u64 = 0x7069_6c6f_745f_6e6c;

/// The light paths per iteration, and what the pilot measured to choose them.
#[derive(Clone, Debug, PartialEq)]
pub struct Budget {
    /// Light paths per iteration.
    pub paths: u64,
    /// The chance with which an eye path goes on past its first merge (Russian roulette, its
    /// contributions from there on divided by it): 1 unless the pilot found the eye's deeper
    /// vertices worth less than they cost.
    pub continues: f32,
    /// The pilot chose to end eye paths at their first merge (`Merges::Last`): where the settings
    /// leave the merges open, the eye's deeper vertices cost most of an iteration.
    pub ends_at_merge: bool,
    /// Light paths are split by importance because they were found running long
    /// (`photon_splitting = "auto"`); the pilot's measurements are then those with them split.
    pub split: bool,
    /// Point–point merges are weighed (`point_merges`; by default not where the eye paths end
    /// at their first merge). The pilot's own result leaves it `true`; the integrator sets it
    /// from the settings and `ends_at_merge`.
    pub point_merges: bool,
    /// The pilot's measurements and ranking; `None` where no pilot ran (the count was
    /// fixed, or no merge counts).
    pub pilot: Option<Pilot>,
}

impl Budget {
    /// `paths` light paths per iteration, fixed: no pilot ran.
    pub fn fixed(paths: u64) -> Self {
        let (continues, ends_at_merge, split, point_merges) = (1.0, false, false, true);
        Self { paths, continues, ends_at_merge, split, point_merges, pilot: None }
    }
}

/// What the pilot measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Pilot {
    /// The counts measured: the scene's, an eighth of it, then none where the eye's techniques
    /// alone were weighed.
    pub measured: Vec<Measured>,
    /// Each candidate count, with its predicted variance times cost per iteration relative to
    /// the scene's count's, the smaller the better.
    pub ranked: Vec<(u64, f64)>,
    /// For the chosen count, each chance of going on past the first merge
    /// ([`Budget::continues`]) with its predicted variance times cost relative to going on
    /// always.
    pub continuation: Vec<(f32, f64)>,
    /// The share of an iteration's modelled cost, at the scene's count, that the eye's vertices
    /// past its first merge take (what ends them there where the merges are open).
    pub deep_share: f64,
    /// Pixels rendered per pilot iteration, and the image's pixels.
    pub pixels: (usize, usize),
    /// Seconds the pilot took (reported only; the choice never reads the clock).
    pub seconds: f64,
}

/// One count as the pilot measured it.
#[derive(Clone, Debug, PartialEq)]
pub struct Measured {
    /// Light paths per iteration.
    pub paths: u64,
    /// Pilot iterations rendered with them.
    pub iterations: u64,
    /// The variance of one iteration's image, summed over the pilot's pixels and channels,
    /// each pixel's held to at most the 99.9 % quantile of the pixels' (0 from fewer than two
    /// iterations).
    pub variance: f64,
    /// The same of the merges' part of the image.
    pub merge_variance: f64,
    /// The image's mean over the pilot's iterations, summed over its pixels and channels, and
    /// that sum's standard error (from the pixels' variances, uncapped).
    pub mean: [f64; 2],
    /// Work of one iteration's light paths: rays and tentative collisions (photons found by
    /// the eye are counted with the eye).
    pub light: [f64; 2],
    /// Photons stored per iteration.
    pub stored: f64,
    /// Of them, those only a merge can carry: their light side is empty (no next-event
    /// estimation or eye path reaching the light could make their paths).
    pub merges_only: f64,
    /// Work of one iteration's eye paths over the whole image: rays, tentative collisions,
    /// photons found.
    pub eye: [f64; 3],
    /// The second moment of what the eye's vertices past its first merge add to a pixel, summed
    /// over the pilot's pixels and channels (not held to a quantile: rare large values are what
    /// Russian roulette on them multiplies).
    pub deep_moment: f64,
    /// The cost model's nanoseconds per iteration of the eye's work past its first merge, over
    /// the whole image (part of `cost`).
    pub deep_cost: f64,
    /// The cost model's nanoseconds per iteration.
    pub cost: f64,
    /// Seconds per pilot iteration, photon pass and camera pass over the pilot's pixels
    /// (reported only).
    pub seconds: [f64; 2],
}

/// What pilot iterations with one count of light paths gave: per pixel the sums of the image's
/// values and squares and of its merges' part's, and of the squares of what the eye's vertices
/// past its first merge added; and the work and time of the iterations.
pub(super) struct Tallies {
    sums: Vec<[Rgb; 5]>,
    light: Work,
    eye: Work,
    deep: Work,
    stored: u64,
    merges_only: u64,
    seconds: [f64; 2],
    iterations: u64,
}

/// One pilot iteration's photon pass: the work of its light paths, the photons stored, those of
/// them only a merge can carry (an empty light side) and the seconds it took.
pub(super) type PhotonPassDone = (Work, u64, u64, f64);

/// One pixel of a pilot iteration: its value, its merges' part, what the eye's vertices past
/// its first merge added, the eye's work and that part of it.
#[derive(Default)]
pub(super) struct PixelDone {
    pub value: Rgb,
    pub merged: Rgb,
    pub deep: Rgb,
    pub work: Work,
    pub deep_work: Work,
}

impl Tallies {
    /// None yet, over `pixels` pixels.
    pub(super) fn new(pixels: usize) -> Self {
        Self {
            sums: vec![[Rgb::ZERO; 5]; pixels],
            light: Work::default(),
            eye: Work::default(),
            deep: Work::default(),
            stored: 0,
            merges_only: 0,
            seconds: [0.0; 2],
            iterations: 0,
        }
    }

    /// One pilot iteration: its photon pass, and its pixels (a pixel whose value is not finite
    /// counts as black, as in a render), the camera pass having taken `camera` seconds.
    pub(super) fn add(&mut self, photons: PhotonPassDone, pixels: &[PixelDone], camera: f64) {
        let (light, stored, merges_only, seconds) = photons;
        self.light += light;
        self.stored += stored;
        self.merges_only += merges_only;
        self.seconds[0] += seconds;
        self.seconds[1] += camera;
        self.iterations += 1;
        for (s, p) in self.sums.iter_mut().zip(pixels) {
            let (v, m, d) = (p.value, p.merged, p.deep);
            let (v, m, d) = if v.is_finite() && m.is_finite() && d.is_finite() {
                (v, m, d)
            } else {
                (Rgb::ZERO, Rgb::ZERO, Rgb::ZERO)
            };
            *s = [s[0] + v, s[1] + v * v, s[2] + m, s[3] + m * m, s[4] + d * d];
            self.eye += p.work;
            self.deep += p.deep_work;
        }
    }

    /// The measurement of `paths` light paths per iteration, the eye's work scaled by `scale`
    /// to the whole image; the variances need at least two iterations.
    fn measured(&self, paths: u64, scale: f64) -> Measured {
        let k = self.iterations.max(1) as f64;
        let variance = |sum: Rgb, squares: Rgb| {
            let (s, s2) = (sum.as_dvec3(), squares.as_dvec3());
            ((s2 - s * s / k) / (k - 1.0)).max(glam::DVec3::ZERO).element_sum()
        };
        let deep_moment: f64 =
            self.sums.iter().map(|s| s[4].as_dvec3().element_sum()).sum::<f64>() / k;
        let (variance, merge_variance, mean) = if self.iterations < 2 {
            (0.0, 0.0, [0.0; 2])
        } else {
            let all: Vec<f64> = self.sums.iter().map(|s| variance(s[0], s[1])).collect();
            let merged: Vec<f64> = self.sums.iter().map(|s| variance(s[2], s[3])).collect();
            let sum: f64 = self.sums.iter().map(|s| s[0].as_dvec3().element_sum()).sum();
            let error = (all.iter().sum::<f64>() / k).sqrt();
            (capped_sum(all), capped_sum(merged), [sum / k, error])
        };
        let per = |x: u64| x as f64 / k;
        let light = [per(self.light.rays), per(self.light.steps)];
        let eye = self.eye;
        let eye = [per(eye.rays) * scale, per(eye.steps) * scale, per(eye.found) * scale];
        let stored = per(self.stored);
        let merges_only = per(self.merges_only);
        let cost = NS_PER_RAY * (light[0] + eye[0])
            + NS_PER_STEP * (light[1] + eye[1])
            + NS_PER_FOUND * eye[2]
            + NS_PER_STORED * stored;
        let deep = self.deep;
        let deep_cost = (NS_PER_RAY * per(deep.rays)
            + NS_PER_STEP * per(deep.steps)
            + NS_PER_FOUND * per(deep.found))
            * scale;
        Measured {
            paths,
            iterations: self.iterations,
            variance,
            merge_variance,
            mean,
            light,
            stored,
            merges_only,
            eye,
            deep_moment,
            deep_cost,
            cost,
            seconds: self.seconds.map(|s| s / k),
        }
    }
}

/// The pilot for a render of `n` light paths per iteration at `resolution`, its pixels drawn
/// from `seed`: `iterate(paths, iterations, pixels)` renders that many pilot iterations (at
/// the radii of [`PILOT_ITERATION`] on) over the pixels. With `eye_alone` it may choose no
/// light paths (the module's notes say when), and with `last` end the eye paths at their first
/// merge ([`LAST_DEEP_SHARE`]). `None` if `iterate` returned `None` (a stop).
pub(super) fn choose(
    n: u64,
    resolution: [u32; 2],
    seed: u64,
    eye_alone: bool,
    last: bool,
    mut iterate: impl FnMut(u64, u64, &[[u32; 2]]) -> Option<Tallies>,
) -> Option<Budget> {
    let eighth = DIVISORS[DIVISORS.len() - 1];
    if n < eighth {
        return Some(Budget::fixed(n));
    }
    let clock = Instant::now();
    let [w, h] = resolution;
    let pixels = pilot_pixels(w, h, seed);
    let scale = (w as f64 * h as f64) / pixels.len() as f64;
    let whole = iterate(n, PILOT_ITERATIONS, &pixels)?.measured(n, scale);
    let fewest = iterate(n / eighth, COST_ITERATIONS, &pixels)?.measured(n / eighth, scale);
    let zero = if eye_alone && whole.merges_only == 0.0 {
        Some(iterate(0, PILOT_ITERATIONS, &pixels)?.measured(0, scale))
    } else {
        None
    };
    let eye_sees = zero.as_ref().filter(|z| sees_the_light(&whole, z));
    let ranked = rank(&whole, &fewest, eye_sees);
    let best = pick(&ranked, best_always(&whole, &fewest)).unwrap_or(n);
    // The eye alone goes on always: its deeper vertices are all it has.
    let divisor = DIVISORS.into_iter().find(|&d| best > 0 && n / d == best);
    let continuation = divisor.map_or(vec![(1.0, 1.0)], |d| continuation(&whole, &fewest, d));
    let continues = pick_continuation(&continuation);
    let deep_share = deep_share(&whole);
    let ends_at_merge = last && best > 0 && deep_share >= LAST_DEEP_SHARE;
    // Ending at the first merge leaves nothing past it to go on to.
    let (continues, continuation) =
        if ends_at_merge { (1.0, vec![(1.0, 1.0)]) } else { (continues, continuation) };
    let pilot = Pilot {
        measured: [whole, fewest].into_iter().chain(zero).collect(),
        ranked,
        continuation,
        deep_share,
        pixels: (pixels.len(), (w * h) as usize),
        seconds: clock.elapsed().as_secs_f64(),
    };
    let (split, point_merges, pilot) = (false, true, Some(pilot));
    Some(Budget { paths: best, continues, ends_at_merge, split, point_merges, pilot })
}

/// Eye paths end at their first merge (`Merges::Last`) where the settings leave the merges open
/// and the eye's vertices past its first merge cost at least this share of an iteration (modelled,
/// at the scene's count). There they are long random walks through a dense, bright medium, whose
/// next-event estimation rarely finds light the light paths do not carry to the first merge at a
/// fraction of the cost. dense-fog (albedo 0.999, ~1,000 events per path): 0.84 of the iteration,
/// and `last` 0.60× the error at equal time; the other twelve bundled scenes: 0.16–0.39, among
/// them vdb-cloud and vdb-edges, where `last` is 3.06× and 1.6× worse (docs/performance.md,
/// "Ending the eye path at its first merge"). The choice reads cost, not variance: the pilot's
/// variance of `last` against the default on dense-fog ranged over 0.08–3.9 of the default's
/// product from one seed to the next (8 iterations of 125 light paths see a few rare events).
const LAST_DEEP_SHARE: f64 = 0.6;

/// The share of the modelled cost of an iteration at the scene's count (`whole`) that the eye's
/// vertices past its first merge take.
fn deep_share(whole: &Measured) -> f64 {
    if whole.cost > 0.0 { (whole.deep_cost / whole.cost).min(1.0) } else { 0.0 }
}

/// The share of the pilot's pixels whose variance is kept as measured; the rest are held to the
/// largest of these. The variances come from a few iterations each, and in a medium that
/// scatters sharply a handful of pixels would otherwise decide the choice by chance (on
/// fog-backward the unheld sums ranked the counts differently from one seed to the next).
pub(crate) const CAP_QUANTILE: f64 = 0.999;

/// The sum of the pixels' variances `v`, each held to at most their [`CAP_QUANTILE`] quantile.
fn capped_sum(mut v: Vec<f64>) -> f64 {
    let mut sorted = v.clone();
    sorted.sort_by(f64::total_cmp);
    let at = ((sorted.len() as f64 * CAP_QUANTILE) as usize).min(sorted.len().saturating_sub(1));
    let limit = sorted.get(at).copied().unwrap_or(0.0);
    v.iter_mut().for_each(|x| *x = x.min(limit));
    v.iter().sum()
}

/// The pixels a pilot iteration renders: one in each cell of s × s pixels over the image, at a
/// place in the cell drawn from `seed`; s is chosen for about [`PILOT_PIXELS`] of them (every
/// pixel of a small image). A drawn place, not the cells' centres: the variance of an image can
/// sit in a few rows or columns (a lamp's edge seen through fog, where a pixel sees the lamp or
/// not), which a regular grid of pixels may miss altogether.
fn pilot_pixels(w: u32, h: u32, seed: u64) -> Vec<[u32; 2]> {
    let s = ((w as f64 * h as f64 / PILOT_PIXELS as f64).sqrt().floor() as u32).max(1);
    let (cw, ch) = (w.div_ceil(s), h.div_ceil(s));
    (0..cw * ch)
        .map(|c| {
            let (cx, cy) = (c % cw * s, c / cw * s);
            let mut r = Sampler::new(seed, Purpose::Pilot, 0, c as u64);
            let at =
                |lo: u32, n: u32, u: f32| lo + ((u * (n - lo).min(s) as f32) as u32).min(s - 1);
            let x = at(cx, w, r.next_f32());
            let y = at(cy, h, r.next_f32());
            [x.min(w - 1), y.min(h - 1)]
        })
        .collect()
}

/// How far below the image's mean with the scene's light paths the eye's techniques alone may
/// fall, in standard errors of the difference, before the pilot takes them to have missed light.
const EYE_MISSES_Z: f64 = 3.0;

/// The shortfall of the eye's mean, as a fraction of the image's, that the comparison must be
/// able to see at [`EYE_MISSES_Z`]; where the pilot's means are too noisy for that, the eye
/// alone is not weighed.
const EYE_MISSES_FRACTION: f64 = 0.1;

/// Whether the eye's techniques alone (`zero`) found the light the scene's count (`whole`)
/// did: their mean over the pilot's pixels is not below the other's by more than
/// [`EYE_MISSES_Z`] standard errors of the difference, and those errors are small enough to see
/// a shortfall of [`EYE_MISSES_FRACTION`]. The census of photons only a merge can carry finds
/// light the eye can never sample; this finds light it samples too rarely for the pilot's
/// iterations to see, whose variance those few iterations would put far too low (dense-fog: the
/// eye's mean over the pilot's pixels 3.4 ± 2.1 against 36 ± 19 with the light paths, and its
/// variance, held to the pixels' 99.9 % quantile, 4 · 10⁻⁵ of theirs).
fn sees_the_light(whole: &Measured, zero: &Measured) -> bool {
    let ([a, ea], [b, eb]) = (whole.mean, zero.mean);
    let error = EYE_MISSES_Z * (ea * ea + eb * eb).sqrt();
    zero.variance > 0.0 && error <= EYE_MISSES_FRACTION * a && a - b <= error
}

/// No light paths are chosen only where their predicted variance × cost is below this share of
/// the best count's. Their variance is measured from 8 iterations, where the counts' comes from
/// the merges' part at the scene's count, and the eye alone has no merges to fall back on where
/// it samples badly. Measured at equal time (docs/performance.md, "No light paths"), the eye
/// alone did better than the best count where it promised 0.68–0.77 of its product (cornell-box,
/// cornell-cloud, vdb-edges, vdb-cloud) and worse on thin-fog, at 0.92 (6.18 % against 5.46 %).
const EYE_ALONE_MARGIN: f64 = 0.8;

/// The count to render with from [`rank`]'s list: the best of the counts, or none where that
/// was ranked ahead of `always`, the best count's product going on always past the first merge,
/// by [`EYE_ALONE_MARGIN`]. The margin was measured against counts that go on always; a count
/// that goes on by Russian roulette is cheaper but no less biased by its merges, which the
/// pilot does not see: against it the eye alone lost where the merges' kernel bias is part of
/// the error (vdb-edges at equal time: 15.73 % with an eighth of the light paths and roulette,
/// 12.50 % with none; docs/performance.md, "Past the first merge"). `None` for an empty list.
fn pick(ranked: &[(u64, f64)], always: f64) -> Option<u64> {
    let (zero, counts): (Vec<&(u64, f64)>, Vec<_>) = ranked.iter().partition(|r| r.0 == 0);
    let best = counts.into_iter().min_by(|a, b| a.1.total_cmp(&b.1))?;
    match zero.first() {
        Some(z) if z.1 < EYE_ALONE_MARGIN * always => Some(0),
        _ => Some(best.0),
    }
}

/// The best count's predicted variance × cost going on always past the first merge, relative
/// as in [`rank`].
fn best_always(whole: &Measured, eighth: &Measured) -> f64 {
    let line = cost_line(whole, eighth);
    let reference = product(whole, line, 1, 1.0);
    let best = DIVISORS.iter().map(|&d| product(whole, line, d, 1.0)).fold(f64::INFINITY, f64::min);
    if reference > 0.0 { best / reference } else { 1.0 }
}

/// The chances of an eye path going on past its first merge that the pilot chooses among
/// ([`Budget::continues`]).
pub(crate) const CONTINUES: [f32; 5] = [1.0, 0.5, 0.25, 0.125, 0.0625];

/// A chance of going on below 1 is chosen only where it promises less than this share of going
/// on always's variance × cost: the second moment it multiplies comes from 8 iterations, which
/// under-count its rare large values. At equal time (docs/performance.md, "Past the first
/// merge") roulette won where it promised 0.48–0.69 (cornell-fog, thin-fog,
/// cornell-cloud-homogeneous) and lost on fog-backward (g = −0.95), where it promised 0.86.
const CONTINUE_MARGIN: f64 = 0.8;

/// Predicted variance × cost per iteration of count n/d going on past the first merge with
/// chance q, from the scene's count's measurement (`whole`) and the cost line (`fixed` +
/// `slope` per light path): the variance V + (d − 1) V_M + (1/q − 1) D, with D the second
/// moment of what the eye adds past its first merge (Russian roulette with chance q adds
/// (1/q − 1) times it), and the cost with that part of the eye's work times q.
fn product(whole: &Measured, line: (f64, f64), d: u64, q: f32) -> f64 {
    let (fixed, slope) = line;
    let q = q as f64;
    let variance = whole.variance
        + (d - 1) as f64 * whole.merge_variance
        + (1.0 / q - 1.0) * whole.deep_moment;
    // `fixed` is extrapolated from two counts and may fall below the deeper part it holds: the
    // work left of that part is q times it at least.
    let eye = (fixed - (1.0 - q) * whole.deep_cost).max(q * whole.deep_cost);
    let cost = eye + slope * (whole.paths / d) as f64;
    variance * cost
}

/// The line of the cost in the light paths through the costs of `whole` and `eighth` (its
/// coefficients at least 0: more light paths never save work): (fixed, per light path).
fn cost_line(whole: &Measured, eighth: &Measured) -> (f64, f64) {
    let (n, m) = (whole.paths as f64, eighth.paths as f64);
    let slope = if n > m { ((whole.cost - eighth.cost) / (n - m)).max(0.0) } else { 0.0 };
    ((whole.cost - slope * n).max(0.0), slope)
}

/// Each candidate count n/d, d in [`DIVISORS`], with its predicted variance times cost per
/// iteration ([`product`], at the chance of going on [`pick_continuation`] chooses for it)
/// relative to count n's going on always; then, if measured (`zero`), no light paths, its variance and cost as measured.
pub(crate) fn rank(
    whole: &Measured,
    eighth: &Measured,
    zero: Option<&Measured>,
) -> Vec<(u64, f64)> {
    let line = cost_line(whole, eighth);
    let reference = product(whole, line, 1, 1.0);
    let relative = |x: f64| if reference > 0.0 { x / reference } else { 1.0 };
    let best = |d: u64| {
        let q = pick_continuation(&continuation(whole, eighth, d));
        relative(product(whole, line, d, q))
    };
    let counts = DIVISORS.iter().map(|&d| (whole.paths / d, best(d)));
    counts.chain(zero.map(|z| (0, relative(z.variance * z.cost)))).collect()
}

/// For count n/`d` ([`DIVISORS`]), each of [`CONTINUES`] with its predicted variance × cost
/// relative to going on always.
pub(crate) fn continuation(whole: &Measured, eighth: &Measured, d: u64) -> Vec<(f32, f64)> {
    let line = cost_line(whole, eighth);
    let always = product(whole, line, d, 1.0);
    let relative = |x: f64| if always > 0.0 { x / always } else { 1.0 };
    CONTINUES.iter().map(|&q| (q, relative(product(whole, line, d, q)))).collect()
}

/// The chance to go on with from [`continuation`]'s list: the best, where it is ahead of going
/// on always by [`CONTINUE_MARGIN`]; else 1.
fn pick_continuation(list: &[(f32, f64)]) -> f32 {
    let best = list.iter().min_by(|a, b| a.1.total_cmp(&b.1));
    match best {
        Some(&(q, x)) if x < CONTINUE_MARGIN => q,
        _ => 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn measured(paths: u64, variance: f64, merge_variance: f64, cost: f64) -> Measured {
        Measured {
            paths,
            iterations: 8,
            variance,
            merge_variance,
            mean: [0.0; 2],
            light: [0.0; 2],
            stored: 0.0,
            merges_only: 0.0,
            eye: [0.0; 3],
            deep_moment: 0.0,
            deep_cost: 0.0,
            cost,
            seconds: [0.0; 2],
        }
    }

    /// Where the merges carry the variance the scene's count wins; where the eye does and the
    /// light paths cost the most, the smallest count.
    #[test]
    fn the_ranking_follows_where_variance_and_cost_lie() {
        // V = 2 of which the merges' 1 at N = 8000: V = 1 + 8000/N. C = 1 + N/8000: 2 at 8000,
        // 1.125 at 1000.
        let r = rank(&measured(8000, 2.0, 1.0, 2.0), &measured(1000, 0.0, 0.0, 1.125), None);
        // (1 + d)(1 + 1/d): 4 at d = 1, 4.5 at 2, 6.25 at 4, 10.125 at 8.
        let want = [(8000, 1.0), (4000, 4.5 / 4.0), (2000, 6.25 / 4.0), (1000, 10.125 / 4.0)];
        for ((m, x), (wm, wx)) in r.iter().zip(want) {
            assert_eq!(*m, wm);
            assert!((x - wx).abs() < 1e-12, "{m}: {x} against {wx}");
        }
        // The merges' part 1 % of the variance, the photons half the cost: an eighth.
        let r = rank(&measured(8000, 1.0, 0.01, 2.0), &measured(1000, 0.0, 0.0, 1.125), None);
        let best = r.iter().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap().0;
        assert_eq!(best, 1000);
        // Costs that do not grow with the light paths: the scene's count, never fewer.
        let r = rank(&measured(8000, 1.0, 0.01, 2.0), &measured(1000, 0.0, 0.0, 2.5), None);
        assert!(r.windows(2).all(|w| w[1].1 > w[0].1), "{r:?}");
    }

    /// Going on past the first merge with chance q multiplies the deeper part's second moment
    /// by 1/q − 1 and its cost by q: where the deeper vertices add nothing and cost much, the
    /// smallest chance; where they add much, always.
    #[test]
    fn the_eye_goes_on_where_its_deeper_vertices_pay() {
        let whole = |deep_moment: f64, deep_cost: f64| Measured {
            deep_moment,
            deep_cost,
            ..measured(8000, 2.0, 1.0, 2.0)
        };
        let eighth = measured(1000, 0.0, 0.0, 1.125);
        // Half the cost in the deeper vertices, which add nothing: V stays 2, the cost
        // 2 − (1 − q), so q = 1/16 gives 1.0625 / 2.
        let w = whole(0.0, 1.0);
        let c = continuation(&w, &eighth, 1);
        assert_eq!(c.len(), CONTINUES.len());
        assert_eq!(c[0], (1.0, 1.0));
        let (q, x) = *c.last().unwrap();
        assert_eq!(q, 0.0625);
        assert!((x - 1.0625 / 2.0).abs() < 1e-12, "{x}");
        assert_eq!(pick_continuation(&c), 0.0625);
        // The same ranking sees it: the scene's count at its best chance.
        let r = rank(&w, &eighth, None);
        assert!((r[0].1 - 1.0625 / 2.0).abs() < 1e-12, "{r:?}");
        // At q = 1/2 a deeper part of second moment 1 adds 1 to V = 2 and saves half its
        // cost 1: (3 · 1.5) / (2 · 2) = 1.125, worse; smaller chances are worse still.
        let c = continuation(&whole(1.0, 1.0), &eighth, 1);
        assert!((c[1].1 - 1.125).abs() < 1e-12, "{c:?}");
        assert_eq!(pick_continuation(&c), 1.0);
        // A gain short of the margin keeps going on always.
        assert_eq!(pick_continuation(&[(1.0, 1.0), (0.5, 0.81)]), 1.0);
        assert_eq!(pick_continuation(&[(1.0, 1.0), (0.5, 0.79)]), 0.5);
        // At an eighth of the light paths: the count's own line.
        let c = continuation(&w, &eighth, 8);
        // V = 2 + 7 · 1 = 9; cost 1.125 − (1 − q): q = 1/16 gives 0.1875 against 1.125.
        assert!((c.last().unwrap().1 - 0.1875 / 1.125).abs() < 1e-12, "{c:?}");
    }

    /// No light paths rank by their own measured variance and cost, after the counts.
    #[test]
    fn no_light_paths_rank_by_their_own_measurement() {
        let (whole, eighth) = (measured(8000, 2.0, 1.0, 2.0), measured(1000, 0.0, 0.0, 1.125));
        // Against V C = 4 at the scene's count: 1.5 · 1 (the eye alone) is 0.375 of it …
        let r = rank(&whole, &eighth, Some(&measured(0, 1.5, 0.0, 1.0)));
        assert_eq!(r.len(), DIVISORS.len() + 1);
        assert_eq!(r[DIVISORS.len()], (0, 0.375));
        assert_eq!(pick(&r, best_always(&whole, &eighth)), Some(0));
        // … and 5 · 1 is 1.25, behind the scene's count.
        let r = rank(&whole, &eighth, Some(&measured(0, 5.0, 0.0, 1.0)));
        assert_eq!(pick(&r, best_always(&whole, &eighth)), Some(8000));
        // Ahead of the best count, but not by the margin: the count.
        let r = [(8000, 1.0), (4000, 0.5), (0, 0.41)];
        assert_eq!(pick(&r, 0.5), Some(4000));
        let r = [(8000, 1.0), (4000, 0.5), (0, 0.39)];
        assert_eq!(pick(&r, 0.5), Some(0));
        // The margin is against the best count going on always: a count ranked ahead by its
        // roulette does not move it.
        let r = [(8000, 0.6), (4000, 0.3), (0, 0.39)];
        assert_eq!(pick(&r, 0.5), Some(0));
        let r = [(8000, 0.6), (4000, 0.3), (0, 0.41)];
        assert_eq!(pick(&r, 0.5), Some(4000));
    }

    /// The eye alone is taken to have missed light where its mean falls more than 3 standard
    /// errors below the scene's count's, where those errors could not see a tenth of the light
    /// missing, or where it saw nothing vary at all.
    #[test]
    fn an_eye_that_misses_the_light_is_not_weighed() {
        let at =
            |mean: [f64; 2], variance: f64| Measured { mean, ..measured(0, variance, 0.0, 1.0) };
        let whole = at([200.0, 3.0], 1.0);
        // The difference's standard error is 5: 14.9 below is within 3 of them, 15.1 is not.
        assert!(sees_the_light(&whole, &at([185.1, 4.0], 1.0)));
        assert!(!sees_the_light(&whole, &at([184.9, 4.0], 1.0)));
        // Above is never missed light.
        assert!(sees_the_light(&whole, &at([230.0, 4.0], 1.0)));
        // No variance: nothing was found.
        assert!(!sees_the_light(&whole, &at([200.0, 0.0], 0.0)));
        // Three errors of 5 are more than a tenth of 140: too noisy to tell.
        assert!(!sees_the_light(&at([140.0, 3.0], 1.0), &at([140.0, 4.0], 1.0)));
    }

    /// Each pixel's variance is held to the quantile of all of them.
    #[test]
    fn a_few_pixels_do_not_decide() {
        let mut v = vec![1.0; 1999];
        v.push(1e6);
        // The 99.9 % quantile of the 2000 pixels is 1: the outlier counts as 1.
        assert_eq!(capped_sum(v), 2000.0);
        assert_eq!(capped_sum(Vec::new()), 0.0);
    }

    /// The pilot's pixels cover the image evenly, about `PILOT_PIXELS` of them, all inside.
    #[test]
    fn the_pilots_pixels_cover_the_image() {
        for (w, h) in [(96, 96), (384, 384), (160, 100), (7, 3), (1000, 20), (250, 141)] {
            let p = pilot_pixels(w, h, 1);
            assert!(p.iter().all(|&[x, y]| x < w && y < h));
            // One per cell, no pixel twice.
            let mut q = p.clone();
            q.sort();
            q.dedup();
            assert_eq!(q.len(), p.len());
            let n = p.len() as f64;
            let all = (w * h) as f64;
            assert!(n == all || (n > PILOT_PIXELS as f64 * 0.5 && n < PILOT_PIXELS as f64 * 2.5));
        }
    }
}
