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
//! - [`PointSourceMedium`]: the fluence of an isotropic point source in an infinite medium with
//!   isotropic scattering (all orders, or single scattering), and the radiance it sends along a
//!   camera ray.

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

/// The source function at the surface of the half-space, per unit irradiance: the in-scattered
/// radiance σ_s ∫ f_p L dω / σ_t just inside the surface, which is the limit of
/// [`half_space_reflectance`] at grazing exit, ω H(1) H(0) / (4π) with H(0) = 1 (the emergent
/// radiance is ∫ S(τ) e^{−τ/μ} dτ/μ, which tends to S(0) as μ → 0). It sets the boundary bias of
/// kernel estimates near the surface.
pub fn half_space_surface_source(h: &HFunction) -> f64 {
    h.omega() * h.eval(1.0) / (4.0 * std::f64::consts::PI)
}

/// Singly scattered radiance reflected by a homogeneous slab of optical thickness τ (σ_t = 1 per
/// unit optical depth, albedo ω) under collimated light at normal incidence, towards a direction
/// with cosine μ to the surface normal, per unit irradiance; `phase` is the phase function's value
/// for the scattering angle between the light's direction and the exit direction (cos θ = −μ).
/// Light at depth z is E e^{−z}; it scatters into the exit direction with ω σ_t f_p and leaves
/// with e^{−z/μ}, over a path length dz/μ:
///
///   L₁(μ)/E = ∫₀^τ ω f_p e^{−z(1 + 1/μ)} dz/μ = ω f_p (1 − e^{−τ(1 + 1/μ)}) / (1 + μ).
pub fn slab_single_scattering(omega: f64, tau: f64, mu: f64, phase: f64) -> f64 {
    omega * phase * (1.0 - (-tau * (1.0 + 1.0 / mu)).exp()) / (1.0 + mu)
}

