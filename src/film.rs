//! Accumulation of iteration images: a running sum in f64 and the number of iterations, so the
//! image is the mean of the iterations (Knaus & Zwicker 2011, eq. 4).

use crate::math::Rgb;
use glam::DVec3;

/// The accumulated render.
#[derive(Clone)]
pub struct Film {
    width: u32,
    height: u32,
    sum: Vec<DVec3>,
    iterations: u64,
}

impl Film {
    /// An empty film.
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, sum: vec![DVec3::ZERO; (width * height) as usize], iterations: 0 }
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
        for (s, p) in self.sum.iter_mut().zip(image) {
            *s += p.as_dvec3();
        }
        self.iterations += 1;
    }

    /// The mean of the iterations so far (black before the first).
    pub fn mean(&self) -> Vec<[f32; 3]> {
        let inv = if self.iterations == 0 { 0.0 } else { 1.0 / self.iterations as f64 };
        self.sum.iter().map(|s| (*s * inv).as_vec3().to_array()).collect()
    }
}
