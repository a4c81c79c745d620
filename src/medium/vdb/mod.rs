//! A heterogeneous medium from an OpenVDB density grid.
//!
//! ```toml
//! [media.cloud]
//! type = "vdb"
//! file = "../media/cloud.vdb"   # relative to the scene file
//! grid = "density"              # default
//! density_scale = 4.0           # multiplies the grid's values (default 1)
//! sigma_a = 0.5                 # per unit density (RGB or grey) …
//! sigma_s = 4.0                 # … or albedo and sigma_t (σ_t may be coloured)
//! g = 0.3
//! transform = { scale = 1.5, translate = [0, 1, 0] }   # grid space → scene
//! # optional: albedo_grid = { grids = ["albedo.r", "albedo.g", "albedo.b"] }  # σ_s(p) = a(p) σ_t(p)
//! # optional: extinction_grid = { grids = "Cd" }   # σ_x,c(p) = … · e_c(p) in channel c
//! ```
//!
//! σ_x(p) = density_scale · density(p) · σ_x, with density(p) trilinear between voxel centres;
//! with an albedo grid, σ_s(p) = a(p) σ_t(p) and σ_a(p) = (1 − a(p)) σ_t(p) instead; an
//! extinction grid multiplies every coefficient of channel c by its value e_c(p).
//! Free flights are sampled by delta tracking (Woodcock et al. 1965) against a piecewise-constant
//! majorant: a coarse grid holding, per cell of [`MAJORANT_CELL`]³ voxels, the largest density
//! any point of the cell can interpolate to, walked with a 3-D DDA so empty cells cost one step.
//! Where more than [`SPLIT_STEPS`] tentative collisions are expected in a cell, the ray's part of
//! it is bisected under tighter bounds ([`VdbMedium::density_bounds`], times
//! [`VdbMedium::colour_bounds`] with an extinction grid; docs/theory.md), so a majorant that
//! dwarfs the extinction along the ray costs few steps.
//! Transmittance is estimated by ratio tracking (Novák et al. 2014) against the same majorant; for
//! the beam estimate one ratio-tracking run per eye segment, at four times the majorant's rate
//! ([`super::BEAM_SEGMENT_RATE`]), is kept as a step function
//! T(0, t) = Π_{t_k < t} (1 − σ_t(t_k)/(4 μ̄(t_k))) and looked up for every photon on the segment
//! (each prefix of a ratio-tracking run is itself an unbiased ratio-tracking estimate). Below a
//! small estimate ratio tracking plays Russian roulette (`medium/tracker.rs`).
//!
//! A coloured extinction is tracked per channel against the largest channel's majorant: ratio
//! tracking per channel, and spectral delta tracking with the balance heuristic over a hero
//! channel (`tracker::spectral_free_flight_with`; docs/theory.md). The grid describes itself to the
//! one tracker (`medium/tracker.rs`), which does all of this for any medium: its majorants in
//! `tracking.rs`.

mod fields;
mod tracking;

pub use fields::{ColourField, TemperatureField};

use super::blocks::Blocked;
use super::grid::{DensityGrid, MAJORANT_CELL};
use super::phase::HenyeyGreenstein;
use crate::math::Rgb;
use fields::index_from_grid;
use glam::{Affine3A, IVec3, Vec3};
use std::sync::atomic::{AtomicU64, Ordering};

/// Expected tentative collisions in one majorant cell above which the cell's part of a ray is
/// bisected under tighter bounds ([`VdbMedium::density_bounds`]). Real media stay below it (so
/// their random sequences are those of one rate per cell); it bounds the work where a majorant
/// dwarfs the density, such as at the edge of a grid scaled to 10³⁰.
const SPLIT_STEPS: f32 = 256.0;

/// A count shared by the threads of a render (cloning starts a new count from the same value).
#[derive(Debug, Default)]
struct Counter(AtomicU64);

impl Clone for Counter {
    fn clone(&self) -> Self {
        Counter(AtomicU64::new(self.0.load(Ordering::Relaxed)))
    }
}

