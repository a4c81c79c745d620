//! Per-tile statistical comparison of two images that carry their noise: each tile's mean
//! difference in standard errors, with a Šidák correction over the tiles — a test that sees
//! *where* two renders disagree, not only whether their means do (Mitsuba 3 tests its renders
//! per pixel against a reference and its variance image in the same spirit).
//!
//! For a tile T of n pixel channels, with images a and b, their per-pixel variances of the mean
//! v_a and v_b (the EXR layer `variance` every render writes) and optional bias bounds β_a, β_b:
//!
//! - Δ = mean over T of (a − b); s = √(Σ_pixels ((Σ_c σ_a,c)² + (Σ_c σ_b,c)²)) / n with σ = √v,
//!   the standard error of Δ when the pixels' errors are independent and a pixel's three
//!   channels (which come from the same paths) fully correlated — conservative where they are
//!   less so; a non-finite pixel fails its tile;
//! - the allowance B = mean over T of (β_a + β_b), and z = sign(Δ) · max(0, |Δ| − B) / s;
//! - the tile fails if |z| > z*, with z* the two-sided critical value at the per-tile level
//!   1 − (1 − α)^{1/m} for m tiles (Šidák): the chance that any tile of two images of the same
//!   expectation fails is α.
//!
//! - beside the tiles, each channel's **whole-image mean** is tested the same way (the pooled
//!   test: Δ_c and s_c over every pixel, s_c = √(Σ v_a,c + v_b,c) / N): a uniform shift too small
//!   to show in any one tile — a colour channel 2 % off everywhere — shows there. The m tiles and
//!   the three channels share the family-wise α (Šidák over m + 3 tests).
//!
//! Independence holds for the path tracer (every pixel's samples are its own). A photon-mapping
//! image's neighbouring pixels share photons, so their errors are positively correlated and s
//! understates the tile's noise — and s_c of the pooled test far more, since every pixel of the
//! image shares the photons: compare such images through several independent renders
//! ([`tile_means`] over seeds) rather than through their variance layers.

use crate::error::{Error, Result};

/// An image with its per-pixel variance of the mean and, optionally, a per-pixel bias bound.
#[derive(Clone, Copy, Debug)]
pub struct NoisyImage<'a> {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear RGB, row-major.
    pub pixels: &'a [[f32; 3]],
    /// Estimated variance of the mean, per pixel and channel.
    pub variance: &'a [[f32; 3]],
    /// Bound on the absolute bias, per pixel and channel (zero if `None`).
    pub bias: Option<&'a [[f32; 3]]>,
}

/// One tile's comparison.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tile {
    /// Left column and top row of the tile.
    pub x0: u32,
    /// Top row.
    pub y0: u32,
    /// Mean difference a − b over the tile's pixels and channels.
    pub difference: f64,
    /// Standard error of the difference.
    pub se: f64,
    /// Bias allowance (mean of the two bias bounds over the tile).
    pub allowance: f64,
    /// The difference beyond the allowance, in standard errors (signed).
    pub z: f64,
}

/// The comparison of every tile.
#[derive(Clone, Debug)]
pub struct Comparison {
    /// Edge of a tile in pixels (tiles at the right and bottom may be smaller).
    pub tile: u32,
    /// Family-wise significance α.
    pub significance: f64,
    /// Critical |z| per tile (Šidák over the tiles).
    pub critical_z: f64,
    /// Every tile, row by row.
    pub tiles: Vec<Tile>,
    /// The whole image's mean, one channel at a time (R, G, B): the pooled test, with the tiles'
    /// critical value. Its tiles' `x0`, `y0` are 0.
    pub pooled: [Tile; 3],
}

impl Comparison {
    /// The tiles whose |z| exceeds the critical value.
    pub fn failures(&self) -> Vec<&Tile> {
        self.tiles.iter().filter(|t| t.z.abs() > self.critical_z).collect()
    }

    /// The channels (0 R, 1 G, 2 B) whose whole-image mean differs beyond the critical value.
    pub fn pooled_failures(&self) -> Vec<usize> {
        (0..3).filter(|&c| self.pooled[c].z.abs() > self.critical_z).collect()
    }

