//! Beam queries over volume photons: which photons lie within the query radius of a ray segment.
//! A query costs about the photons it finds, not the photons stored.
//!
//! Two structures over the same photons answer the same question:
//!
//! - **View bins**, for eye segments on a line through a pinhole camera's eye — in practice every
//!   segment of an eye path before its first change of direction, which is nearly every beam query
//!   in a scene viewed through fog. The image plane is cut into square bins a few pixels wide, and
//!   every photon is entered in each bin its kernel sphere's projection overlaps. A ray through the
//!   eye meets the sphere only where it pierces the image plane inside that projection, so the
//!   photons the query must test are the few in one bin: no walk, no corridor of cells. Segments
//!   that start at a pass-through interface are kept if their line passes within a small margin
//!   of the eye (the spheres are entered grown by that margin).
//! - A **dense uniform grid** over the photons' bounds, walked along the ray with a 3-D DDA
//!   (Amanatides & Woo 1987), for every other segment (after refraction or reflection, from a
//!   thin-lens or orthographic camera, or when the view bins would hold too many entries). Every
//!   photon is entered in each cell its kernel sphere overlaps. A query visits the cells the
//!   segment passes through, each for its own interval [t_in, t_out) of the ray, and takes a
//!   photon from a cell only if its projection t_p onto the ray falls in that interval: the point
//!   of the ray nearest a photon lies in exactly one visited cell, and a photon within the radius
//!   overlaps that cell, so every photon is found exactly once without any bookkeeping.
//!
//! Both find exactly the photons with 0 < t_p < t_max and distance below the radius (tested). The
//! order in which a query finds photons depends only on the ray, so sums are the same whatever the
//! thread count. Bins are numbered row by row, and cells along the axis nearest the view
//! direction first (x first without view bins); their entries are stored in that order, with the
//! photons sorted by the bin they project to (or, without view bins, the cell they lie in), so a
//! query reads memory that lies close together (a hashed grid was 2–3× slower: every cell visit
//! was a cache miss). The bucketed entries are in `entries.rs`, the view bins in `view.rs`. Both are built by parallel counting sorts whose
//! result does not depend on the thread count; buffers are reused between iterations.

use super::VolumePhoton;
use super::entries::{Entries, Lanes, Span};
use super::sort::CountingSort;
use super::view::ViewBins;
use crate::rng::{Purpose, Sampler};
use crate::scene::camera::Camera;
use glam::{IVec3, Vec3};
use rayon::prelude::*;

/// Mean photons per cell the grid's cell size aims for when the radius is small, when the grid
/// serves every query …
const PHOTONS_PER_CELL: f32 = 4.0;

/// … and when it only serves the segments the view bins cannot (measured on the volumetric
/// caustic: coarser cells build faster and cost those few queries little; docs/performance.md).
const PHOTONS_PER_FALLBACK_CELL: f32 = 16.0;

/// Most cells in the grid (4 bytes each in the cell table).
const MAX_CELLS: f32 = (1 << 22) as f32;

/// Russian-roulette thinning of dense photon cells, which bounds the cost of a beam query where
/// photons crowd (near a light inside a medium, in a volumetric caustic) without changing the
/// expected estimate.
///
/// Space is cut into thinning cells (cubes of the size the beam grid's cells have when the grid
/// serves every query: about `PHOTONS_PER_CELL` photons each on average, and at least twice the
/// radius). A photon whose centre lies in a thinning cell holding n > `budget` photons is kept
/// with probability p = budget / n, and its power is divided by p. The decision uses a random
/// number of its own, keyed by (seed, iteration, photon index), independent of everything else
/// once the photons are placed; so, given the photons, its expected contribution to any query is
/// exactly its contribution without thinning, and the estimate stays unbiased (its variance grows
/// where photons were dropped). A cell then holds about `budget` photons of its own, which bounds the photons a
/// query tests per unit length of its segment.
#[derive(Clone, Copy, Debug)]
pub struct Thinning {
    /// Photons a cell may hold before it is thinned.
    pub budget: u32,
    /// Render seed.
    pub seed: u64,
    /// Iteration (1-based).
    pub iteration: u64,
}