/// Fraction of the normally incident power the half-space reflects: 1 − √(1 − ω) H(1).
pub fn half_space_albedo(h: &HFunction) -> f64 {
    1.0 - (1.0 - h.omega()).sqrt() * h.eval(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exponential integral E₁(x), x > 0 (series below 1, continued fraction above).
    fn e1(x: f64) -> f64 {
        if x < 1.0 {
            let mut sum = 0.0;
            let mut term = 1.0;
            for k in 1..60 {
                term *= -x / k as f64;
                sum -= term / k as f64;
            }
            -0.577_215_664_901_532_9 - x.ln() + sum
        } else {
            // Lentz on E1(x) = e^{-x} / (x + 1 / (1 + 1 / (x + 2 / (1 + 2 / (x + …))))).
            let (mut b, mut c, mut d) = (x + 1.0, 1e300, 1.0 / (x + 1.0));
            let mut h = d;
            for i in 1..200 {
                let a = -(i as f64) * (i as f64);
                b += 2.0;
                d = 1.0 / (a * d + b);
                c = b + a / c;
                let del = c * d;
                h *= del;
                if (del - 1.0).abs() < 1e-15 {
                    break;
                }
            }
            h * (-x).exp()
        }
    }

    #[test]
    fn single_scattered_fluence_agrees_with_a_real_space_integral() {
        // φ₁(r) = (ω / (2r)) ∫₀^∞ (e^{−r'}/(4π r')) [E₁(|r − r'|) − E₁(r + r')] dr', evaluated
        // with substitutions that smooth the logarithmic singularity at r' = r.
        use std::f64::consts::PI;
        let (x, w) = gauss_legendre_unit(200);
        for omega in [0.3, 0.9] {
            let m = PointSourceMedium { omega };
            for r in [0.5, 1.0, 2.0, 5.0] {
                let f = |rp: f64| {
                    (-rp).exp() / (4.0 * PI * rp) * (e1((r - rp).abs().max(1e-300)) - e1(r + rp))
                };
                // [0, r]: r' = r (1 − s²).
                let a: f64 =
                    x.iter().zip(&w).map(|(&s, &w)| w * f(r * (1.0 - s * s)) * 2.0 * r * s).sum();
                // [r, r + 40]: r' = r + s², s ∈ [0, √40].
                let sm = 40f64.sqrt();
                let b: f64 = x
                    .iter()
                    .zip(&w)
                    .map(|(&u, &w)| {
                        let s = u * sm;
                        w * sm * f(r + s * s) * 2.0 * s
                    })
                    .sum();
                let direct = omega / (2.0 * r) * (a + b);
                let fourier = m.scattered(Scattering::Single, r);
                assert!(
                    (fourier / direct - 1.0).abs() < 2e-3,
                    "ω {omega}, r {r}: {fourier} vs {direct}"
                );
            }
        }
    }

    #[test]
    fn multiply_scattered_fluence_exceeds_single_scattering() {
        // All orders ≥ the first, and close to it in a nearly absorbing medium near the source.
        for r in [0.5, 2.0, 6.0] {
            let thin = PointSourceMedium { omega: 0.05 };
            let (s, c) =
                (thin.scattered(Scattering::Single, r), thin.scattered(Scattering::Collided, r));
            assert!(c >= s, "r {r}: {c} vs {s}");
            if r < 1.0 {
                assert!(c / s - 1.0 < 0.05, "r {r}: {c} vs {s}");
            }
            let thick = PointSourceMedium { omega: 0.9 };
            assert!(
                thick.scattered(Scattering::Collided, r)
                    > 1.5 * thick.scattered(Scattering::Single, r)
            );
        }
    }

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
    fn single_scattering_is_the_first_order_of_the_half_space() {
        // For a thick slab and isotropic scattering, L₁ is the half-space reflectance with H = 1:
        // their ratio is H(1) H(μ) = 1 + O(ω).
        for mu in [0.3, 0.6, 1.0] {
            let phase = 1.0 / (4.0 * std::f64::consts::PI);
            let thick = slab_single_scattering(1e-3, 50.0, mu, phase);
            let h = HFunction::new(1e-3).unwrap();
            let full = half_space_reflectance(&h, mu);
            assert!((full / thick - 1.0).abs() < 2e-3, "μ {mu}: {full} vs {thick}");
            // A midpoint-rule integral of the depth integrand.
            let (tau, n) = (0.7, 200_000);
            let dz = tau / n as f64;
            let sum: f64 = (0..n)
                .map(|i| {
                    let z = (i as f64 + 0.5) * dz;
                    0.8 * phase * (-z * (1.0 + 1.0 / mu)).exp() * dz / mu
                })
                .sum();
            let closed = slab_single_scattering(0.8, tau, mu, phase);
            assert!((sum / closed - 1.0).abs() < 1e-8, "μ {mu}: {sum} vs {closed}");
        }
        // The surface source is the grazing limit of the reflectance.
        let h = HFunction::new(0.8).unwrap();
        let grazing = half_space_reflectance(&h, 1e-9);
        assert!((half_space_surface_source(&h) / grazing - 1.0).abs() < 1e-6);
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

/// Fluence around an isotropic point source of unit power in an infinite homogeneous medium with
/// isotropic scattering, in units where σ_t = 1 (distances in mean free paths).
///
/// Method (haze's own): the Fourier transform of the fluence of a unit point source is
/// F(k) = g(k) / (1 − ω g(k)), g(k) = arctan(k)/k (Case & Zweifel, *Linear Transport Theory*,
/// 1967, §2.6); the uncollided part is g, the single-scattered part ω g². The radial inversion
/// φ(r) = 1/(2π² r) ∫₀^∞ k sin(kr) F(k) dk converges slowly because F_c ~ ωπ²/(4k²); that tail is
/// taken out as ωπ²/(4(k² + 1)), whose transform is (π/2) e^{−r} in closed form, and the rest, now
/// decaying like k⁻³, is integrated numerically (Simpson, k ≤ 4000).
#[derive(Clone, Copy, Debug)]
pub struct PointSourceMedium {
    /// Single-scattering albedo ω ∈ [0, 1).
    pub omega: f64,
}

/// Which part of the fluence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scattering {
    /// Light that scattered exactly once.
    Single,
    /// Light that scattered any number of times (≥ 1).
    Collided,
}

impl PointSourceMedium {
    fn g(k: f64) -> f64 {
        if k < 1e-4 { 1.0 - k * k / 3.0 } else { k.atan() / k }
    }

    /// Transform of the part `which`, minus its k⁻² tail ωπ²/(4(k² + 1)).
    fn remainder(&self, which: Scattering, k: f64) -> f64 {
        let g = Self::g(k);
        let part = match which {
            Scattering::Single => self.omega * g * g,
            Scattering::Collided => self.omega * g * g / (1.0 - self.omega * g),
        };
        part - self.omega * std::f64::consts::PI.powi(2) / (4.0 * (k * k + 1.0))
    }

    /// Uncollided fluence e^{−r}/(4π r²).
    pub fn uncollided(&self, r: f64) -> f64 {
        (-r).exp() / (4.0 * std::f64::consts::PI * r * r)
    }

    /// Scattered fluence (single or all orders) at distance r > 0.
    pub fn scattered(&self, which: Scattering, r: f64) -> f64 {
        use std::f64::consts::PI;
        let k_max = 4000.0;
        // Enough Simpson intervals for sin(kr) (≥ 24 per period), and for the peak of the
        // transform near k = 0, whose width is about √(3(1 − ω)) (≥ 20 steps across it).
        let width = (3.0 * (1.0 - self.omega)).sqrt().max(1e-3);
        let per_unit = (24.0 * r / (2.0 * PI)).max(20.0 / width).max(5.0);
        let n = (((k_max * per_unit).min(4e7)) as usize + 1) & !1;
        let h = k_max / n as f64;
        let f = |k: f64| k * (k * r).sin() * self.remainder(which, k);
        let mut sum = f(0.0) + f(k_max);
        for i in 1..n {
            sum += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        let numeric = sum * h / 3.0;
        let tail = self.omega * PI * PI / 4.0 * (PI / 2.0) * (-r).exp();
        (numeric + tail) / (2.0 * PI * PI * r)
    }

    /// Radiance reaching a camera at distance `b` (mean free paths) from the source, looking
    /// along a ray whose closest approach to the source is the camera itself (perpendicular to
    /// the line to the source), for a source of unit power: ∫₀^∞ e^{−t} ω φ(√(b² + t²)) / (4π) dt,
    /// with φ the fluence that has scattered once (`Single`: the single-scattered radiance) or the
    /// total fluence (`Collided`: the full radiance, uncollided light included as the source of
    /// the first scattering).
    /// `None` unless b > 0.
    pub fn camera_radiance(&self, which: Scattering, b: f64) -> Option<f64> {
        use std::f64::consts::PI;
        if !(b > 0.0 && b.is_finite()) {
            return None;
        }
        // φ on a grid of distances, then Simpson in t with linear interpolation in r.
        let t_max = 40.0;
        let n = 2000;
        let h = t_max / n as f64;
        let r_max = (b * b + t_max * t_max).sqrt();
        let grid_n = 400;
        let rs: Vec<f64> =
            (0..=grid_n).map(|i| b + (r_max - b) * i as f64 / grid_n as f64).collect();
        let phi: Vec<f64> = rs
            .iter()
            .map(|&r| match which {
                Scattering::Single => self.uncollided(r),
                Scattering::Collided => self.uncollided(r) + self.scattered(which, r),
            })
            .collect();
        let lookup = |r: f64| {
            let x = (r - b) / (r_max - b) * grid_n as f64;
            let i = (x.floor() as usize).min(grid_n - 1);
            let f = x - i as f64;
            // Interpolate r²φ (smooth) rather than φ.
            let a = phi[i] * rs[i] * rs[i];
            let c = phi[i + 1] * rs[i + 1] * rs[i + 1];
            (a + (c - a) * f) / (r * r)
        };
        let integrand =
            |t: f64| (-t).exp() * self.omega * lookup((b * b + t * t).sqrt()) / (4.0 * PI);
        let mut sum = integrand(0.0) + integrand(t_max);
        for i in 1..n {
            sum += integrand(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        Some(sum * h / 3.0)
    }
}
