//! Emitting media as a light source of the photon pass: photons leave a point of an emitting
//! medium, drawn over its volume, in a uniform direction, carrying 4π σ_a(p) L_e(p) / (p_V(p) P)
//! — the emitted flux density σ_a L_e per unit volume and solid angle over the densities of the
//! choice (P the probability of the medium, p_V the density of the point).
//!
//! Points are drawn from a piecewise-constant density over boxes: for a grid, the unit cubes
//! between its voxel centres (interpolation cells), each by a bound on the emission σ_a L_e
//! inside it, then a uniform point in it; for a homogeneous medium, the scene's bounding box. A
//! point belongs to the medium only if the medium interfaces say so ([`Scene::medium_at`]); a
//! photon drawn elsewhere carries nothing. The estimate is unbiased wherever the density of
//! points is positive where the medium emits, and a bound makes it so: inside an interpolation
//! cell the density and the temperature are trilinear in their eight corners, so neither leaves
//! the corners' range, and σ_a L_e is at most the largest corner density times σ_a's largest
//! channel per unit density times the largest L_e those ranges allow (the blackbody's through
//! [`blackbody::max_mean_channel`], colour grids' through their corners' maxima). A drawn point's
//! mean channel of f / p is then at most the sum of the bounds times a cell's volume: no photon
//! and no emitter point carries a spike, however the emission varies between voxel centres.
//! The cells are kept per majorant cell (8³ of them, a cumulative table of 512 bounds for each
//! cell with any emission: memory like a brick's), picked by their sums, then within.
//! Emission of a homogeneous medium outside the scene's bounds is not sampled: an emitting
//! homogeneous medium must be enclosed by the scene's geometry.
//!
//! Next-event estimation towards emitting media draws the same points without the rejection,
//! in advance: an [`EmitterPool`] per iteration, from which the estimates pick their candidates.

use crate::math::{Rgb, luminance, sample_uniform_sphere};
use crate::medium::Medium;
use crate::medium::emission::EmissionCells;
use crate::rng::{Purpose, Sampler};
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;

/// Points used to estimate a homogeneous medium's power (its share of the scene's box).
const POWER_PROBES: u32 = 16;

