//! View bins: the beam map's structure for eye segments on rays from a pinhole camera's eye. The
//! image plane is cut into square bins and every photon is entered in each bin its kernel
//! sphere's projection overlaps, so a query along such a ray scans the one bin it pierces.

use super::VolumePhoton;
use super::entries::{Entries, NO_SPAN, Span};
use crate::scene::camera::{Camera, Projection};
use glam::{IVec3, Vec3};
use rayon::prelude::*;

/// Side of a view bin in units of the median radius (in pixels) of the photons' projected spheres.
const BIN_PER_FOOTPRINT: f32 = 1.0;

/// Largest side of a view bin, in pixels.
const MAX_BIN_PIXELS: f32 = 64.0;

/// The view bins are skipped (the grid serves every query) when they would hold more than this
/// many entries per photon on average — a camera inside a dense cloud of photons, for instance.
const MAX_VIEW_ENTRIES_PER_PHOTON: usize = 32;

/// How far (in units of the radius) a segment's line may pass from the eye and still use the
/// view bins: it covers the offsets of ray origins at pass-through interfaces.
pub(super) const VIEW_LINE_MARGIN: f32 = 0.01;

/// Bins on the image plane of a pinhole camera, in the plane's tangent coordinates
/// (u, v) = (x/z, y/z) of the camera frame (x right, y up, z forward).
#[derive(Default)]
pub(super) struct ViewBins {
    pub(super) entries: Entries,
    eye: Vec3,
    right: Vec3,
    pub(super) up: Vec3,
    pub(super) forward: Vec3,
    /// Lower corner of bin (0, 0), in (u, v).
    u0: f32,
    v0: f32,
    inv_bin: f32,
    pub(super) nx: i32,
    pub(super) ny: i32,
    /// Squared distance from the eye a segment's line may pass at and still use the bins.
    margin2: f32,
    /// Radius of the spheres entered: the query radius grown by the margin.
    grow: f32,
}

impl ViewBins {
    /// Sets up bins for `camera` over `photons` queried with radius `radius`; false for cameras
    /// that are not pinholes, and when the bins would hold more than `MAX_VIEW_ENTRIES_PER_PHOTON`
    /// entries per photon.
    pub(super) fn setup(&mut self, camera: &Camera, photons: &[VolumePhoton], radius: f32) -> bool {
        let Projection::Perspective { tan_half_fov, lens_radius, .. } = camera.projection else {
            return false;
        };
        if lens_radius > 0.0 {
            return false;
        }
        let [w, h] = camera.resolution;
        (self.eye, self.right, self.up, self.forward) =
            (camera.position, camera.right, camera.up, camera.forward);
        let margin = VIEW_LINE_MARGIN * radius;
        self.margin2 = margin * margin;
        self.grow = radius * 1.001 + margin;
        // Pixels are square: 2 tan(fov/2) / height on both axes.
        let pixel = 2.0 * tan_half_fov / h as f32;
        // The median radius, in pixels, of the projections of the photons in front of the eye
        // sets the bin size.
        let mut depth: Vec<f32> = photons
            .iter()
            .step_by(photons.len().div_ceil(4096).max(1))
            .map(|p| (p.p - self.eye).dot(self.forward))
            .filter(|&z| z > self.grow)
            .collect();
        let footprint = if depth.is_empty() {
            1.0
        } else {
            let n = depth.len();
            self.grow / *depth.select_nth_unstable_by(n / 2, f32::total_cmp).1 / pixel
        };
        let bin_pixels = (footprint * BIN_PER_FOOTPRINT).clamp(1.0, MAX_BIN_PIXELS).round();
        self.inv_bin = 1.0 / (bin_pixels * pixel);
        self.nx = (w as f32 / bin_pixels).ceil() as i32;
        self.ny = (h as f32 / bin_pixels).ceil() as i32;
        self.u0 = -tan_half_fov * camera.aspect();
        self.v0 = -tan_half_fov;
        // Entries per photon, from an evenly strided sample.
        let stride = photons.len().div_ceil(1 << 15);
        let sample: Vec<&VolumePhoton> = photons.iter().step_by(stride).collect();
        let entries: usize = sample
            .par_iter()
            .map(|p| {
                self.footprint(p.p)
                    .map_or(0, |(a, b)| (b - a + IVec3::ONE).element_product() as usize)
            })
            .sum();
        entries <= MAX_VIEW_ENTRIES_PER_PHOTON * sample.len()
    }

