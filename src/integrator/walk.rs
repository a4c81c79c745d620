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
use crate::math::Rgb;
use crate::medium::Medium;
use crate::rng::{Purpose, Sampler};
use crate::scene::Scene;
use crate::scene::material::{Material, Transport};
use crate::scene::step::{Travel, Traveller, Vertex, step};
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
    /// The current ray, the medium it travels in, the interfaces crossed.
    pub(crate) ray: Travel,
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
    /// The segment `path.o + t path.d`, 0 < t < `t_max`, lies in medium `medium` (index `id`)
    /// and ends at the surface `end`, if any: estimate what it contributes, update the
    /// throughput, and say where the path goes.
    fn medium(
        &mut self,
        path: &mut EyePath,
        medium: &Medium,
        id: u32,
        t_max: f32,
        end: Option<&Hit>,
    ) -> Next;

    /// The path reached the front of an emitting shape (radiance `le`); returns what it adds to
    /// the path's radiance, throughput included.
    fn emission(&mut self, path: &EyePath, hit: &Hit, le: Rgb) -> Rgb;

    /// The path left the scene along its ray and reached the environment light, of radiance
    /// `le` that way (not called where the environment is hidden from camera rays and the path
    /// is one); returns what it adds to the path's radiance, throughput included.
    fn environment(&mut self, path: &EyePath, le: Rgb) -> Rgb;

    /// The path reached a diffuse surface (`material`) at `hit`.
    fn diffuse(&mut self, path: &mut EyePath, hit: &Hit, material: &Material) -> Next;

    /// After a specular bounce at `hit` (the path already turned; `wo` points back the way it
    /// came).
    fn after_specular(&mut self, _path: &mut EyePath, _hit: &Hit, _wo: Vec3) {}

    /// After every scattering event: false ends the path (Russian roulette).
    fn survive(&mut self, _path: &mut EyePath) -> bool {
        true
    }
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
            ray: Travel::new(ray.o, ray.d, scene.camera_medium),
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
    loop {
        if path.depth >= path.max_bounces {
            // The last allowed event was a specular bounce: the path may still reach an emitter.
            to_emitter(&mut path, visitor);
            break;
        }
        match step(scene, &mut Walking { path: &mut path, visitor, spent: false }) {
            Vertex::Crossed => continue,
            Vertex::Stop => break,
            Vertex::Scattered => {
                if !visitor.survive(&mut path) {
                    break;
                }
                path.depth += 1;
            }
        }
    }
    path.l
}

/// An eye path on its way, with the integrator that says what it does.
struct Walking<'p, 'a, V> {
    path: &'p mut EyePath<'a>,
    visitor: &'p mut V,
    /// The path has used up its events (its last one a specular bounce): it goes straight on
    /// through pass-through interfaces and the transmittance of the media it crosses to the
    /// emitter it reaches, if any (light → (specular)* → eye paths of exactly `max_bounces`
    /// events).
    spent: bool,
}

impl<V: EyeVisitor> Traveller for Walking<'_, '_, V> {
    fn travel(&mut self) -> &mut Travel {
        &mut self.path.ray
    }

    /// Emission along the segment, seen straight on: every integrator counts it in full (nothing
    /// else samples it from here; nothing is drawn for a medium that does not emit); then the
    /// visitor's estimate, or for a spent path the transmittance.
    fn in_medium(
        &mut self,
        scene: &Scene,
        id: u32,
        t_max: f32,
        end: Option<&Hit>,
    ) -> Option<Vertex> {
        let path = &mut *self.path;
        let m = &scene.media[id as usize];
        let Travel { o, d, .. } = path.ray;
        path.l += path.beta * m.emitted(o, d, t_max, &mut path.s);
        if self.spent {
            path.beta *= m.transmittance(o, d, t_max, &mut path.s);
            return (path.beta.max_element() <= 0.0).then_some(Vertex::Stop);
        }
        match self.visitor.medium(path, m, id, t_max, end) {
            Next::Stop => Some(Vertex::Stop),
            Next::Scatter { o, d } => {
                (path.ray.o, path.ray.d) = (o, d);
                Some(Vertex::Scattered)
            }
            Next::Continue => (path.beta.max_element() <= 0.0).then_some(Vertex::Stop),
        }
    }

    /// An emitter counts, whatever else the surface does.
    fn reached(&mut self, scene: &Scene, hit: &Hit) {
        if let Some(le) = scene.le(hit, -self.path.ray.d) {
            self.path.l += self.visitor.emission(self.path, hit, le);
        }
    }

    /// The environment counts ([`environment_seen`]).
    fn escaped(&mut self, _scene: &Scene) {
        if let Some(le) = environment_seen(self.path) {
            self.path.l += self.visitor.environment(self.path, le);
        }
    }

    /// A diffuse surface goes to the visitor, a specular one turns the path; a spent path ends.
    fn at_surface(&mut self, scene: &Scene, hit: &Hit, material: &Material) -> Vertex {
        let path = &mut *self.path;
        if self.spent {
            return Vertex::Stop;
        }
        if let Material::Diffuse { .. } = material {
            return match self.visitor.diffuse(path, hit, material) {
                Next::Scatter { o, d } => {
                    (path.ray.o, path.ray.d) = (o, d);
                    Vertex::Scattered
                }
                Next::Continue | Next::Stop => Vertex::Stop,
            };
        }
        // A specular bounce may be the path's last event: what it sees next can only be an
        // emitter (`to_emitter`).
        let (u, u_lobe) = (path.s.next_2d(), path.s.next_f32());
        let wo = -path.ray.d;
        let Some(bs) = material.sample(wo, hit.ng, hit.ns, u, u_lobe, Transport::Radiance) else {
            return Vertex::Stop;
        };
        path.beta *= bs.weight;
        path.ray.leave(scene, hit, bs.wi);
        self.visitor.after_specular(path, hit, wo);
        Vertex::Scattered
    }
}

/// The environment's radiance along the path's ray, if the scene has an environment light and
/// the path may see it: not on a camera ray (no event yet) where it is hidden.
pub(crate) fn environment_seen(path: &EyePath) -> Option<Rgb> {
    let (_, env) = path.scene.environment()?;
    (path.depth > 0 || env.visible).then(|| env.radiance(path.ray.d))
}

/// Adds the emitter a path that has used up its events reaches, if any (a spent [`Walking`]).
fn to_emitter(path: &mut EyePath, visitor: &mut impl EyeVisitor) {
    let scene = path.scene;
    while step(scene, &mut Walking { path, visitor, spent: true }) == Vertex::Crossed {}
}

/// Russian roulette from the fourth event on, survival probability min(1, max β): a path whose
/// throughput has not fallen is never killed. (An earlier cap of 0.95 killed paths in albedo-1
/// media after ~20 events whatever their throughput; in optically thick media, where light needs
/// thousands of events to escape, the survivors' weights 0.95^−k then made the estimate useless.)
#[inline]
pub(crate) fn roulette(beta: &mut Rgb, depth: u32, s: &mut Sampler) -> bool {
    if beta.max_element() <= 0.0 {
        return false;
    }
    if depth < 3 || beta.max_element() >= 1.0 {
        return true;
    }
    let q = beta.max_element();
    if s.next_f32() >= q {
        return false;
    }
    *beta /= q;
    true
}
