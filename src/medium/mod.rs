//! Participating media: one closed set that the integrators use without knowing the kind. Every
//! medium answers the same questions: sample a free-flight distance, the transmittance along a
//! ray, σ_a, σ_s and the emitted radiance L_e at a point, the emission reaching a point along a
//! ray, and its phase function.
//!
//! ```toml
//! [media.fog]
//! type = "homogeneous"
//! sigma_a = [0.01, 0.01, 0.01]  # absorption, 1/length …
//! sigma_s = [0.5, 0.5, 0.5]     # … and scattering; or give `albedo` and `sigma_t` (extinction)
//! g = 0.3                       # Henyey–Greenstein mean cosine; 0 = isotropic (default)
//! emission = [2.0, 1.0, 0.5]    # emitted radiance L_e (default 0): the source is σ_a · L_e
//! ```

pub mod blackbody;
pub(crate) mod blocks;
pub(crate) mod emission;
pub mod grid;
pub mod homogeneous;
pub mod phase;
pub(crate) mod track;
pub(crate) mod tracker;
pub mod vdb;
pub(crate) mod vdbscan;

use crate::math::Rgb;
use crate::rng::Sampler;
use glam::Vec3;
use homogeneous::Homogeneous;
use phase::HenyeyGreenstein;
use smallvec::SmallVec;
pub use track::FreeFlight;
pub use tracker::SegmentTransmittance;
use tracker::Tracked;
use vdb::VdbMedium;

/// Runs `$e` with `$m` bound to the medium's own kind, as the tracker sees it.
macro_rules! tracked {
    ($medium:expr, $m:ident => $e:expr) => {
        match $medium {
            Medium::Homogeneous($m) => $e,
            Medium::Vdb(v) => {
                let $m = &**v;
                $e
            }
        }
    };
}

/// The rate, in multiples of a grid's majorants, of the ratio tracking behind the transmittance
/// step function of an eye segment the beam estimate gathers along ([`Medium::segment`]): every
/// photon on the segment is weighted by it (as are the hybrid's single scattering there and the
/// path's continuation). At rate 1 a tight majorant makes every factor 1 − σ_t/μ̄ all but zero, so
/// the step function is all but binary: photons count in full up to a random depth and not
/// beyond. At rate 4 the factors lie in [¾, 1] and the function follows the true transmittance
/// far more closely (relative variance e^{τ/4} − 1 instead of e^τ − 1 over a homogeneous piece of
/// optical depth τ), with Russian roulette ending the walk where the estimate has become
/// negligible. Measured at equal time (30 s, 2 cores; docs/theory.md): relative noise over
/// vdb-cloud 14.2 % → 10.3 %, over the cumulus 25.8 % → 20.5 %. Where only single scattering uses
/// the function (the path tracer, the point estimate) rate 1 is as good at equal time: the path
/// tracer's noise on vdb-cloud in 30 s was 11.04 % at rate 1 and 11.17 % at rate 4 (631 and 514
/// samples per pixel).
pub(crate) const BEAM_SEGMENT_RATE: f32 = 4.0;

/// A participating medium.
#[derive(Clone, Debug)]
pub enum Medium {
    /// Constant coefficients.
    Homogeneous(Homogeneous),
    /// Coefficients proportional to an OpenVDB density grid.
    Vdb(Box<VdbMedium>),
}

/// Distances along a segment, [t0, t1], with density proportional to its transmittance: a
/// truncated exponential of the mean extinction in a homogeneous medium, the ratio-tracking step
/// function of the segment in a grid (its largest channel, for a coloured extinction; the density
/// then depends on that estimate, which is
/// independent of the distance drawn, so an estimator linear in the transmittance stays unbiased).
/// One of the two distance strategies of single scattering (the other is equiangular sampling).
pub struct TransmittanceDistance<'a> {
    tr: &'a SegmentTransmittance,
    t0: f32,
    t1: f32,
    /// Exponential rate (homogeneous media).
    sigma: f32,
    /// ∫ T over [t0, t1] (grids), or the exponential's normalisation 1 − e^{−σ (t1 − t0)}.
    total: f32,
    /// Cumulative ∫ T over the step function's intervals (grids; see [`step_areas`]).
    areas: StepAreas,
}

/// Cumulative areas under a step function (one more than its steps), on the stack for up to 35
/// steps (smallvec's sizes past 32 are 36 and powers of two).
type StepAreas = SmallVec<[f32; 36]>;

