//! Scenes: what is rendered. A [`Scene`] is immutable once built, either from a TOML scene file
//! ([`Scene::load`], format in `docs/scene-format.md`) or in code with a [`SceneBuilder`].

pub mod camera;
mod format;
pub mod light;
mod load;
pub mod material;
pub mod shape;

use crate::accel::{Accel, Hit, Primitive};
use crate::error::{Error, Result};
use crate::math::Rgb;
use crate::medium::Medium;
use crate::settings::RenderSettings;
use camera::Camera;
use glam::Vec3;
use light::{Emitter, Light};
use material::Material;
use shape::Mesh;
use std::path::{Path, PathBuf};

/// The media on the two sides of a shape's surface (pbrt's medium interface). The exterior is
/// the side the surface normals point to; `None` is vacuum.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MediumInterface {
    /// Medium behind the surface (inside a closed shape).
    pub interior: Option<u32>,
    /// Medium in front of the surface.
    pub exterior: Option<u32>,
}

impl MediumInterface {
    /// The medium on the side that direction `w` points to, for geometric normal `ng`.
    #[inline]
    pub fn side(&self, w: Vec3, ng: Vec3) -> Option<u32> {
        if w.dot(ng) >= 0.0 { self.exterior } else { self.interior }
    }
}

/// A shape's non-geometric properties.
#[derive(Clone, Debug)]
pub struct Shape {
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
    pub fn medium_after(&self, current: Option<u32>, wo: Vec3, wi: Vec3, ng: Vec3) -> Option<u32> {
        match &self.media {
            Some(m) if wi.dot(ng) * wo.dot(ng) < 0.0 => m.side(wi, ng),
            _ => current,
        }
    }
}

/// A renderable scene.
pub struct Scene {
    /// The camera.
    pub camera: Camera,
    /// Materials, indexed by [`Shape::material`].
    pub materials: Vec<Material>,
    /// Shapes, indexed by a hit's `tag`.
    pub shapes: Vec<Shape>,
    /// Light sources, area lights included.
    pub lights: Vec<Light>,
    /// The medium each light emits into, aligned with `lights`.
    pub light_media: Vec<Option<u32>>,
    /// Participating media, indexed by medium ids.
    pub media: Vec<Medium>,
    /// Names of the media, aligned with `media`.
    pub medium_names: Vec<String>,
    /// The medium around the camera.
    pub camera_medium: Option<u32>,
    /// Render settings from the scene (the caller may override them before rendering).
    pub settings: RenderSettings,
    /// Axis-aligned bounds of geometry and lights (min, max).
    pub bounds: (Vec3, Vec3),
    /// The scene file, if loaded from one.
    pub source: Option<PathBuf>,
    accel: Accel,
}

impl Scene {
    /// Loads and validates a scene file.
    pub fn load(path: impl AsRef<Path>) -> Result<Scene> {
        load::load_file(path.as_ref())
    }

    /// Parses and validates scene text; relative file references resolve against `base_dir`.
    pub fn from_toml(text: &str, origin: &Path, base_dir: &Path) -> Result<Scene> {
        load::load_str(text, origin, base_dir)
    }

    /// Closest surface hit along `o + t d`, 0 < t < `t_max`; the hit's `tag` indexes
    /// [`Scene::shapes`].
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<Hit> {
        self.accel.intersect(o, d, t_max)
    }

    /// Length of the bounding box's diagonal.
    pub fn diagonal(&self) -> f32 {
        (self.bounds.1 - self.bounds.0).length()
    }

    /// The material of a hit.
    #[inline]
    pub fn material_of(&self, hit: &Hit) -> &Material {
        &self.materials[self.shapes[hit.tag as usize].material as usize]
    }
}

/// A light as described by a user, before the scene's bounds are known.
#[derive(Clone, Debug)]
pub enum LightDesc {
    /// Isotropic point light of total power `power` (W).
    Point {
        /// Position.
        position: Vec3,
        /// Total power (W).
        power: Rgb,
    },
    /// Spot light of total power `power` (W), cone half-angle `cone_angle` and smooth falloff from
    /// `falloff_start` (degrees).
    Spot {
        /// Position.
        position: Vec3,
        /// Point the spot aims at.
        look_at: Vec3,
        /// Total power (W).
        power: Rgb,
        /// Half-angle of the cone (degrees, in (0, 180)).
        cone_angle: f32,
        /// Half-angle where the falloff starts (degrees, ≤ cone_angle).
        falloff_start: f32,
    },
    /// Parallel light travelling along `direction` with irradiance `irradiance` (W/m²).
    Directional {
        /// Direction light travels.
        direction: Vec3,
        /// Irradiance on a perpendicular plane (W/m²).
        irradiance: Rgb,
    },
}