/// A VDB medium.
#[derive(Clone, Debug)]
pub struct VdbMedium {
    grid: DensityGrid,
    /// Scene → grid index space.
    to_index: Affine3A,
    /// σ_s per unit of (scaled) density, and σ_t's largest channel (the one majorants bound).
    sigma_s: Rgb,
    sigma_t: f32,
    /// Coloured extinction: σ_t per channel over `sigma_t` (each ≤ 1, one of them 1); `None`
    /// where σ_t is grey.
    tint: Option<Rgb>,
    /// σ_a / σ_t per channel (zero where σ_t is): σ_a at a point is this times σ_t there.
    absorption_share: Rgb,
    /// Emitted radiance everywhere the grid absorbs (the source σ_a L_e follows the density).
    emission: Rgb,
    /// Blackbody emission from a temperature grid, added to `emission`.
    temperature: Option<Box<TemperatureField>>,
    /// Emitted radiance from colour grids, added to both.
    emission_grid: Option<Box<ColourField>>,
    /// Single-scattering albedo from colour grids, replacing the constant σ_s / σ_t: σ_s(p) =
    /// albedo(p) σ_t(p), σ_a(p) = (1 − albedo(p)) σ_t(p).
    albedo_grid: Option<Box<ColourField>>,
    /// Coloured extinction from colour grids: σ_t,c(p) = density(p) · σ_t,c · e_c(p), σ_a and σ_s
    /// in proportion (the albedo stays). Stored normalised, its largest value 1, with that
    /// largest value folded into `sigma_t`, `sigma_s` and so into the majorants.
    extinction_grid: Option<Box<ColourField>>,
    /// Per majorant cell, a bound on the normalised extinction field's channels there (each
    /// cell's μ̄ is its density majorant times this times σ_t); empty without an extinction grid.
    extinction_majorant: Option<Blocked<f32>>,
    phase: HenyeyGreenstein,
    /// Majorant densities per coarse cell (x fastest), covering index space from `lo`.
    majorant: Blocked<f32>,
    cells: IVec3,
    lo: Vec3,
    /// Trackings cut at the tracker's step cap.
    truncated: Counter,
    /// [`SPLIT_STEPS`] (tests lower it to bisect every cell).
    split_steps: f32,
}

impl VdbMedium {
    /// Builds the medium from a loaded grid. `to_scene` places the grid's world space in the
    /// scene; `density_scale` multiplies the grid's values.
    pub fn new(
        mut grid: DensityGrid,
        to_scene: Affine3A,
        density_scale: f32,
        sigma_a: Rgb,
        sigma_s: Rgb,
        phase: HenyeyGreenstein,
    ) -> Self {
        grid.scale_values(density_scale);
        let to_index = index_from_grid(&grid) * to_scene.inverse();
        // Trilinear lookups are non-zero for q in (first − 1, last + 1) of the active box: cover
        // it (the active box, not the layout's, so that both layouts track alike).
        let (first, last) = grid.active_box;
        let lo = (first - IVec3::ONE).as_vec3();
        let extent = last - first + IVec3::ONE;
        let cells = (extent + IVec3::splat(2) + IVec3::splat(MAJORANT_CELL - 1)) / MAJORANT_CELL;
        let majorant = grid.majorants(first - IVec3::ONE, cells);
        // Grey (to f32 rounding, which the average removes), or coloured: then the largest
        // channel sets the majorant and the others are its fractions.
        let t = sigma_a + sigma_s;
        let grey = t.max_element() - t.min_element() <= 1e-5 * t.max_element();
        let sigma_t = if grey { t.element_sum() / 3.0 } else { t.max_element() };
        let tint = (!grey).then(|| t / sigma_t);
        let absorption_share = if sigma_t > 0.0 { sigma_a / sigma_t } else { Rgb::ZERO };
        Self {
            grid,
            to_index,
            sigma_s,
            sigma_t,
            tint,
            absorption_share,
            emission: Rgb::ZERO,
            temperature: None,
            emission_grid: None,
            albedo_grid: None,
            extinction_grid: None,
            extinction_majorant: None,
            phase,
            majorant,
            cells,
            lo,
            truncated: Counter::default(),
            split_steps: SPLIT_STEPS,
        }
    }

    /// The medium emitting radiance `emission` wherever it absorbs, plus blackbody radiance from
    /// `temperature` if given: L_e(p) = emission + temperature's L_e(p), the source σ_a(p) L_e(p).
    pub fn with_emission(mut self, emission: Rgb, temperature: Option<TemperatureField>) -> Self {
        self.emission = emission;
        self.temperature = temperature.map(Box::new);
        self
    }

