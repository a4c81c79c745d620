//! The one tracker: every way haze tracks a ray through a medium, written once for any medium
//! that describes itself ([`Tracked`]): its majorant segments along a ray, its extinction and the
//! extinction's colour at a point, its emission source at a point, and — for a homogeneous
//! medium — that it is constant, where the tracker uses closed forms (the limit of tracking
//! against a majorant equal to the extinction everywhere).
//!
//! Built on the tentative collisions of a ray (a Poisson process at `rate` times the majorants,
//! [`tentative`], with a step cap): delta tracking and spectral delta tracking (free flights),
//! ratio tracking at any rate with Russian roulette (transmittance, and the step function the
//! beam estimate looks up), and the emission estimate. Grids (`vdb/`) give their majorants by a
//! DDA over majorant cells with dense pieces bisected under tighter bounds.

use super::track::FreeFlight;
use crate::math::Rgb;
use crate::rng::Sampler;
use glam::Vec3;

/// Tentative collisions one tracking may draw along one segment: a last guard. Real media never
/// come near it (ratio tracking stops when its estimate reaches zero, delta tracking at its first
/// real collision, and cells whose majorant dwarfs the density along the ray are bisected); it
/// keeps anything still unforeseen from making one iteration take minutes or never end. A
/// tracking that reaches the cap ends as if the segment were opaque (transmittance 0, the free
/// flight absorbed) — biased, so every such event is counted ([`Tracked::cut`]) and reported
/// (the render's `truncatedTrackings`).
pub const MAX_TRACKING_STEPS: u32 = 1 << 18;

/// The emission estimate ([`emitted`]) draws its tentative collisions at this multiple of the
/// majorant: any rate at or above σ_t keeps ratio tracking unbiased, and more points score more
/// of the emission along a ray (in the fire of scenes/fire.toml a ray crosses the flame with
/// about three collisions at the majorant's rate). Measured there (100×100, 4 iterations, 6
/// seeds): per-pixel relative variance in the flame 0.147 at rate 1, 0.045 at 8, for 1.1× the
/// render time. It costs only on segments through emitting grids.
const EMISSION_RATE: f32 = 8.0;

/// Transmittance below which the emission estimate plays Russian roulette.
const EMISSION_ROULETTE: f32 = 0.01;

/// Estimate below which ratio tracking plays Russian roulette ([`roulette`]). At a rate above 1
/// no factor 1 − σ_t/(rate μ̄) is zero, so without it a walk through a thick cloud would go on to
/// the far side carrying a negligible estimate (at rate 4 about 4 steps per mean free path).
const TRACKING_ROULETTE: f32 = 0.05;

/// A transmittance step function along one segment: `(t_k, T after t_k)`.
pub type TransmittanceSteps = smallvec::SmallVec<[(f32, Rgb); 32]>;

/// T(0, t) from a step function.
#[inline]
pub fn steps_at(steps: &[(f32, Rgb)], t: f32) -> Rgb {
    let n = steps.partition_point(|&(tk, _)| tk < t);
    if n == 0 { Rgb::ONE } else { steps[n - 1].1 }
}

/// Transmittance along one ray segment, T(0, t), for many lookups (the beam estimate asks it for
/// every photon on the segment).
#[derive(Clone, Debug)]
// One per eye segment, on the stack, never stored in bulk: the step function's 32 inline steps
// (no allocation on most segments) are worth the size.
#[allow(clippy::large_enum_variant)]
pub enum SegmentTransmittance {
    /// One ratio-tracking estimate kept as a step function (heterogeneous media).
    Steps(TransmittanceSteps),
    /// exp(−σ_t t).
    Exponential {
        /// Extinction.
        sigma_t: Rgb,
    },
    /// exp(−σ_t t) with the same σ_t in every channel: one exponential instead of three.
    Grey {
        /// Extinction.
        sigma_t: f32,
    },
}

