//! Emitting media as a light source of the photon pass: photons leave a point of an emitting
//! medium, drawn over its volume, in a uniform direction, carrying 4π σ_a(p) L_e(p) / (p_V(p) P)
//! — the emitted flux density σ_a L_e per unit volume and solid angle over the densities of the
//! choice (P the probability of the medium, p_V the density of the point).
//!
//! Points are drawn from a piecewise-constant density over boxes: for a grid, its majorant cells
//! (a cell by a weight, then a uniform point in it); for a homogeneous medium, the scene's
//! bounding box. A point belongs to the medium only if the medium interfaces say so
//! ([`Scene::medium_at`]); a photon drawn elsewhere carries nothing. The estimate is unbiased
//! wherever the density of points is positive where the medium emits: a grid cell's weight is
//! the mean emission σ_a L_e at its voxel centres, plus a guard of 10⁻³ of a bound on it wherever
//! the cell has density (so a cell whose voxel centres happen not to emit can still be drawn).
//! Emission of a homogeneous medium outside the scene's bounds is not sampled: an emitting
//! homogeneous medium must be enclosed by the scene's geometry.

use crate::math::{Rgb, luminance, sample_uniform_sphere};
use crate::medium::grid::MAJORANT_CELL;
use crate::medium::{Medium, blackbody};
use crate::rng::Sampler;
use crate::scene::Scene;
use glam::{Affine3A, IVec3, Vec3};
use rayon::prelude::*;
use std::f32::consts::PI;

/// Share of a grid cell's weight bound given to every cell with density (see the module docs).
const GUARD: f32 = 1e-3;

/// Points used to estimate a homogeneous medium's power (its share of the scene's box).
const POWER_PROBES: u32 = 16;

/// Where the points of one emitting medium are drawn.
#[derive(Clone, Debug)]
enum Region {
    /// Uniform in a scene-space box.
    Box { lo: Vec3, size: Vec3 },
    /// Majorant cells of a grid: cell `ids[k]` with probability (cdf[k] − cdf[k−1]) / total, then
    /// a uniform point in it.
    Cells {
        /// Index space → scene.
        to_scene: Affine3A,
        /// Index-space position of cell (0, 0, 0)'s corner, and the cell count along each axis.
        lo: Vec3,
        cells: IVec3,
        ids: Vec<u32>,
        /// In f64: with millions of cells a small cell's weight must not vanish in the sum.
        cdf: Vec<f64>,
        /// Scene-space volume of one cell.
        cell_volume: f32,
    },
}

/// One emitting medium.
#[derive(Clone, Debug)]
struct Source {
    medium: u32,
    region: Region,
    /// Estimated emitted power (mean channel, W), for the choice between sources.
    power: f32,
}

/// A photon leaving an emitting medium.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MediumEmission {
    /// Where it starts, in medium `medium`, travelling along `d`.
    pub p: Vec3,
    pub d: Vec3,
    pub medium: u32,
    /// Power carried (before the probability of choosing media over lights).
    pub beta: Rgb,
}

/// The emitting media of a scene, for the photon pass.
#[derive(Clone, Debug, Default)]
pub(crate) struct EmissiveMedia {
    sources: Vec<Source>,
    /// Cumulative estimated power of the sources.
    cdf: Vec<f32>,
}