/// Geometry of a shape added in code.
#[derive(Clone, Debug)]
pub enum Geometry {
    /// A triangle mesh, already in world space.
    Mesh(Mesh),
    /// An analytic sphere.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
    },
}

/// Builds a [`Scene`] in code; the scene-file loader goes through it too, so both get the same
/// validation. Errors name the offending item as a key (`shapes[2].emission`).
///
/// ```
/// use haze::scene::{SceneBuilder, Geometry, LightDesc, camera::{Camera, Projection}};
/// use haze::scene::{material::Material, shape};
/// use glam::Vec3;
///
/// let camera = Camera::new(
///     Projection::Perspective { tan_half_fov: 0.5, lens_radius: 0.0, focus_distance: 1.0 },
///     Vec3::new(0.0, 1.0, 3.0), Vec3::ZERO, Vec3::Y, [64, 48]);
/// let mut b = SceneBuilder::new(camera);
/// let grey = b.material("grey", Material::Diffuse { albedo: Vec3::splat(0.5) })?;
/// let floor = shape::rectangle(4.0, 4.0)
///     .transformed(&shape::affine(Vec3::ONE, Vec3::new(-90.0, 0.0, 0.0), Vec3::ZERO));
/// b.shape(Geometry::Mesh(floor), grey, None)?;
/// b.light(LightDesc::Point { position: Vec3::new(0.0, 2.0, 0.0), power: Vec3::splat(30.0) })?;
/// let scene = b.build()?;
/// assert_eq!(scene.lights.len(), 1);
/// # Ok::<(), haze::Error>(())
/// ```
pub struct SceneBuilder {
    camera: Camera,
    camera_medium: Option<u32>,
    settings: RenderSettings,
    materials: Vec<(String, Material)>,
    media: Vec<(String, Medium)>,
    shapes: Vec<(Shape, Geometry)>,
    lights: Vec<(LightDesc, Option<u32>)>,
    source: Option<PathBuf>,
}

fn invalid(key: String, message: impl Into<String>) -> Error {
    Error::Invalid { path: PathBuf::new(), line: None, key, message: message.into() }
}

fn check_color(key: String, c: Rgb, max: Option<f32>) -> Result<()> {
    if !c.is_finite() {
        return Err(invalid(key, format!("must be finite, got {c}")));
    }
    if c.min_element() < 0.0 {
        return Err(invalid(key, format!("must not be negative, got {c}")));
    }
    if let Some(m) = max {
        if c.max_element() > m {
            return Err(invalid(key, format!("must not exceed {m}, got {c}")));
        }
    }
    Ok(())
}

/// Largest coordinate magnitude accepted: beyond it f32 positions are too coarse for ray offsets
/// and the BVH's quantised boxes (obvhs asserts on such extents).
pub const MAX_COORDINATE: f32 = 1e6;

fn check_point(key: String, p: Vec3) -> Result<()> {
    if !p.is_finite() {
        return Err(invalid(key, format!("must be finite, got {p}")));
    }
    if p.abs().max_element() > MAX_COORDINATE {
        return Err(invalid(
            key,
            format!("{p} lies outside haze's working range of ±{MAX_COORDINATE} scene units"),
        ));
    }
    Ok(())
}

impl SceneBuilder {
    /// Starts a scene with the given camera and default render settings.
    pub fn new(camera: Camera) -> Self {
        Self {
            camera,
            camera_medium: None,
            settings: RenderSettings::default(),
            materials: Vec::new(),
            media: Vec::new(),
            shapes: Vec::new(),
            lights: Vec::new(),
            source: None,
        }
    }

    /// Sets the render settings (validated).
    pub fn settings(&mut self, settings: RenderSettings) -> Result<()> {
        settings.validate().map_err(|e| invalid(format!("render.{}", e.key), e.message))?;
        self.settings = settings;
        Ok(())
    }

    /// Records the scene file this scene came from.
    pub fn source(&mut self, path: PathBuf) {
        self.source = Some(path);
    }