impl SegmentTransmittance {
    /// T(0, t).
    #[inline]
    pub fn at(&self, t: f32) -> Rgb {
        match self {
            // A zero coefficient transmits fully even over an infinite distance (not 0·∞ = NaN).
            SegmentTransmittance::Exponential { sigma_t } => {
                Rgb::select(sigma_t.cmpgt(Rgb::ZERO), (-*sigma_t * t).exp(), Rgb::ONE)
            }
            SegmentTransmittance::Grey { sigma_t } => {
                Rgb::splat(if *sigma_t > 0.0 { (-sigma_t * t).exp() } else { 1.0 })
            }
            SegmentTransmittance::Steps(steps) => steps_at(steps, t),
        }
    }

    /// The distance past which T(0, t) is at most e^{−`depth`} in every channel: `depth` over
    /// the smallest extinction of an exponential (infinite where a channel has none); for a step
    /// function, where its last step falls to zero (the walk's Russian roulette ended it), past
    /// which it is zero, and infinite if it never does.
    pub fn reach(&self, depth: f32) -> f32 {
        let over = |sigma: f32| if sigma > 0.0 { depth / sigma } else { f32::INFINITY };
        match self {
            SegmentTransmittance::Exponential { sigma_t } => over(sigma_t.min_element()),
            SegmentTransmittance::Grey { sigma_t } => over(*sigma_t),
            SegmentTransmittance::Steps(steps) => match steps.last() {
                Some(&(t, v)) if v.max_element() <= 0.0 => t,
                _ => f32::INFINITY,
            },
        }
    }
}

/// A medium whose coefficients are the same everywhere, for the closed forms.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Constant {
    /// Extinction per channel.
    pub sigma_t: Rgb,
    /// The source σ_a L_e per channel.
    pub source: Rgb,
}

/// What a medium tells the tracker about itself.
pub(crate) trait Tracked {
    /// Its coefficients, if they are the same everywhere (the tracker then uses closed forms).
    fn constant(&self) -> Option<Constant>;

    /// Calls `f(μ̄, a, b)` in order along o + t d for pieces [a, b) of [0, `t_max`), μ̄ a bound
    /// over the piece on every channel's extinction, max_c [`Self::tint`]_c · [`Self::sigma_t`]
    /// (so on `sigma_t` itself wherever the medium is not [`Self::coloured`]), sized for
    /// tentative collisions at `rate` times μ̄ (pieces where μ̄ is zero may be left out); stops
    /// when `f` returns `false`.
    fn majorants(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        rate: f32,
        f: impl FnMut(f32, f32, f32) -> bool,
    );

    /// The tracked extinction at `p`: the one the majorants bound (the largest channel's, for
    /// a coloured extinction).
    fn sigma_t(&self, p: Vec3) -> f32;

    /// True if the extinction differs between channels somewhere.
    fn coloured(&self) -> bool;

    /// σ_t per channel at `p` over [`Self::sigma_t`] there: each in [0, 1].
    fn tint(&self, p: Vec3) -> Rgb;

    /// At `p`: the tint ([`Self::tint`]), σ_a per channel over [`Self::sigma_t`], and the
    /// emitted radiance L_e.
    fn emission_at(&self, p: Vec3) -> (Rgb, Rgb, Rgb);

    /// True if the medium can emit anywhere.
    fn emits(&self) -> bool;

    /// Counts a tracking cut at [`MAX_TRACKING_STEPS`].
    fn cut(&self);
}

impl Constant {
    /// exp(−σ_t t) (1 in a channel without extinction, even over an infinite distance).
    #[inline]
    pub fn transmittance(&self, t: f32) -> Rgb {
        if t.is_infinite() {
            return Rgb::select(self.sigma_t.cmpgt(Vec3::ZERO), Rgb::ZERO, Rgb::ONE);
        }
        (-self.sigma_t * t).exp()
    }

    /// ∫₀^t_max T(0, t) σ_a L_e dt over a segment of length `t_max` (may be infinite):
    /// σ_a L_e (1 − e^{−σ_t t_max}) / σ_t per channel, exactly.
    pub fn emitted(&self, t_max: f32) -> Rgb {
        let sigma_t = self.sigma_t;
        // σ_a ≤ σ_t, so a channel without extinction has no source either.
        let absorbed = -(-sigma_t * t_max).map(f32::exp_m1);
        Rgb::select(sigma_t.cmpgt(Rgb::ZERO), self.source * absorbed / sigma_t, Rgb::ZERO)
    }

