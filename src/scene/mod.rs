//! Scenes: what is rendered. A [`Scene`] is immutable once built, either from a TOML scene file
//! ([`Scene::load`], format in `docs/scene-format.md`) or in code with a [`SceneBuilder`].

mod builder;
pub(crate) mod camera;
pub mod describe;
mod format;
pub(crate) mod light;
mod load;
pub(crate) mod material;
pub(crate) mod shape;
pub(crate) mod step;

pub use builder::{MAX_TESSELLATION, SceneBuilder};
pub use camera::{CameraDesc, Lens, MAX_PIXELS};
pub use describe::MAX_COORDINATE;
pub use describe::{
    GeometryDesc, GridLayout, IntoRgb, LightDesc, LightKind, MaterialId, MaterialRef, MediumDesc,
    MediumId, MediumRef, ShapeDesc, TemperatureDesc, Transform, VoxelGrid,
};
pub use light::{EnvMap, Environment, SkyParams, sky};
pub use material::{BsdfSample, Material, Transport};
pub use shape::Mesh;

use crate::accel::{Accel, Hit};
use crate::error::Result;
use crate::error::invalid;
use crate::math::Rgb;
use crate::medium::Medium;
use crate::settings::RenderSettings;
use camera::Camera;
use glam::Vec3;
use light::Light;
use std::path::{Path, PathBuf};

/// How one grid of a grid medium is stored ([`Scene::grids`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GridInfo {
    /// The medium's name.
    pub medium: String,
    /// The grid's name in its file.
    pub grid: String,
    /// The layout chosen (or asked for): [`GridLayout::Dense`] or [`GridLayout::Bricks`].
    pub layout: GridLayout,
    /// The box the layout covers, in voxels.
    pub dims: [i32; 3],
    /// Active voxels in the file (tiles counted voxel by voxel).
    pub active_voxels: u64,
    /// Bytes of the stored values (the dense array, or the brick table, constants and bricks).
    pub bytes: usize,
    /// The same stored values as a grid listed before it (the same grid of the same file
    /// referenced again): no more memory.
    pub shared: bool,
}

impl GridInfo {
    pub(crate) fn of(
        medium: &str,
        grid: &str,
        g: &crate::medium::grid::DensityGrid,
        shared: bool,
    ) -> Self {
        Self {
            medium: medium.to_string(),
            grid: grid.to_string(),
            layout: g.layout(),
            dims: g.dims.to_array(),
            active_voxels: g.active_voxels,
            bytes: g.stored_bytes(),
            shared,
        }
    }
}

impl std::fmt::Display for GridInfo {
    /// `medium cloud, grid density: dense 64×51×59, 118421 active voxels, 0.74 MB`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [x, y, z] = self.dims;
        let layout = match self.layout {
            GridLayout::Bricks => "8³ bricks over",
            _ => "dense",
        };
        write!(
            f,
            "medium {}, grid {}: {layout} {x}×{y}×{z}, {} active voxels, {:.2} MB",
            self.medium,
            self.grid,
            self.active_voxels,
            self.bytes as f64 / 1e6
        )?;
        if self.shared {
            write!(f, " (stored once with the same grid above)")?;
        }
        Ok(())
    }
}

/// The media on the two sides of a shape's surface (pbrt's medium interface). The exterior is
/// the side the surface normals point to; `None` is vacuum.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct MediumInterface {
    /// Medium behind the surface (inside a closed shape).
    pub interior: Option<u32>,
    /// Medium in front of the surface.
    pub exterior: Option<u32>,
}

impl MediumInterface {
    /// The medium on the side that direction `w` points to, for geometric normal `ng`.
    #[inline]
    pub(crate) fn side(&self, w: Vec3, ng: Vec3) -> Option<u32> {
        if w.dot(ng) >= 0.0 { self.exterior } else { self.interior }
    }
}

/// A shape's non-geometric properties.
#[derive(Clone, Debug)]
pub(crate) struct Shape {
    /// Where the shape was defined, e.g. `shapes[3]`.
    pub label: String,
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// Emitted radiance from the front side, if the shape is an area light.
    pub emission: Option<Rgb>,
    /// Media on either side; `None` means crossing the surface leaves the medium unchanged.
    pub media: Option<MediumInterface>,
}