    /// Adds a named material; returns its index.
    pub fn material(&mut self, name: &str, m: Material) -> Result<u32> {
        let key = |k: &str| format!("materials.{name}.{k}");
        if self.materials.iter().any(|(n, _)| n == name) {
            return Err(invalid(format!("materials.{name}"), "defined twice"));
        }
        match &m {
            Material::Diffuse { albedo } => check_color(key("albedo"), *albedo, Some(1.0))?,
            Material::Mirror { reflectance } => {
                check_color(key("reflectance"), *reflectance, Some(1.0))?
            }
            Material::Dielectric { ior } => {
                if !(ior.is_finite() && *ior > 0.0) {
                    return Err(invalid(key("ior"), format!("must be positive, got {ior}")));
                }
            }
            Material::Interface => {}
        }
        self.materials.push((name.to_string(), m));
        Ok(self.materials.len() as u32 - 1)
    }

    /// Adds a named participating medium; returns its id.
    pub fn medium(&mut self, name: &str, medium: Medium) -> Result<u32> {
        if self.media.iter().any(|(n, _)| n == name) {
            return Err(invalid(format!("media.{name}"), "defined twice"));
        }
        let key = |k: &str| format!("media.{name}.{k}");
        let (sigma_a, sigma_s, g) = match &medium {
            Medium::Homogeneous(h) => (h.sigma_a, h.sigma_s, h.phase.g),
            Medium::Vdb(v) => {
                let (a, s) = v.coefficients();
                (a, s, v.phase().g)
            }
        };
        check_color(key("sigma_a"), sigma_a, None)?;
        check_color(key("sigma_s"), sigma_s, None)?;
        if !(g > -1.0 && g < 1.0) {
            return Err(invalid(key("g"), format!("must lie strictly between -1 and 1, got {g}")));
        }
        if let Medium::Vdb(_) = &medium {
            let t = sigma_a + sigma_s;
            // Equal up to f32 rounding (albedo · σ_t + (1 − albedo) · σ_t need not sum exactly).
            let spread = t.max_element() - t.min_element();
            if spread > 1e-5 * t.max_element() {
                return Err(invalid(
                    key("sigma_s"),
                    format!(
                        "a grid medium needs the same extinction σ_a + σ_s in every channel \
                         (delta tracking), got {t}; colour the albedo instead"
                    ),
                ));
            }
        }
        self.media.push((name.to_string(), medium));
        Ok(self.media.len() as u32 - 1)
    }

    /// Id of a medium by name.
    pub fn medium_index(&self, name: &str) -> Option<u32> {
        self.media.iter().position(|(n, _)| n == name).map(|i| i as u32)
    }

    /// Sets the medium around the camera (default: vacuum).
    pub fn camera_medium(&mut self, medium: Option<u32>) -> Result<()> {
        self.check_medium_id("camera.medium".into(), medium)?;
        self.camera_medium = medium;
        Ok(())
    }

    fn check_medium_id(&self, key: String, medium: Option<u32>) -> Result<()> {
        match medium {
            Some(m) if m as usize >= self.media.len() => Err(invalid(key, "no such medium")),
            _ => Ok(()),
        }
    }

    /// Index of a material by name.
    pub fn material_index(&self, name: &str) -> Option<u32> {
        self.materials.iter().position(|(n, _)| n == name).map(|i| i as u32)
    }

    /// Adds a shape with material index `material` and optional emitted radiance; crossing it
    /// does not change the medium.
    pub fn shape(
        &mut self,
        geometry: Geometry,
        material: u32,
        emission: Option<Rgb>,
    ) -> Result<()> {
        self.shape_with_media(geometry, material, emission, None)
    }

    /// Adds a shape whose surface separates two media (see [`MediumInterface`]).
    pub fn shape_with_media(
        &mut self,
        geometry: Geometry,
        material: u32,
        emission: Option<Rgb>,
        media: Option<MediumInterface>,
    ) -> Result<()> {
        let label = format!("shapes[{}]", self.shapes.len());
        if let Some(m) = media {
            self.check_medium_id(format!("{label}.interior"), m.interior)?;
            self.check_medium_id(format!("{label}.exterior"), m.exterior)?;
        }
        if material as usize >= self.materials.len() {
            return Err(invalid(format!("{label}.material"), "no such material"));
        }
        if let Some(e) = emission {
            check_color(format!("{label}.emission"), e, None)?;
        }
        match &geometry {
            Geometry::Sphere { center, radius } => {
                check_point(format!("{label}.center"), *center)?;
                check_point(format!("{label}.radius"), center.abs() + Vec3::splat(*radius))?;
                if !(radius.is_finite() && *radius > 0.0) {
                    return Err(invalid(
                        format!("{label}.radius"),
                        format!("must be positive, got {radius}"),
                    ));
                }
            }
            Geometry::Mesh(mesh) => {
                if mesh.triangles.is_empty() {
                    return Err(invalid(label, "mesh has no triangles"));
                }
                let n = mesh.positions.len();
                for (i, p) in mesh.positions.iter().enumerate() {
                    check_point(format!("{label}.vertices[{i}] (after the transform)"), *p)?;
                }
                if let Some(t) =
                    mesh.triangles.iter().position(|t| t.iter().any(|&i| i as usize >= n))
                {
                    return Err(invalid(
                        format!("{label}.triangles[{t}]"),
                        format!("vertex index out of range (the mesh has {n} vertices)"),
                    ));
                }
                if let Some(ns) = &mesh.normals {
                    if ns.len() != n {
                        return Err(invalid(
                            format!("{label}.normals"),
                            format!("{} normals for {n} vertices", ns.len()),
                        ));
                    }
                    if ns.iter().any(|v| !v.is_finite() || v.length_squared() == 0.0) {
                        return Err(invalid(
                            format!("{label}.normals"),
                            "must be finite and non-zero",
                        ));
                    }
                }
            }
        }
        let shape = Shape { label, material, emission, media };
        self.shapes.push((shape, geometry));
        Ok(())
    }