    /// A collision before `t_max` (may be infinite) from uniforms `u_channel`, `u`. With
    /// chromatic σ_t a channel is picked uniformly and its exponential sampled; the distance's
    /// pdf is then the average over channels (the balance heuristic, Miller et al. 2019 §4;
    /// pbrt-v4 §14.2.2), so no channel's weight blows up:
    ///
    ///   p(t) = (1/3) Σ_c σ_t,c e^{−σ_t,c t},  P(no collision before t_max) = (1/3) Σ_c e^{−σ_t,c t_max}.
    pub fn free_flight(&self, t_max: f32, u_channel: f32, u: f32) -> FreeFlight {
        let sigma_t = self.sigma_t;
        let c = ((u_channel * 3.0) as usize).min(2);
        let s = sigma_t[c];
        let t = if s > 0.0 { -(1.0 - u).ln() / s } else { f32::INFINITY };
        if t < t_max {
            let tr = (-sigma_t * t).exp();
            let pdf = (sigma_t * tr).element_sum() / 3.0;
            FreeFlight { t, scattered: true, weight: tr / pdf }
        } else {
            let tr = self.transmittance(t_max);
            let p_pass = tr.element_sum() / 3.0;
            let weight = if p_pass > 0.0 { tr / p_pass } else { Rgb::ZERO };
            FreeFlight { t: t_max, scattered: false, weight }
        }
    }

    /// The density per unit length with which [`Self::free_flight`] collides at distance `t`
    /// (the reverse density of a flight of length `t`: a constant medium is the same both ways):
    /// (1/3) Σ_c σ_t,c e^{−σ_t,c t}.
    pub fn collision_pdf(&self, t: f32) -> f32 {
        (self.sigma_t * self.transmittance(t)).element_sum() / 3.0
    }
}

/// The smallest f32 above `t ≥ 0` (`f32::next_up`, which needs Rust 1.86).
fn next_up(t: f32) -> f32 {
    if t <= 0.0 { f32::from_bits(1) } else { f32::from_bits(t.to_bits() + 1) }
}

/// Russian roulette on a ratio-tracking estimate whose largest channel is `m`: below
/// [`TRACKING_ROULETTE`] the walk goes on with probability m / [`TRACKING_ROULETTE`], its
/// estimate divided by that probability, and otherwise ends at zero. Returns the factor to
/// multiply the estimate by (1 above the threshold). Every later value of the estimate keeps its
/// expectation, so a step function's every prefix stays unbiased.
#[inline]
fn roulette(m: f32, s: &mut Sampler) -> f32 {
    if m >= TRACKING_ROULETTE || m <= 0.0 {
        return 1.0;
    }
    let survive = m / TRACKING_ROULETTE;
    if s.next_f32() < survive { 1.0 / survive } else { 0.0 }
}

/// Draws the tentative collisions of o + t d, t ∈ [0, t_max), at `rate` times the majorants of
/// `m` (pieces of zero majorant cost nothing), calling `f(t, σ_t(t), rate·μ̄, sampler)` at each;
/// `f` returns `false` to stop. Returns `false` if the walk was cut at [`MAX_TRACKING_STEPS`]
/// (counted).
pub(crate) fn tentative<M: Tracked>(
    m: &M,
    o: Vec3,
    d: Vec3,
    t_max: f32,
    rate: f32,
    s: &mut Sampler,
    mut f: impl FnMut(f32, f32, f32, &mut Sampler) -> bool,
) -> bool {
    let mut steps = 0u32;
    let mut cut = false;
    m.majorants(o, d, t_max, rate, |mu, a, b| {
        let mu = mu * rate;
        let mut t = a;
        loop {
            steps += 1;
            if steps > MAX_TRACKING_STEPS {
                cut = true;
                return false;
            }
            // A step below t's precision (μ̄ beyond 10²⁰ or so) still moves on by one ulp:
            // otherwise t would stay where it is, on a point of zero density, until the cap.
            let next = t - (1.0 - s.next_f32()).ln() / mu;
            t = if next > t { next } else { next_up(t) };
            if t >= b {
                return true;
            }
            if !f(t, m.sigma_t(o + d * t), mu, s) {
                return false;
            }
        }
    });
    crate::work::steps(steps.into());
    if cut {
        m.cut();
    }
    !cut
}