impl Shape {
    /// The medium a path is in after a scattering event at this surface that turned direction
    /// `wo` (pointing away from the surface, towards where the path came from) into `wi`, having
    /// been in `current`: unchanged by a reflection or by a surface without media, the medium on
    /// the far side after a transmission.
    #[inline]
    pub(crate) fn medium_after(
        &self,
        current: Option<u32>,
        wo: Vec3,
        wi: Vec3,
        ng: Vec3,
    ) -> Option<u32> {
        match &self.media {
            Some(m) if wi.dot(ng) * wo.dot(ng) < 0.0 => m.side(wi, ng),
            _ => current,
        }
    }
}

/// A renderable scene: built by [`SceneBuilder`] or loaded from a scene file, immutable but for
/// its render settings and resolution.
pub struct Scene {
    pub(crate) camera: Camera,
    /// Materials, indexed by [`Shape::material`].
    pub(crate) materials: Vec<Material>,
    /// Shapes, indexed by a hit's `tag`.
    pub(crate) shapes: Vec<Shape>,
    /// For each shape, whether it is a pass-through interface (material `interface`): what
    /// [`Accel::through`](crate::accel::Accel::through) crosses.
    pub(crate) passthrough: Vec<bool>,
    /// Light sources, area lights included.
    pub(crate) lights: Vec<Light>,
    /// For each shape, the index of its area light, if it emits.
    pub(crate) area_light: Vec<Option<u32>>,
    /// Where each light was defined and what it is ([`Scene::light_label`]), aligned with
    /// `lights`.
    pub(crate) light_labels: Vec<String>,
    /// The index of the environment light in `lights`, if there is one.
    pub(crate) environment: Option<u32>,
    /// The medium each light emits into, aligned with `lights`.
    pub(crate) light_media: Vec<Option<u32>>,
    /// Participating media, indexed by medium ids.
    pub(crate) media: Vec<Medium>,
    /// Names of the media, aligned with `media`.
    pub(crate) medium_names: Vec<String>,
    /// The medium around the camera.
    pub(crate) camera_medium: Option<u32>,
    /// The media that emit, as a source of photons.
    pub(crate) emissive_media: light::media::EmissiveMedia,
    /// How each grid of the grid media is stored.
    pub(crate) grids: Vec<GridInfo>,
    /// Render settings from the scene file (`[render]`) or the builder; a render takes settings
    /// of its own, usually these with changes.
    pub settings: RenderSettings,
    /// Axis-aligned bounds of geometry and lights (min, max).
    pub(crate) bounds: (Vec3, Vec3),
    /// The scene file, if loaded from one.
    pub(crate) source: Option<PathBuf>,
    pub(crate) accel: Accel,
    /// The shapes that emit (`Shape::emission` given), alone: a ray that meets none of them
    /// reaches no emitter.
    pub(crate) emitters: Accel,
    /// [`Scene::fingerprint`], computed on first use (and forgotten when the resolution changes).
    pub(crate) fingerprint: std::sync::OnceLock<[u8; 32]>,
}

impl Scene {
    /// Closest surface hit along `o + t d`, 0 < t < `t_max`; the hit's `tag` indexes
    /// [`Scene::shapes`].
    #[inline]
    pub(crate) fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<Hit> {
        crate::work::ray();
        self.accel.intersect(o, d, t_max)
    }

    /// A SHA-256 digest of everything that defines the scene's image but the render settings:
    /// camera (resolution included), materials, shapes and their geometry, lights, and media
    /// (grid voxels included) — the scene as built, whatever files it came from, so an edit to
    /// the scene file or to any mesh or volume it loads changes it. Partial renders carry it, and
    /// only renders of the same scene are merged or resumed.
    pub fn fingerprint(&self) -> [u8; 32] {
        *self.fingerprint.get_or_init(|| self.compute_fingerprint())
    }

    fn compute_fingerprint(&self) -> [u8; 32] {
        use sha2::Digest;
        let mut h = sha2::Sha256::new();
        let mut feed = |b: &[u8]| h.update(b);
        feed(b"haze scene fingerprint 1\n");
        let text = format!(
            "{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n",
            self.camera,
            self.materials,
            self.shapes,
            self.lights,
            self.light_media,
            self.medium_names,
            self.camera_medium
        );
        feed(text.as_bytes());
        for m in &self.media {
            m.fingerprint(&mut feed);
        }
        self.accel.fingerprint(&mut feed);
        h.finalize().into()
    }

    /// Trackings through the scene's media cut at their step cap so far (see
    /// `RenderInfo::truncated_trackings`).
    pub(crate) fn truncated_trackings(&self) -> u64 {
        self.media.iter().map(|m| m.truncated_trackings()).sum()
    }

