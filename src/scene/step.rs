//! One vertex step for every path haze traces. An eye path, a light path and a shadow ray all
//! move the same way between vertices: along a ray in the medium they are in, to the surface the
//! ray hits; straight on through a pass-through interface (not a scattering event), into the
//! medium on its far side; off a surface they scatter at, into the medium on the side they leave
//! towards. [`Travel`] is where a path stands between vertices and does the moves at surfaces;
//! [`step`] takes a path from one vertex to the next, and what a path does in a medium and at a
//! surface it scatters at it says through a [`Traveller`]: eye paths (`integrator/walk.rs`) and
//! light paths (`photon/trace.rs`) are two travellers; a shadow ray, which finds every interface
//! on its way in one traversal, crosses them with [`medium_beyond`].

use super::Scene;
use super::material::{MAX_CROSSINGS, Material};
use crate::accel::Hit;
use crate::math::offset_origin;
use glam::Vec3;

/// Where a path stands between vertices: the ray it travels, the medium it travels in, and the
/// pass-through interfaces it has crossed.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Travel {
    /// Origin of the ray.
    pub o: Vec3,
    /// Its unit direction.
    pub d: Vec3,
    /// The medium along it (`None`: vacuum).
    pub medium: Option<u32>,
    /// Pass-through interfaces crossed so far.
    pub crossings: u32,
}

impl Travel {
    /// A path leaving `o` along `d` in `medium`, having crossed nothing.
    pub fn new(o: Vec3, d: Vec3, medium: Option<u32>) -> Self {
        Self { o, d, medium, crossings: 0 }
    }

    /// Crosses the pass-through interface at `hit` straight on, into the medium on its far side.
    /// Returns `false` if that is more than [`MAX_CROSSINGS`] crossings: the path ends.
    #[inline]
    pub fn cross(&mut self, scene: &Scene, hit: &Hit) -> bool {
        self.crossings += 1;
        if self.crossings > MAX_CROSSINGS {
            return false;
        }
        self.medium = medium_beyond(scene, hit, self.medium, self.d);
        self.o = offset_origin(hit.p, hit.ng, self.d);
        true
    }

    /// Leaves the surface at `hit`, where the path scattered, along `wi`: into the medium on the
    /// side `wi` points to (the same one after a reflection), from just off the surface.
    #[inline]
    pub fn leave(&mut self, scene: &Scene, hit: &Hit, wi: Vec3) {
        let shape = &scene.shapes[hit.tag as usize];
        self.medium = shape.medium_after(self.medium, -self.d, wi, hit.ng);
        self.o = offset_origin(hit.p, hit.ng, wi);
        self.d = wi;
    }
}

/// The medium a ray along `d` in `medium` is in past the surface at `hit`, crossed straight on.
#[inline]
pub(crate) fn medium_beyond(scene: &Scene, hit: &Hit, medium: Option<u32>, d: Vec3) -> Option<u32> {
    scene.shapes[hit.tag as usize].medium_after(medium, -d, d, hit.ng)
}

/// What a step did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Vertex {
    /// Crossed a pass-through interface: not a scattering event.
    Crossed,
    /// Scattered, in a medium or at a surface: the path goes on from its new origin.
    Scattered,
    /// The path ends.
    Stop,
}

/// What a path does at the vertices of a [`step`].
pub(crate) trait Traveller {
    /// Where the path stands.
    fn travel(&mut self) -> &mut Travel;

    /// The segment o + t d, 0 < t < `t_max` (the hit's distance, or infinity), lies in medium
    /// `id`: what the path does there. `None`: it goes on to the surface at `t_max`, if any
    /// (`end`).
    fn in_medium(
        &mut self,
        scene: &Scene,
        id: u32,
        t_max: f32,
        end: Option<&Hit>,
    ) -> Option<Vertex>;

    /// The path reached the surface at `hit`, whatever it is (before it crosses or scatters).
    fn reached(&mut self, _scene: &Scene, _hit: &Hit) {}

    /// The path left the scene (its ray meets no surface, and it did not scatter in the medium
    /// it was in): it ends, having reached the environment, if there is one.
    fn escaped(&mut self, _scene: &Scene) {}

    /// The path reached `hit`, on a surface of `material` that is not pass-through: it
    /// scatters ([`Travel::leave`]; a reflection may also set the ray's origin and direction
    /// itself, the medium being unchanged) or ends.
    fn at_surface(&mut self, scene: &Scene, hit: &Hit, material: &Material) -> Vertex;
}

/// Takes `path` from where it stands to its next vertex: along its ray through its medium, then
/// through a pass-through interface or to the surface it scatters at.
#[inline]
pub(crate) fn step(scene: &Scene, path: &mut impl Traveller) -> Vertex {
    let Travel { o, d, medium, .. } = *path.travel();
    let hit = scene.intersect(o, d, f32::INFINITY);
    if let Some(id) = medium {
        let t_max = hit.as_ref().map_or(f32::INFINITY, |h| h.t);
        if let Some(vertex) = path.in_medium(scene, id, t_max, hit.as_ref()) {
            return vertex;
        }
    }
    let Some(hit) = hit else {
        path.escaped(scene);
        return Vertex::Stop;
    };
    path.reached(scene, &hit);
    let material = &scene.materials[scene.shapes[hit.tag as usize].material as usize];
    if *material == Material::Interface {
        return if path.travel().cross(scene, &hit) { Vertex::Crossed } else { Vertex::Stop };
    }
    path.at_surface(scene, &hit, material)
}