impl<'a> TransmittanceDistance<'a> {
    /// The distribution over [t0, t1] for the segment's transmittance `tr`; `None` if it has no
    /// mass (nothing to sample).
    pub fn new(tr: &'a SegmentTransmittance, t0: f32, t1: f32) -> Option<Self> {
        let sigma = match tr {
            SegmentTransmittance::Grey { sigma_t } => *sigma_t,
            SegmentTransmittance::Exponential { sigma_t } => sigma_t.element_sum() / 3.0,
            SegmentTransmittance::Steps(steps) => {
                let areas = step_areas(steps, t0, t1);
                let total = areas.last().copied().unwrap_or(0.0);
                // A density of T/total ≤ 1/total: a segment of next to no length (area below
                // ~3·10⁻³⁹, say at a surface) would give infinite densities and NaN weights
                // (2 samples in 8.2 M on scenes/cumulus.toml): nothing to sample there.
                let ok = total > 0.0 && (1.0 / total).is_finite();
                return ok.then_some(Self { tr, t0, t1, sigma: 0.0, total, areas });
            }
        };
        let total = -(-sigma * (t1 - t0)).exp_m1();
        let areas = StepAreas::new();
        (sigma > 0.0 && total > 0.0 && (sigma / total).is_finite()).then_some(Self {
            tr,
            t0,
            t1,
            sigma,
            total,
            areas,
        })
    }

    /// A distance drawn from a uniform `u`, and its density.
    pub fn sample(&self, u: f32) -> (f32, f32) {
        let t = match self.tr {
            SegmentTransmittance::Steps(steps) => {
                let areas = &self.areas;
                let target = u * self.total;
                let i = areas.partition_point(|&a| a <= target).min(areas.len() - 1);
                let (lo, hi) = step_interval(steps, i, self.t0, self.t1);
                let before = if i == 0 { 0.0 } else { areas[i - 1] };
                let value = step_value(steps, i);
                if value > 0.0 { (lo + (target - before) / value).clamp(lo, hi) } else { lo }
            }
            _ => self.t0 - (-u * self.total).ln_1p() / self.sigma,
        };
        let t = t.clamp(self.t0, self.t1);
        (t, self.pdf(t))
    }

    /// The density of distance `t`.
    pub fn pdf(&self, t: f32) -> f32 {
        if !(t >= self.t0 && t <= self.t1) {
            return 0.0;
        }
        match self.tr {
            SegmentTransmittance::Steps(steps) => {
                tracker::steps_at(steps, t).max_element() / self.total
            }
            _ => self.sigma * (-self.sigma * (t - self.t0)).exp() / self.total,
        }
    }
}

/// Interval i of a transmittance step function clipped to [t0, t1]: [t0, s_1), [s_1, s_2), …,
/// [s_n, t1], where T is 1 on the first and the value after step k on the others.
fn step_interval(steps: &[(f32, Rgb)], i: usize, t0: f32, t1: f32) -> (f32, f32) {
    let lo = if i == 0 { t0 } else { steps[i - 1].0.clamp(t0, t1) };
    let hi = if i < steps.len() { steps[i].0.clamp(t0, t1) } else { t1 };
    (lo, hi)
}

/// The distances' density (unnormalised) on interval i of a step function (see
/// [`step_interval`]): the largest channel of T there (T itself for grey media), positive wherever
/// some channel is.
fn step_value(steps: &[(f32, Rgb)], i: usize) -> f32 {
    if i == 0 { 1.0 } else { steps[i - 1].1.max_element() }
}

/// Cumulative ∫ T over the intervals of a step function clipped to [t0, t1].
fn step_areas(steps: &[(f32, Rgb)], t0: f32, t1: f32) -> StepAreas {
    let mut total = 0.0;
    (0..=steps.len())
        .map(|i| {
            let (lo, hi) = step_interval(steps, i, t0, t1);
            total += step_value(steps, i) * (hi - lo).max(0.0);
            total
        })
        .collect()
}

impl Medium {
    /// Feeds what defines the medium to `feed` (see [`crate::scene::Scene::fingerprint`]).
    pub(crate) fn fingerprint(&self, feed: &mut dyn FnMut(&[u8])) {
        match self {
            Medium::Homogeneous(h) => {
                // As the derived Debug printed it before media could emit (fingerprints of
                // scenes without emission stay as they were).
                let (a, s, phase) = (h.sigma_a, h.sigma_s, h.phase);
                let text =
                    format!("Homogeneous {{ sigma_a: {a:?}, sigma_s: {s:?}, phase: {phase:?} }}");
                feed(text.as_bytes());
                if h.emission != Rgb::ZERO {
                    feed(format!("emission {:?}", h.emission).as_bytes());
                }
            }
            Medium::Vdb(v) => v.fingerprint(feed),
        }
    }

    /// Trackings cut at [`tracker::MAX_TRACKING_STEPS`] so far (always 0 for homogeneous media).
    pub fn truncated_trackings(&self) -> u64 {
        match self {
            Medium::Homogeneous(_) => 0,
            Medium::Vdb(v) => v.truncated_trackings(),
        }
    }

    /// Samples a collision along `o + t d`, 0 < t < `t_max` (`t_max` may be infinite).
    #[inline]
    pub fn sample_free_flight(&self, o: Vec3, d: Vec3, t_max: f32, s: &mut Sampler) -> FreeFlight {
        tracked!(self, m => tracker::free_flight(m, o, d, t_max, s))
    }