    /// The medium also emitting the radiance of three colour grids (added to the rest).
    pub fn with_emission_grid(mut self, field: Option<ColourField>) -> Self {
        self.emission_grid = field.map(Box::new);
        self
    }

    /// The medium with its albedo from colour grids (values in [0, 1]; the caller checks), in
    /// place of the constant σ_s / σ_t it was built with: its extinction stays.
    pub fn with_albedo_grid(mut self, field: Option<ColourField>) -> Self {
        self.albedo_grid = field.map(Box::new);
        self
    }

    /// The medium with its extinction coloured by colour grids (values ≥ 0, the caller checks):
    /// every channel's σ_t, σ_a and σ_s at p multiplied by the field's value there.
    pub fn with_extinction_grid(mut self, field: Option<ColourField>) -> Self {
        if let Some(mut field) = field {
            // Normalised to a largest value of 1 (so that the scalar σ_t bounds every channel
            // everywhere and the density majorants stay valid), the largest value moved into σ_t
            // and σ_s; σ_a follows σ_t through `absorption_share`.
            let max = field.max_value();
            if max > 0.0 {
                field.scale /= max;
            } else {
                field.scale = 0.0;
            }
            self.sigma_t *= max;
            self.sigma_s *= max;
            // Each cell's largest field value where the field's grids share the density's index
            // space (as grids of one file written together do), so that the majorants follow
            // the field too (a constant density with all its structure in the colour still
            // skips the field's empty regions); 1 (the normalised maximum) elsewhere. Raised by
            // a few ulps for the rounding of trilinear lookups.
            self.extinction_majorant = if field.to_index.iter().all(|t| *t == self.to_index) {
                let per: Vec<Blocked<f32>> = field
                    .grids
                    .iter()
                    .map(|g| g.majorants(self.lo.as_ivec3(), self.cells))
                    .collect();
                let scale = field.scale * (1.0 + 1e-5);
                Some(Blocked::from_fn(self.cells, |c| {
                    per.iter().map(|m| m.get(c)).fold(0.0f32, f32::max) * scale
                }))
            } else {
                None
            };
            self.extinction_grid = Some(Box::new(field));
        }
        self
    }

    /// The (normalised) extinction grid's colour at `p`; 1 without one.
    #[inline]
    fn extinction_colour(&self, p: Vec3) -> Rgb {
        self.extinction_grid.as_ref().map_or(Rgb::ONE, |e| e.at(p))
    }

    /// σ_t per channel at `p` over the scalar σ_t · density(p): each in [0, 1].
    #[inline]
    fn tint_at(&self, p: Vec3) -> Rgb {
        self.tint.unwrap_or(Rgb::ONE) * self.extinction_colour(p)
    }

    /// σ_a / (the scalar σ_t) at `p`, per channel, with `e` the extinction colour there.
    #[inline]
    fn absorption_share_at(&self, p: Vec3, e: Rgb) -> Rgb {
        let share = match &self.albedo_grid {
            Some(a) => (Rgb::ONE - a.at(p)).max(Rgb::ZERO) * self.tint.unwrap_or(Rgb::ONE),
            None => self.absorption_share,
        };
        share * e
    }

    /// The colour grids' emission, if any.
    pub(crate) fn emission_grid(&self) -> Option<&ColourField> {
        self.emission_grid.as_deref()
    }

    /// True if the medium can emit (it absorbs somewhere, and some emission is given).
    pub fn emits(&self) -> bool {
        (self.absorption_share.max_element() > 0.0 || self.albedo_grid.is_some())
            && self.grid.max_density > 0.0
            && (self.emission.max_element() > 0.0
                || self.temperature.is_some()
                || self.emission_grid.is_some())
    }

    /// Emitted radiance L_e at `p` (the medium adds σ_a(p) L_e(p) per unit length).
    #[inline]
    pub fn le(&self, p: Vec3) -> Rgb {
        let mut le = match &self.temperature {
            Some(t) => self.emission + t.le(p),
            None => self.emission,
        };
        if let Some(c) = &self.emission_grid {
            le += c.at(p);
        }
        le
    }

