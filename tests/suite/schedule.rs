//! The radius schedule: closed form, no stall or underflow over 10⁷ iterations.

use haze::estimate::radius::{ln_gamma, radius_ratio};

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