/// The extent of a photon cloud and the cell sizes that hold a given number of its photons.
struct Sizing {
    /// Lower corner of the photons' bounds, less the radius.
    lo: Vec3,
    /// Size of the bounds, grown by the radius on each side.
    extent: Vec3,
    /// Volume per photon in the central 90 % of the photons along each axis.
    volume_per_photon: f32,
    radius: f32,
}

impl Sizing {
    fn new(photons: &[VolumePhoton], radius: f32) -> Self {
        let (lo, hi) = photons
            .par_iter()
            .fold(|| (Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p.p), hi.max(p.p)))
            .reduce(|| (Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), (c, d)| (a.min(c), b.max(d)));
        let lo = lo - Vec3::splat(radius);
        let extent = (hi + Vec3::splat(radius) - lo).max(Vec3::splat(1e-6));
        // The photons' typical spacing, from the volume holding the central 90% of them along
        // each axis (a few stray photons far away must not make every cell huge), estimated from
        // an evenly strided sample.
        let stride = photons.len().div_ceil(1 << 16);
        // The sample gathered once, in parallel: a strided read misses the cache at every photon.
        let sample: Vec<Vec3> = photons.par_iter().step_by(stride).map(|p| p.p).collect();
        let side = |axis: usize| {
            let mut coord: Vec<f32> = sample.iter().map(|p| p[axis]).collect();
            let n = coord.len();
            let a = *coord.select_nth_unstable_by(n / 20, f32::total_cmp).1;
            let b = *coord.select_nth_unstable_by(n - 1 - n / 20, f32::total_cmp).1;
            (b - a).max(radius).max(1e-6 * extent.max_element())
        };
        // The three axes side by side.
        let (x, (y, z)) = rayon::join(|| side(0), || rayon::join(|| side(1), || side(2)));
        let core = Vec3::new(x, y, z);
        let volume_per_photon = core.element_product() / 0.9f32.powi(3) / photons.len() as f32;
        Self { lo, extent, volume_per_photon, radius }
    }

    /// The side of cells holding `per_cell` photons on average in the core, at least twice the
    /// radius, and no smaller than MAX_CELLS cells over the extent allow.
    fn cell(&self, per_cell: f32) -> f32 {
        let spacing = (per_cell * self.volume_per_photon).cbrt();
        let cap = (self.extent.element_product() / MAX_CELLS).cbrt();
        spacing.max(2.0 * self.radius).max(cap) * 1.0001
    }
}

/// The beam-query structure.
#[derive(Default)]
pub struct BeamMap {
    photons: Vec<VolumePhoton>,
    /// The grid's cells: cell c is bucket c.
    grid: Entries,
    dims: IVec3,
    inv_cell: f32,
    radius: f32,
    lo: Vec3,
    /// Axes from the fastest-varying in the cell numbering to the slowest.
    axes: [usize; 3],
    /// Index step per cell along x, y and z (derived from `axes` and `dims`).
    stride: IVec3,
    /// Bins for segments on rays from the eye, when the camera is a pinhole.
    view: ViewBins,
    view_active: bool,
    /// Scratch space, reused between builds.
    keys: Vec<u32>,
    count: Vec<u32>,
    sort: CountingSort,
    spans: Vec<Span>,
    spare: Vec<VolumePhoton>,
    /// With tracking on: for each photon kept by the thinning, its index in the built list …
    kept: Vec<u32>,
    /// … and for each slot, the index in the built list of the photon it holds.
    origin: Vec<u32>,
    track: bool,
}

impl BeamMap {
    /// An empty map.
    pub fn new() -> Self {
        Self::default()
    }

