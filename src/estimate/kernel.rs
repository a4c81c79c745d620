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

crate::settings::choices! {
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
}
