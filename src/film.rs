//! Accumulation of iteration images: exact fixed-point sums and the number of iterations, so the
//! image is the mean of the iterations (Knaus & Zwicker 2011, eq. 4). A sum of squares gives each
//! pixel's sample variance over the iterations, from which references carry an estimate of their
//! own noise.
//!
//! **Exact sums.** Every iteration value (an f32) is rounded once to the nearest multiple of
//! 2⁻⁶⁰ (≈ 8.7 · 10⁻¹⁹) and added as a 128-bit integer; its square (exact in f64: 24 + 24
//! mantissa bits) likewise. Integer addition is associative, so the sums over a set of iterations
//! do not depend on the order or grouping in which they were added: a render split into ranges —
//! on other threads, processes or machines — and merged ([`Film::merge`]) has exactly the sums of
//! one render of all the iterations, and so a bit-identical image. (Floating-point sums would
//! differ in their last bits with the grouping.) The range is ±2⁶⁷ ≈ 1.5 · 10²⁰ per sum; a value
//! that would leave it saturates and is counted ([`Film::saturated`]).
//!
//! **Kernel bias.** A photon-mapping film also sums, in the same way, each iteration's estimate
//! of its kernel bias (2 (L_r − L_{r/√2}), docs/theory.md), so the bias of the mean image and that
//! estimate's own variance survive splitting, merging and resuming exactly.

use crate::math::Rgb;
use rayon::prelude::*;

/// Pixels per parallel work item when an image is added to the sums.
const ADD_CHUNK: usize = 4096;

/// Fixed-point scale: sums hold value · 2⁶⁰.
const SCALE: f64 = (1u64 << 60) as f64;

/// An image's estimated relative error from its noise ([`Film::error_estimate`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorEstimate {
    /// Estimated relative RMSE: √(mean variance of the mean) / mean value.
    pub relative_rmse: f64,
    /// Its upper confidence limit at `confidence`.
    pub upper: f64,
    /// The confidence of `upper`.
    pub confidence: f64,
}

/// Exact sums of values and of their squares, per pixel and channel.
#[derive(Clone, Debug, PartialEq)]
struct Sums {
    sum: Vec<[i128; 3]>,
    sum_sq: Vec<[i128; 3]>,
}

impl Sums {
    /// Zeros written ([`crate::buffers::filled`]), since [`Self::add`] reads each sum before
    /// writing it (`vec!`'s zeroed pages cost a TLB shootdown each: 12 000 at 640×400).
    fn new(n: usize) -> Self {
        Sums { sum: crate::buffers::filled(n, [0; 3]), sum_sq: crate::buffers::filled(n, [0; 3]) }
    }

    /// Adds one image; returns the number of values saturated. In parallel over runs of
    /// [`ADD_CHUNK`] pixels (each sum is exact, so the result does not depend on the split).
    fn add(&mut self, image: &[Rgb]) -> u64 {
        debug_assert_eq!(image.len(), self.sum.len());
        let put = |acc: &mut i128, v: f64| {
            let (x, bad) = match fixed(v) {
                Some(x) => acc.overflowing_add(x),
                None => (0, true),
            };
            if bad {
                *acc = if v.is_sign_negative() { i128::MIN } else { i128::MAX };
            } else {
                *acc = x;
            }
            bad as u64
        };
        // Runs handed out one at a time to whichever thread is free (`par_bridge`; see
        // `integrator::frame::render_pixels_with`).
        let sums = self.sum.chunks_mut(ADD_CHUNK).zip(self.sum_sq.chunks_mut(ADD_CHUNK));
        sums.zip(image.chunks(ADD_CHUNK))
            .par_bridge()
            .map(|((s, q), image)| {
                let mut saturated = 0;
                for ((s, q), p) in s.iter_mut().zip(q).zip(image) {
                    for c in 0..3 {
                        let v = p[c] as f64;
                        saturated += put(&mut s[c], v) + put(&mut q[c], v * v);
                    }
                }
                saturated
            })
            .sum()
    }

    /// Adds another's sums; returns the number of sums saturated.
    fn merge(&mut self, other: &Sums) -> u64 {
        let mut saturated = 0;
        let mut add = |a: &mut i128, b: i128| {
            *a = a.checked_add(b).unwrap_or_else(|| {
                saturated += 1;
                a.saturating_add(b)
            })
        };
        for (s, o) in self.sum.iter_mut().zip(&other.sum) {
            (0..3).for_each(|c| add(&mut s[c], o[c]));
        }
        for (s, o) in self.sum_sq.iter_mut().zip(&other.sum_sq) {
            (0..3).for_each(|c| add(&mut s[c], o[c]));
        }
        saturated
    }