    /// Adds a light in vacuum.
    pub fn light(&mut self, desc: LightDesc) -> Result<()> {
        self.light_in(desc, None)
    }

    /// Adds a light that emits into `medium`.
    pub fn light_in(&mut self, desc: LightDesc, medium: Option<u32>) -> Result<()> {
        let key = |k: &str| format!("lights[{}].{k}", self.lights.len());
        self.check_medium_id(key("medium"), medium)?;
        match &desc {
            LightDesc::Point { position, power } => {
                check_point(key("position"), *position)?;
                check_color(key("power"), *power, None)?;
            }
            LightDesc::Spot { position, look_at, power, cone_angle, falloff_start } => {
                check_point(key("position"), *position)?;
                check_point(key("look_at"), *look_at)?;
                if (*look_at - *position).length_squared() == 0.0 {
                    return Err(invalid(key("look_at"), "must differ from position"));
                }
                check_color(key("power"), *power, None)?;
                if !(*cone_angle > 0.0 && *cone_angle < 180.0) {
                    return Err(invalid(
                        key("cone_angle"),
                        format!("must lie in (0, 180) degrees, got {cone_angle}"),
                    ));
                }
                if !(*falloff_start >= 0.0 && falloff_start <= cone_angle) {
                    return Err(invalid(
                        key("falloff_start"),
                        format!("must lie in [0, cone_angle = {cone_angle}], got {falloff_start}"),
                    ));
                }
            }
            LightDesc::Directional { direction, irradiance } => {
                check_point(key("direction"), *direction)?;
                if direction.length_squared() == 0.0 {
                    return Err(invalid(key("direction"), "must not be zero"));
                }
                check_color(key("irradiance"), *irradiance, None)?;
            }
        }
        self.lights.push((desc, medium));
        Ok(())
    }