    /// Transmittance along `o + t d` for 0 < t < `t_max` (an unbiased estimate for grids).
    #[inline]
    pub fn transmittance(&self, o: Vec3, d: Vec3, t_max: f32, s: &mut Sampler) -> Rgb {
        self.transmittance_at_rate(o, d, t_max, 1.0, s)
    }

    /// [`Self::transmittance`], a grid's ratio tracking at `rate` ≥ 1 times its majorants (lower
    /// variance for more steps; [`tracker::transmittance`]).
    #[inline]
    pub fn transmittance_at_rate(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        rate: f32,
        s: &mut Sampler,
    ) -> Rgb {
        tracked!(self, m => tracker::transmittance(m, o, d, t_max, rate, s))
    }

    /// A transmittance function T(0, t) along `o + t d` for t < `t_max`: exact for homogeneous
    /// media, for grids one ratio-tracking estimate at `rate` ≥ 1 times the majorants (1 where
    /// only single scattering uses it; [`BEAM_SEGMENT_RATE`] for the beam estimate).
    #[inline]
    pub fn segment(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        rate: f32,
        s: &mut Sampler,
    ) -> SegmentTransmittance {
        tracked!(self, m => tracker::segment(m, o, d, t_max, rate, s))
    }

    /// The part [t0, t1] of o + t d, 0 ≤ t ≤ `t_max`, where the medium can scatter: all of it
    /// for a homogeneous medium, the grid's extent for a grid; `None` if empty.
    pub fn scattering_extent(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32)> {
        match self {
            Medium::Homogeneous(h) => {
                (t_max > 0.0 && h.sigma_s.max_element() > 0.0).then_some((0.0, t_max))
            }
            Medium::Vdb(v) => v.extent(o, d, t_max),
        }
    }

    /// True if the medium emits light somewhere (a source σ_a L_e that is not zero everywhere).
    pub fn emits(&self) -> bool {
        tracked!(self, m => Tracked::emits(m))
    }

    /// Emitted radiance L_e at `p`: the medium adds σ_a(p) L_e(p) per unit length.
    #[inline]
    pub fn le(&self, p: Vec3) -> Rgb {
        match self {
            Medium::Homogeneous(h) => h.emission,
            Medium::Vdb(v) => v.le(p),
        }
    }

    /// Absorption coefficient at `p`.
    #[inline]
    pub fn sigma_a(&self, p: Vec3) -> Rgb {
        match self {
            Medium::Homogeneous(h) => h.sigma_a,
            Medium::Vdb(v) => v.sigma_a(p),
        }
    }

    /// The emitted radiance reaching `o` along `o + t d`, 0 < t < `t_max`:
    /// ∫ T(0, t) σ_a L_e dt, exact for homogeneous media, an unbiased estimate for grids; zero
    /// (and no random numbers drawn) if the medium does not emit.
    #[inline]
    pub fn emitted(&self, o: Vec3, d: Vec3, t_max: f32, s: &mut Sampler) -> Rgb {
        tracked!(self, m => tracker::emitted(m, o, d, t_max, s))
    }

    /// Scattering coefficient at `p`.
    #[inline]
    pub fn sigma_s(&self, p: Vec3) -> Rgb {
        match self {
            Medium::Homogeneous(h) => h.sigma_s,
            Medium::Vdb(v) => v.sigma_s(p),
        }
    }

    /// The extinction at `p`, averaged over the channels (the combined estimator's weights,
    /// `estimate/mis.rs`).
    #[inline]
    pub fn mean_sigma_t(&self, p: Vec3) -> f32 {
        tracked!(self, m => Tracked::sigma_t(m, p) * crate::math::luminance(m.tint(p)))
    }

    /// The phase function.
    #[inline]
    pub fn phase(&self) -> &HenyeyGreenstein {
        match self {
            Medium::Homogeneous(h) => &h.phase,
            Medium::Vdb(v) => v.phase(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A segment of next to no length has nothing to sample: the distance strategy declines
    /// rather than return infinite densities (whose MIS weights came out NaN: 2 samples in 8.2 M
    /// path-traced on scenes/cumulus.toml), and an ordinary segment still samples finitely.
    #[test]
    fn distances_on_a_vanishing_segment_are_declined() {
        let steps = SegmentTransmittance::Steps(tracker::TransmittanceSteps::new());
        let grey = SegmentTransmittance::Exponential { sigma_t: Rgb::splat(2.0) };
        for tr in [&steps, &grey] {
            assert!(TransmittanceDistance::new(tr, 0.0, 1e-45).is_none());
            let d = TransmittanceDistance::new(tr, 0.0, 1.0).unwrap();
            for u in [0.0, 0.5, 0.999_999] {
                let (t, pdf) = d.sample(u);
                assert!((0.0..=1.0).contains(&t) && pdf.is_finite() && pdf > 0.0, "{t} {pdf}");
            }
        }
    }
}
