//! Where a grid medium emits, and how much at most: bounds on its emission over the unit cubes
//! between voxel centres (interpolation cells), kept per majorant cell, and the pick among them,
//! for the emitting-media sampler (`scene/light/media.rs`, whose module docs derive the bound).
//! They live here so that the grid's layout stays private to the medium.

use super::blackbody;
use super::blocks::Blocked;
use super::grid::DensityGrid;
use super::grid::MAJORANT_CELL;
use super::vdb::{ColourField, TemperatureField, VdbMedium};
use crate::math::luminance;
use glam::{Affine3A, IVec3, Vec3};
use rayon::prelude::*;
use std::f32::consts::PI;

/// Share of a grid's summed emission bounds added to its power estimate (the emission at voxel
/// centres), so that a grid whose centres happen not to emit is still a source.
const GUARD: f32 = 1e-3;

/// Interpolation cells in one majorant cell.
const PER_CELL: usize = (MAJORANT_CELL * MAJORANT_CELL * MAJORANT_CELL) as usize;

/// The interpolation cells of a grid, grouped by majorant cell: majorant cell `ids[k]` with
/// probability (cdf[k] − cdf[k−1]) / total, then its interpolation cell j (x fastest) with
/// probability by the cumulative bounds `local[512 k ..][j]`, then a uniform point in it.
#[derive(Clone, Debug)]
pub(crate) struct EmissionCells {
    /// Index space → scene.
    to_scene: Affine3A,
    /// Index-space position of majorant cell (0, 0, 0)'s corner, and the majorant cell count
    /// along each axis.
    lo: Vec3,
    cells: IVec3,
    ids: Vec<u32>,
    /// In f64: with millions of cells a small cell's weight must not vanish in the sum.
    cdf: Vec<f64>,
    /// Per listed majorant cell, its interpolation cells' cumulative bounds.
    local: Vec<f32>,
    /// Scene-space volume of one interpolation cell.
    pub(crate) voxel_volume: f32,
}

impl EmissionCells {
    /// The interpolation cells of grid medium `v` with their bounds (module docs), and the
    /// medium's estimated power (mean channel): the emission at voxel centres, plus [`GUARD`]
    /// of the bounds' sum.
    pub(crate) fn of(v: &VdbMedium) -> (Self, f32) {
        let (grid, to_index, cells, lo, majorant) = v.layout();
        let to_scene = to_index.inverse();
        let voxel_volume = to_scene.matrix3.determinant().abs();
        // σ_a per unit density: its largest channel bounds the mean channel of σ_a ⊙ L_e with
        // L_e's.
        let sigma_a = v.sigma_a_per_density().max_element();
        let constant = luminance(v.emission()).max(0.0);
        // Fields on the density's voxels are bounded voxel by voxel, others by their maxima.
        let temperature = v.temperature();
        let shared_temperature = temperature.filter(|t| t.to_index == to_index);
        let global_temperature = temperature.filter(|t| t.to_index != to_index).map_or(0.0, |t| {
            let (a, b) = (t.scaled(0.0), t.scaled(t.grid.max_density));
            blackbody_bound(t, a.min(b), a.max(b))
        });
        let colour = v.emission_grid();
        let shared_colour = colour.filter(|c| c.to_index.iter().all(|&t| t == to_index));
        let global_colour = colour.filter(|c| c.to_index.iter().any(|&t| t != to_index));
        let global_colour = global_colour.map_or(0.0, |c| c.bound());
        let fields = Fields {
            v,
            grid,
            to_scene,
            lo,
            majorant,
            temperature: shared_temperature,
            colour: shared_colour,
            uniform: [constant, global_temperature, global_colour],
            sigma_a,
        };
        let count = (cells.x * cells.y * cells.z) as usize;
        // Per majorant cell: the emission at its voxel centres, and its interpolation cells' bounds.
        let per_cell: Vec<(f32, Option<Vec<f32>>)> = (0..count)
            .into_par_iter()
            .map(|i| {
                let i = i as i32;
                fields.cell(IVec3::new(i % cells.x, i / cells.x % cells.y, i / cells.x / cells.y))
            })
            .collect();
        let (mut ids, mut cdf, mut local, mut total, mut centres) =
            (Vec::new(), Vec::new(), Vec::new(), 0.0f64, 0.0f64);
        for (i, (sum, bounds)) in per_cell.into_iter().enumerate() {
            centres += sum as f64;
            if let Some(b) = bounds {
                total += b[PER_CELL - 1] as f64;
                ids.push(i as u32);
                cdf.push(total);
                local.extend_from_slice(&b);
            }
        }
        let power = centres + GUARD as f64 * total;
        let power = (4.0 * PI as f64 * power * voxel_volume as f64) as f32;
        (EmissionCells { to_scene, lo, cells, ids, cdf, local, voxel_volume }, power)
    }