impl EmissiveMedia {
    /// The emitting media of `scene` (an empty set if none emits).
    pub(crate) fn new(scene: &Scene) -> Self {
        let mut sources = Vec::new();
        for (id, m) in scene.media.iter().enumerate() {
            if !m.emits() {
                continue;
            }
            let id = id as u32;
            let (region, power) = match m {
                Medium::Homogeneous(h) => {
                    let (lo, hi) = scene.bounds;
                    let size = (hi - lo).max(Vec3::ZERO);
                    let volume = size.x * size.y * size.z;
                    // The share of the box in the medium, on a regular grid of probes.
                    let n = POWER_PROBES;
                    let inside = (0..n * n * n)
                        .filter(|k| {
                            let c =
                                Vec3::new((k % n) as f32, (k / n % n) as f32, (k / n / n) as f32);
                            let p = lo + size * ((c + 0.5) / n as f32);
                            scene.medium_at(p) == Some(id)
                        })
                        .count();
                    let share = inside as f32 / (n * n * n) as f32;
                    // A small medium between the probes still gets photons.
                    let share = share.max(1.0 / (n * n * n) as f32);
                    let power = 4.0 * PI * luminance(h.sigma_a * h.emission) * volume * share;
                    (Region::Box { lo, size }, power)
                }
                Medium::Vdb(v) => grid_cells(m, v),
            };
            if power > 0.0 && power.is_finite() {
                sources.push(Source { medium: id, region, power });
            }
        }
        let mut total = 0.0;
        let cdf = sources
            .iter()
            .map(|s| {
                total += s.power;
                total
            })
            .collect();
        Self { sources, cdf }
    }

    /// True if no medium of the scene emits.
    pub(crate) fn is_empty(&self) -> bool {
        self.sources.is_empty()
    }

    /// Estimated emitted power of all media (mean channel), comparable with the lights'
    /// ([`super::LightSampler::total_power`]).
    pub(crate) fn power(&self) -> f32 {
        self.cdf.last().copied().unwrap_or(0.0)
    }

    /// Draws a photon from the emitting media (7 uniforms from `s`); `None` if the point drawn
    /// emits nothing (outside the medium, or a cold voxel).
    pub(crate) fn sample(&self, scene: &Scene, s: &mut Sampler) -> Option<MediumEmission> {
        let (u_source, u_cell) = (s.next_f32(), s.next_f32());
        let u_pos = Vec3::new(s.next_f32(), s.next_f32(), s.next_f32());
        let d = sample_uniform_sphere(s.next_2d());
        let e = self.point(scene, u_source, u_cell, u_pos)?;
        let beta = e.f * (4.0 * PI / e.pdf);
        Some(MediumEmission { p: e.p, d, medium: e.medium, beta })
    }

    /// Draws a point of the emitting media by their emission (5 uniforms from `s`), for
    /// next-event estimation: `None` if it emits nothing.
    pub(crate) fn sample_point(&self, scene: &Scene, s: &mut Sampler) -> Option<EmitterPoint> {
        let (u_source, u_cell) = (s.next_f32(), s.next_f32());
        let u_pos = Vec3::new(s.next_f32(), s.next_f32(), s.next_f32());
        self.point(scene, u_source, u_cell, u_pos)
    }

    /// The point of the media that the uniforms pick: a source by power, a cell of it by weight,
    /// a uniform point in the cell.
    fn point(
        &self,
        scene: &Scene,
        u_source: f32,
        u_cell: f32,
        u_pos: Vec3,
    ) -> Option<EmitterPoint> {
        let total = self.power();
        let k = self.cdf.partition_point(|&c| c <= u_source * total).min(self.cdf.len() - 1);
        let source = &self.sources[k];
        let p_source = source.power / total;
        let (p, pdf_v) = match &source.region {
            Region::Box { lo, size } => (*lo + *size * u_pos, 1.0 / (size.x * size.y * size.z)),
            Region::Cells { to_scene, lo, cells, ids, cdf, cell_volume } => {
                let total = *cdf.last()?;
                let j = cdf.partition_point(|&c| c <= u_cell as f64 * total).min(cdf.len() - 1);
                let weight = cdf[j] - if j == 0 { 0.0 } else { cdf[j - 1] };
                let (weight, total) = (weight as f32, total as f32);
                let id = ids[j] as i32;
                let cell = IVec3::new(id % cells.x, id / cells.x % cells.y, id / cells.x / cells.y);
                let q = *lo + (cell.as_vec3() + u_pos) * MAJORANT_CELL as f32;
                (to_scene.transform_point3(q), weight / total / cell_volume)
            }
        };
        if !(pdf_v > 0.0 && pdf_v.is_finite()) || scene.medium_at(p) != Some(source.medium) {
            return None;
        }
        let m = &scene.media[source.medium as usize];
        let f = m.sigma_a(p) * m.le(p);
        if f.max_element() <= 0.0 {
            return None;
        }
        Some(EmitterPoint { p, medium: source.medium, f, pdf: pdf_v * p_source })
    }
}