/// A collision along o + t d before `t_max` (may be infinite): closed form for a constant
/// medium; delta tracking (pdf σ_t(t) T(0, t), weight 1/σ_t(t); or none, weight 1) otherwise,
/// spectral delta tracking where the extinction is coloured ([`spectral_free_flight_with`]).
pub(crate) fn free_flight<M: Tracked>(
    m: &M,
    o: Vec3,
    d: Vec3,
    t_max: f32,
    s: &mut Sampler,
) -> FreeFlight {
    free_flight_with(m, o, d, t_max, s, |_| {})
}

/// [`free_flight`], calling `null(t)` at each null collision: with the flight's end, what
/// [`ln_flight_pdf`] takes.
pub(crate) fn free_flight_with<M: Tracked>(
    m: &M,
    o: Vec3,
    d: Vec3,
    t_max: f32,
    s: &mut Sampler,
    null: impl FnMut(f32),
) -> FreeFlight {
    if let Some(c) = m.constant() {
        return c.free_flight(t_max, s.next_f32(), s.next_f32());
    }
    if m.coloured() {
        return spectral_free_flight_with(m, o, d, t_max, s, null);
    }
    delta_tracking_with(m, o, d, t_max, s, null)
}

/// Delta tracking against the majorants (Woodcock et al. 1965), calling `null(t)` at each null
/// collision (for [`ln_flight_pdf`]).
pub(crate) fn delta_tracking_with<M: Tracked>(
    m: &M,
    o: Vec3,
    d: Vec3,
    t_max: f32,
    s: &mut Sampler,
    mut null: impl FnMut(f32),
) -> FreeFlight {
    let mut hit: Option<(f32, f32)> = None;
    let mut last = 0.0;
    let complete = tentative(m, o, d, t_max, 1.0, s, |t, sigma_t, mu, s| {
        last = t;
        if s.next_f32() * mu < sigma_t {
            hit = Some((t, sigma_t));
            return false;
        }
        null(t);
        true
    });
    if !complete {
        // Cut: absorbed where the walk stopped.
        return FreeFlight { t: last.min(t_max), scattered: true, weight: Rgb::ZERO };
    }
    match hit {
        Some((t, sigma_t)) => FreeFlight { t, scattered: true, weight: Rgb::splat(1.0 / sigma_t) },
        None => FreeFlight { t: t_max, scattered: false, weight: Rgb::ONE },
    }
}

