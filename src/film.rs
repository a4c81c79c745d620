//! Accumulation of iteration images: a running sum in f64 and the number of iterations, so the
//! image is the mean of the iterations (Knaus & Zwicker 2011, eq. 4). A running sum of squares
//! gives each pixel's sample variance over the iterations, from which references carry an
//! estimate of their own noise.

use crate::math::Rgb;
use glam::DVec3;

/// The accumulated render.
#[derive(Clone)]
pub struct Film {
    width: u32,
    height: u32,
    sum: Vec<DVec3>,
    sum_sq: Vec<DVec3>,
    iterations: u64,
}

impl Film {
    /// An empty film.
    pub fn new(width: u32, height: u32) -> Self {
        let n = (width * height) as usize;
        Self {
            width,
            height,
            sum: vec![DVec3::ZERO; n],
            sum_sq: vec![DVec3::ZERO; n],
            iterations: 0,
        }
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

    /// Adds one finished iteration image (row-major, top row first).
    pub fn add(&mut self, image: &[Rgb]) {
        debug_assert_eq!(image.len(), self.sum.len());
        for ((s, q), p) in self.sum.iter_mut().zip(&mut self.sum_sq).zip(image) {
            let v = p.as_dvec3();
            *s += v;
            *q += v * v;
        }
        self.iterations += 1;
    }

    /// The mean of the iterations so far (black before the first).
    pub fn mean(&self) -> Vec<[f32; 3]> {
        let inv = if self.iterations == 0 { 0.0 } else { 1.0 / self.iterations as f64 };
        self.sum.iter().map(|s| (*s * inv).as_vec3().to_array()).collect()
    }

    /// Each pixel's estimated variance of the mean: the sample variance of its iteration values
    /// divided by the iteration count (zero before the second iteration). Exact in expectation when
    /// the iterations are identically distributed (the path tracer); for photon mapping, whose
    /// iterations drift as the radius shrinks, it also counts that drift and so overstates the noise.
    pub fn variance_of_mean(&self) -> Vec<[f32; 3]> {
        let n = self.iterations as f64;
        if self.iterations < 2 {
            return vec![[0.0; 3]; self.sum.len()];
        }
        self.sum
            .iter()
            .zip(&self.sum_sq)
            .map(|(s, q)| {
                let mean = *s / n;
                let var = ((*q - *s * mean) / (n - 1.0)).max(DVec3::ZERO);
                (var / n).as_vec3().to_array()
            })
            .collect()
    }

    /// Counts one more iteration whose running estimate is `image` itself rather than a term of
    /// a mean (the original PPM keeps per-pixel statistics, not a mean of iterations): afterwards
    /// [`Self::mean`] returns `image` and the variance estimate is zero.
    pub fn replace(&mut self, image: &[Rgb]) {
        debug_assert_eq!(image.len(), self.sum.len());
        self.iterations += 1;
        let n = self.iterations as f64;
        for ((s, q), p) in self.sum.iter_mut().zip(&mut self.sum_sq).zip(image) {
            *s = p.as_dvec3() * n;
            *q = *s * *s / n;
        }
    }
}