    /// The sum of every cell's bound on the emission's mean channel.
    #[cfg(test)]
    pub(crate) fn bound_sum(&self) -> f64 {
        self.cdf.last().copied().unwrap_or(0.0)
    }

    /// The point that the uniforms pick: a majorant cell by its bounds (`u_cell`, 53 bits: there
    /// may be millions), an interpolation cell in it by its bound (`u_voxel`), the point `u_pos`
    /// of that cell; with its density per unit volume and the cell's bound on the emission's
    /// mean channel at any of its points. `None` if no cell emits.
    pub(crate) fn pick(&self, u_cell: f64, u_voxel: f32, u_pos: Vec3) -> Option<(Vec3, f32, f32)> {
        let c = self.cells;
        let total = *self.cdf.last()?;
        let j = self.cdf.partition_point(|&c| c <= u_cell * total).min(self.cdf.len() - 1);
        let weight = self.cdf[j] - if j == 0 { 0.0 } else { self.cdf[j - 1] };
        let (weight, total) = (weight as f32, total as f32);
        let id = self.ids[j] as i32;
        let cell = IVec3::new(id % c.x, id / c.x % c.y, id / c.x / c.y);
        // An interpolation cell of it by its bound.
        let sums = &self.local[j * PER_CELL..(j + 1) * PER_CELL];
        let sum = sums[PER_CELL - 1];
        let v = sums.partition_point(|&c| c <= u_voxel * sum).min(PER_CELL - 1);
        let bound = sums[v] - if v == 0 { 0.0 } else { sums[v - 1] };
        let (m, v) = (MAJORANT_CELL, v as i32);
        let offset = IVec3::new(v % m, v / m % m, v / m / m);
        let q = self.lo + (cell * m + offset).as_vec3() + u_pos;
        let pdf = weight / total * (bound / sum) / self.voxel_volume;
        // `bound`: the cell's bound on the emission's mean channel at any of its points.
        Some((self.to_scene.transform_point3(q), pdf, bound))
    }
}

/// What bounding a grid's emission cell by cell reads: the medium, its density grid and layout,
/// the emission fields that share the density's voxels, and the bounds that hold everywhere.
struct Fields<'a> {
    v: &'a VdbMedium,
    grid: &'a DensityGrid,
    to_scene: Affine3A,
    lo: Vec3,
    majorant: &'a Blocked<f32>,
    /// A temperature field on the density's voxels, bounded voxel by voxel.
    temperature: Option<&'a TemperatureField>,
    /// Colour grids on the density's voxels, bounded voxel by voxel.
    colour: Option<&'a ColourField>,
    /// Bounds on L_e's mean channel everywhere: the constant emission, a temperature field's
    /// and colour grids' on other voxels (by their maxima).
    uniform: [f32; 3],
    /// σ_a's largest channel per unit density.
    sigma_a: f32,
}

/// The values at the (8 + 1)³ voxels that one majorant cell's interpolation reads: density,
/// scaled temperature, the colour grids' mean channel; and the emission at its voxel centres.
struct Corners {
    density: Vec<f32>,
    temp: Vec<f32>,
    rgb: Vec<f32>,
    centres: f32,
}

/// Voxels along an edge of the corner block.
const N: usize = (MAJORANT_CELL + 1) as usize;