    /// True if no tile and no channel's whole-image mean fails.
    pub fn pass(&self) -> bool {
        self.failures().is_empty() && self.pooled_failures().is_empty()
    }

    /// The smallest shift of channel `c`'s whole-image mean, relative to image b's, that the
    /// pooled test detects with power 0.9: (z* + z₀.₉) s_c / |mean_b,c| (plus the allowance).
    pub fn pooled_detectable(&self, c: usize, mean_b: f64) -> f64 {
        let t = &self.pooled[c];
        (t.allowance + (self.critical_z + 1.2816) * t.se) / mean_b.abs()
    }

    /// The tile of largest |z|.
    pub fn worst(&self) -> Option<&Tile> {
        self.tiles.iter().max_by(|a, b| a.z.abs().total_cmp(&b.z.abs()))
    }

    /// A one-line summary: tiles, failures, the worst tile.
    pub fn summary(&self) -> String {
        let worst = self.worst().map_or(String::new(), |t| {
            format!(
                "; worst tile at ({}, {}): difference {:.4e} ± {:.4e}{}, z {:+.2}",
                t.x0,
                t.y0,
                t.difference,
                t.se,
                if t.allowance > 0.0 {
                    format!(" (bias allowance {:.3e})", t.allowance)
                } else {
                    String::new()
                },
                t.z
            )
        });
        let pooled = self.pooled.map(|t| format!("{:+.2}", t.z));
        format!(
            "{} of {} tiles of {}×{} differ beyond |z| {:.2} (significance {} over all tiles and the three channel means, Šidák){worst}; whole-image channel means z {}, {}, {}{}",
            self.failures().len(),
            self.tiles.len(),
            self.tile,
            self.tile,
            self.critical_z,
            self.significance,
            pooled[0],
            pooled[1],
            pooled[2],
            if self.pooled_failures().is_empty() { "" } else { " (FAIL)" }
        )
    }
}

/// The two-sided critical |z| for `tiles` tests at family-wise level `significance` (Šidák).
pub fn critical_z(tiles: usize, significance: f64) -> f64 {
    use statrs::distribution::{ContinuousCDF, Normal};
    let per_tile = 1.0 - (1.0 - significance).powf(1.0 / tiles.max(1) as f64);
    let normal = Normal::new(0.0, 1.0).expect("the standard normal");
    normal.inverse_cdf(1.0 - per_tile / 2.0)
}

/// Refuses images of different sizes, layers of the wrong length, an empty tile or a
/// significance outside (0, 1).
fn check_inputs(a: &NoisyImage, b: &NoisyImage, tile: u32, significance: f64) -> Result<()> {
    let bad = |m: String| Error::Invalid {
        path: Default::default(),
        line: None,
        key: "tiles".into(),
        message: m,
    };
    if (a.width, a.height) != (b.width, b.height) {
        return Err(bad(format!(
            "the images differ in size: {}x{} and {}x{}",
            a.width, a.height, b.width, b.height
        )));
    }
    let n = (a.width * a.height) as usize;
    for (what, len) in [
        ("pixels", a.pixels.len()),
        ("pixels", b.pixels.len()),
        ("variance", a.variance.len()),
        ("variance", b.variance.len()),
        ("bias", a.bias.map_or(n, |v| v.len())),
        ("bias", b.bias.map_or(n, |v| v.len())),
    ] {
        if len != n {
            return Err(bad(format!("{what}: {len} values for {n} pixels")));
        }
    }
    if tile == 0 || !(significance > 0.0 && significance < 1.0) {
        return Err(bad(format!(
            "tile {tile} and significance {significance}: need a tile of at least 1 and 0 < α < 1"
        )));
    }
    Ok(())
}

