//! The fields a grid medium carries besides its density: a temperature grid's blackbody
//! emission, and colour grids (emission, albedo, extinction), each with its own placement.

use super::super::grid::DensityGrid;
use crate::math::Rgb;
use glam::{Affine3A, Vec3};

/// Blackbody emission from a temperature grid, as pbrt-v4's `nanovdb` medium defines it: with
/// T'(p) = (T(p) − offset) · scale, L_e(p) = blackbody_scale · B̂(T'(p)) where T' exceeds `cutoff`
/// and zero elsewhere (B̂: the peak-normalised Planck spectrum as linear sRGB, see
/// [`super::super::blackbody`]).
#[derive(Clone, Debug)]
pub struct TemperatureField {
    /// The grid's name in its file.
    pub name: String,
    /// The temperature grid (trilinear like the density).
    pub grid: DensityGrid,
    /// Scene → the temperature grid's index space.
    pub to_index: Affine3A,
    /// T' = (T − offset) · scale.
    pub scale: f32,
    /// Subtracted before scaling.
    pub offset: f32,
    /// No emission at or below this T' (K).
    pub cutoff: f32,
    /// Multiplies the blackbody colour.
    pub blackbody_scale: f32,
}

impl TemperatureField {
    /// The field of `grid` (placed in the scene by `to_scene`, like the density grid).
    pub fn new(
        grid: DensityGrid,
        to_scene: Affine3A,
        scale: f32,
        offset: f32,
        cutoff: f32,
        blackbody_scale: f32,
    ) -> Self {
        let to_index = index_from_grid(&grid) * to_scene.inverse();
        let name = "temperature".into();
        Self { name, grid, to_index, scale, offset, cutoff, blackbody_scale }
    }

    /// T' at a voxel of the temperature grid.
    #[inline]
    pub(crate) fn scaled(&self, t: f32) -> f32 {
        (t - self.offset) * self.scale
    }

    /// Emitted radiance at temperature `t` of the grid (before `offset` and `scale`).
    #[inline]
    pub(crate) fn le_of(&self, t: f32) -> Rgb {
        let t = self.scaled(t);
        if t > self.cutoff {
            super::super::blackbody::blackbody(t) * self.blackbody_scale
        } else {
            Rgb::ZERO
        }
    }

    /// Emitted radiance at scene point `p`.
    #[inline]
    pub fn le(&self, p: Vec3) -> Rgb {
        self.le_of(self.grid.density_index(self.to_index.transform_point3(p)))
    }
}

/// Emitted radiance from three float grids, one per channel, times a scale. (OpenVDB stores
/// colours as vector grids, which vdb-rs 0.6 cannot read: the channels come as float grids.)
#[derive(Clone, Debug)]
pub struct ColourField {
    /// The grids' names in their file (R, G, B).
    pub names: [String; 3],
    /// The grids, trilinear like the density.
    pub grids: [DensityGrid; 3],
    /// Scene → each grid's index space.
    pub to_index: [Affine3A; 3],
    /// Multiplies the three values.
    pub scale: f32,
}

impl ColourField {
    /// The field of `grids` (R, G, B), placed in the scene by `to_scene` like the density grid.
    pub fn new(
        grids: [DensityGrid; 3],
        names: [String; 3],
        to_scene: Affine3A,
        scale: f32,
    ) -> Self {
        let to_index = [0, 1, 2].map(|c| index_from_grid(&grids[c]) * to_scene.inverse());
        Self { names, grids, to_index, scale }
    }

    /// The field's value (the three grids' trilinear values times the scale) at scene point `p`.
    #[inline]
    pub fn at(&self, p: Vec3) -> Rgb {
        let v =
            [0, 1, 2].map(|c| self.grids[c].density_index(self.to_index[c].transform_point3(p)));
        Rgb::from(v) * self.scale
    }

    /// The largest value of any channel (each grid's maximum times the scale).
    pub fn max_value(&self) -> f32 {
        self.grids.iter().map(|g| g.max_density).fold(0.0, f32::max) * self.scale
    }

    /// A bound on the mean channel of the field anywhere.
    pub(crate) fn bound(&self) -> f32 {
        self.grids.iter().map(|g| g.max_density).sum::<f32>() / 3.0 * self.scale
    }
}

/// Index space of `grid` from its world space.
pub(super) fn index_from_grid(grid: &DensityGrid) -> Affine3A {
    Affine3A::from_scale(grid.voxel_size.recip()) * Affine3A::from_translation(-grid.translation)
}