/// Index of corner voxel (x, y, z) in a [`Corners`] block.
#[inline]
fn at(x: usize, y: usize, z: usize) -> usize {
    x + N * (y + N * z)
}

impl Fields<'_> {
    /// Majorant cell `c`: the emission at its voxel centres, and its interpolation cells'
    /// cumulative bounds (none if they sum to nothing).
    fn cell(&self, c: IVec3) -> (f32, Option<Vec<f32>>) {
        // A cell without density emits nothing (and costs no lookups).
        if self.majorant.get(c) <= 0.0 {
            return (0.0, None);
        }
        let corners = self.corners((self.lo + (c * MAJORANT_CELL).as_vec3()).as_ivec3());
        let (sums, total) = self.bounds(&corners);
        let bounds = (total > 0.0 && total.is_finite()).then_some(sums);
        (corners.centres, bounds)
    }

    /// The (cell + 1)³ voxels from `base` that a cell's interpolation reads: density, the
    /// temperature's emission bound range, the colour grids' mean channel.
    fn corners(&self, base: IVec3) -> Corners {
        let n = N;
        let mut density = vec![0.0f32; n * n * n];
        let mut temp = vec![0.0f32; if self.temperature.is_some() { n * n * n } else { 0 }];
        let mut rgb = vec![0.0f32; if self.colour.is_some() { n * n * n } else { 0 }];
        let mut centres = 0.0f32;
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let q = base + IVec3::new(x as i32, y as i32, z as i32);
                    let k = at(x, y, z);
                    density[k] = self.grid.voxel(q);
                    if let Some(t) = self.temperature {
                        temp[k] = t.scaled(t.grid.voxel(q));
                    }
                    if let Some(c) = self.colour {
                        let v = c.grids.each_ref().map(|g| g.voxel(q));
                        rgb[k] = v.iter().sum::<f32>() / 3.0 * c.scale;
                    }
                    if density[k] > 0.0 && x < n - 1 && y < n - 1 && z < n - 1 {
                        let p = self.to_scene.transform_point3(q.as_vec3());
                        centres += luminance(self.v.sigma_a(p) * self.v.le(p));
                    }
                }
            }
        }
        Corners { density, temp, rgb, centres }
    }

    /// The cumulative bounds of a majorant cell's interpolation cells (x fastest) from its
    /// corner values, and their sum.
    fn bounds(&self, corners: &Corners) -> (Vec<f32>, f32) {
        let Corners { density, temp, rgb, .. } = corners;
        let [constant, global_temperature, global_colour] = self.uniform;
        let mut sums = vec![0.0f32; PER_CELL];
        let mut total = 0.0f32;
        let m = MAJORANT_CELL as usize;
        for z in 0..m {
            for y in 0..m {
                for x in 0..m {
                    let corners = (0..8).map(|k| at(x + (k & 1), y + (k >> 1 & 1), z + (k >> 2)));
                    let (mut d, mut t0, mut t1, mut e) = (0.0f32, f32::MAX, f32::MIN, 0.0f32);
                    for k in corners {
                        d = d.max(density[k]);
                        if !temp.is_empty() {
                            (t0, t1) = (t0.min(temp[k]), t1.max(temp[k]));
                        }
                        if !rgb.is_empty() {
                            e = e.max(rgb[k]);
                        }
                    }
                    let mut le = constant + global_temperature + global_colour;
                    if let Some(t) = self.temperature {
                        le += blackbody_bound(t, t0, t1);
                    }
                    // The colour's mean channel is trilinear in its corners' means.
                    le += e;
                    let b = if d > 0.0 { d * self.sigma_a * le } else { 0.0 };
                    total += b;
                    sums[x + m * (y + m * z)] = total;
                }
            }
        }
        (sums, total)
    }
}

/// A bound on the mean channel of a temperature field's emission where its scaled temperature T'
/// lies in [t0, t1]: none at or below the cut-off.
fn blackbody_bound(t: &TemperatureField, t0: f32, t1: f32) -> f32 {
    if t1 <= t.cutoff {
        return 0.0;
    }
    blackbody::max_mean_channel(t0.max(t.cutoff), t1) * t.blackbody_scale
}