    /// Enters `photons` in the bins (set up by `setup`).
    pub(super) fn fill(&mut self, photons: &[VolumePhoton], spans: &mut Vec<Span>) {
        let span = |p: &VolumePhoton| self.footprint(p.p).unwrap_or(NO_SPAN);
        crate::buffers::collect(spans, photons.par_iter().map(span));
        // Rows of bins are the grid's z-slices, so that bands of rows are filled in parallel.
        self.entries.fill(IVec3::new(self.nx, 1, self.ny), photons, spans);
    }

    /// The bin that `p` projects to; one past the last bin if it lies behind the eye or outside.
    pub(super) fn centre_bin(&self, p: Vec3) -> u32 {
        let c = p - self.eye;
        let z = c.dot(self.forward);
        let bx = (c.dot(self.right) / z - self.u0) * self.inv_bin;
        let by = (c.dot(self.up) / z - self.v0) * self.inv_bin;
        if z > 0.0 && bx >= 0.0 && by >= 0.0 && bx < self.nx as f32 && by < self.ny as f32 {
            by as u32 * self.nx as u32 + bx as u32
        } else {
            (self.nx * self.ny) as u32
        }
    }

    /// The bins (inclusive corners) that the projection of the sphere of radius `grow` around `p`
    /// overlaps, if any: the projection lies within the bounds of the camera-aligned cube around
    /// the sphere, and only its part in front of the eye (z > 0) matters.
    fn footprint(&self, p: Vec3) -> Option<Span> {
        let grow = self.grow;
        let c = p - self.eye;
        let (x, y, z) = (c.dot(self.right), c.dot(self.up), c.dot(self.forward));
        let (z0, z1) = (z - grow, z + grow);
        if z1 <= 0.0 {
            return None;
        }
        // Bounds of c/z over c ∈ [c0, c1], z ∈ [z0, z1] ∩ (0, ∞).
        let range = |c0: f32, c1: f32| {
            if z0 > 0.0 {
                ((c0 / z0).min(c0 / z1), (c1 / z0).max(c1 / z1))
            } else {
                (
                    if c0 >= 0.0 { c0 / z1 } else { f32::NEG_INFINITY },
                    if c1 <= 0.0 { c1 / z1 } else { f32::INFINITY },
                )
            }
        };
        let to_bins = |(lo, hi): (f32, f32), origin: f32, n: i32| {
            // A margin for the rounding of these bounds and of the query's own projection.
            let size = |v: f32| if v.is_finite() { v.abs() } else { 0.0 };
            let pad = 1e-6 * (1.0 + size(lo).max(size(hi)));
            let (a, b) = ((lo - pad - origin) * self.inv_bin, (hi + pad - origin) * self.inv_bin);
            if b < 0.0 || a >= n as f32 {
                return None;
            }
            Some((a.max(0.0) as i32, (b.min(n as f32 - 1.0) as i32).min(n - 1)))
        };
        let (ax, bx) = to_bins(range(x - grow, x + grow), self.u0, self.nx)?;
        let (ay, by) = to_bins(range(y - grow, y + grow), self.v0, self.ny)?;
        Some((IVec3::new(ax, 0, ay), IVec3::new(bx, 0, by)))
    }

    /// The bin holding every photon a query along o + t d (t > 0) can find, if the segment lies on
    /// a ray from the eye (within the margin) that pierces the image plane inside the bins.
    #[inline]
    pub(super) fn bin(&self, o: Vec3, d: Vec3) -> Option<usize> {
        let z = d.dot(self.forward);
        let rel = o - self.eye;
        if z <= 0.0 || rel.dot(d) < 0.0 || rel.cross(d).length_squared() > self.margin2 {
            return None;
        }
        let bx = (d.dot(self.right) / z - self.u0) * self.inv_bin;
        let by = (d.dot(self.up) / z - self.v0) * self.inv_bin;
        if bx >= 0.0 && by >= 0.0 && bx < self.nx as f32 && by < self.ny as f32 {
            Some(by as usize * self.nx as usize + bx as usize)
        } else {
            None
        }
    }
}
