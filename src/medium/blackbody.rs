//! Blackbody emission as linear sRGB, for media whose emission comes from a temperature grid.
//!
//! Planck's law gives the spectral radiance of a blackbody at temperature T,
//!
//!   B(λ, T) = 2hc² / (λ⁵ (e^{hc / (λ k T)} − 1)),
//!
//! which peaks at λ_max = b / T (Wien's displacement law, b = 2.897771955·10⁻³ m·K). As in
//! pbrt-v4's `BlackbodySpectrum` the spectrum is normalised to 1 at its peak, B̂(λ, T) =
//! B(λ, T) / B(λ_max, T), so that a scale factor sets the brightness and the temperature only the
//! colour and relative brightness. The colour is the CIE 1931 XYZ of B̂ over 360–830 nm, divided by
//! ∫ ȳ dλ (so that the constant spectrum 1 has Y = 1), converted to linear sRGB (Rec. 709
//! primaries, D65 white) and clamped at zero (below about 1900 K a blackbody lies outside the sRGB
//! gamut). The colour-matching functions are the multi-lobe Gaussian fit of Wyman, Sloan and
//! Shirley, "Simple Analytic Approximations to the CIE XYZ Color Matching Functions" (JCGT 2(2),
//! 2013). Colours are tabulated once, log-spaced in T from [`T_MIN`] to [`T_MAX`], and
//! interpolated.

use crate::math::Rgb;
use std::sync::OnceLock;

/// Lowest tabulated temperature (K); below it the emission is taken as zero.
pub const T_MIN: f64 = 100.0;
/// Highest tabulated temperature (K); above it the colour of `T_MAX` is used.
pub const T_MAX: f64 = 100_000.0;
const ENTRIES: usize = 2048;

/// Planck's constant, the speed of light and Boltzmann's constant (SI, exact since 2019).
const H: f64 = 6.626_070_15e-34;
const C: f64 = 299_792_458.0;
const K: f64 = 1.380_649e-23;
/// Wien's displacement constant (m·K).
const WIEN: f64 = 2.897_771_955e-3;

/// Planck's law: spectral radiance at wavelength `lambda` (m) and temperature `t` (K).
pub fn planck(lambda: f64, t: f64) -> f64 {
    let x = H * C / (lambda * K * t);
    2.0 * H * C * C / (lambda.powi(5) * x.exp_m1())
}

/// The fit's piecewise Gaussian: exp(−½ ((λ − μ)/σ)²) with σ = `s1` below μ and `s2` above.
fn lobe(lambda_nm: f64, mu: f64, s1: f64, s2: f64) -> f64 {
    let s = if lambda_nm < mu { s1 } else { s2 };
    let x = (lambda_nm - mu) / s;
    (-0.5 * x * x).exp()
}

/// CIE 1931 x̄, ȳ, z̄ at `lambda_nm` (Wyman, Sloan and Shirley 2013, multi-lobe fit).
pub fn cie_xyz(lambda_nm: f64) -> [f64; 3] {
    let l = lambda_nm;
    [
        1.056 * lobe(l, 599.8, 37.9, 31.0) + 0.362 * lobe(l, 442.0, 16.0, 26.7)
            - 0.065 * lobe(l, 501.1, 20.4, 26.2),
        0.821 * lobe(l, 568.8, 46.9, 40.5) + 0.286 * lobe(l, 530.9, 16.3, 31.1),
        1.217 * lobe(l, 437.0, 11.8, 36.0) + 0.681 * lobe(l, 459.0, 26.0, 13.8),
    ]
}

/// Linear sRGB (D65) of CIE XYZ.
pub fn xyz_to_srgb([x, y, z]: [f64; 3]) -> [f64; 3] {
    [
        3.240_454_2 * x - 1.537_138_5 * y - 0.498_531_4 * z,
        -0.969_266_0 * x + 1.876_010_8 * y + 0.041_556_0 * z,
        0.055_643_4 * x - 0.204_025_9 * y + 1.057_225_2 * z,
    ]
}

/// The colour of the peak-normalised blackbody spectrum at `t` K, computed (not tabulated): XYZ
/// by the midpoint rule at 1 nm over 360–830 nm, over ∫ ȳ, to linear sRGB, clamped at 0.
pub fn blackbody_srgb_exact(t: f64) -> [f64; 3] {
    let peak = planck(WIEN / t, t);
    let (mut xyz, mut y_norm) = ([0.0f64; 3], 0.0);
    for i in 0..470 {
        let l = 360.5 + i as f64;
        let cmf = cie_xyz(l);
        let b = planck(l * 1e-9, t) / peak;
        for c in 0..3 {
            xyz[c] += b * cmf[c];
        }
        y_norm += cmf[1];
    }
    xyz_to_srgb(xyz.map(|v| v / y_norm)).map(|v| v.max(0.0))
}

