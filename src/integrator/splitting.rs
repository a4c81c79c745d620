//! The pilots of light-path splitting by importance (`photon/importance.rs`, docs/theory.md,
//! "Light paths split by importance"), once per render: eye random walks from the camera that sum
//! the importance over a grid, and light paths to their first collision for the target value.
//! Both draw streams no iteration uses, so they are the same in every process of a split render.

use super::walk::{EyePath, EyeVisitor, Next, walk_eye};
use crate::accel::Hit;
use crate::buffers;
use crate::math::{Rgb, luminance, offset_origin};
use crate::medium::Medium;
use crate::photon::importance::{Importance, cell, grid};
use crate::photon::trace::{PhotonPass, Photons, trace_photons};
use crate::plan::Plan;
use crate::scene::Scene;
use crate::scene::light::LightSampler;
use crate::scene::material::{Material, Transport};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Most eye walks of the importance pilot (one per pixel below that, pixels spread evenly
/// above).
const WALKS: u64 = 16_384;

/// Eye walks per parallel work item (each sums into its own grid; the grids are added in order).
const WALK_CHUNK: u64 = 512;

/// Light paths of the target's pilot …
const LIGHT_PATHS: u64 = 4096;

/// … traced to at most this many events (a path with no collision by then adds nothing).
const LIGHT_BOUNCES: u32 = 16;

/// The iteration number of the pilot's eye walks: one no render reaches.
const PILOT_ITERATION: u64 = u64::MAX;

/// The importance of `scene` for the light paths of `plan` (its seed and bounce limit), or `None` if the scene has no media, or the
/// pilots found no importance or no light path that reaches it (the renders then go unsplit);
/// `Err(())` if `stop` was raised.
pub(crate) fn learn(
    scene: &Scene,
    lights: &LightSampler,
    plan: &Plan,
    stop: &AtomicBool,
) -> Result<Option<Importance>, ()> {
    let (seed, max_bounces) = (plan.seed, plan.max_bounces);
    if !scene.has_media() {
        return Ok(None);
    }
    let Some((sums, counts)) = deposits(scene, seed, max_bounces, stop) else { return Err(()) };
    let Some(importance) = Importance::from_deposits(scene.bounds, sums, counts) else {
        return Ok(None);
    };
    let pass = PhotonPass {
        seed,
        iteration: 0,
        // Streams of "iteration 0" past the guiding pilot's.
        first_path: 1 << 40,
        paths: LIGHT_PATHS,
        max_bounces: max_bounces.min(LIGHT_BOUNCES),
        skip_direct: false,
        media_near: f32::INFINITY,
        record: true,
        mis: None,
    };
    let mut photons = Photons::default();
    if !trace_photons(scene, lights, None, None, &pass, stop, &mut photons) {
        return Err(());
    }
    // Each path's first volume photon (a path's photons are stored in order).
    let mut total = 0.0f64;
    let mut last = None;
    for (photon, &path) in photons.volume.iter().zip(&photons.volume_path) {
        if last != Some(path) {
            total += importance.value(photon.beta, photon.p) as f64;
            last = Some(path);
        }
    }
    Ok(importance.with_target(total / LIGHT_PATHS as f64))
}

/// The eye walks' summed deposits and their number per cell of the grid over the scene's bounds,
/// or `None` if `stop` was raised.
fn deposits(
    scene: &Scene,
    seed: u64,
    max_bounces: u32,
    stop: &AtomicBool,
) -> Option<(Vec<f32>, Vec<u32>)> {
    let [width, height] = scene.camera.resolution;
    let pixels = width as u64 * height as u64;
    let walks = pixels.min(WALKS);
    let (min, scale, dims) = grid(scene.bounds);
    let cells = dims.iter().product::<usize>();
    let chunks = walks.div_ceil(WALK_CHUNK);
    let items: Option<Vec<Importon>> = (0..chunks as usize)
        .into_par_iter()
        .with_max_len(1)
        .map(|c| {
            let c = c as u64;
            // Zeros written, since deposits are added to them (`buffers::filled` says why).
            let (sums, counts) = (buffers::filled(cells, 0.0), buffers::filled(cells, 0));
            let mut importon = Importon { sums, counts, min, scale, dims };
            for k in c * WALK_CHUNK..((c + 1) * WALK_CHUNK).min(walks) {
                if stop.load(Ordering::Relaxed) {
                    return None;
                }
                // Pixels spread evenly over the image.
                let i = k * pixels / walks;
                let pixel = [(i % width as u64) as u32, (i / width as u64) as u32];
                walk_eye(scene, seed, PILOT_ITERATION, pixel, max_bounces, &mut importon);
            }
            Some(importon)
        })
        .collect();
    let (mut sums, mut counts) = (buffers::filled(cells, 0.0f32), buffers::filled(cells, 0u32));
    for item in items? {
        for (s, v) in sums.iter_mut().zip(item.sums) {
            *s += v;
        }
        for (c, n) in counts.iter_mut().zip(item.counts) {
            *c += n;
        }
    }
    Some((sums, counts))
}

/// An eye random walk that leaves, at each collision in a medium, its throughput times σ_s
/// there in the collision's cell, and gathers nothing.
struct Importon {
    sums: Vec<f32>,
    counts: Vec<u32>,
    min: glam::Vec3,
    scale: f32,
    dims: [usize; 3],
}

impl EyeVisitor for Importon {
    fn medium(
        &mut self,
        path: &mut EyePath,
        m: &Medium,
        _id: u32,
        t_max: f32,
        _end: Option<&Hit>,
    ) -> Next {
        let (o, d) = (path.ray.o, path.ray.d);
        let flight = m.sample_free_flight(o, d, t_max, &mut path.s);
        path.beta *= flight.weight;
        if !flight.scattered {
            return Next::Continue;
        }
        let x = o + d * flight.t;
        let sigma_s = m.sigma_s(x);
        // After the free flight's weight the throughput is the collision estimator's of the
        // adjoint fluence; times σ_s, what a light path scattering here would meet.
        if let Some(i) = cell(self.min, self.scale, self.dims, x) {
            let v = luminance(path.beta * sigma_s);
            if v.is_finite() {
                self.sums[i] += v;
                self.counts[i] += 1;
            }
        }
        let ps = m.phase().sample(d, path.s.next_2d());
        path.beta *= sigma_s * (ps.value / ps.pdf);
        Next::Scatter { o: x, d: ps.wi }
    }

    fn emission(&mut self, _path: &EyePath, _hit: &Hit, _le: Rgb) -> Rgb {
        Rgb::ZERO
    }

    fn environment(&mut self, _path: &EyePath, _le: Rgb) -> Rgb {
        Rgb::ZERO
    }

    fn diffuse(&mut self, path: &mut EyePath, hit: &Hit, material: &Material) -> Next {
        let wo = -path.ray.d;
        let ng = if wo.dot(hit.ng) >= 0.0 { hit.ng } else { -hit.ng };
        let u = path.s.next_2d();
        let Some(bs) = material.sample(wo, hit.ng, hit.ns, u, 0.0, Transport::Radiance) else {
            return Next::Stop;
        };
        path.beta *= bs.weight;
        Next::Scatter { o: offset_origin(hit.p, ng, ng), d: bs.wi }
    }

    fn survive(&mut self, path: &mut EyePath) -> bool {
        super::walk::roulette(&mut path.beta, path.depth, &mut path.s)
    }
}
