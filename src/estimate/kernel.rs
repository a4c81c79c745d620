//! Normalised radial kernels for density estimation (Silverman 1986, table 3.1).
//!
//! With u = distance / r, a kernel of dimension d is K(u) · r^−d and integrates to one over the
//! d-ball of radius r:
//!
//! | kernel       | 2-D            | 3-D                 |
//! |--------------|----------------|---------------------|
//! | constant     | 1/π            | 3/(4π)              |
//! | Epanechnikov | (2/π)(1−u²)    | (15/(8π))(1−u²)     |
//! | biweight     | (3/π)(1−u²)²   | (105/(32π))(1−u²)²  |

use std::f32::consts::PI;

crate::choices::choices! {
    /// A density-estimation kernel.
    pub enum Kernel ("kernel") {
        /// Uniform over the ball.
        Constant = "constant",
        /// 1 − u² (the MSE-optimal kernel).
        Epanechnikov = "epanechnikov",
        /// (1 − u²)².
        Biweight = "biweight",
    }
}

impl Kernel {
    /// Kernel value at squared normalised distance `u2` = (d / r)² for dimension `dim` (2 or 3),
    /// without the r^−d factor; zero outside the unit ball.
    #[inline]
    pub fn eval(self, u2: f32, dim: u32) -> f32 {
        if u2 >= 1.0 {
            return 0.0;
        }
        let three = dim == 3;
        match self {
            Kernel::Constant => {
                if three {
                    3.0 / (4.0 * PI)
                } else {
                    1.0 / PI
                }
            }
            Kernel::Epanechnikov => (1.0 - u2) * if three { 15.0 / (8.0 * PI) } else { 2.0 / PI },
            Kernel::Biweight => {
                let s = 1.0 - u2;
                s * s * if three { 105.0 / (32.0 * PI) } else { 3.0 / PI }
            }
        }
    }

    /// The kernel's values at `u2` for radius r and for the inner radius r/√2 of the bias
    /// estimate (`Estimate`), both without the common r^−d factor: (K(u²),
    /// 2^{d/2} K(2u²)).
    #[inline]
    pub fn eval_pair(self, u2: f32, dim: u32) -> (f32, f32) {
        let inner = if dim == 3 { std::f32::consts::SQRT_2 * 2.0 } else { 2.0 };
        (self.eval(u2, dim), inner * self.eval(2.0 * u2, dim))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn kernels_integrate_to_one() {
        let n = 100_000;
        for &k in Kernel::ALL {
            // Radial quadrature (midpoint rule): ∫ K(u) · (2πu | 4πu²) du over [0, 1].
            let (mut two, mut three) = (0.0f64, 0.0f64);
            for i in 0..n {
                let u = (i as f64 + 0.5) / n as f64;
                let du = 1.0 / n as f64;
                two += k.eval((u * u) as f32, 2) as f64 * 2.0 * PI * u * du;
                three += k.eval((u * u) as f32, 3) as f64 * 4.0 * PI * u * u * du;
            }
            assert!((two - 1.0).abs() < 1e-5, "{k:?} 2-D integrates to {two}");
            assert!((three - 1.0).abs() < 1e-5, "{k:?} 3-D integrates to {three}");
            assert_eq!(k.eval(1.0, 2), 0.0);
            assert_eq!(k.eval(1.5, 3), 0.0);
            assert_eq!(k.name().parse::<Kernel>(), Ok(k));
        }
        assert!("gaussian".parse::<Kernel>().is_err());
    }
}
