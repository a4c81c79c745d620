//! The probabilistic progressive photon mapping radius schedule (Knaus & Zwicker 2011, eq. 16).
//!
//! For a kernel of dimension d, r_{i+1}^d / r_i^d = (i + α) / (i + 1), i = 1, 2, …; so
//!
//!   r_n^d = r_1^d · ∏_{i=1}^{n−1} (i + α)/(i + 1) = r_1^d · Γ(n + α) / (Γ(1 + α) Γ(n + 1)),
//!
//! which behaves as r_1^d · n^(α−1) / Γ(1 + α). The product in f32 stalls near i ≈ 2²³ (the factor
//! rounds to 1), so the closed form is evaluated in f64 through ln Γ.

/// ln Γ(x) for x > 0 (Lanczos approximation, g = 7, n = 9; relative error below 1e-14).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x) Γ(1 − x) = π / sin(πx).
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// ln[Γ(n + α) / Γ(n + 1)] for integer n ≥ 1, accurate to a few ulps of its (small) value at any n.
///
/// Below n = 64 it is the running product ∏_{i=1}^{n−1} (i + α)/(i + 1) times Γ(1 + α), in f64.
/// From n = 64 on it is the difference of Stirling series written so that nothing cancels:
/// (n + α − ½)·ln(1 + (α − 1)/(n + 1)) + (α − 1)(ln(n + 1) − 1) + Σ_k B_2k/(2k(2k−1)) (z₁^(1−2k) − z₂^(1−2k))
/// with z₁ = n + α, z₂ = n + 1. Subtracting two separate ln Γ values instead would lose about
/// 1e-7 in the logarithm at n = 10⁷, more than one iteration's step of 3·10⁻⁸, and the schedule would
/// stall or even grow.
fn ln_gamma_ratio(n: u64, alpha: f64) -> f64 {
    if n < 64 {
        let mut ln = ln_gamma(1.0 + alpha);
        for i in 1..n {
            ln += ((i as f64 + alpha) / (i as f64 + 1.0)).ln();
        }
        return ln;
    }
    let n = n as f64;
    let (z1, z2) = (n + alpha, n + 1.0);
    let main = (n + alpha - 0.5) * ((alpha - 1.0) / z2).ln_1p() + (alpha - 1.0) * (z2.ln() - 1.0);
    let series = |z: f64| {
        let z2 = z * z;
        (1.0 / 12.0 - (1.0 / 360.0 - (1.0 / 1260.0 - 1.0 / (1680.0 * z2)) / z2) / z2) / z
    };
    main + (series(z1) - series(z2))
}

/// Smallest radius ratio r_n / r_1 returned, so a radius never underflows to zero.
pub const MIN_RATIO: f64 = 1e-12;

/// r_n / r_1 for iteration `n` ≥ 1 of the schedule with reduction `alpha` and kernel dimension
/// `dim`: (Γ(n + α) / (Γ(1 + α) Γ(n + 1)))^(1/d), floored at `MIN_RATIO` (10⁻¹²).
pub fn radius_ratio(n: u64, alpha: f64, dim: u32) -> f64 {
    let ln_rd = ln_gamma_ratio(n.max(1), alpha) - ln_gamma(1.0 + alpha);
    (ln_rd / dim as f64).exp().max(MIN_RATIO)
}

/// Radius of iteration `n` (1-based) given the initial radius `r1`.
pub fn radius(n: u64, r1: f64, alpha: f64, dim: u32) -> f64 {
    r1 * radius_ratio(n, alpha, dim)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ln_gamma_matches_known_values() {
        assert!((ln_gamma(1.0)).abs() < 1e-13);
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - std::f64::consts::PI.sqrt().ln()).abs() < 1e-12);
        assert!((ln_gamma(100.5) - 361.435_540_467_777_6).abs() < 1e-9);
        for x in [0.7, 3.3, 41.0] {
            assert!((ln_gamma(x + 1.0) - ln_gamma(x) - f64::ln(x)).abs() < 1e-12);
        }
    }

    #[test]
    fn ratio_matches_running_product_in_f64() {
        for &alpha in &[0.1, 0.5, 2.0 / 3.0, 0.9] {
            for dim in [2, 3] {
                let mut rd = 1.0f64;
                for n in 1..20_000u64 {
                    let r = radius_ratio(n, alpha, dim);
                    let want = rd.powf(1.0 / dim as f64);
                    assert!(
                        (r / want - 1.0).abs() < 1e-10,
                        "n={n} α={alpha} d={dim}: {r} vs {want}"
                    );
                    rd *= (n as f64 + alpha) / (n as f64 + 1.0);
                }
            }
        }
    }

    #[test]
    fn schedule_follows_the_recurrence_and_its_asymptote() {
        for &alpha in &[0.3, 0.5, 2.0 / 3.0, 0.8] {
            for dim in [2u32, 3] {
                // Recurrence r_{i+1}^d / r_i^d = (i + α)/(i + 1) at scattered iterations.
                for &i in &[1u64, 2, 10, 63, 64, 65, 1000, 123_456, 9_999_999] {
                    let a = radius_ratio(i, alpha, dim).powi(dim as i32);
                    let b = radius_ratio(i + 1, alpha, dim).powi(dim as i32);
                    let want = (i as f64 + alpha) / (i as f64 + 1.0);
                    assert!(((b / a) / want - 1.0).abs() < 1e-12, "α={alpha} d={dim} i={i}");
                }
                // Asymptote r_n^d ≈ n^(α−1) / Γ(1+α).
                let n = 1e7f64;
                let asym = n.powf(alpha - 1.0) / ln_gamma(1.0 + alpha).exp();
                let got = radius_ratio(n as u64, alpha, dim).powi(dim as i32);
                assert!((got / asym - 1.0).abs() < 1e-6, "α={alpha} d={dim}: {got} vs {asym}");
            }
        }
    }

    #[test]
    fn schedule_strictly_decreases_for_ten_million_iterations() {
        for dim in [2u32, 3] {
            let mut prev = radius_ratio(1, 0.7, dim);
            assert_eq!(prev, 1.0);
            for i in 2..=10_000_000u64 {
                let r = radius_ratio(i, 0.7, dim);
                assert!(r < prev && r > 0.0 && r.is_finite(), "stalled at i = {i} (d = {dim})");
                prev = r;
            }
        }
    }
}
