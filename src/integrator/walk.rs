//! The one eye-path walker. Every integrator's camera pass follows eye paths the same way: the
//! pixel's random stream, the jittered camera ray, the surface hits, pass-through interfaces
//! (which change the medium and are not scattering events), specular bounces (mirror, glass),
//! medium changes and ray offsets, and the count of scattering events against `max_bounces`. What
//! an integrator does differently — along a segment in a medium, at an emitter, at a diffuse
//! surface, and whether a path survives a bounce — it says through an [`EyeVisitor`].
//!
//! The walker draws its random numbers in a fixed order (pixel jitter, lens, then per specular
//! bounce a 2-D and a 1-D sample), and a visitor draws its own from the same stream in between,
//! so an eye path depends only on (seed, iteration, pixel).

use crate::accel::Hit;
use crate::math::{Rgb, offset_origin};
use crate::medium::Medium;
use crate::rng::{Purpose, Sampler};
use crate::scene::Scene;
use crate::scene::material::{MAX_CROSSINGS, Material, Transport};
use glam::{Vec2, Vec3};

/// Where an eye path goes after a vertex.
pub(crate) enum Next {
    /// On along the same ray, to the surface it hits.
    Continue,
    /// A scattering event: on from `o` in direction `d` (counts towards `max_bounces`).
    Scatter {
        /// New origin.
        o: Vec3,
        /// New direction.
        d: Vec3,
    },
    /// The path ends.
    Stop,
}

/// The state of an eye path.
pub(crate) struct EyePath<'a> {
    pub(crate) scene: &'a Scene,
    /// The pixel's random stream.
    pub(crate) s: Sampler,
    /// Origin and direction of the current ray.
    pub(crate) o: Vec3,
    pub(crate) d: Vec3,
    /// The medium the ray travels in.
    pub(crate) medium: Option<u32>,
    /// Path throughput.
    pub(crate) beta: Rgb,
    /// Radiance collected so far.
    pub(crate) l: Rgb,
    /// Scattering events so far.
    pub(crate) depth: u32,
    pub(crate) max_bounces: u32,
}

impl EyePath<'_> {
    /// True if the next scattering event is the last the path may have.
    #[inline]
    pub(crate) fn last(&self) -> bool {
        self.depth + 1 == self.max_bounces
    }
}

/// What an integrator does along an eye path.
pub(crate) trait EyeVisitor {
    /// The segment `path.o + t path.d`, 0 < t < `t_max`, lies in medium `medium` (index `id`):
    /// estimate what it contributes, update the throughput, and say where the path goes.
    fn medium(&mut self, path: &mut EyePath, medium: &Medium, id: u32, t_max: f32) -> Next;

    /// The path reached the front of an emitting shape (radiance `le`); returns what it adds to
    /// the path's radiance, throughput included.
    fn emission(&mut self, path: &EyePath, hit: &Hit, le: Rgb) -> Rgb;

    /// The path reached a diffuse surface (`material`) at `hit`.
    fn diffuse(&mut self, path: &mut EyePath, hit: &Hit, material: &Material) -> Next;

    /// After a specular bounce (the path already turned).
    fn after_specular(&mut self, _path: &mut EyePath) {}

    /// After every scattering event: false ends the path (Russian roulette).
    fn survive(&mut self, _path: &mut EyePath) -> bool {
        true
    }
}

/// What one step of a walk did.
enum Step {
    /// Crossed a pass-through interface: not a scattering event.
    Crossed,
    /// Scattered (in a medium or at a surface): the path goes on from its new origin.
    Scattered,
    /// The path ends.
    Stop,
}

impl<'a> EyePath<'a> {
    /// The path of pixel (x, y) of iteration `iteration`: its stream, and the jittered camera
    /// ray.
    fn start(
        scene: &'a Scene,
        seed: u64,
        iteration: u64,
        pixel: [u32; 2],
        max_bounces: u32,
    ) -> Self {
        let [x, y] = pixel;
        let width = scene.camera.resolution[0];
        let mut s = Sampler::new(seed, Purpose::Camera, iteration, (y * width + x) as u64);
        let jittered = Vec2::new(x as f32, y as f32) + s.next_2d();
        let ray = scene.camera.generate_ray(jittered, s.next_2d());
        EyePath {
            scene,
            s,
            o: ray.o,
            d: ray.d,
            medium: scene.camera_medium,
            beta: Rgb::ONE,
            l: Rgb::ZERO,
            depth: 0,
            max_bounces,
        }
    }
}