/// The table of [`blackbody_srgb_exact`], log-spaced in T.
fn table() -> &'static [[f32; 3]] {
    static TABLE: OnceLock<Vec<[f32; 3]>> = OnceLock::new();
    TABLE.get_or_init(|| {
        (0..ENTRIES)
            .map(|i| {
                let t = T_MIN * (T_MAX / T_MIN).powf(i as f64 / (ENTRIES - 1) as f64);
                blackbody_srgb_exact(t).map(|v| v as f32)
            })
            .collect()
    })
}

/// The table's mean channels as a sparse table for range maxima: level k holds the largest of
/// entries i .. i + 2^k.
fn mean_channel_maxima() -> &'static [Vec<f32>] {
    static LEVELS: OnceLock<Vec<Vec<f32>>> = OnceLock::new();
    LEVELS.get_or_init(|| {
        let mut levels =
            vec![table().iter().map(|c| crate::math::luminance(Rgb::from(*c))).collect::<Vec<_>>()];
        let mut width = 1;
        while 2 * width <= ENTRIES {
            let last = levels.last().expect("level 0");
            let next = (0..=ENTRIES - 2 * width).map(|i| last[i].max(last[i + width])).collect();
            levels.push(next);
            width *= 2;
        }
        levels
    })
}

/// The table position of `t` (≥ [`T_MIN`]), clamped to the last entry.
#[inline]
fn position(t: f32) -> f64 {
    ((t as f64 / T_MIN).ln() / (T_MAX / T_MIN).ln() * (ENTRIES - 1) as f64)
        .clamp(0.0, (ENTRIES - 1) as f64)
}

/// The largest mean channel of [`blackbody`] over temperatures in [`t0`, `t1`] (K): exact for
/// the tabulated colours, which are linear between entries (so the largest is at an entry inside
/// the range or at one of its ends). Zero if the range lies below [`T_MIN`].
pub fn max_mean_channel(t0: f32, t1: f32) -> f32 {
    let (t0, t1) = (t0.min(t1), t0.max(t1));
    if t1.is_nan() || (t1 as f64) < T_MIN {
        return 0.0;
    }
    let t0 = t0.max(T_MIN as f32);
    let ends = crate::math::luminance(blackbody(t0)).max(crate::math::luminance(blackbody(t1)));
    let (x0, x1) = (position(t0), position(t1));
    let (i0, i1) = (x0.ceil() as usize, x1.floor() as usize);
    if i0 > i1 {
        return ends;
    }
    // The largest of entries i0..=i1 from two overlapping power-of-two ranges.
    let levels = mean_channel_maxima();
    let n = i1 - i0 + 1;
    let k = (usize::BITS - 1 - n.leading_zeros()) as usize;
    let inside = levels[k][i0].max(levels[k][i1 + 1 - (1 << k)]);
    ends.max(inside)
}