/// A point of an emitting medium drawn for next-event estimation.
#[derive(Clone, Copy, Debug)]
pub(crate) struct EmitterPoint {
    /// Where, in medium `medium`.
    pub p: Vec3,
    pub medium: u32,
    /// The emitted radiance per unit length, σ_a(p) L_e(p).
    pub f: Rgb,
    /// The density of the point per unit volume (the medium's choice included).
    pub pdf: f32,
}

/// The cells of a grid medium with their weights (module docs), and the medium's estimated power.
fn grid_cells(m: &Medium, v: &crate::medium::vdb::VdbMedium) -> (Region, f32) {
    let (grid, to_index, cells, lo, majorant) = v.layout();
    let to_scene = to_index.inverse();
    let cell = MAJORANT_CELL;
    let cell_volume = to_scene.matrix3.determinant().abs() * (cell * cell * cell) as f32;
    // A bound on L_e's mean channel, for the guard.
    let le_bound = luminance(v.emission()).max(0.0)
        + v.temperature().map_or(0.0, |t| t.blackbody_scale * blackbody::peak_luminance())
        + v.emission_grid().map_or(0.0, |c| c.bound());
    let sigma_a_per_density = luminance(v.sigma_a_per_density());
    let count = (cells.x * cells.y * cells.z) as usize;
    let weights: Vec<f32> = (0..count)
        .into_par_iter()
        .map(|i| {
            // A cell without density emits nothing (and costs no lookups).
            if majorant[i] <= 0.0 {
                return 0.0;
            }
            let i = i as i32;
            let c = IVec3::new(i % cells.x, i / cells.x % cells.y, i / cells.x / cells.y);
            let base = (lo + (c * cell).as_vec3()).as_ivec3();
            // Largest voxel density the cell's interpolation reaches (its majorant).
            let mut max_density = 0.0f32;
            let mut sum = 0.0f32;
            for z in 0..=cell {
                for y in 0..=cell {
                    for x in 0..=cell {
                        let q = base + IVec3::new(x, y, z);
                        let density = grid.voxel(q);
                        max_density = max_density.max(density);
                        if density > 0.0 && x < cell && y < cell && z < cell {
                            let p = to_scene.transform_point3(q.as_vec3());
                            sum += luminance(m.sigma_a(p) * m.le(p));
                        }
                    }
                }
            }
            if max_density <= 0.0 {
                return 0.0;
            }
            let mean = sum / (cell * cell * cell) as f32;
            mean + GUARD * max_density * sigma_a_per_density * le_bound
        })
        .collect();
    let (mut ids, mut cdf, mut total) = (Vec::new(), Vec::new(), 0.0f64);
    for (i, w) in weights.into_iter().enumerate() {
        if w > 0.0 && w.is_finite() {
            total += w as f64;
            ids.push(i as u32);
            cdf.push(total);
        }
    }
    let power = total;
    let power = (4.0 * PI as f64 * power * cell_volume as f64) as f32;
    (Region::Cells { to_scene, lo, cells, ids, cdf, cell_volume }, power)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Purpose;
    use crate::scene::{CameraDesc, Material, MediumDesc, SceneBuilder, ShapeDesc};
    use std::path::Path;

    fn media(name: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("media").join(name)
    }

    /// A unit cube of `medium` (interface box) in a larger closed room, in vacuum.
    fn cube_scene(medium: MediumDesc) -> Scene {
        let camera = CameraDesc::perspective([0.0, 0.0, 5.0], [0.0, 0.0, 0.0], 40.0);
        let mut b = SceneBuilder::new(camera.resolution(8, 8));
        let m = b.medium("glow", medium).unwrap();
        let air = b.material("air", Material::Interface).unwrap();
        let black = b.material("black", Material::diffuse(0.0)).unwrap();
        b.shape(ShapeDesc::cuboid([1.0, 1.0, 1.0]).material(air).interior(m)).unwrap();
        b.shape(ShapeDesc::cuboid([6.0, 6.0, 12.0]).material(black)).unwrap();
        b.build().unwrap()
    }

    /// The mean power of the photons drawn is the emitted power 4π ∫ σ_a L_e dV (z-test over
    /// batch means at the suite's significance), for a homogeneous cube (4π σ_a L_e, the cube
    /// drawn from the room's box, most points outside it) and the constant grid of box.vdb
    /// (density 1 between its voxel centres) placed on the same cube.
    #[test]
    fn photons_carry_the_emitted_power() {
        let (sigma_a, le) = (0.7f32, Rgb::new(2.0, 1.0, 0.5));
        for (what, desc) in emitting_cubes(sigma_a, 0.3, le) {
            let scene = cube_scene(desc);
            let emitting = EmissiveMedia::new(&scene);
            assert!(!emitting.is_empty(), "{what}");
            let want = (le * (4.0 * PI * sigma_a)).to_array().map(f64::from);
            assert_channel_means(what, (3, Purpose::Photon, 10_000), want, |s| {
                emitting.sample(&scene, s).map_or(Rgb::ZERO, |e| {
                    assert_eq!(e.medium, 0);
                    e.beta
                })
            });
        }
    }

    /// 20 batch means of `n` samples each of `sample` (sampler streams `seed`, `purpose`, batch,
    /// index), each channel against `want` by a t-test at the suite's significance.
    fn assert_channel_means(
        what: &str,
        (seed, purpose, n): (u64, Purpose, u64),
        want: [f64; 3],
        mut sample: impl FnMut(&mut Sampler) -> Rgb,
    ) {
        let means: Vec<[f64; 3]> = (0..20)
            .map(|b| {
                let mut sum = [0.0f64; 3];
                for i in 0..n {
                    let l = sample(&mut Sampler::new(seed, purpose, b, i));
                    for (c, total) in sum.iter_mut().enumerate() {
                        *total += l[c] as f64;
                    }
                }
                sum.map(|v| v / n as f64)
            })
            .collect();
        for (c, want) in want.into_iter().enumerate() {
            let xs: Vec<f64> = means.iter().map(|m| m[c]).collect();
            crate::testing::assert_agrees(&format!("{what}, channel {c}"), &xs, want, 0.0);
        }
    }

    /// Next-event estimation towards an emitting cube (σ_a 0.7, σ_s 0.3: σ_t 1), f ≡ 1, from a
    /// point 0.7 outside its face with points nearer than 0.9 left out, and from a point inside
    /// it with points nearer than 0.2 left out: its mean is the integral
    /// ∫ σ_a L_e T(x, p) / |p − x|² over the cube beyond the cut (midpoint rule on 128³ cells, T
    /// in closed form from the chord inside the cube), for a homogeneous cube and the constant
    /// grid (whose shadow rays run ratio tracking); batch means by a t-test at the suite's
    /// significance. A cut 10 % off fails it.
    #[test]
    fn next_event_estimation_towards_media_integrates_their_emission() {
        let (sigma_a, le) = (0.7f32, Rgb::new(2.0, 1.0, 0.5));
        for (x, near, inside) in
            [(Vec3::new(0.1, -0.2, 1.2), 0.9f32, false), (Vec3::new(0.1, -0.2, 0.15), 0.2, true)]
        {
            check_media_next_event(x, near, inside, sigma_a, le);
        }
    }

    /// Single scattering of an emitting cube's light along an eye segment through it (σ_a 0.7,
    /// σ_s 0.3, isotropic; from the middle of a face straight through, emitter points nearer than
    /// 0.2 to the scattering point left out): its mean is
    /// ∫₀¹ e^{−t} σ_s/(4π) ∫ σ_a L_e e^{−|p − x_t|} / |p − x_t|² dV dt over the cube beyond the cut
    /// (midpoint rule, 64 distances × 64³ cells), for the homogeneous cube and the constant grid;
    /// batch means by a t-test at the suite's significance.
    #[test]
    fn media_single_scattering_integrates_their_emission() {
        use crate::estimate::volume::EyeSegment;
        use crate::integrator::single::media_single_scattering;
        let (sigma_a, sigma_s, le, near) = (0.7f32, 0.3f32, Rgb::new(2.0, 1.0, 0.5), 0.2f32);
        let (o, w) = (Vec3::new(0.1, -0.2, 0.5), Vec3::new(0.0, 0.0, -1.0));
        let (nt, n) = (64, 64);
        let mut want = 0.0f64;
        for i in 0..nt {
            let t = (i as f32 + 0.5) / nt as f32;
            let x = o + w * t;
            let mut inner = 0.0f64;
            for k in 0..n * n * n {
                let c = Vec3::new((k % n) as f32, (k / n % n) as f32, (k / n / n) as f32);
                let p = (c + 0.5) / n as f32 - 0.5;
                let dist = (p - x).length();
                if dist >= near {
                    inner += ((-dist).exp() / (dist * dist)) as f64;
                }
            }
            want += (-t as f64).exp() * inner / (n * n * n) as f64;
        }
        want *= (sigma_s * sigma_a) as f64 / (4.0 * std::f64::consts::PI) / nt as f64;
        for (what, desc) in emitting_cubes(sigma_a, sigma_s, le) {
            let scene = cube_scene(desc);
            let m = &scene.media[0];
            let segment = EyeSegment { o, w, t_max: 1.0 };
            let want = le.to_array().map(|c| want * c as f64);
            assert_channel_means(what, (5, Purpose::Other, 20_000), want, |s| {
                let tr = m.segment(o, w, 1.0, s);
                media_single_scattering(&scene, &segment, (0, m), &tr, near, s)
            });
        }
    }

    /// The emitting unit cube, homogeneous and as the constant grid of box.vdb.
    fn emitting_cubes(sigma_a: f32, sigma_s: f32, le: Rgb) -> [(&'static str, MediumDesc); 2] {
        let homogeneous = MediumDesc::homogeneous(sigma_a, sigma_s).emission(le);
        let scale = 1.0 / (15.0 / 16.0);
        let grid = MediumDesc::vdb(media("box.vdb"))
            .coefficients(sigma_a, sigma_s)
            .emission(le)
            .transform(crate::scene::Transform {
                scale: Vec3::splat(scale),
                translate: Vec3::splat(-0.5),
                ..Default::default()
            });
        [("homogeneous", homogeneous), ("grid", grid)]
    }

    fn check_media_next_event(x: Vec3, near: f32, inside: bool, sigma_a: f32, le: Rgb) {
        use crate::integrator::direct::media_next_event;
        // The integral: exit of the segment p → x through the cube's faces, T = e^{−σ_t·chord}.
        let n = 128;
        let mut want = 0.0f64;
        for k in 0..n * n * n {
            let c = Vec3::new((k % n) as f32, (k / n % n) as f32, (k / n / n) as f32);
            let p = (c + 0.5) / n as f32 - 0.5;
            let to = x - p;
            let dist = to.length();
            if dist < near {
                continue;
            }
            let d = to / dist;
            let exit = (0..3)
                .map(|a| {
                    if d[a] > 0.0 {
                        (0.5 - p[a]) / d[a]
                    } else if d[a] < 0.0 {
                        (-0.5 - p[a]) / d[a]
                    } else {
                        f32::INFINITY
                    }
                })
                .fold(f32::INFINITY, f32::min)
                .min(dist);
            want += ((-exit).exp() / (dist * dist)) as f64;
        }
        want *= sigma_a as f64 / (n * n * n) as f64;
        for (what, desc) in emitting_cubes(sigma_a, 0.3, le) {
            let scene = cube_scene(desc);
            let medium = inside.then_some(0);
            let want = le.to_array().map(|c| want * c as f64);
            assert_channel_means(
                &format!("{what} at {x}"),
                (4, Purpose::Other, 20_000),
                want,
                |s| media_next_event(&scene, x, medium, near, s, |_| Rgb::ONE),
            );
        }
    }
}