    /// Finishes the scene: builds the BVH and the lights.
    pub fn build(self) -> Result<Scene> {
        let mut prims = Vec::new();
        let mut lights = Vec::new();
        let mut light_media = Vec::new();
        for (i, (shape, geometry)) in self.shapes.iter().enumerate() {
            let tag = i as u32;
            match geometry {
                Geometry::Mesh(mesh) => {
                    for tri in &mesh.triangles {
                        let p = tri.map(|v| mesh.positions[v as usize]);
                        // Degenerate triangles have no normal and can never be hit: drop them.
                        if (p[1] - p[0]).cross(p[2] - p[0]).length_squared() == 0.0 {
                            continue;
                        }
                        let normals = mesh.normals.as_ref().map(|n| tri.map(|v| n[v as usize]));
                        prims.push(Primitive::Triangle { p, normals, tag });
                    }
                }
                Geometry::Sphere { center, radius } => {
                    prims.push(Primitive::Sphere { center: *center, radius: *radius, tag });
                }
            }
            if let Some(radiance) = shape.emission.filter(|e| e.max_element() > 0.0) {
                let emitter = match geometry {
                    Geometry::Mesh(mesh) => {
                        let triangles: Vec<[Vec3; 3]> = mesh
                            .triangle_vertices()
                            .filter(|[a, b, c]| (*b - *a).cross(*c - *a).length() > 0.0)
                            .collect();
                        let mut total = 0.0;
                        let cdf = triangles
                            .iter()
                            .map(|[a, b, c]| {
                                total += 0.5 * (*b - *a).cross(*c - *a).length();
                                total
                            })
                            .collect();
                        if triangles.is_empty() {
                            return Err(invalid(
                                format!("{}.emission", shape.label),
                                "the emitting mesh has no area",
                            ));
                        }
                        Emitter::Triangles { triangles, cdf }
                    }
                    Geometry::Sphere { center, radius } => {
                        Emitter::Sphere { center: *center, radius: *radius }
                    }
                };
                lights.push(Light::Area { shape: tag, radiance, emitter });
                light_media.push(shape.media.and_then(|m| m.exterior));
            }
        }
        // obvhs asserts on some degenerate inputs; contain that rather than crash.
        let accel = std::panic::catch_unwind(|| Accel::build(&prims)).map_err(|_| {
            invalid("shapes".into(), "the geometry could not be organised into a BVH (degenerate?)")
        })?;
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for p in &prims {
            let b = obvhs::Boundable::aabb(p);
            lo = lo.min(b.min.into());
            hi = hi.max(b.max.into());
        }
        for (l, _) in &self.lights {
            if let LightDesc::Point { position, .. } | LightDesc::Spot { position, .. } = l {
                lo = lo.min(*position);
                hi = hi.max(*position);
            }
        }
        if !lo.is_finite() {
            lo = Vec3::splat(-1.0);
            hi = Vec3::splat(1.0);
        }
        let (center, radius) = ((lo + hi) * 0.5, ((hi - lo).length() * 0.5).max(1e-3) * 1.01);
        for (l, medium) in &self.lights {
            light_media.push(*medium);
            lights.push(match *l {
                LightDesc::Point { position, power } => {
                    Light::Point { position, intensity: power / (4.0 * std::f32::consts::PI) }
                }
                LightDesc::Spot { position, look_at, power, cone_angle, falloff_start } => {
                    let cos_max = cone_angle.to_radians().cos();
                    let cos_start = falloff_start.to_radians().cos();
                    let omega = light::spot_solid_angle(cos_max, cos_start);
                    Light::Spot {
                        position,
                        frame: crate::math::Frame::new((look_at - position).normalize()),
                        intensity: power / omega,
                        cos_max,
                        cos_start,
                    }
                }
                LightDesc::Directional { direction, irradiance } => Light::Directional {
                    direction: direction.normalize(),
                    irradiance,
                    center,
                    radius,
                },
            });
        }
        let scene = Scene {
            camera: self.camera,
            materials: self.materials.into_iter().map(|(_, m)| m).collect(),
            shapes: self.shapes.into_iter().map(|(s, _)| s).collect(),
            lights,
            light_media,
            medium_names: self.media.iter().map(|(n, _)| n.clone()).collect(),
            media: self.media.into_iter().map(|(_, m)| m).collect(),
            camera_medium: self.camera_medium,
            settings: self.settings,
            bounds: (lo, hi),
            source: self.source,
            accel,
        };
        debug_assert_eq!(scene.lights.len(), scene.light_media.len());
        scene.check_media()?;
        Ok(scene)
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
    /// interfaces around it.
    fn check_media(&self) -> Result<()> {
        let name = |m: Option<u32>| match m {
            Some(i) => format!("medium `{}`", self.medium_names[i as usize]),
            None => "vacuum".to_string(),
        };
        let n_area = self.lights.iter().filter(|l| matches!(l, Light::Area { .. })).count();
        let probe = |what: String, p: Vec3, declared: Option<u32>| -> Result<()> {
            // Tilted off the axes so that no probe runs exactly along a mesh edge (e.g. the
            // diagonal of a rectangle straight below), where a ray can slip between triangles.
            let tilt = glam::Quat::from_axis_angle(Vec3::new(0.3, 0.5, 0.8).normalize(), 0.1);
            for d in PROBES.map(|d| tilt * d) {
                if let Some((seen, shape)) = self.medium_seen(p, d) {
                    if seen != declared {
                        return Err(invalid(
                            what,
                            format!(
                                "declared {} but the medium interface of {} says this point is in {}",
                                name(declared),
                                shape.label,
                                name(seen)
                            ),
                        ));
                    }
                }
            }
            Ok(())
        };
        let cam = &self.camera;
        probe("camera.medium".into(), cam.position, self.camera_medium)?;
        for (i, (light, medium)) in self.lights.iter().zip(&self.light_media).enumerate() {
            if let Light::Point { position, .. } | Light::Spot { position, .. } = light {
                probe(format!("lights[{}].medium", i - n_area), *position, *medium)?;
            }
        }
        Ok(())
    }
}