/// Spectral delta tracking for coloured extinction, with the balance heuristic over the three
/// channels (the null-scattering path integral of Miller, Georgiev & Jarosz 2019): a hero channel
/// h, chosen uniformly, decides at each tentative collision (rate μ̄, the largest channel's
/// majorant) whether it is real, with probability q_h = σ_t,h/μ̄; every channel's probability of
/// the decisions taken is tracked, A_c = Π (1 − q_c) over the null collisions. The weight is the
/// channel's path contribution over the hero-averaged path density: A_c / (μ̄ · mean_h A_h q_h)
/// at a real collision, A_c / mean_h A_h if the ray passes. Unbiased in every channel, and
/// bounded: times σ_t,c it is at most 3 at a collision, and at most 3 when passing — no
/// channel's throughput blows up.
/// `null(t)` is called at each null collision.
pub(crate) fn spectral_free_flight_with<M: Tracked>(
    m: &M,
    o: Vec3,
    d: Vec3,
    t_max: f32,
    s: &mut Sampler,
    mut null: impl FnMut(f32),
) -> FreeFlight {
    let h = ((s.next_f32() * 3.0) as usize).min(2);
    let mut a = Rgb::ONE;
    let mut hit: Option<(f32, Rgb)> = None;
    let mut last = 0.0;
    let complete = tentative(m, o, d, t_max, 1.0, s, |t, sigma_t, mu, s| {
        last = t;
        // At most 1: trilinear weights may sum to a few ulps over 1 where the density equals
        // its majorant.
        let q = (m.tint(o + d * t) * (sigma_t / mu)).min(Rgb::ONE);
        if s.next_f32() < q[h] {
            hit = Some((t, a / (mu * (a * q).element_sum() / 3.0)));
            return false;
        }
        null(t);
        a *= Rgb::ONE - q;
        // Only ratios of the A_c count: rescale before they underflow (a long walk through
        // dense smoke multiplies hundreds of factors), which would make 0/0.
        let m = a.max_element();
        if m < 1e-20 && m > 0.0 {
            a /= m;
        }
        true
    });
    if !complete {
        return FreeFlight { t: last.min(t_max), scattered: true, weight: Rgb::ZERO };
    }
    match hit {
        Some((t, weight)) => FreeFlight { t, scattered: true, weight },
        None => {
            let mean = a.element_sum() / 3.0;
            let weight = if mean > 0.0 { a / mean } else { Rgb::ZERO };
            FreeFlight { t: t_max, scattered: false, weight }
        }
    }
}

/// The density of a free flight along o + t d, 0 ≤ t < `t_max`, as its natural logarithm: in the
/// null-scattering path integral (Miller, Georgiev & Jarosz 2019) the flight is its tentative
/// collisions, null at the distances `nulls` (in order) and real at `end` (`None`: it passed
/// `t_max`), and its density is the product of majorant-based probabilities, exactly computable:
///
///   p = (1/C) Σ_c e^{−∫₀^{t_e} μ̄} · Π_j (μ̄(t_j) − σ_t,c(t_j)) · [σ_t,c(t_e) at a collision]
///
/// with t_e the end (or `t_max`), μ̄ the medium's majorants for this ray and segment (rate 1),
/// and the average over the C = 3 channels where the extinction is coloured (the hero channel
/// of spectral tracking, chosen uniformly), C = 1 where it is grey. A constant medium has no null
/// collisions and gives its closed form ([`Constant::free_flight`]'s densities). This is the
/// density of the decision [`free_flight`] takes along that ray; the reverse decision, a flight
/// from the end back towards the start, is this function on the reversed ray: origin at the end,
/// its nulls at t_e − t_j in reverse order, its `t_max` the distance to the surface behind the
/// start (the majorants of a grid depend on the segment), a collision at t_e if the start was a
/// medium vertex. Invalid input — nulls out of order or not before the end, an end not before
/// `t_max` or where no majorant covers it — has density 0.
/// −∞ for a flight that cannot happen (a null where the majorant is zero, a real collision where
/// σ_t is).
#[allow(dead_code)] // for the combined estimator's weights; read by the tests now
pub(crate) fn ln_flight_pdf<M: Tracked>(
    m: &M,
    o: Vec3,
    d: Vec3,
    t_max: f32,
    nulls: &[f32],
    end: Option<f32>,
) -> f64 {
    let t_end = end.unwrap_or(t_max);
    let ordered = nulls.windows(2).all(|w| w[0] < w[1]);
    let before_end = nulls.last().is_none_or(|&t| t < t_end);
    if !ordered || !before_end || end.is_some_and(|t| t >= t_max || t.is_nan()) {
        return f64::NEG_INFINITY;
    }
    if let Some(c) = m.constant() {
        if !nulls.is_empty() {
            return f64::NEG_INFINITY;
        }
        let pdf = match end {
            Some(t) => c.collision_pdf(t),
            None => c.transmittance(t_max).element_sum() / 3.0,
        };
        return (pdf as f64).ln();
    }
    // Per channel: Σ ln(μ̄ − σ_t,c) over the nulls; ∫ μ̄ up to the end; whether a piece of
    // non-zero majorant holds the end of a collision.
    let mut ln = [0.0f64; 3];
    let mut integral = 0.0f64;
    let mut k = 0;
    let mut covered = end.is_none();
    m.majorants(o, d, t_max, 1.0, |mu, a, b| {
        let hi = b.min(t_end);
        if hi > a {
            integral += mu as f64 * (hi - a) as f64;
        }
        covered |= a < t_end && t_end < b;
        while k < nulls.len() && nulls[k] < b {
            let t = nulls[k];
            let p = o + d * t;
            let sigma = m.tint(p) * m.sigma_t(p);
            for (c, l) in ln.iter_mut().enumerate() {
                let factor = if t >= a { (mu - sigma[c]).max(0.0) } else { 0.0 };
                *l += (factor as f64).ln();
            }
            k += 1;
        }
        b < t_end
    });
    if k < nulls.len() || !covered {
        return f64::NEG_INFINITY;
    }
    if let Some(t) = end {
        let p = o + d * t;
        let sigma = m.tint(p) * m.sigma_t(p);
        for (c, l) in ln.iter_mut().enumerate() {
            *l += (sigma[c] as f64).ln();
        }
    }
    let channels = if m.coloured() { 3 } else { 1 };
    let top = ln[..channels].iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if top == f64::NEG_INFINITY {
        return top;
    }
    let mean = ln[..channels].iter().map(|l| (l - top).exp()).sum::<f64>() / channels as f64;
    top + mean.ln() - integral
}