    /// The radius the map was last built for: its gathers' radius.
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// True if the last build made view bins (pinhole camera, not too many entries).
    #[cfg(test)]
    pub fn has_view_bins(&self) -> bool {
        self.view_active
    }

    /// Index of cell `c` (which must lie in the grid).
    #[inline]
    fn index(&self, c: IVec3) -> usize {
        (c * self.stride).element_sum() as usize
    }

    /// Cell coordinates reordered from the fastest-varying axis of the cell numbering to the
    /// slowest.
    #[inline]
    fn swizzle(&self, c: IVec3) -> IVec3 {
        let [a, b, d] = self.axes;
        IVec3::new(c[a], c[b], c[d])
    }

    /// Cell coordinates of `p`, clamped to the grid.
    #[inline]
    fn cell_of(&self, p: Vec3) -> IVec3 {
        // Truncation, then the clamp, gives the floor's cell (no libm floor in the hot loops).
        ((p - self.lo) * self.inv_cell).as_ivec3().clamp(IVec3::ZERO, self.dims - 1)
    }

    /// Rebuilds the map over `photons` for queries of radius `radius`, storing each photon with
    /// its power replaced by `weight(photon)` (the beam estimate stores β·σ_s(x_p) here, so that
    /// σ_s is looked up once per photon rather than once per ray that finds it). With a pinhole
    /// `camera`, it also builds the view bins for segments on rays from its eye.
    pub fn build(
        &mut self,
        photons: &[VolumePhoton],
        radius: f32,
        thinning: Option<Thinning>,
        camera: Option<&Camera>,
        weight: impl Fn(&VolumePhoton) -> crate::math::Rgb + Sync,
    ) {
        self.photons.clear();
        self.radius = radius;
        self.view_active = false;
        if photons.is_empty() {
            return;
        }
        self.view_active = camera.is_some_and(|c| self.view.setup(c, photons, radius));
        let sizing = Sizing::new(photons, radius);
        self.lay_out_grid(&sizing);
        self.weigh_and_thin(photons, &sizing, thinning, weight);
        self.reorder();
        // Enter each photon in every grid cell its (slightly grown) sphere overlaps.
        let grow = radius * 1.001 + 1e-6 * sizing.extent.max_element();
        let mut spans = std::mem::take(&mut self.spans);
        crate::buffers::collect(
            &mut spans,
            self.photons.par_iter().map(|p| {
                let (a, b) =
                    (self.cell_of(p.p - Vec3::splat(grow)), self.cell_of(p.p + Vec3::splat(grow)));
                (self.swizzle(a), self.swizzle(b))
            }),
        );
        let mut grid = std::mem::take(&mut self.grid);
        grid.fill(self.swizzle(self.dims), &self.photons, &spans);
        self.grid = grid;
        if self.view_active {
            let mut view = std::mem::take(&mut self.view);
            view.fill(&self.photons, &mut spans);
            self.view = view;
        }
        self.spans = spans;
    }

    /// Sets the grid's bounds, cell size and cell numbering.
    fn lay_out_grid(&mut self, sizing: &Sizing) {
        self.lo = sizing.lo;
        let per_cell = if self.view_active { PHOTONS_PER_FALLBACK_CELL } else { PHOTONS_PER_CELL };
        self.inv_cell = 1.0 / sizing.cell(per_cell);
        self.dims = (sizing.extent * self.inv_cell).ceil().as_ivec3().max(IVec3::ONE);
        // Cells are numbered x-fastest; but when the photons will be in view-bin order (image
        // rows, then columns), the axis nearest the view direction varies fastest and the one
        // nearest the image's up axis slowest, so that photons next to each other in that order
        // fill cells next to each other.
        self.axes = [0, 1, 2];
        if self.view_active {
            let dominant = |v: Vec3, skip: Option<usize>| {
                (0..3)
                    .filter(|&a| Some(a) != skip)
                    .max_by(|&a, &b| v[a].abs().total_cmp(&v[b].abs()))
            };
            let fast = dominant(self.view.forward, None).unwrap_or(2);
            let slow = dominant(self.view.up, Some(fast)).unwrap_or((fast + 1) % 3);
            self.axes = [fast, 3 - fast - slow, slow];
        }
        let [a, b, c] = self.axes;
        self.stride[a] = 1;
        self.stride[b] = self.dims[a];
        self.stride[c] = self.dims[a] * self.dims[b];
    }