    /// σ_a at `p`.
    #[inline]
    pub fn sigma_a(&self, p: Vec3) -> Rgb {
        self.absorption_share_at(p, self.extinction_colour(p)) * (self.sigma_t * self.density(p))
    }

    /// The grid's density (scaled), its map from scene to index space, and the majorant cells
    /// (count, index-space origin and majorants), for samplers of the medium's emission.
    pub(crate) fn layout(&self) -> (&DensityGrid, Affine3A, IVec3, Vec3, &Blocked<f32>) {
        (&self.grid, self.to_index, self.cells, self.lo, &self.majorant)
    }

    /// σ_a per unit of (scaled) density, or a bound on it where an albedo grid (then σ_t) or an
    /// extinction grid (then its largest value) varies it.
    pub(crate) fn sigma_a_per_density(&self) -> Rgb {
        match self.albedo_grid {
            Some(_) => self.tint.unwrap_or(Rgb::ONE) * self.sigma_t,
            None => self.absorption_share * self.sigma_t,
        }
    }

    /// The temperature field, if any.
    pub(crate) fn temperature(&self) -> Option<&TemperatureField> {
        self.temperature.as_deref()
    }

    /// The emission colour given for the whole grid.
    pub(crate) fn emission(&self) -> Rgb {
        self.emission
    }

    /// The phase function.
    pub fn phase(&self) -> &HenyeyGreenstein {
        &self.phase
    }

    /// Density (scaled) at scene point `p`.
    #[inline]
    pub fn density(&self, p: Vec3) -> f32 {
        self.grid.density_index(self.to_index.transform_point3(p))
    }

    /// σ_s at `p`.
    #[inline]
    pub fn sigma_s(&self, p: Vec3) -> Rgb {
        match &self.albedo_grid {
            Some(a) => a.at(p) * (self.tint_at(p) * (self.sigma_t * self.density(p))),
            None => match &self.extinction_grid {
                Some(e) => self.sigma_s * e.at(p) * self.density(p),
                None => self.sigma_s * self.density(p),
            },
        }
    }

    /// Feeds what defines the medium (grid, placement, coefficients; not its counters) to
    /// `feed`, for a scene's fingerprint.
    pub(crate) fn fingerprint(&self, feed: &mut dyn FnMut(&[u8])) {
        let g = &self.grid;
        feed(
            format!("{:?} {:?} {:?} {:?}", g.origin, g.dims, g.translation, g.voxel_size)
                .as_bytes(),
        );
        g.feed_values(feed);
        let t =
            format!("{:?} {:?} {:?} {:?}", self.to_index, self.sigma_s, self.sigma_t, self.phase);
        feed(t.as_bytes());
        if let Some(tint) = self.tint {
            feed(format!("tint {tint:?}").as_bytes());
        }
        if let Some(c) = &self.albedo_grid {
            feed(format!("albedo grids {:?} {:?} {}", c.names, c.to_index, c.scale).as_bytes());
            c.grids.iter().for_each(|g| g.feed_values(feed));
        }
        if let Some(c) = &self.extinction_grid {
            let what = format!("extinction grids {:?} {:?} {}", c.names, c.to_index, c.scale);
            feed(what.as_bytes());
            c.grids.iter().for_each(|g| g.feed_values(feed));
        }
        // Emission, only where given (fingerprints of media without it stay as they were).
        if self.emits() {
            feed(format!("emission {:?} {:?}", self.absorption_share, self.emission).as_bytes());
            if let Some(t) = &self.temperature {
                let g = &t.grid;
                let what = (g.origin, g.dims, g.translation, g.voxel_size, t.to_index);
                feed(
                    format!(
                        "temperature {what:?} {:?}",
                        (t.scale, t.offset, t.cutoff, t.blackbody_scale)
                    )
                    .as_bytes(),
                );
                g.feed_values(feed);
            }
            if let Some(c) = &self.emission_grid {
                feed(
                    format!("emission grids {:?} {:?} {}", c.names, c.to_index, c.scale).as_bytes(),
                );
                c.grids.iter().for_each(|g| g.feed_values(feed));
            }
        }
    }

    /// Trackings so far cut at the tracker's step cap (zero in any sensible medium).
    pub fn truncated_trackings(&self) -> u64 {
        self.truncated.0.load(Ordering::Relaxed)
    }
}

#[cfg(test)]
mod tests;