/// The transmittance along o + t d over [0, t_max): exact for a constant medium, otherwise a
/// ratio-tracking estimate (per channel with coloured extinction: every factor 1 − σ_t,c/μ̄ lies
/// in [0, 1]) with tentative collisions at `rate` ≥ 1 times the majorants: a higher rate puts
/// each factor 1 − σ_t/(rate μ̄) nearer 1, for a lower variance (for a homogeneous piece of
/// optical depth τ the relative variance is e^{τ/rate} − 1: at rate 1 where the majorant is
/// tight the estimate is all but binary) at `rate` times the steps.
pub(crate) fn transmittance<M: Tracked>(
    m: &M,
    o: Vec3,
    d: Vec3,
    t_max: f32,
    rate: f32,
    s: &mut Sampler,
) -> Rgb {
    if let Some(c) = m.constant() {
        return c.transmittance(t_max);
    }
    ratio_tracking(m, o, d, t_max, rate, s, |_, _| {}).unwrap_or(Rgb::ZERO)
}

/// One ratio-tracking run over [0, t_max) at `rate` times the majorants, kept as a step function
/// (see the module docs of `vdb`; a constant medium's transmittance needs none, it is exact).
pub(crate) fn transmittance_steps<M: Tracked>(
    m: &M,
    o: Vec3,
    d: Vec3,
    t_max: f32,
    rate: f32,
    s: &mut Sampler,
) -> TransmittanceSteps {
    let mut steps = TransmittanceSteps::new();
    let complete = ratio_tracking(m, o, d, t_max, rate, s, |t, tr| steps.push((t, tr)));
    if complete.is_none() {
        // Opaque from where the walk stopped.
        let last = steps.last().map_or(0.0, |&(t, _)| t);
        steps.push((last, Rgb::ZERO));
    }
    steps
}

/// The one ratio-tracking walk (Novák et al. 2014) behind [`transmittance`] and
/// [`transmittance_steps`]: tentative collisions at `rate` times the majorants, each multiplying
/// the running transmittance by 1 − σ_t/μ̄ (per channel where the extinction is coloured, in one
/// channel otherwise) and then by the Russian roulette's factor ([`roulette`]); `step(t, T)` sees
/// the transmittance after each. Returns the final transmittance, or `None` if the walk was cut
/// at the step cap.
pub(crate) fn ratio_tracking<M: Tracked>(
    m: &M,
    o: Vec3,
    d: Vec3,
    t_max: f32,
    rate: f32,
    s: &mut Sampler,
    mut step: impl FnMut(f32, Rgb),
) -> Option<Rgb> {
    if m.coloured() {
        let mut tr = Rgb::ONE;
        let complete = tentative(m, o, d, t_max, rate, s, |t, sigma_t, mu, s| {
            let tint = m.tint(o + d * t);
            tr = (tr * (Rgb::ONE - tint * (sigma_t / mu))).max(Rgb::ZERO);
            tr *= roulette(tr.max_element(), s);
            step(t, tr);
            tr.max_element() > 0.0
        });
        return complete.then_some(tr);
    }
    let mut tr = 1.0f32;
    let complete = tentative(m, o, d, t_max, rate, s, |t, sigma_t, mu, s| {
        tr = (tr * (1.0 - sigma_t / mu)).max(0.0);
        tr *= roulette(tr, s);
        step(t, Rgb::splat(tr));
        tr > 0.0
    });
    complete.then_some(Rgb::splat(tr.max(0.0)))
}