    /// Length of the bounding box's diagonal (radius fractions are relative to it).
    pub fn diagonal(&self) -> f32 {
        (self.bounds.1 - self.bounds.0).length()
    }

    /// Image width and height in pixels.
    pub fn resolution(&self) -> [u32; 2] {
        self.camera.resolution
    }

    /// Renders at another size, keeping the vertical field of view; at most [`MAX_PIXELS`].
    pub fn set_resolution(&mut self, resolution: [u32; 2]) -> Result<()> {
        camera::check_resolution(resolution).map_err(|m| invalid("camera.resolution".into(), m))?;
        self.camera.resolution = resolution;
        self.fingerprint = Default::default();
        Ok(())
    }

    /// The number of shapes.
    pub fn shape_count(&self) -> usize {
        self.shapes.len()
    }

    /// The number of lights, area lights (emitting shapes) included.
    pub fn light_count(&self) -> usize {
        self.lights.len()
    }

    /// Where light `i` (as counted by [`Self::light_count`]) was defined and what it is, e.g.
    /// `shapes[7], an area light` or `lights[1], a spot light`.
    pub fn light_label(&self, i: usize) -> String {
        self.light_labels.get(i).cloned().unwrap_or_else(|| format!("no light {i}"))
    }

    /// The names of the media, in the order they were defined.
    pub fn medium_names(&self) -> &[String] {
        &self.medium_names
    }

    /// The extinction σ_t = σ_a + σ_s (per unit length, per channel) of the medium named
    /// `medium` at the world-space point `p`, as the integrators see it (a grid's trilinear
    /// density, transform, scale and colour grids applied); `None` if no medium has that name.
    /// For probing a scene's media — and for tests that integrate them independently of the
    /// renderer's tracking (tests/suite/vdb.rs).
    pub fn extinction(&self, medium: &str, p: Vec3) -> Option<crate::math::Rgb> {
        let i = self.medium_names.iter().position(|n| n == medium)?;
        let m = &self.media[i];
        Some(m.sigma_a(p) + m.sigma_s(p))
    }

    /// True if the scene has participating media.
    pub fn has_media(&self) -> bool {
        !self.media.is_empty()
    }

    /// The scene file it was loaded from, if any.
    pub fn source(&self) -> Option<&Path> {
        self.source.as_deref()
    }
}

/// Directions probed from the camera and from point and spot lights to check their declared
/// medium against the medium interfaces around them.
const PROBES: [Vec3; 14] = [
    Vec3::X,
    Vec3::NEG_X,
    Vec3::Y,
    Vec3::NEG_Y,
    Vec3::Z,
    Vec3::NEG_Z,
    Vec3::new(0.577_350_26, 0.577_350_26, 0.577_350_26),
    Vec3::new(-0.577_350_26, 0.577_350_26, 0.577_350_26),
    Vec3::new(0.577_350_26, -0.577_350_26, 0.577_350_26),
    Vec3::new(0.577_350_26, 0.577_350_26, -0.577_350_26),
    Vec3::new(-0.577_350_26, -0.577_350_26, 0.577_350_26),
    Vec3::new(-0.577_350_26, 0.577_350_26, -0.577_350_26),
    Vec3::new(0.577_350_26, -0.577_350_26, -0.577_350_26),
    Vec3::new(-0.577_350_26, -0.577_350_26, -0.577_350_26),
];

impl Scene {
    /// The radiance an emitting shape sends from `hit` in direction `w` (away from it), if the
    /// shape is an area light and `w` leaves its front side ([`Light::le`]).
    #[inline]
    pub(crate) fn le(&self, hit: &crate::accel::Hit, w: Vec3) -> Option<crate::math::Rgb> {
        let li = self.area_light.get(hit.tag as usize).copied().flatten()?;
        let le = self.lights[li as usize].le(hit.ng, w);
        (le != crate::math::Rgb::ZERO).then_some(le)
    }

    /// The environment light, if the scene has one: its index among the lights, and itself.
    #[inline]
    pub(crate) fn environment(&self) -> Option<(usize, &light::Environment)> {
        let i = self.environment? as usize;
        match &self.lights[i] {
            Light::Environment(env) => Some((i, env)),
            _ => None,
        }
    }

    /// The medium at `p`: the one the first medium interface hit along a fixed direction says
    /// `p` is in, or the camera's medium if no interface is hit.
    pub(crate) fn medium_at(&self, p: Vec3) -> Option<u32> {
        // Off the axes, so that the probe does not run along mesh edges.
        const PROBE: Vec3 = Vec3::new(0.267_261_24, 0.534_522_5, 0.801_783_7);
        match self.medium_seen(p, PROBE) {
            Some((m, _)) => m,
            None => self.camera_medium,
        }
    }

