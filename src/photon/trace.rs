//! The photon pass: light paths from the lights, through specular and diffuse bounces and through
//! media, leaving photons on diffuse surfaces and at real collisions in media.
//!
//! Paths are traced in parallel in fixed chunks; each path draws from its own random stream
//! (seed, iteration, path index), and chunks are concatenated in order, so the photon lists are the
//! same whatever the thread count.

use super::{Photon, VolumePhoton};
use crate::math::{Rgb, offset_origin};
use crate::rng::{Purpose, Sampler};
use crate::scene::Scene;
use crate::scene::light::LightSampler;
use crate::scene::material::{MAX_CROSSINGS, Material, Transport};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Light paths per parallel work item.
const CHUNK: u64 = 4096;

/// Settings of one photon pass.
#[derive(Clone, Copy, Debug)]
pub struct PhotonPass {
    /// Render seed.
    pub seed: u64,
    /// Iteration number (1-based).
    pub iteration: u64,
    /// Light paths to emit.
    pub paths: u64,
    /// Maximum scattering events per path (pass-through interfaces are not events): a photon is
    /// stored at each of its first `max_depth` scattering vertices at most.
    pub max_depth: u32,
}

/// Photons left by a pass.
#[derive(Default)]
pub struct Photons {
    /// On diffuse surfaces.
    pub surface: Vec<Photon>,
    /// In media.
    pub volume: Vec<VolumePhoton>,
}

/// Russian roulette after an event that turned throughput `before` into `after`: survive with
/// probability min(1, max(after)/max(before)), so survivors keep about their power.
#[inline]
fn roulette(before: Rgb, after: Rgb, u: f32) -> Option<Rgb> {
    let q = (after.max_element() / before.max_element()).min(1.0);
    if q > 0.0 && u < q { Some(after / q) } else { None }
}

/// Traces one light path, storing its photons in `out`.
fn trace_path(
    scene: &Scene,
    lights: &LightSampler,
    pass: &PhotonPass,
    index: u64,
    out: &mut Photons,
) {
    let mut s = Sampler::new(pass.seed, Purpose::Photon, pass.iteration, index);
    let (li, p_light) = lights.pick(s.next_f32());
    let e = scene.lights[li].sample_emission(s.next_f32(), s.next_2d(), s.next_2d());
    let mut beta: Rgb = e.beta / p_light;
    if beta.max_element() <= 0.0 {
        return;
    }
    let mut medium = scene.light_media[li];
    let mut o = if e.n == glam::Vec3::ZERO { e.p } else { offset_origin(e.p, e.n, e.d) };
    let mut d = e.d;
    // Scattering events so far (medium collisions and surface scatterings; pass-through
    // interfaces are not events), and pass-through crossings.
    let (mut bounces, mut crossings) = (0u32, 0u32);
    loop {
        let hit = scene.intersect(o, d, f32::INFINITY);
        if let Some(id) = medium {
            let m = &scene.media[id as usize];
            let t_max = hit.map_or(f32::INFINITY, |h| h.t);
            let flight = m.sample_free_flight(o, d, t_max, &mut s);
            if flight.scattered {
                let p = o + d * flight.t;
                beta *= flight.weight;
                let sigma_s = m.sigma_s(p);
                // Power convention (see `VolumePhoton`): β after the free-flight pdf, before σ_s.
                // Where σ_s = 0 the photon could only ever be weighted by zero: skip it.
                if sigma_s.max_element() > 0.0 {
                    out.volume.push(VolumePhoton { p, d, beta, medium: id });
                }
                bounces += 1;
                if bounces >= pass.max_depth {
                    return;
                }
                let ps = m.phase().sample(d, s.next_2d());
                // Phase sampling is exact, so the scattering weight is σ_s alone.
                let Some(b) = roulette(beta, beta * sigma_s, s.next_f32()) else {
                    return;
                };
                beta = b;
                o = p;
                d = ps.d_out;
                continue;
            }
            beta *= flight.weight;
            if beta.max_element() <= 0.0 {
                return;
            }
        }
        let Some(hit) = hit else { return };
        let wo = -d;
        let shape = &scene.shapes[hit.tag as usize];
        let material = &scene.materials[shape.material as usize];
        if *material == Material::Interface {
            // Index-matched: the photon goes straight on into the medium on the far side.
            crossings += 1;
            if crossings > MAX_CROSSINGS {
                return;
            }
            medium = shape.medium_after(medium, wo, d, hit.ng);
            o = offset_origin(hit.p, hit.ng, d);
            continue;
        }
        if material.is_diffuse() {
            // Power convention (see `Photon`): store the path throughput as it arrives.
            let n = if wo.dot(hit.ng) >= 0.0 { hit.ng } else { -hit.ng };
            out.surface.push(Photon { p: hit.p, n, beta });
        }
        bounces += 1;
        if bounces >= pass.max_depth {
            return;
        }
        let u = s.next_2d();
        let u_lobe = s.next_f32();
        let Some(bs) = material.sample(wo, hit.ng, hit.ns, u, u_lobe, Transport::Importance) else {
            return;
        };
        let Some(b) = roulette(beta, beta * bs.weight, s.next_f32()) else {
            return;
        };
        beta = b;
        medium = shape.medium_after(medium, wo, bs.wi, hit.ng);
        o = offset_origin(hit.p, hit.ng, bs.wi);
        d = bs.wi;
    }
}

/// Runs the photon pass into `out` (cleared first). Returns `false` if `stop` was raised before
/// it finished (the photons are then incomplete and must not be used).
pub fn trace_photons(
    scene: &Scene,
    lights: &LightSampler,
    pass: &PhotonPass,
    stop: &AtomicBool,
    out: &mut Photons,
) -> bool {
    out.surface.clear();
    out.volume.clear();
    if lights.is_empty() {
        return true;
    }
    let chunks = pass.paths.div_ceil(CHUNK);
    let parts: Vec<Option<Photons>> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            if stop.load(Ordering::Relaxed) {
                return None;
            }
            let mut local = Photons::default();
            let end = ((c + 1) * CHUNK).min(pass.paths);
            for index in c * CHUNK..end {
                trace_path(scene, lights, pass, index, &mut local);
            }
            Some(local)
        })
        .collect();
    for part in parts {
        match part {
            Some(p) => {
                out.surface.extend_from_slice(&p.surface);
                out.volume.extend_from_slice(&p.volume);
            }
            None => return false,
        }
    }
    true
}