    /// Puts the photons, with their powers replaced by `weight` and thinned, into `spare`.
    fn weigh_and_thin(
        &mut self,
        photons: &[VolumePhoton],
        sizing: &Sizing,
        thinning: Option<Thinning>,
        weight: impl Fn(&VolumePhoton) -> crate::math::Rgb + Sync,
    ) {
        self.spare.clear();
        self.kept.clear();
        let Some(t) = thinning else {
            let weighed = photons.par_iter().map(|p| VolumePhoton { beta: weight(p), ..*p });
            crate::buffers::collect(&mut self.spare, weighed);
            if self.track {
                self.kept.extend(0..photons.len() as u32);
            }
            return;
        };
        // Photons per thinning cell: cells of the size the grid has when it serves every query
        // (about PHOTONS_PER_CELL photons each on average), whatever the grid's own size.
        let inv = 1.0 / sizing.cell(PHOTONS_PER_CELL);
        let dims = (sizing.extent * inv).ceil().as_ivec3().max(IVec3::ONE);
        let key = |p: &VolumePhoton| {
            let c = ((p.p - sizing.lo) * inv).as_ivec3().clamp(IVec3::ZERO, dims - 1);
            (c.x + dims.x * (c.y + dims.y * c.z)) as u32
        };
        crate::buffers::collect(&mut self.keys, photons.par_iter().map(key));
        // Photons per thinning cell, from a counting sort's bucket starts.
        let mut cells = std::mem::take(&mut self.count);
        self.sort.starts(&self.keys, dims.element_product() as usize, &mut cells);
        let kept = |i: usize, k: u32| {
            let k = k as usize;
            let keep = (t.budget as f64 / (cells[k + 1] - cells[k]) as f64).min(1.0);
            if keep < 1.0 {
                let mut u = Sampler::new(t.seed, Purpose::Thinning, t.iteration, i as u64);
                if u.next_f32() as f64 >= keep {
                    return None;
                }
            }
            Some(keep)
        };
        self.spare.par_extend(photons.par_iter().zip(&self.keys).enumerate().filter_map(
            |(i, (p, &k))| {
                let keep = kept(i, k)?;
                Some(VolumePhoton { beta: weight(p) * (1.0 / keep) as f32, ..*p })
            },
        ));
        if self.track {
            let which =
                self.keys.par_iter().enumerate().filter_map(|(i, &k)| kept(i, k).map(|_| i as u32));
            self.kept.par_extend(which);
        }
        self.count = cells;
    }

    /// Moves the photons from `spare` into `photons`, ordered by the view bin their centre
    /// projects to when the view bins will serve most queries, else by grid cell, so that the
    /// photons a bucket lists lie together in memory (a stable counting sort).
    fn reorder(&mut self) {
        let kept = &self.spare;
        let mut keys = std::mem::take(&mut self.keys);
        let buckets = if self.view_active {
            crate::buffers::collect(&mut keys, kept.par_iter().map(|p| self.view.centre_bin(p.p)));
            (self.view.nx * self.view.ny) as usize + 1
        } else {
            let cell = |p: &VolumePhoton| self.index(self.cell_of(p.p)) as u32;
            crate::buffers::collect(&mut keys, kept.par_iter().map(cell));
            self.dims.element_product() as usize
        };
        let mut start = std::mem::take(&mut self.grid.start);
        // `source[j]` is the photon that goes to place j.
        let mut source = std::mem::take(&mut self.count);
        self.sort.sort(&keys, buckets, &mut start, &mut source);
        crate::buffers::collect(&mut self.photons, source.par_iter().map(|&i| kept[i as usize]));
        self.origin.clear();
        if self.track {
            let built = &self.kept;
            crate::buffers::collect(
                &mut self.origin,
                source.par_iter().map(|&i| built[i as usize]),
            );
        }
        self.grid.start = start;
        self.keys = keys;
        self.count = source;
    }

