//! Analytic and semi-analytic references for participating media, each with its source and
//! conventions. Units: lengths in the scene's units, coefficients per unit length, radiance and
//! irradiance in consistent units; boundaries are index-matched (no Fresnel reflection).
//!
//! - [`white_furnace`]: in a closed enclosure emitting radiance L_e uniformly, filled with a
//!   medium of single-scattering albedo 1 (any density, any phase function), the radiance is L_e
//!   everywhere and in every direction — emission balances extinction exactly.
//! - [`beer_lambert`], [`optical_depth_linear`]: transmittance T = exp(−τ) with τ = ∫ σ_t dt,
//!   constant or linear in the distance.
//! - [`HFunction`]: Chandrasekhar's H-function for isotropic scattering of albedo ω
//!   (Chandrasekhar, *Radiative Transfer*, 1950, ch. V), solved by haze itself; with it,
//!   [`half_space_reflectance`] and [`half_space_albedo`] give the light reflected by a
//!   semi-infinite, isotropically scattering half-space under collimated normal incidence.

/// Radiance inside a white furnace whose walls emit `le`: `le` itself.
pub fn white_furnace(le: f64) -> f64 {
    le
}

/// Transmittance exp(−σ_t d) of a homogeneous medium over a distance d.
pub fn beer_lambert(sigma_t: f64, distance: f64) -> f64 {
    (-sigma_t * distance).exp()
}

/// Optical depth ∫_a^b σ (s·x + c) dx of a density s·x + c with extinction σ per unit density.
pub fn optical_depth_linear(sigma: f64, slope: f64, offset: f64, a: f64, b: f64) -> f64 {
    sigma * (slope * (b * b - a * a) / 2.0 + offset * (b - a))
}

/// Gauss–Legendre nodes and weights on [0, 1] (Newton's method on P_n).
fn gauss_legendre_unit(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = Vec::with_capacity(n);
    let mut weights = Vec::with_capacity(n);
    for i in 0..n {
        // Initial guess (Tricomi), then Newton on P_n(x).
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        // Map [-1, 1] to [0, 1].
        nodes.push(0.5 * (x + 1.0));
        weights.push(0.5 * w);
    }
    (nodes, weights)
}

/// Chandrasekhar's H-function for isotropic scattering with single-scattering albedo ω ∈ (0, 1],
/// from the equation 1/H(μ) = √(1 − ω) + (ω/2) ∫₀¹ μ′ H(μ′) / (μ + μ′) dμ′ (Chandrasekhar 1950,
/// eq. V.(33)), solved by fixed-point iteration on a Gauss–Legendre grid and evaluated elsewhere by
/// the same equation (Nyström interpolation).
#[derive(Clone, Debug)]
pub struct HFunction {
    omega: f64,
    nodes: Vec<f64>,
    weights: Vec<f64>,
    values: Vec<f64>,
}

impl HFunction {
    /// Solves for albedo `omega` ∈ (0, 1] by Newton's method on the discretised equation
    /// H_i · (√(1 − ω) + (ω/2) Σ_j w_j μ_j H_j / (μ_i + μ_j)) = 1 (plain fixed-point iteration
    /// crawls as ω → 1).
    /// `None` unless 0 < ω ≤ 1.
    pub fn new(omega: f64) -> Option<Self> {
        if !(omega > 0.0 && omega <= 1.0) {
            return None;
        }
        let (nodes, weights) = gauss_legendre_unit(96);
        let n = nodes.len();
        let mut values = vec![1.0; n];
        for _ in 0..100 {
            let rhs: Vec<f64> =
                nodes.iter().map(|&mu| Self::rhs(omega, &nodes, &weights, &values, mu)).collect();
            let f: Vec<f64> = (0..n).map(|i| values[i] * rhs[i] - 1.0).collect();
            let mut jac = vec![vec![0.0; n]; n];
            for i in 0..n {
                for k in 0..n {
                    jac[i][k] =
                        values[i] * 0.5 * omega * weights[k] * nodes[k] / (nodes[i] + nodes[k]);
                }
                jac[i][i] += rhs[i];
            }
            let step = solve(jac, f);
            let mut change = 0.0f64;
            for i in 0..n {
                values[i] -= step[i];
                change = change.max(step[i].abs());
            }
            if change < 1e-13 {
                break;
            }
        }
        Some(Self { omega, nodes, weights, values })
    }

    fn rhs(omega: f64, nodes: &[f64], weights: &[f64], values: &[f64], mu: f64) -> f64 {
        let integral: f64 =
            nodes.iter().zip(weights).zip(values).map(|((&m, &w), &h)| w * m * h / (mu + m)).sum();
        (1.0 - omega).sqrt() + 0.5 * omega * integral
    }