/// The linear sRGB colour of the peak-normalised blackbody spectrum at temperature `t` (K):
/// zero below [`T_MIN`] (and for NaN), the colour of [`T_MAX`] above it.
#[inline]
pub fn blackbody(t: f32) -> Rgb {
    // NaN fails the comparison too.
    if t.is_nan() || (t as f64) < T_MIN {
        return Rgb::ZERO;
    }
    let table = table();
    let x = position(t);
    let i = (x as usize).min(ENTRIES - 2);
    let f = (x - i as f64) as f32;
    let (a, b) = (Rgb::from(table[i]), Rgb::from(table[i + 1]));
    a + (b - a) * f
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fit reproduces the tabulated CIE 1931 functions' integrals (∫ x̄ = ∫ ȳ = ∫ z̄ =
    /// 106.857 for the real ones, 1 nm steps 360–830 nm) within 1 %, and ȳ peaks at 555 nm.
    #[test]
    fn colour_matching_fit_has_the_cie_integrals() {
        let mut sums = [0.0f64; 3];
        for i in 0..470 {
            let v = cie_xyz(360.5 + i as f64);
            for c in 0..3 {
                sums[c] += v[c];
            }
        }
        for s in sums {
            assert!((s / 106.857 - 1.0).abs() < 0.01, "∫ = {s}");
        }
        let peak = (400..700)
            .max_by(|&a, &b| cie_xyz(a as f64)[1].partial_cmp(&cie_xyz(b as f64)[1]).unwrap());
        assert!((553..=558).contains(&peak.unwrap()), "ȳ peaks at {peak:?} nm");
    }

    /// Planck's law peaks at Wien's λ_max, and its integral over all wavelengths is σT⁴/π
    /// (Stefan–Boltzmann, σ = 5.670374·10⁻⁸ W m⁻² K⁻⁴).
    #[test]
    fn planck_obeys_wien_and_stefan_boltzmann() {
        let t = 3000.0;
        let peak = WIEN / t;
        for f in [0.97, 1.03] {
            assert!(planck(peak * f, t) < planck(peak, t));
        }
        let (mut sum, n) = (0.0, 200_000);
        let (lo, hi) = (1e-8f64, 1e-3f64);
        for i in 0..n {
            // Log-spaced midpoint rule.
            let u = (i as f64 + 0.5) / n as f64;
            let l = lo * (hi / lo).powf(u);
            sum += planck(l, t) * l * (hi / lo).ln() / n as f64;
        }
        let want = 5.670_374e-8 * t.powi(4) / std::f64::consts::PI;
        assert!((sum / want - 1.0).abs() < 1e-3, "{sum} vs {want}");
    }

    /// Colours go from red through white to blue: a candle flame (1850 K) is red > green >
    /// blue, 6500 K is close to the D65 white point (channels within 10 % of each other), 15000 K
    /// is bluish. The table agrees with the direct computation between its entries.
    #[test]
    fn blackbody_colours_run_from_red_to_blue() {
        let c = blackbody(1850.0);
        assert!(c.x > c.y && c.y > c.z, "{c}");
        let w = blackbody(6500.0);
        assert!(w.max_element() / w.min_element() < 1.1, "{w}");
        let b = blackbody(15000.0);
        assert!(b.z > b.x, "{b}");
        for t in [150.0f32, 800.0, 1234.5, 3333.3, 6500.0, 25_000.0] {
            let exact = Rgb::from(blackbody_srgb_exact(t as f64).map(|v| v as f32));
            let tab = blackbody(t);
            let scale = exact.max_element().max(1e-30);
            assert!((tab - exact).abs().max_element() < 2e-3 * scale, "{t} K: {tab} vs {exact}");
        }
        assert_eq!(blackbody(50.0), Rgb::ZERO);
        assert_eq!(blackbody(f32::NAN), Rgb::ZERO);
        assert!(blackbody(1e9).max_element() > 0.0);
    }

    /// The range maximum of the mean channel bounds every temperature of the range and is
    /// reached by one (to rounding), over ranges from a few kelvin to the whole table, below,
    /// across and above its ends; a range below 100 K emits nothing.
    #[test]
    fn the_range_maximum_bounds_the_blackbody_and_is_reached() {
        let lum = |t: f32| crate::math::luminance(blackbody(t));
        let mut s = crate::rng::Sampler::new(7, crate::rng::Purpose::Photon, 0, 0);
        for k in 0..2000 {
            let a = 10f32.powf(1.5 + 4.0 * s.next_f32());
            let b = if k % 2 == 0 {
                a * (1.0 + 0.01 * s.next_f32())
            } else {
                10f32.powf(1.5 + 4.0 * s.next_f32())
            };
            let (lo, hi) = (a.min(b), a.max(b));
            let bound = max_mean_channel(b, a);
            let seen = (0..=400)
                .map(|i| lum(lo * (hi / lo).powf(i as f32 / 400.0)))
                .fold(0.0f32, f32::max);
            assert!(seen <= bound * (1.0 + 1e-5), "[{lo}, {hi}]: {seen} above {bound}");
            // The entries are 0.34 % apart in T: a 400-step scan comes close to each.
            assert!(seen >= bound * (1.0 - 2e-3) - 1e-7, "[{lo}, {hi}]: {bound}, seen {seen}");
        }
        assert_eq!(max_mean_channel(10.0, 99.0), 0.0);
        let peak =
            table().iter().map(|c| crate::math::luminance(Rgb::from(*c))).fold(0.0, f32::max);
        assert_eq!(max_mean_channel(0.0, 1e9), peak);
    }
}