    /// The mean of `n` values.
    fn mean(&self, n: u64) -> Vec<[f32; 3]> {
        let inv = if n == 0 { 0.0 } else { 1.0 / n as f64 };
        self.sum.par_iter().map(|s| s.map(|x| (float(x) / SCALE * inv) as f32)).collect()
    }

    /// The sample variance of `n` values over n (zero below two).
    fn variance_of_mean(&self, n: u64) -> Vec<[f32; 3]> {
        if n < 2 {
            return vec![[0.0; 3]; self.sum.len()];
        }
        let n = n as f64;
        self.sum
            .par_iter()
            .zip(&self.sum_sq)
            .map(|(s, q)| {
                let mut out = [0.0f32; 3];
                for c in 0..3 {
                    let (s, q) = (float(s[c]) / SCALE, float(q[c]) / SCALE);
                    let var = ((q - s * s / n) / (n - 1.0)).max(0.0);
                    out[c] = (var / n) as f32;
                }
                out
            })
            .collect()
    }

    /// Sums whose mean after `n` values is `image` and whose variance is zero.
    fn replace(&mut self, image: &[Rgb], n: u64) {
        let n = n as f64;
        for ((s, q), p) in self.sum.iter_mut().zip(&mut self.sum_sq).zip(image) {
            for c in 0..3 {
                let total = p[c] as f64 * n;
                s[c] = fixed(total).unwrap_or(0);
                q[c] = fixed(total * total / n).unwrap_or(0);
            }
        }
    }
}

/// The accumulated render: the sums of the iteration images and, for photon mapping, of their
/// kernel-bias estimates (docs/theory.md, "The kernel bias of each pixel").
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    width: u32,
    height: u32,
    value: Sums,
    bias: Option<Sums>,
    iterations: u64,
    saturated: u64,
}

/// `v` in fixed point (rounded to the nearest multiple of 2⁻⁶⁰); `None` if out of range.
#[inline]
fn fixed(v: f64) -> Option<i128> {
    let x = (v * SCALE).round(); // scaling by a power of two is exact
    // Most values are below 8 (2⁶³ in fixed point): the hardware's conversion to i64 gives the
    // same integer as the far slower one to i128.
    if x.abs() < 2f64.powi(63) {
        return Some(x as i64 as i128);
    }
    (x.is_finite() && x.abs() < 2f64.powi(126)).then_some(x as i128)
}

/// `x` as the nearest f64, as `x as f64` gives it, by the hardware's conversion of 64 bits
/// rather than the library routine `as` calls for 128 (the image of the cumulus's 640×400
/// photon-mapping film, four layers, took 33–35 ms on one thread with it, 22–23 ms with this).
/// A value beyond 64 bits keeps its top 64, the bits below folded into the lowest of them
/// (rounding to odd: with 11 bits to spare beyond f64's 53, the one rounding that follows is the
/// exact value's), and is scaled back by a power of two.
#[inline]
fn float(x: i128) -> f64 {
    if let Ok(x) = i64::try_from(x) {
        return x as f64;
    }
    let m = x.unsigned_abs(); // at least 2⁶³: 64 to 128 bits
    let shift = 64 - m.leading_zeros();
    let below = m & ((1u128 << shift) - 1);
    let top = (m >> shift) as u64 | (below != 0) as u64;
    let scale = f64::from_bits(u64::from(1023 + shift) << 52);
    let f = top as f64 * scale;
    if x < 0 { -f } else { f }
}