    /// The albedo ω.
    pub fn omega(&self) -> f64 {
        self.omega
    }

    /// H(μ) for μ ∈ [0, 1].
    pub fn eval(&self, mu: f64) -> f64 {
        Self::rhs(self.omega, &self.nodes, &self.weights, &self.values, mu).recip()
    }

    /// The moment ∫₀¹ μⁿ H(μ) dμ.
    pub fn moment(&self, n: i32) -> f64 {
        self.nodes
            .iter()
            .zip(&self.weights)
            .zip(&self.values)
            .map(|((&m, &w), &h)| w * m.powi(n) * h)
            .sum()
    }
}

/// Solves A x = b by Gaussian elimination with partial pivoting (A is small and well conditioned
/// here).
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for c in 0..n {
        let p = (c..n).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs())).unwrap_or(c);
        a.swap(c, p);
        b.swap(c, p);
        let (top, rest) = a.split_at_mut(c + 1);
        let pivot = &top[c];
        for (r, row) in rest.iter_mut().enumerate() {
            let f = row[c] / pivot[c];
            if f != 0.0 {
                for (x, p) in row[c..].iter_mut().zip(&pivot[c..]) {
                    *x -= f * p;
                }
                b[c + 1 + r] -= f * b[c];
            }
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    x
}

/// Radiance reflected by a semi-infinite, isotropically scattering half-space towards a direction
/// with cosine μ to the surface normal, per unit irradiance of collimated light at normal
/// incidence: L_r(μ)/E = ω H(1) H(μ) / (4π (1 + μ)) (Chandrasekhar 1950, eq. IV.(51) with
/// μ₀ = 1 and the irradiance E = π F μ₀ on the surface).
pub fn half_space_reflectance(h: &HFunction, mu: f64) -> f64 {
    h.omega() * h.eval(1.0) * h.eval(mu) / (4.0 * std::f64::consts::PI * (1.0 + mu))
}

/// Fraction of the normally incident power the half-space reflects: 1 − √(1 − ω) H(1).
pub fn half_space_albedo(h: &HFunction) -> f64 {
    1.0 - (1.0 - h.omega()).sqrt() * h.eval(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        let (x, w) = gauss_legendre_unit(16);
        for k in 0..31 {
            let q: f64 = x.iter().zip(&w).map(|(&x, &w)| w * x.powi(k)).sum();
            assert!((q - 1.0 / (k as f64 + 1.0)).abs() < 1e-13, "x^{k}");
        }
    }

    #[test]
    fn h_function_has_its_known_moments_and_values() {
        for omega in [0.2, 0.5, 0.9, 0.99, 1.0] {
            let h = HFunction::new(omega).unwrap();
            // α₀ = ∫ H dμ = (2/ω)(1 − √(1 − ω))  (Chandrasekhar 1950, eq. V.(30)).
            let alpha0 = 2.0 / omega * (1.0 - (1.0 - omega).sqrt());
            assert!(
                (h.moment(0) - alpha0).abs() < 2e-5 * alpha0,
                "ω = {omega}: {} vs {alpha0}",
                h.moment(0)
            );
            assert!((h.eval(0.0) - 1.0).abs() < 1e-12, "H(0) = 1");
        }
        // Conservative scattering: H(1) = 2.9078 and the first moment α₁ = 2/√3 (Chandrasekhar's
        // table V.1 and eq. V.(41)).
        let h = HFunction::new(1.0).unwrap();
        assert!(HFunction::new(0.0).is_none() && HFunction::new(1.5).is_none());
        assert!((h.eval(1.0) - 2.9078).abs() < 2e-3, "H(1) = {}", h.eval(1.0));
        assert!((h.moment(1) - 2.0 / 3f64.sqrt()).abs() < 2e-3, "α₁ = {}", h.moment(1));
    }

    #[test]
    fn reflected_radiance_integrates_to_the_albedo() {
        for omega in [0.3, 0.8, 0.95] {
            let h = HFunction::new(omega).unwrap();
            let (x, w) = gauss_legendre_unit(64);
            // Outgoing flux per unit irradiance: 2π ∫ L_r(μ) μ dμ.
            let flux: f64 = x
                .iter()
                .zip(&w)
                .map(|(&mu, &w)| w * half_space_reflectance(&h, mu) * mu)
                .sum::<f64>()
                * 2.0
                * std::f64::consts::PI;
            let a = half_space_albedo(&h);
            assert!((flux - a).abs() < 1e-4, "ω = {omega}: {flux} vs {a}");
        }
    }
}