    /// How the grids of the scene's grid media are stored: one entry per grid.
    pub fn grids(&self) -> &[GridInfo] {
        &self.grids
    }

    /// True if some medium of the scene emits light.
    pub fn has_emissive_media(&self) -> bool {
        !self.emissive_media.is_empty()
    }

    /// The medium at `p` according to the first medium interface hit along `d`, if any.
    fn medium_seen(&self, p: Vec3, d: Vec3) -> Option<(Option<u32>, &Shape)> {
        let mut o = p;
        // Skip shapes without an interface (they do not say which medium is around).
        for _ in 0..64 {
            let hit = self.intersect(o, d, f32::INFINITY)?;
            let shape = &self.shapes[hit.tag as usize];
            if let Some(m) = &shape.media {
                return Some((m.side(-d, hit.ng), shape));
            }
            o = crate::math::offset_origin(hit.p, hit.ng, d);
        }
        None
    }

    /// Rejects a camera or point/spot light whose declared medium contradicts the medium
    /// interfaces around it, and an emitting shape that names no medium on its emitting side
    /// but lies inside one (it would emit into vacuum there: silently wrong).
    fn check_media(&self) -> Result<()> {
        let name = |m: Option<u32>| match m {
            Some(i) => format!("medium `{}`", self.medium_names[i as usize]),
            None => "vacuum".to_string(),
        };
        // The first probe whose medium interface contradicts `declared` at `p`.
        let contradiction = |p: Vec3, declared: Option<u32>| -> Option<(Option<u32>, &Shape)> {
            // Tilted off the axes so that no probe runs exactly along a mesh edge (e.g. the
            // diagonal of a rectangle straight below), where a ray can slip between triangles.
            let tilt = glam::Quat::from_axis_angle(Vec3::new(0.3, 0.5, 0.8).normalize(), 0.1);
            PROBES
                .map(|d| tilt * d)
                .into_iter()
                .filter_map(|d| self.medium_seen(p, d))
                .find(|(seen, _)| *seen != declared)
        };
        let probe = |what: String, p: Vec3, declared: Option<u32>| -> Result<()> {
            match contradiction(p, declared) {
                Some((seen, shape)) => Err(invalid(
                    what,
                    format!(
                        "declared {} but the medium interface of {} says this point is in {}",
                        name(declared),
                        shape.label,
                        name(seen)
                    ),
                )),
                None => Ok(()),
            }
        };
        let cam = &self.camera;
        probe("camera.medium".into(), cam.position, self.camera_medium)?;
        let n_area = self.lights.iter().filter(|l| matches!(l, Light::Area { .. })).count();
        for (i, (light, medium)) in self.lights.iter().zip(&self.light_media).enumerate() {
            match light {
                Light::Point { position, .. } | Light::Spot { position, .. } => {
                    probe(format!("lights[{}].medium", i - n_area), *position, *medium)?;
                }
                Light::Area { shape, emitter, .. } => {
                    let shape = &self.shapes[*shape as usize];
                    if shape.media.is_some() {
                        continue;
                    }
                    // A point just in front of the middle of the emitting surface.
                    let (p, n) = emitter.sample_point(0.5, glam::Vec2::splat(0.5));
                    let front = crate::math::offset_origin(p, n, n);
                    if let Some((Some(seen), around)) = contradiction(front, None) {
                        let medium = &self.medium_names[seen as usize];
                        return Err(invalid(
                            format!("{}.exterior", shape.label),
                            format!(
                                "the shape emits but names no `exterior` medium, so its light would \
                                 leave into vacuum; yet it lies in medium `{medium}` (inside {}): \
                                 add exterior = \"{medium}\" (or interior and exterior, for a shape \
                                 on a medium's boundary)",
                                around.label
                            ),
                        ));
                    }
                }
                Light::Directional { .. } | Light::Environment(_) => {}
            }
        }
        Ok(())
    }
}

impl light::media::MediaSpace for Scene {
    fn media(&self) -> &[Medium] {
        &self.media
    }
    fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }
    fn medium_at(&self, p: Vec3) -> Option<u32> {
        Scene::medium_at(self, p)
    }
    fn emissive_media(&self) -> &light::media::EmissiveMedia {
        &self.emissive_media
    }
}