/// Follows the eye path of pixel (x, y) of iteration `iteration` and returns the radiance it
/// collects.
pub(crate) fn walk_eye(
    scene: &Scene,
    seed: u64,
    iteration: u64,
    pixel: [u32; 2],
    max_bounces: u32,
    visitor: &mut impl EyeVisitor,
) -> Rgb {
    let mut path = EyePath::start(scene, seed, iteration, pixel, max_bounces);
    let mut crossings = 0u32;
    loop {
        if path.depth >= path.max_bounces {
            // The last allowed event was a specular bounce: the path may still reach an emitter.
            to_emitter(&mut path, visitor, &mut crossings);
            break;
        }
        let hit = scene.intersect(path.o, path.d, f32::INFINITY);
        let step = match through_medium(&mut path, hit.as_ref(), visitor) {
            Some(step) => step,
            None => match &hit {
                Some(hit) => at_surface(&mut path, hit, visitor, &mut crossings),
                None => Step::Stop,
            },
        };
        match step {
            Step::Crossed => continue,
            Step::Stop => break,
            Step::Scattered => {
                if !visitor.survive(&mut path) {
                    break;
                }
                path.depth += 1;
            }
        }
    }
    path.l
}

/// The segment up to `hit` (or to infinity) in the path's medium, if it is in one. `None` when the
/// path goes on to the surface.
fn through_medium(
    path: &mut EyePath,
    hit: Option<&Hit>,
    visitor: &mut impl EyeVisitor,
) -> Option<Step> {
    let id = path.medium?;
    let scene = path.scene;
    let t_max = hit.map_or(f32::INFINITY, |h| h.t);
    let m = &scene.media[id as usize];
    // Emission along the segment, seen straight on: every integrator counts it in full (nothing
    // else samples it from here). Nothing is drawn for a medium that does not emit.
    path.l += path.beta * m.emitted(path.o, path.d, t_max, &mut path.s);
    match visitor.medium(path, m, id, t_max) {
        Next::Stop => Some(Step::Stop),
        Next::Scatter { o, d } => {
            (path.o, path.d) = (o, d);
            Some(Step::Scattered)
        }
        Next::Continue => (path.beta.max_element() <= 0.0).then_some(Step::Stop),
    }
}

/// The path reached a surface: an emitter counts, a pass-through interface is crossed, a diffuse
/// surface goes to the visitor, a specular one turns the path.
fn at_surface(
    path: &mut EyePath,
    hit: &Hit,
    visitor: &mut impl EyeVisitor,
    crossings: &mut u32,
) -> Step {
    let scene = path.scene;
    let wo = -path.d;
    let shape = &scene.shapes[hit.tag as usize];
    if let Some(le) = scene.le(hit, wo) {
        path.l += visitor.emission(path, hit, le);
    }
    let material = &scene.materials[shape.material as usize];
    match material {
        Material::Interface => {
            // Index-matched: straight on into the medium on the far side; not an event.
            *crossings += 1;
            if *crossings > MAX_CROSSINGS {
                return Step::Stop;
            }
            path.medium = shape.medium_after(path.medium, wo, path.d, hit.ng);
            path.o = offset_origin(hit.p, hit.ng, path.d);
            Step::Crossed
        }
        Material::Diffuse { .. } => match visitor.diffuse(path, hit, material) {
            Next::Scatter { o, d } => {
                (path.o, path.d) = (o, d);
                Step::Scattered
            }
            Next::Continue | Next::Stop => Step::Stop,
        },
        _ => {
            // A specular bounce may be the path's last event: what it sees next can only be an
            // emitter (`to_emitter`).
            let (u, u_lobe) = (path.s.next_2d(), path.s.next_f32());
            let Some(bs) = material.sample(wo, hit.ng, hit.ns, u, u_lobe, Transport::Radiance)
            else {
                return Step::Stop;
            };
            path.beta *= bs.weight;
            path.medium = shape.medium_after(path.medium, wo, bs.wi, hit.ng);
            path.o = offset_origin(hit.p, hit.ng, bs.wi);
            path.d = bs.wi;
            visitor.after_specular(path);
            Step::Scattered
        }
    }
}

/// Follows a path that has used up its events (its last one a specular bounce) straight on,
/// through pass-through interfaces and the transmittance of the media it crosses, and adds the
/// emitter it reaches, if any: light → (specular)* → eye paths of exactly `max_bounces` events.
fn to_emitter(path: &mut EyePath, visitor: &mut impl EyeVisitor, crossings: &mut u32) {
    let scene = path.scene;
    loop {
        let hit = scene.intersect(path.o, path.d, f32::INFINITY);
        if let Some(id) = path.medium {
            let t_max = hit.map_or(f32::INFINITY, |h| h.t);
            let m = &scene.media[id as usize];
            path.l += path.beta * m.emitted(path.o, path.d, t_max, &mut path.s);
            path.beta *= m.transmittance(path.o, path.d, t_max, &mut path.s);
            if path.beta.max_element() <= 0.0 {
                return;
            }
        }
        let Some(hit) = hit else { return };
        let wo = -path.d;
        let shape = &scene.shapes[hit.tag as usize];
        if let Some(le) = scene.le(&hit, wo) {
            path.l += visitor.emission(path, &hit, le);
        }
        if scene.materials[shape.material as usize] != Material::Interface {
            return;
        }
        *crossings += 1;
        if *crossings > MAX_CROSSINGS {
            return;
        }
        path.medium = shape.medium_after(path.medium, wo, path.d, hit.ng);
        path.o = offset_origin(hit.p, hit.ng, path.d);
    }
}