/// Where the points of one emitting medium are drawn.
#[derive(Clone, Debug)]
enum Region {
    /// Uniform in a scene-space box.
    Box { lo: Vec3, size: Vec3 },
    /// Interpolation cells of a grid by their bounds on the emission.
    Cells(EmissionCells),
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

/// What the emitting media need of the scene they lie in: its media, its bounds, which medium
/// holds a point, and the emitting media themselves. [`Scene`](crate::scene::Scene) answers; the
/// questions are asked here so that this file stands below the scene that holds its media.
pub(crate) trait MediaSpace: Sync {
    /// The scene's media, by id.
    fn media(&self) -> &[Medium];
    /// The scene's bounding box (lower and upper corner).
    fn bounds(&self) -> (Vec3, Vec3);
    /// The id of the medium at `p`, as the scene's medium interfaces say (a ray query).
    fn medium_at(&self, p: Vec3) -> Option<u32>;
    /// The scene's emitting media.
    fn emissive_media(&self) -> &EmissiveMedia;
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
    pub(crate) fn new(scene: &impl MediaSpace) -> Self {
        let mut sources = Vec::new();
        for (id, m) in scene.media().iter().enumerate() {
            if !m.emits() {
                continue;
            }
            let id = id as u32;
            let (region, power) = match m {
                Medium::Homogeneous(h) => {
                    let (lo, hi) = scene.bounds();
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
                Medium::Vdb(v) => {
                    let (cells, power) = EmissionCells::of(v);
                    (Region::Cells(cells), power)
                }
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

    /// Draws a photon from the emitting media (9 uniforms from `s`); `None` if the point drawn
    /// emits nothing (outside the medium, a cold voxel, or rejected).
    pub(crate) fn sample(
        &self,
        scene: &impl MediaSpace,
        s: &mut Sampler,
    ) -> Option<MediumEmission> {
        let u_pick = (s.next_f32(), s.next_f64(), s.next_f32());
        let u_pos = Vec3::new(s.next_f32(), s.next_f32(), s.next_f32());
        let u_accept = s.next_f32();
        let d = sample_uniform_sphere(s.next_2d());
        let e = self.point(scene, u_pick, u_pos, Some(u_accept))?;
        if !e.inside(scene) {
            return None;
        }
        let beta = e.f * (4.0 * PI / e.pdf);
        Some(MediumEmission { p: e.p, d, medium: e.medium, beta })
    }

    /// Draws a candidate point of the emitting media for next-event estimation (6 uniforms from
    /// `s`): as a photon's point, but never rejected — its density is that of the bounds, and
    /// the resampling weight (target over density) takes the place of the rejection test, so
    /// that no draw is wasted. `None` if it emits nothing there. Whether a grid's point lies in
    /// its medium, as the scene's interfaces say, is left to [`EmitterPoint::inside`]: a ray
    /// query, which resampling needs for the chosen point only.
    pub(crate) fn sample_candidate(
        &self,
        scene: &impl MediaSpace,
        s: &mut Sampler,
    ) -> Option<EmitterPoint> {
        let u_pick = (s.next_f32(), s.next_f64(), s.next_f32());
        let u_pos = Vec3::new(s.next_f32(), s.next_f32(), s.next_f32());
        self.point(scene, u_pick, u_pos, None)
    }

    /// The point of the media that the uniforms pick: a source by power (`u_pick.0`), a
    /// majorant cell of it by its bounds (`.1`, 53 bits: there may be millions), an interpolation
    /// cell in that (`.2`), a uniform point in the cell; in a grid, given `u_accept`, kept with
    /// probability (mean channel of σ_a L_e there) / (the cell's bound) — rejection sampling, so
    /// that the points kept are distributed as the emission's mean channel and each carries the
    /// same luminance (the grid's summed bounds times a cell's volume), and no time goes into
    /// tracing points that emit little.
    fn point(
        &self,
        scene: &impl MediaSpace,
        u_pick: (f32, f64, f32),
        u_pos: Vec3,
        u_accept: Option<f32>,
    ) -> Option<EmitterPoint> {
        let (u_source, u_cell, u_voxel) = u_pick;
        let total = self.power();
        let k = self.cdf.partition_point(|&c| c <= u_source * total).min(self.cdf.len() - 1);
        let source = &self.sources[k];
        let p_source = source.power / total;
        let (p, pdf_v, cap) = match &source.region {
            Region::Box { lo, size } => {
                (*lo + *size * u_pos, 1.0 / (size.x * size.y * size.z), None)
            }
            Region::Cells(cells) => {
                let (p, pdf, bound) = cells.pick(u_cell, u_voxel, u_pos)?;
                (p, pdf, Some(bound))
            }
        };
        if !(pdf_v > 0.0 && pdf_v.is_finite()) {
            return None;
        }
        // A homogeneous medium's box is mostly outside it: a point there is dropped here. A
        // grid's cells lie in its medium as a rule, and most drawn points are rejected below:
        // the ray query waits until a point is kept (or chosen, `EmitterPoint::inside`).
        let known_inside = cap.is_none();
        if known_inside && scene.medium_at(p) != Some(source.medium) {
            return None;
        }
        let m = &scene.media()[source.medium as usize];
        let f = m.sigma_a(p) * m.le(p);
        if f.max_element() <= 0.0 {
            return None;
        }
        let keep = match (cap, u_accept) {
            (Some(b), Some(u)) => {
                let keep = (luminance(f) / b).min(1.0);
                if u >= keep {
                    return None;
                }
                keep
            }
            _ => 1.0,
        };
        Some(EmitterPoint {
            p,
            medium: source.medium,
            f,
            pdf: pdf_v * keep * p_source,
            known_inside,
        })
    }
}

/// Points of an emitting medium per pool: candidates of the next-event estimates of one
/// iteration are picked from these (see [`EmitterPool`]).
const POOL_POINTS: usize = 1 << 14;

/// One iteration's pool of candidate emitter points ([`EmissiveMedia::sample_candidate`],
/// drawn in advance), shared by every next-event estimate towards emitting media of the
/// iteration (`media_next_event`): picking a uniform entry costs a load, where drawing
/// afresh costs two table searches, a density lookup and the emission. Each pick is
/// distributed as a fresh draw, so estimates that are linear in their candidates (resampling's
/// mean weight times the chosen one's contribution over its weight) stay unbiased; what
/// the sharing adds is correlation between the pixels of one iteration, which the average
/// over iterations, each with its own pool, removes ("light tiles" of Wyman and Panteleev 2021
/// are the same idea for many lights). An entry that drew nothing (a cold or empty point)
/// stays a candidate that weighs nothing, as it would be drawn.
#[derive(Clone, Debug, Default)]
pub(crate) struct EmitterPool {
    points: Vec<Option<EmitterPoint>>,
}

impl EmitterPool {
    /// The pool of iteration `iteration` under `seed`: entry k from its own stream, so the pool
    /// is the same whatever the threads (empty if no medium emits).
    pub(crate) fn new(scene: &impl MediaSpace, seed: u64, iteration: u64) -> Self {
        if scene.emissive_media().is_empty() {
            return Self::default();
        }
        let points = (0..POOL_POINTS as u64)
            .into_par_iter()
            .map(|k| {
                let mut s = Sampler::new(seed, Purpose::EmitterPool, iteration, k);
                scene.emissive_media().sample_candidate(scene, &mut s)
            })
            .collect();
        Self { points }
    }

    /// A pool of `n` points drawn from `s` (for tests that redraw it per estimate).
    #[cfg(test)]
    pub(crate) fn drawn(scene: &impl MediaSpace, n: usize, s: &mut Sampler) -> Self {
        Self { points: (0..n).map(|_| scene.emissive_media().sample_candidate(scene, s)).collect() }
    }

    /// A uniformly chosen entry (one uniform from `s`); `None` if it drew nothing or the pool
    /// is empty.
    #[inline]
    pub(crate) fn pick(&self, s: &mut Sampler) -> Option<&EmitterPoint> {
        let n = self.points.len();
        let k = ((s.next_f32() * n as f32) as usize).min(n.checked_sub(1)?);
        self.points[k].as_ref()
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
    /// True if the point is known to lie in its medium (else [`Self::inside`] asks the scene).
    known_inside: bool,
}

impl EmitterPoint {
    /// True if the point lies in its medium as the scene's interfaces say (a ray query): a point
    /// outside emits nothing there.
    pub(crate) fn inside(&self, scene: &impl MediaSpace) -> bool {
        self.known_inside || scene.medium_at(self.p) == Some(self.medium)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Purpose;
    use crate::scene::{CameraDesc, Material, MediumDesc, Scene, SceneBuilder, ShapeDesc};
    use glam::IVec3;
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
        sample: impl FnMut(&mut Sampler) -> Rgb,
    ) {
        assert_channel_means_within(what, (seed, purpose, n), want, [0.0; 3], sample);
    }

    /// [`assert_channel_means`] allowing a known bias bound per channel.
    fn assert_channel_means_within(
        what: &str,
        (seed, purpose, n): (u64, Purpose, u64),
        want: [f64; 3],
        bias: [f64; 3],
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
            crate::testing::assert_agrees(&format!("{what}, channel {c}"), &xs, want, bias[c]);
        }
    }

    /// Photons of the fire (media/fire.vdb: soot density and a temperature grid, blackbody
    /// emission with a cut-off at 500 K, as scenes/fire.toml has it) carry its emitted power
    /// 4π ∫ σ_a L_e dV: the integral by the midpoint rule at 4³ points per interpolation cell,
    /// its error bounded by its difference from the rule at 2³ (a stated bias bound); batch means
    /// by a t-test at the suite's significance. And no photon carries a spike: each one's mean
    /// channel is at most 4π × the grid's summed emission bounds × a cell's volume (module docs).
    #[test]
    fn fire_photons_carry_its_power_without_spikes() {
        use crate::scene::TemperatureDesc;
        let t = TemperatureDesc { cutoff: 500.0, blackbody_scale: 120.0, ..Default::default() };
        let desc = MediumDesc::vdb(media("fire.vdb")).coefficients(6.0, 2.0).temperature(t);
        let camera = CameraDesc::perspective([1.0, 1.7, 8.0], [1.0, 1.7, 1.0], 40.0);
        let mut b = SceneBuilder::new(camera.resolution(8, 8));
        let m = b.medium("fire", desc).unwrap();
        let air = b.material("air", Material::Interface).unwrap();
        // The grids lie well inside this box.
        let container = ShapeDesc::cuboid([2.5, 4.0, 2.5]).translate([1.0, 1.7, 1.0]);
        b.shape(container.material(air).interior(m)).unwrap();
        let scene = b.build().unwrap();
        let medium = &scene.media[0];
        let Medium::Vdb(v) = medium else { unreachable!() };
        let (grid, to_index, ..) = v.layout();
        let to_scene = to_index.inverse();
        let volume = to_scene.matrix3.determinant().abs() as f64;
        let (first, last) = grid.active_box;
        let integral = |k: i32| {
            let cells: Vec<IVec3> = (first.z - 1..=last.z)
                .flat_map(|z| {
                    (first.y - 1..=last.y)
                        .flat_map(move |y| (first.x - 1..=last.x).map(move |x| IVec3::new(x, y, z)))
                })
                .collect();
            let sum = cells
                .par_iter()
                .map(|&q| {
                    let mut sum = [0.0f64; 3];
                    for i in 0..k * k * k {
                        let o = IVec3::new(i % k, i / k % k, i / k / k).as_vec3();
                        let p = to_scene.transform_point3(q.as_vec3() + (o + 0.5) / k as f32);
                        let f = medium.sigma_a(p) * medium.le(p);
                        for (c, s) in sum.iter_mut().enumerate() {
                            *s += f[c] as f64;
                        }
                    }
                    sum
                })
                .reduce(|| [0.0; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]]);
            sum.map(|s| 4.0 * std::f64::consts::PI * s * volume / (k * k * k) as f64)
        };
        let (fine, coarse) = (integral(4), integral(2));
        let bias = [0, 1, 2].map(|c| (fine[c] - coarse[c]).abs());
        assert!(fine[0] > 0.0 && bias[0] < 0.05 * fine[0], "{fine:?} vs {coarse:?}");
        let emitting = EmissiveMedia::new(&scene);
        let Region::Cells(cells) = &emitting.sources[0].region else { unreachable!() };
        let spike = 4.0 * PI * cells.bound_sum() as f32 * cells.voxel_volume * (1.0 + 1e-3);
        let mut largest = 0.0f32;
        assert_channel_means_within("fire", (11, Purpose::Photon, 10_000), fine, bias, |s| {
            emitting.sample(&scene, s).map_or(Rgb::ZERO, |e| {
                largest = largest.max(luminance(e.beta));
                e.beta
            })
        });
        assert!(largest <= spike, "a photon carried {largest}, above the bound {spike}");
    }

    /// Next-event estimation towards an emitting cube (σ_a 0.7, σ_s 0.3: σ_t 1), f ≡ 1, from a
    /// point 0.7 outside its face with points nearer than 0.9 left out, and from a point inside
    /// it with points nearer than 0.2 left out, and from the outside point with a receiver lobe
    /// f(ω) = (ω · n)₊⁴ that sees part of the cube (so the resampling's choice matters): its mean
    /// is the integral ∫ f σ_a L_e T(x, p) / |p − x|² over the cube beyond the cut (midpoint rule
    /// on 128³ cells, T in closed form from the chord inside the cube), for a homogeneous cube and
    /// the constant grid (whose shadow rays run ratio tracking); batch means by a t-test at the
    /// suite's significance. A cut 10 % off fails it.
    #[test]
    fn next_event_estimation_towards_media_integrates_their_emission() {
        let (sigma_a, le) = (0.7f32, Rgb::new(2.0, 1.0, 0.5));
        for (x, near, inside) in
            [(Vec3::new(0.1, -0.2, 1.2), 0.9f32, false), (Vec3::new(0.1, -0.2, 0.15), 0.2, true)]
        {
            check_media_next_event(x, near, inside, sigma_a, le, None);
        }
        // A receiver whose BSDF favours part of the cube, which the resampling steers towards.
        let lobe = Vec3::new(-0.3, 0.4, -1.0).normalize();
        check_media_next_event(Vec3::new(0.1, -0.2, 1.2), 0.9, false, sigma_a, le, Some(lobe));
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

    /// [`next_event_estimation_towards_media_integrates_their_emission`]'s check from `x`, with
    /// the receiver's f(ω) = 1, or (ω · n)₊⁴ for a `lobe` n.
    fn check_media_next_event(
        x: Vec3,
        near: f32,
        inside: bool,
        sigma_a: f32,
        le: Rgb,
        lobe: Option<Vec3>,
    ) {
        use crate::integrator::direct::media_next_event;
        let f = |w: Vec3| lobe.map_or(1.0, |n| w.dot(n).max(0.0).powi(4));
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
            want += (f(-d) * (-exit).exp() / (dist * dist)) as f64;
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
                |s| {
                    // A small pool per estimate: the sharing of a pool is part of what is tested.
                    let pool = EmitterPool::drawn(&scene, 16, s);
                    media_next_event(&scene, x, medium, near, &pool, s, |w| Rgb::splat(f(w)))
                },
            );
        }
    }
}