/// A tile's difference in standard errors beyond its kernel-bias allowance (0 within it; ±∞ for
/// a non-finite difference or noise, or a difference beyond the allowance without noise).
fn z_of(difference: f64, se: f64, allowance: f64) -> f64 {
    let excess = (difference.abs() - allowance).max(0.0);
    if !difference.is_finite() || !se.is_finite() {
        // A non-finite pixel (NaN, ∞) fails its tile whatever else it holds.
        f64::INFINITY
    } else {
        match (excess > 0.0, se > 0.0) {
            (false, _) => 0.0,
            (true, true) => excess / se * difference.signum(),
            (true, false) => f64::INFINITY * difference.signum(),
        }
    }
}

/// Compares `a` and `b` tile by tile (tiles of `tile`×`tile` pixels) at family-wise level
/// `significance` (see the module documentation).
pub fn compare(a: &NoisyImage, b: &NoisyImage, tile: u32, significance: f64) -> Result<Comparison> {
    check_inputs(a, b, tile, significance)?;
    let n = (a.width * a.height) as usize;
    let w = a.width as usize;
    let pooled = [0, 1, 2].map(|c| {
        let (mut diff, mut var, mut allowance) = (0.0, 0.0, 0.0);
        for i in 0..n {
            diff += a.pixels[i][c] as f64 - b.pixels[i][c] as f64;
            var += (a.variance[i][c] as f64).max(0.0) + (b.variance[i][c] as f64).max(0.0);
            allowance +=
                a.bias.map_or(0.0, |v| v[i][c] as f64) + b.bias.map_or(0.0, |v| v[i][c] as f64);
        }
        let (difference, se, allowance) =
            (diff / n as f64, var.sqrt() / n as f64, allowance / n as f64);
        Tile { x0: 0, y0: 0, difference, se, allowance, z: z_of(difference, se, allowance) }
    });
    let mut tiles = Vec::new();
    for y0 in (0..a.height).step_by(tile as usize) {
        for x0 in (0..a.width).step_by(tile as usize) {
            let (mut diff, mut var, mut allowance, mut count) = (0.0, 0.0, 0.0, 0.0);
            for y in y0..(y0 + tile).min(a.height) {
                for x in x0..(x0 + tile).min(a.width) {
                    let i = y as usize * w + x as usize;
                    // A pixel's channels come from the same paths: their errors are taken as
                    // fully correlated, so the standard deviations of the three add.
                    let (mut sd_a, mut sd_b) = (0.0, 0.0);
                    for c in 0..3 {
                        diff += a.pixels[i][c] as f64 - b.pixels[i][c] as f64;
                        sd_a += (a.variance[i][c] as f64).max(0.0).sqrt();
                        sd_b += (b.variance[i][c] as f64).max(0.0).sqrt();
                        allowance += a.bias.map_or(0.0, |v| v[i][c] as f64)
                            + b.bias.map_or(0.0, |v| v[i][c] as f64);
                        count += 1.0;
                    }
                    var += sd_a * sd_a + sd_b * sd_b;
                }
            }
            let (difference, allowance) = (diff / count, allowance / count);
            let se = var.sqrt() / count;
            tiles.push(Tile {
                x0,
                y0,
                difference,
                se,
                allowance,
                z: z_of(difference, se, allowance),
            });
        }
    }
    let critical_z = critical_z(tiles.len() + 3, significance);
    Ok(Comparison { tile, significance, critical_z, tiles, pooled })
}