    /// Keep, from the next build on, which photon of the built list each slot holds
    /// ([`Self::origin`]); off by default.
    pub fn set_tracking(&mut self, on: bool) {
        self.track = on;
    }

    /// The photons held (slots 0..len): those the thinning kept.
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    /// The index in the built list of the photon in `slot` (with tracking on).
    pub fn origin(&self, slot: usize) -> usize {
        self.origin[slot] as usize
    }

    /// Calls `f(photon, t_p, d²)` for every photon whose projection onto the ray o + t d (d unit)
    /// falls at 0 < t_p < `t_max` within the build radius of the ray; d² is its squared distance
    /// to the ray.
    #[cfg(test)]
    pub fn query(&self, o: Vec3, d: Vec3, t_max: f32, mut f: impl FnMut(&VolumePhoton, f32, f32)) {
        self.query_slots(o, d, t_max, |ph, _, t, d2| f(ph, t, d2));
    }

    /// [`Self::query`], also passing each photon's slot.
    #[inline]
    pub fn query_slots(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        mut f: impl FnMut(&VolumePhoton, usize, f32, f32),
    ) {
        if self.photons.is_empty() {
            return;
        }
        let ray = Lanes::new(o, d, self.radius);
        let mut n = 0u64;
        let mut found = |i: u32, t: f32, d2: f32| {
            n += 1;
            f(&self.photons[i as usize], i as usize, t, d2)
        };
        match self.view_active.then(|| self.view.bin(o, d)).flatten() {
            Some(b) => self.view.entries.scan(b, &ray, 0.0, t_max, &mut found),
            None => {
                // Walk the cells in grid coordinates, where cell k spans [k, k + 1).
                let og = (o - self.lo) * self.inv_cell;
                let dg = d * self.inv_cell;
                crate::dda::walk(og, dg, t_max, self.dims, |cell, t_in, t_out| {
                    self.grid.scan(self.index(cell), &ray, t_in, t_out, &mut found);
                    true
                });
            }
        }
        crate::work::found(n);
    }
}

#[cfg(test)]
mod tests {
    use super::super::view::VIEW_LINE_MARGIN;
    use super::*;
    use crate::rng::{Purpose, Sampler};
    use crate::scene::camera::Projection;
    use glam::Vec2;

    fn cloud(s: &mut Sampler, n: usize, centre: Vec3, half: f32) -> Vec<VolumePhoton> {
        (0..n)
            .map(|i| VolumePhoton {
                p: centre
                    + (Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * 2.0 - 1.0) * half,
                medium: i as u16 % 3,
                ..Default::default()
            })
            .collect()
    }

    /// Asserts that the query along o + t d, 0 < t < t_max, finds exactly the photons a brute
    /// force search finds, each once.
    fn assert_exact(map: &BeamMap, photons: &[VolumePhoton], r: f32, o: Vec3, d: Vec3, t_max: f32) {
        let mut found = Vec::new();
        map.query(o, d, t_max, |ph, _, _| found.push(ph.p.to_array()));
        let mut want: Vec<[f32; 3]> = photons
            .iter()
            .filter(|ph| {
                let (t, d2) = super::super::entries::distance2(ph.p - o, d);
                t > 0.0 && t < t_max && d2 < r * r
            })
            .map(|ph| ph.p.to_array())
            .collect();
        let key = |a: &[f32; 3], b: &[f32; 3]| a.partial_cmp(b).unwrap();
        found.sort_by(key);
        want.sort_by(key);
        assert_eq!(found, want, "r = {r}, o = {o}, d = {d}, t_max = {t_max}");
    }