impl Film {
    /// An empty film (without kernel-bias sums: the path tracer's).
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self { width, height, value: Sums::new(n), bias: None, iterations: 0, saturated: 0 }
    }

    /// An empty film that also sums the iterations' kernel-bias estimates (photon mapping's).
    pub fn with_bias(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self { bias: Some(Sums::new(n)), ..Self::new(width, height) }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Iterations accumulated.
    pub fn iterations(&self) -> u64 {
        self.iterations
    }

    /// Values that fell outside the fixed-point range and were saturated (0 in any sane render).
    pub fn saturated(&self) -> u64 {
        self.saturated
    }

    /// True if the film sums kernel-bias estimates.
    pub fn has_bias(&self) -> bool {
        self.bias.is_some()
    }

    /// Adds one finished iteration image (row-major, top row first); its kernel bias, if the
    /// film sums one, is taken as zero (which leaves the bias sums as they are).
    pub fn add(&mut self, image: &[Rgb]) {
        self.saturated += self.value.add(image);
        self.iterations += 1;
    }

    /// Adds one finished iteration image and the estimate of its kernel bias (ignored by a film
    /// without bias sums).
    pub fn add_with_bias(&mut self, image: &[Rgb], bias: &[Rgb]) {
        debug_assert_eq!(image.len(), bias.len());
        if let Some(b) = &mut self.bias {
            self.saturated += b.add(bias);
        }
        self.add(image);
    }

    /// Adds the sums of another film of the same size (disjoint iterations, e.g. another range
    /// of the same render). Exact: the result does not depend on the order of merging. The
    /// result has bias sums only if both films have them.
    ///
    /// # Panics
    /// If the sizes differ ([`crate::Partial::merge`] checks before it merges).
    pub fn merge(&mut self, other: &Film) {
        assert_eq!((self.width, self.height), (other.width, other.height), "film sizes differ");
        let mut saturated = self.value.merge(&other.value);
        match (&mut self.bias, &other.bias) {
            (Some(a), Some(b)) => saturated += a.merge(b),
            _ => self.bias = None,
        }
        self.iterations += other.iterations;
        self.saturated += other.saturated + saturated;
    }

    /// The mean of the iterations so far (black before the first).
    pub fn mean(&self) -> Vec<[f32; 3]> {
        self.value.mean(self.iterations)
    }

    /// Each pixel's estimated variance of the mean: the sample variance of its iteration values
    /// divided by the iteration count (zero before the second iteration). Exact in expectation when
    /// the iterations are identically distributed (the path tracer); for photon mapping, whose
    /// iterations drift as the radius shrinks, it also counts that drift and so overstates the noise.
    pub fn variance_of_mean(&self) -> Vec<[f32; 3]> {
        self.value.variance_of_mean(self.iterations)
    }

    /// Each pixel's estimated kernel bias: the mean of the iterations' bias estimates (docs/
    /// theory.md), the bias of [`Self::mean`]; `None` for a film without bias sums.
    pub fn bias(&self) -> Option<Vec<[f32; 3]>> {
        self.bias.as_ref().map(|b| b.mean(self.iterations))
    }

    /// The variance of [`Self::bias`] (as [`Self::variance_of_mean`] is that of the mean).
    pub fn bias_variance(&self) -> Option<Vec<[f32; 3]>> {
        self.bias.as_ref().map(|b| b.variance_of_mean(self.iterations))
    }

    /// The image's estimated relative error (docs/error.md): with v each pixel's and channel's
    /// variance of the mean ([`Self::variance_of_mean`]), V its mean and m the image's mean
    /// value, the relative RMSE √(V + B) / m, B being the mean squared kernel bias (0 without
    /// bias sums; below), and its upper confidence limit at `confidence`: √(V + B + z·s) / m
    /// with z the one-sided normal quantile and s the standard error of V + B. The sampling
    /// variance of each v is taken as 2v²/(N − 1) for N iterations, as for Gaussian values;
    /// pixels independent, a pixel's three channels fully correlated. B is the mean over pixels
    /// and channels of b² − w, b the bias estimate and w its variance (so that it is unbiased for
    /// the mean squared bias), floored at 0. Over `region`'s pixels only, if given, and in any
    /// case without the 0.1 % of them with the largest variance ([`crate::region::Region::counted`];
    /// docs/error.md). `None` before the second iteration; zero for a black image without noise.
    pub fn error_estimate(
        &self,
        confidence: f64,
        region: Option<crate::region::Region>,
    ) -> Option<ErrorEstimate> {
        if self.iterations < 2 {
            return None;
        }
        let (bias, bias_variance) = (self.bias(), self.bias_variance());
        let layers = ErrorLayers {
            mean: &self.mean(),
            variance: &self.variance_of_mean(),
            bias: bias.as_deref(),
            bias_variance: bias_variance.as_deref(),
            iterations: self.iterations,
            size: (self.width, self.height),
        };
        layers.estimate(confidence, region)
    }
    /// Counts one more iteration whose running estimate is `image` itself rather than a term of
    /// a mean (the original PPM keeps per-pixel statistics, not a mean of iterations): afterwards
    /// [`Self::mean`] returns `image`, [`Self::bias`] returns `bias` (if the film sums one and
    /// `bias` is given), and the variance estimates are zero.
    pub fn replace(&mut self, image: &[Rgb], bias: Option<&[Rgb]>) {
        debug_assert_eq!(image.len(), self.value.sum.len());
        self.iterations += 1;
        self.value.replace(image, self.iterations);
        match (&mut self.bias, bias) {
            (Some(b), Some(bias)) => b.replace(bias, self.iterations),
            (Some(b), None) => *b = Sums::new(image.len()),
            (None, _) => {}
        }
    }

    /// The raw sums, for partial-render files: per pixel the sums of values and of squares, in
    /// units of 2⁻⁶⁰, and the same of the bias estimates if the film has them.
    #[allow(clippy::type_complexity)]
    pub(crate) fn sums(&self) -> ([&[[i128; 3]]; 2], Option<[&[[i128; 3]]; 2]>) {
        (
            [&self.value.sum, &self.value.sum_sq],
            self.bias.as_ref().map(|b| [&b.sum[..], &b.sum_sq[..]]),
        )
    }

    /// A film from raw sums (see [`Self::sums`]).
    #[allow(clippy::type_complexity)]
    pub(crate) fn from_sums(
        width: u32,
        height: u32,
        [sum, sum_sq]: [Vec<[i128; 3]>; 2],
        bias: Option<[Vec<[i128; 3]>; 2]>,
        iterations: u64,
        saturated: u64,
    ) -> Self {
        Self {
            width,
            height,
            value: Sums { sum, sum_sq },
            bias: bias.map(|[sum, sum_sq]| Sums { sum, sum_sq }),
            iterations,
            saturated,
        }
    }
}