/// The emitted radiance reaching `o` along o + t d, 0 < t < `t_max`: ∫ T(0, t) σ_a L_e dt, exact
/// for a constant medium; otherwise an unbiased estimate by ratio tracking that scores σ_a L_e / μ̄
/// times its running transmittance at every tentative collision (the tentative collisions are a
/// Poisson process of rate μ̄, so the expected sum is ∫ μ̄ T σ_a L_e / μ̄ dt). A walk cut at the
/// step cap keeps what it scored (counted, as every cut). Zero, with nothing drawn, for a medium
/// that does not emit.
pub(crate) fn emitted<M: Tracked>(m: &M, o: Vec3, d: Vec3, t_max: f32, s: &mut Sampler) -> Rgb {
    if !m.emits() {
        return Rgb::ZERO;
    }
    if let Some(c) = m.constant() {
        return c.emitted(t_max);
    }
    emission_tracking(m, o, d, t_max, s)
}

/// The emission estimate of [`emitted`] by tracking, for any medium.
fn emission_tracking<M: Tracked>(m: &M, o: Vec3, d: Vec3, t_max: f32, s: &mut Sampler) -> Rgb {
    let mut tr = Rgb::ONE;
    let mut sum = Rgb::ZERO;
    tentative(m, o, d, t_max, EMISSION_RATE, s, |t, sigma_t, mu, s| {
        if sigma_t > 0.0 {
            let (tint, share, le) = m.emission_at(o + d * t);
            sum += share * (tr * (sigma_t / mu)) * le;
            tr = (tr * (Rgb::ONE - tint * (sigma_t / mu))).max(Rgb::ZERO);
            // Russian roulette once the transmittance is small (unbiased: survivors are divided
            // by their chance), so that a walk through thick emitting smoke ends long before its
            // factors of 7/8 at the raised rate underflow.
            let m = tr.max_element();
            if m > 0.0 && m < EMISSION_ROULETTE {
                let q = m / EMISSION_ROULETTE;
                if s.next_f32() >= q {
                    return false;
                }
                tr /= q;
            }
        }
        tr.max_element() > 0.0
    });
    sum
}