    #[test]
    fn beam_query_finds_exactly_the_photons_near_the_segment() {
        let mut s = Sampler::new(3, Purpose::Other, 0, 0);
        let photons = cloud(&mut s, 20_000, Vec3::ZERO, 1.0);
        let mut map = BeamMap::new();
        for r in [0.003f32, 0.01, 0.05, 0.2] {
            map.build(&photons, r, None, None, |p| p.beta);
            assert!(!map.has_view_bins());
            for q in 0..60 {
                let o = Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * 3.0 - 1.5;
                let d = match q {
                    0 => Vec3::Z,
                    1 => -Vec3::X,
                    2 => Vec3::new(1.0, 1.0, 0.0).normalize(),
                    _ => crate::math::sample_uniform_sphere(s.next_2d()),
                };
                let t_max = if q % 5 == 0 { f32::INFINITY } else { 1.5 };
                assert_exact(&map, &photons, r, o, d, t_max);
            }
        }
    }

    /// Segments on rays from a pinhole eye use the view bins; they must find exactly what the
    /// grid finds: from the eye, from further along the ray (as after a pass-through interface,
    /// slightly off the ray), and with the eye inside the photons (spheres straddling the eye's
    /// plane). Other segments and thin-lens cameras fall back to the grid.
    #[test]
    fn view_bins_find_exactly_the_photons_near_eye_rays() {
        let mut s = Sampler::new(4, Purpose::Other, 0, 0);
        let perspective = |lens_radius| Projection::Perspective {
            tan_half_fov: (20f32.to_radians() / 2.0).tan(),
            lens_radius,
            focus_distance: 6.0,
        };
        for (eye, lens, photons) in [
            (Vec3::new(0.1, 0.2, 6.0), 0.0, cloud(&mut s, 20_000, Vec3::ZERO, 1.0)),
            (Vec3::new(0.0, 0.0, 0.5), 0.0, cloud(&mut s, 20_000, Vec3::ZERO, 1.0)),
            (Vec3::new(0.1, 0.2, 6.0), 0.05, cloud(&mut s, 5_000, Vec3::ZERO, 1.0)),
        ] {
            let camera = Camera::new(perspective(lens), eye, Vec3::ZERO, Vec3::Y, [90, 50]);
            let mut map = BeamMap::new();
            for r in [0.004f32, 0.02, 0.1] {
                map.build(&photons, r, None, Some(&camera), |p| p.beta);
                assert_eq!(map.has_view_bins(), lens == 0.0, "eye {eye}, lens {lens}");
                for q in 0..80 {
                    let pixel = Vec2::new(s.next_f32() * 90.0, s.next_f32() * 50.0);
                    let ray = camera.generate_ray(pixel, s.next_2d());
                    let t_max = if q % 4 == 0 { f32::INFINITY } else { 8.0 * s.next_f32() };
                    assert_eq!(map.view.bin(ray.o, ray.d).is_some(), lens == 0.0);
                    assert_exact(&map, &photons, r, ray.o, ray.d, t_max);
                    // Further along the same ray, nudged off it by less than the margin.
                    let nudge = ray.d.any_orthonormal_vector() * (0.5 * VIEW_LINE_MARGIN * r);
                    let o = ray.o + ray.d * (6.0 * s.next_f32()) + nudge;
                    assert_eq!(map.view.bin(o, ray.d).is_some(), lens == 0.0);
                    assert_exact(&map, &photons, r, o, ray.d, t_max);
                    // Any other segment.
                    let o = Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * 3.0 - 1.5;
                    let d = crate::math::sample_uniform_sphere(s.next_2d());
                    assert_exact(&map, &photons, r, o, d, t_max);
                }
            }
        }
    }
}