/// The layers an error estimate reads (docs/error.md): the mean image, each pixel's variance of
/// the mean, and the kernel bias with its variance where there is one.
pub(crate) struct ErrorLayers<'a> {
    pub mean: &'a [[f32; 3]],
    pub variance: &'a [[f32; 3]],
    pub bias: Option<&'a [[f32; 3]]>,
    pub bias_variance: Option<&'a [[f32; 3]]>,
    /// Iterations averaged (at least 2).
    pub iterations: u64,
    /// (width, height).
    pub size: (u32, u32),
}

impl ErrorLayers<'_> {
    /// [`Film::error_estimate`] on these layers.
    pub fn estimate(
        &self,
        confidence: f64,
        region: Option<crate::region::Region>,
    ) -> Option<ErrorEstimate> {
        let (mean, variance) = (self.mean, self.variance);
        let (bias, bias_var) = (self.bias, self.bias_variance);
        let n = self.iterations as f64;
        let (mut sum, mut v, mut v2, mut count) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        let (mut b, mut b2) = (0.0f64, 0.0f64);
        let (w, h) = self.size;
        let pixel_variance = |i: usize| variance[i].iter().map(|&c| c as f64).sum::<f64>();
        let region = region.unwrap_or(crate::region::Region::whole(w, h));
        for i in region.counted(w, h, pixel_variance) {
            let (m, var) = (mean[i], variance[i]);
            let (mut pixel, mut pixel_b) = (0.0, 0.0);
            for c in 0..3 {
                sum += m[c] as f64;
                pixel += var[c] as f64;
                count += 1.0;
                if let (Some(bias), Some(w)) = (&bias, &bias_var) {
                    let (bb, w) = (bias[i][c] as f64, w[i][c] as f64);
                    b += bb * bb - w;
                    // Sampling variance of b² − w: 4 b² w + 2 w² (Gaussian b).
                    pixel_b += (4.0 * (bb * bb - w).max(0.0) * w + 2.0 * w * w).sqrt();
                }
            }
            v += pixel;
            // A pixel's channels come from the same paths: their variance estimates' errors are
            // taken as fully correlated (the sampling s.d. of the three add).
            v2 += pixel * pixel;
            b2 += pixel_b * pixel_b;
        }
        let (mean, v_mean) = (sum / count, v / count);
        let b_mean = (b / count).max(0.0);
        if mean.is_nan() || mean < 0.0 {
            return None;
        }
        if mean == 0.0 && v_mean == 0.0 && b_mean == 0.0 {
            // A black image without noise: nothing left to estimate (and a render stopping on a
            // target must stop).
            return Some(ErrorEstimate { relative_rmse: 0.0, upper: 0.0, confidence });
        }
        if mean == 0.0 {
            return None;
        }
        let se = ((2.0 * v2 / (n - 1.0)) + b2).sqrt() / count;
        let z = crate::math::normal_quantile(confidence.clamp(1e-9, 1.0 - 1e-9));
        let total = v_mean + b_mean;
        Some(ErrorEstimate {
            relative_rmse: total.sqrt() / mean,
            upper: (total + z * se).max(0.0).sqrt() / mean,
            confidence,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fast conversion of small values gives the integer the general one gives, on both
    /// sides of its limit (8 in fixed point) and for values that do not fit.
    #[test]
    fn fixed_point_conversion_agrees_with_the_general_one() {
        let general = |v: f64| {
            let x = (v * SCALE).round();
            (x.is_finite() && x.abs() < 2f64.powi(126)).then_some(x as i128)
        };
        let limit = 2f64.powi(63) / SCALE;
        let mut values = vec![0.0, -0.0, 1e-30, 0.3, -5.5, 1e30, -1e38, f64::NAN, f64::INFINITY];
        for k in -4..=4 {
            let near = limit + k as f64 * limit * f64::EPSILON;
            values.extend([near, -near]);
        }
        for i in 0..10_000 {
            let v = (i as f64 * 0.618_034).fract() * 20.0 - 10.0;
            values.extend([v, v * 1e-9, v * 1e9]);
        }
        for v in values {
            assert_eq!(fixed(v), general(v), "{v}");
        }
    }

    /// The fast conversion of sums to f64 rounds as the general one does: on both sides of the
    /// 64-bit limit, where rounding to 53 bits loses bits (ties included), and far beyond it.
    #[test]
    fn sums_convert_to_float_as_the_general_conversion_does() {
        let mut values: Vec<i128> = vec![0, 1, -1, i128::MAX, i128::MIN];
        for edge in [i64::MAX as i128, i64::MIN as i128, 1 << 53, -(1 << 53), 1 << 100] {
            values.extend((-70..=70).map(|k| edge + k));
        }
        // Odd values with more than 53 significant bits, ties to even among them.
        for shift in [0u32, 9, 10, 11, 40, 60] {
            for low in [1i128, 0x3ff, 0x400, 0x401, 0xc00, 0x7ff_ffff] {
                let x = ((1i128 << 60) + low) << shift;
                values.extend([x, -x, x + 1, x - 1]);
            }
        }
        let mut x = 0x9e37_79b9_7f4a_7c15_i128;
        for _ in 0..10_000 {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            values.extend([x >> 40, x >> 64, x >> 1, -(x >> 70)]);
        }
        for x in values {
            assert_eq!(float(x).to_bits(), (x as f64).to_bits(), "{x}");
        }
    }

    /// A black film without noise has reached any target (so a render stopping on one stops);
    /// a noisy one reports √V / m, with the upper limit above it.
    #[test]
    fn error_estimates_of_black_and_noisy_films() {
        let mut black = Film::new(2, 2);
        for _ in 0..3 {
            black.add(&[Rgb::ZERO; 4]);
        }
        let e = black.error_estimate(0.95, None).unwrap();
        assert_eq!((e.relative_rmse, e.upper), (0.0, 0.0));
        let mut noisy = Film::new(1, 1);
        for v in [1.0, 3.0] {
            noisy.add(&[Rgb::splat(v)]);
        }
        // Sample variance 2, of the mean 1; mean 2: √1 / 2.
        let e = noisy.error_estimate(0.95, None).unwrap();
        assert!((e.relative_rmse - 0.5).abs() < 1e-12 && e.upper > e.relative_rmse, "{e:?}");
        assert!(Film::new(1, 1).error_estimate(0.95, None).is_none());
    }

    /// Values spread over many orders of magnitude, added in two groupings: floating-point sums
    /// would differ in their last bits; the fixed-point sums are identical.
    #[test]
    fn sums_do_not_depend_on_grouping() {
        let images: Vec<Vec<Rgb>> = (0..50)
            .map(|k| {
                let v = (1.7f32).powi(k % 23 - 11) * (1.0 + k as f32 * 0.013);
                vec![Rgb::new(v, v * 1e-6, v * 3e5); 4]
            })
            .collect();
        let mut one = Film::new(2, 2);
        images.iter().for_each(|i| one.add(i));
        let (mut a, mut b, mut c) = (Film::new(2, 2), Film::new(2, 2), Film::new(2, 2));
        images[..17].iter().for_each(|i| a.add(i));
        images[17..30].iter().for_each(|i| b.add(i));
        images[30..].iter().for_each(|i| c.add(i));
        c.merge(&a);
        c.merge(&b);
        assert_eq!(c, one);
        assert_eq!(c.mean(), one.mean());
        // The mean agrees with an f64 mean to f32 precision.
        let exact: f64 = images.iter().map(|i| i[0].x as f64).sum::<f64>() / 50.0;
        assert!((one.mean()[0][0] as f64 / exact - 1.0).abs() < 1e-6);
    }

    #[test]
    fn out_of_range_values_saturate_and_are_counted() {
        let mut f = Film::new(1, 1);
        f.add(&[Rgb::new(1e30, 1.0, -1e30)]);
        assert_eq!(f.saturated(), 4); // 1e30 and its square, -1e30 and its square
        assert!(f.mean()[0][0] > 1e19);
        assert_eq!(f.mean()[0][1], 1.0);
    }
}