/// A transmittance function T(0, t) along o + t d for t < `t_max`: exact for a constant medium
/// (one exponential where σ_t is grey), otherwise one ratio-tracking estimate at `rate` ≥ 1 times
/// the majorants kept as a step function.
pub(crate) fn segment<M: Tracked>(
    m: &M,
    o: Vec3,
    d: Vec3,
    t_max: f32,
    rate: f32,
    s: &mut Sampler,
) -> SegmentTransmittance {
    match m.constant() {
        Some(Constant { sigma_t, .. }) if sigma_t.x == sigma_t.y && sigma_t.y == sigma_t.z => {
            SegmentTransmittance::Grey { sigma_t: sigma_t.x }
        }
        Some(Constant { sigma_t, .. }) => SegmentTransmittance::Exponential { sigma_t },
        None => SegmentTransmittance::Steps(transmittance_steps(m, o, d, t_max, rate, s)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::homogeneous::Homogeneous;
    use crate::medium::phase::HenyeyGreenstein;
    use crate::testing::{ChiSquare, Domain, Sample, assert_agrees, batch_means};
    use glam::DVec2;

    fn medium(sigma_a: Rgb, sigma_s: Rgb, emission: Rgb) -> Homogeneous {
        Homogeneous { sigma_a, sigma_s, phase: HenyeyGreenstein { g: 0.0 }, emission }
    }

    /// The tracking algorithms, run on a homogeneous medium as on any other (its one majorant
    /// segment, at a majorant equal to the largest channel's extinction) instead of by its closed
    /// forms, agree with those closed forms: delta tracking's distances follow σ_t e^{−σ_t t}
    /// (chi-square, the failure bin P = e^{−σ_t t_max}) with weight 1/σ_t; ratio tracking at rates
    /// 1 and 4, its step function at t/2, spectral delta tracking's weights and the emission
    /// estimate are unbiased in every channel of a coloured extinction (t-tests on batch means).
    #[test]
    fn tracking_a_constant_medium_agrees_with_its_closed_forms() {
        let (o, d, len) = (Vec3::ZERO, Vec3::X, 1.2f32);
        let grey = medium(Rgb::splat(0.5), Rgb::splat(1.0), Rgb::ZERO);
        let sigma = 1.5f64;
        let mut test = ChiSquare::new("delta tracking, constant medium", Domain::Square, 1);
        test.bins = [32, 1];
        test.run(
            |s| {
                let f = delta_tracking_with(&grey, o, d, len, s, |_| {});
                let want = if f.scattered { 1.0 / sigma as f32 } else { 1.0 };
                assert!((f.weight.x - want).abs() < 1e-6, "{f:?}");
                f.scattered.then(|| Sample::Point(DVec2::new(f.t as f64 / len as f64, 0.5)))
            },
            |p| {
                let t = p.point().x * len as f64;
                len as f64 * sigma * (-sigma * t).exp()
            },
        );
        let coloured = medium(Rgb::new(0.2, 0.5, 1.0), Rgb::new(0.3, 1.0, 2.0), Rgb::splat(2.0));
        let c = coloured.constant().unwrap();
        assert!(coloured.coloured() && !grey.coloured());
        let tr = c.transmittance(len);
        let half = c.transmittance(len / 2.0);
        let emitted = c.emitted(len);
        for k in 0..3 {
            let mean = |seed, f: &dyn Fn(&mut Sampler) -> Rgb| {
                batch_means(20, 4000, seed, |s| f(s)[k] as f64)
            };
            for (j, rate) in [1.0f32, 4.0].into_iter().enumerate() {
                let ratio = mean(10 + j as u64, &|s| {
                    ratio_tracking(&coloured, o, d, len, rate, s, |_, _| {}).unwrap()
                });
                assert_agrees(
                    &format!("ratio tracking at rate {rate}, channel {k}"),
                    &ratio,
                    tr[k] as f64,
                    0.0,
                );
                let steps = mean(20 + j as u64, &|s| {
                    steps_at(&transmittance_steps(&coloured, o, d, len, rate, s), len / 2.0)
                });
                assert_agrees(
                    &format!("step function at rate {rate}, channel {k}"),
                    &steps,
                    half[k] as f64,
                    0.0,
                );
            }
            let sigma_t = c.sigma_t[k];
            let passes = mean(30, &|s| {
                let f = spectral_free_flight_with(&coloured, o, d, len, s, |_| {});
                if f.scattered { Rgb::ZERO } else { f.weight }
            });
            assert_agrees(
                &format!("spectral tracking passes, channel {k}"),
                &passes,
                tr[k] as f64,
                0.0,
            );
            let hits = mean(31, &|s| {
                let f = spectral_free_flight_with(&coloured, o, d, len, s, |_| {});
                if f.scattered { f.weight * sigma_t } else { Rgb::ZERO }
            });
            let collided = 1.0 - tr[k] as f64;
            assert_agrees(
                &format!("spectral tracking collides, channel {k}"),
                &hits,
                collided,
                0.0,
            );
            let emission = mean(40, &|s| emission_tracking(&coloured, o, d, len, s));
            assert_agrees(&format!("emission, channel {k}"), &emission, emitted[k] as f64, 0.0);
        }
    }
}