/// Per-tile means of an image (RGB averaged), row by row, for comparisons through several
/// independent renders: their spread over renders estimates each tile's noise whatever the
/// correlation between its pixels.
pub fn tile_means(width: u32, height: u32, pixels: &[[f32; 3]], tile: u32) -> Vec<f64> {
    let w = width as usize;
    let mut out = Vec::new();
    for y0 in (0..height).step_by(tile.max(1) as usize) {
        for x0 in (0..width).step_by(tile.max(1) as usize) {
            let (mut sum, mut count) = (0.0, 0.0);
            for y in y0..(y0 + tile).min(height) {
                for x in x0..(x0 + tile).min(width) {
                    sum +=
                        pixels[y as usize * w + x as usize].iter().map(|&c| c as f64).sum::<f64>();
                    count += 3.0;
                }
            }
            out.push(sum / count);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, Sampler};

    /// Gaussian noise of standard deviation `sd` per pixel channel around `base`.
    fn noisy(base: f32, sd: f32, n: usize, seed: u64) -> Vec<[f32; 3]> {
        let mut s = Sampler::new(seed, Purpose::Other, 0, 7);
        (0..n)
            .map(|_| {
                [0; 3].map(|_| {
                    // Box–Muller.
                    let (u, v) = (s.next_f32().max(1e-7), s.next_f32());
                    base + sd * (-2.0 * u.ln()).sqrt() * (2.0 * std::f32::consts::PI * v).cos()
                })
            })
            .collect()
    }

    #[test]
    fn the_critical_value_is_sidaks() {
        // One test: the plain two-sided 1.96 at 5 %; 1000 tiles at 10⁻³ overall: per tile
        // 1 − 0.999^(1/1000) ≈ 1.0005e-6, z ≈ 4.89.
        assert!((critical_z(1, 0.05) - 1.959964).abs() < 1e-5);
        assert!((critical_z(1000, 1e-3) - 4.8916).abs() < 1e-3, "{}", critical_z(1000, 1e-3));
    }

    /// Two images of the same expectation pass; a shift of about 12 standard errors in one tile
    /// fails there and nowhere else; a bias allowance of the shift's size lets it pass.
    #[test]
    fn a_shifted_tile_is_found_where_it_is() {
        let (w, h, sd) = (64u32, 48u32, 0.05f32);
        let n = (w * h) as usize;
        let variance = vec![[sd * sd; 3]; n];
        let a = noisy(1.0, sd, n, 1);
        let b = noisy(1.0, sd, n, 2);
        let image =
            |pixels| NoisyImage { width: w, height: h, pixels, variance: &variance, bias: None };
        let c = compare(&image(&a), &image(&b), 8, 1e-3).unwrap();
        assert_eq!(c.tiles.len(), 48);
        assert!(c.pass(), "{}", c.summary());
        // The tile mean's s.e., channels taken as fully correlated, is √(2·64·(3 sd)²) / 192 ≈
        // 0.0088; shift one tile by 0.06 (6.8 of them).
        let mut shifted = b.clone();
        for y in 16..24 {
            for x in 40..48 {
                shifted[y * w as usize + x].iter_mut().for_each(|c| *c += 0.06);
            }
        }
        let c = compare(&image(&a), &image(&shifted), 8, 1e-3).unwrap();
        let failed: Vec<(u32, u32)> = c.failures().iter().map(|t| (t.x0, t.y0)).collect();
        assert_eq!(failed, vec![(40, 16)], "{}", c.summary());
        // An allowance of 0.06 on one side covers it.
        let allowance = vec![[0.06; 3]; n];
        let covered = NoisyImage { bias: Some(&allowance), ..image(&shifted) };
        assert!(compare(&image(&a), &covered, 8, 1e-3).unwrap().pass());
        // A NaN pixel fails its tile, and only its tile.
        let mut broken = a.clone();
        broken[3][1] = f32::NAN;
        let c = compare(&image(&broken), &image(&b), 8, 1e-3).unwrap();
        let failed: Vec<(u32, u32)> = c.failures().iter().map(|t| (t.x0, t.y0)).collect();
        assert_eq!(failed, vec![(0, 0)], "{}", c.summary());
        // A uniform shift of one channel by 0.3 sd per pixel: 0.57 standard errors in each tile
        // (0.1 sd on the tile's mean over channels, s.e. 0.177 sd), invisible there, but 11.8
        // in the whole-image red mean (s.e. √(2 · 3072) sd / 3072 = 0.0255 sd).
        let mut red = b.clone();
        red.iter_mut().for_each(|p| p[0] += 0.3 * sd);
        let c = compare(&image(&a), &image(&red), 8, 1e-3).unwrap();
        assert!(c.failures().is_empty(), "{}", c.summary());
        assert_eq!(c.pooled_failures(), vec![0], "{}", c.summary());
        assert!(!c.pass());
        // Mismatched sizes are an error.
        let small = NoisyImage { width: 8, height: 8, ..image(&a) };
        assert!(compare(&image(&a), &small, 8, 1e-3).is_err());
    }
}
