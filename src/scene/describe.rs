//! Scene descriptions: what a scene file says, as values a program can build. A
//! [`SceneBuilder`](super::SceneBuilder) takes them, checks them exactly as it checks a scene file
//! (the loader turns each table into one of these), and makes the [`Scene`](super::Scene).
//!
//! ```
//! use haze::scene::{CameraDesc, LightDesc, Material, MediumDesc, SceneBuilder, ShapeDesc};
//!
//! let mut b = SceneBuilder::new(
//!     CameraDesc::perspective([0.0, 1.0, 4.0], [0.0, 0.5, 0.0], 40.0).resolution(64, 48),
//! );
//! b.material("white", Material::diffuse(0.7))?;
//! b.material("air", Material::Interface)?;
//! b.medium("fog", MediumDesc::homogeneous(0.05, 0.4).g(0.3))?;
//! b.shape(ShapeDesc::rectangle(6.0, 6.0).material("white").rotate([-90.0, 0.0, 0.0]))?;
//! b.shape(ShapeDesc::cuboid([1.0, 1.0, 1.0]).material("air").interior("fog").translate([0.0, 0.5, 0.0]))?;
//! b.light(LightDesc::spot([0.0, 3.0, 0.0], [0.0, 0.0, 0.0], 200.0, 30.0).falloff_start(25.0))?;
//! let scene = b.build()?;
//! # Ok::<(), haze::Error>(())
//! ```

use super::shape::Mesh;
use crate::math::Rgb;
pub use crate::medium::grid::Layout as GridLayout;
use glam::{Affine3A, Vec3};
use std::path::PathBuf;

/// Largest coordinate magnitude accepted: beyond it f32 positions are too coarse for ray offsets
/// and the BVH's quantised boxes (obvhs asserts on such extents).
pub const MAX_COORDINATE: f32 = 1e6;

/// A colour: one number for grey, three for RGB, or a `Vec3`.
pub trait IntoRgb {
    /// The RGB value.
    fn into_rgb(self) -> Rgb;
}

impl IntoRgb for f32 {
    fn into_rgb(self) -> Rgb {
        Rgb::splat(self)
    }
}

impl IntoRgb for [f32; 3] {
    fn into_rgb(self) -> Rgb {
        Rgb::from(self)
    }
}

impl IntoRgb for Vec3 {
    fn into_rgb(self) -> Rgb {
        self
    }
}

/// The id of a material added to a [`SceneBuilder`](super::SceneBuilder).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MaterialId(pub(crate) u32);

/// The id of a medium added to a [`SceneBuilder`](super::SceneBuilder).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MediumId(pub(crate) u32);

/// A material by its name or its id.
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialRef {
    /// By name, as in a scene file.
    Name(String),
    /// By the id [`SceneBuilder::material`](super::SceneBuilder::material) returned.
    Id(MaterialId),
}

impl From<&str> for MaterialRef {
    fn from(name: &str) -> Self {
        MaterialRef::Name(name.to_string())
    }
}

impl From<String> for MaterialRef {
    fn from(name: String) -> Self {
        MaterialRef::Name(name)
    }
}

impl From<MaterialId> for MaterialRef {
    fn from(id: MaterialId) -> Self {
        MaterialRef::Id(id)
    }
}

/// A medium by its name or its id.
#[derive(Clone, Debug, PartialEq)]
pub enum MediumRef {
    /// By name, as in a scene file.
    Name(String),
    /// By the id [`SceneBuilder::medium`](super::SceneBuilder::medium) returned.
    Id(MediumId),
}

impl From<&str> for MediumRef {
    fn from(name: &str) -> Self {
        MediumRef::Name(name.to_string())
    }
}

impl From<String> for MediumRef {
    fn from(name: String) -> Self {
        MediumRef::Name(name)
    }
}

impl From<MediumId> for MediumRef {
    fn from(id: MediumId) -> Self {
        MediumRef::Id(id)
    }
}

/// Scale, then rotation (degrees about x, then y, then z), then translation — the scene file's
/// `transform = { scale, rotate, translate }`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Scale along each axis (not zero).
    pub scale: Vec3,
    /// Euler angles in degrees, applied about x, then y, then z.
    pub rotate: Vec3,
    /// Translation.
    pub translate: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Self { scale: Vec3::ONE, rotate: Vec3::ZERO, translate: Vec3::ZERO }
    }
}

impl Transform {
    /// The matrix: translate · rotate_z · rotate_y · rotate_x · scale.
    pub(crate) fn matrix(&self) -> Affine3A {
        super::shape::affine(self.scale, self.rotate, self.translate)
    }
}

/// A participating medium, as a `[media.NAME]` table describes it. Coefficients are per unit
/// length (per unit density for grids); `g` is the Henyey–Greenstein mean cosine.
#[derive(Clone, Debug, PartialEq)]
pub enum MediumDesc {
    /// Constant coefficients.
    Homogeneous {
        /// Absorption coefficient.
        sigma_a: Rgb,
        /// Scattering coefficient.
        sigma_s: Rgb,
        /// Mean cosine of the phase function, in (−1, 1).
        g: f32,
        /// Emitted radiance L_e (the source is σ_a L_e).
        emission: Rgb,
    },
    /// Coefficients proportional to a density grid read from an OpenVDB file.
    Vdb {
        /// The OpenVDB file (scene files give it relative to themselves).
        file: PathBuf,
        /// The float grid to read.
        grid: String,
        /// Multiplies the grid's values.
        density_scale: f32,
        /// Absorption per unit density.
        sigma_a: Rgb,
        /// Scattering per unit density (σ_a + σ_s may be coloured).
        sigma_s: Rgb,
        /// Mean cosine of the phase function.
        g: f32,
        /// Emitted radiance L_e wherever the grid absorbs (the source σ_a L_e follows the
        /// density).
        emission: Rgb,
        /// Blackbody emission from a temperature grid, added to `emission`.
        temperature: Option<TemperatureDesc>,
        /// Emitted radiance from three float grids (R, G, B) of the same file, times a scale,
        /// added to the rest.
        emission_grid: Option<Box<([String; 3], f32)>>,
        /// Single-scattering albedo from three float grids (R, G, B) of the same file, times a
        /// scale (values in [0, 1]), in place of the constant σ_s / σ_t; the extinction stays.
        albedo_grid: Option<Box<([String; 3], f32)>>,
        /// Coloured extinction from three float grids (R, G, B) of the same file, times a scale
        /// (values ≥ 0): σ_t, σ_a and σ_s of each channel multiplied by its value.
        extinction_grid: Option<Box<([String; 3], f32)>>,
        /// How the grids are stored (dense or in bricks; by default chosen per grid).
        layout: GridLayout,
        /// Places the grid's world space in the scene.
        transform: Transform,
        /// A grid made in code ([`MediumDesc::voxels`]) in place of `file`'s: the density only
        /// (the temperature and colour grids come from files).
        voxels: Option<std::sync::Arc<VoxelGrid>>,
    },
}

/// A density grid made in code, for small procedural media that need no file: `dims` voxels
/// filling a box of `size` scene units centred on the origin (the medium's transform places it),
/// each voxel's value at its centre, interpolated trilinearly between centres like an OpenVDB
/// grid's and zero beyond the outer centres' half voxel.
///
/// ```
/// use haze::scene::VoxelGrid;
/// // A soft ball of smoke, 32³ voxels over a 2-unit cube.
/// let ball = VoxelGrid::from_fn([32, 32, 32], [2.0, 2.0, 2.0], |p| (1.0 - p.length()).max(0.0));
/// assert_eq!(ball.values().len(), 32 * 32 * 32);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct VoxelGrid {
    dims: [u32; 3],
    size: [f32; 3],
    values: Vec<f32>,
}

impl VoxelGrid {
    /// A grid of `dims` voxels over a box of `size`, from its values, x fastest, then y, then z
    /// (`values.len()` must be the voxel count; checked when the scene is built, with the values:
    /// finite and non-negative).
    pub fn new(dims: [u32; 3], size: [f32; 3], values: Vec<f32>) -> Self {
        Self { dims, size, values }
    }

    /// A grid of `dims` voxels over a box of `size`, with `density(p)` at each voxel centre p
    /// (scene units, the box centred on the origin). Dims whose product exceeds haze's dense
    /// limit (2²⁷ voxels) give an empty grid, refused when the scene is built.
    pub fn from_fn(dims: [u32; 3], size: [f32; 3], density: impl Fn(glam::Vec3) -> f32) -> Self {
        let n = dims.iter().map(|&d| d as u64).product::<u64>();
        if n > crate::medium::grid::MAX_VOXELS {
            return Self { dims, size, values: Vec::new() };
        }
        let (d, sz) = (glam::UVec3::from(dims).as_vec3(), glam::Vec3::from(size));
        let mut values = Vec::with_capacity(n as usize);
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let centre = (glam::UVec3::new(i, j, k).as_vec3() + 0.5) / d * sz - 0.5 * sz;
                    values.push(density(centre));
                }
            }
        }
        Self { dims, size, values }
    }

    /// The voxels along each axis.
    pub fn dims(&self) -> [u32; 3] {
        self.dims
    }

    /// The box's size in scene units (before the medium's transform).
    pub fn size(&self) -> [f32; 3] {
        self.size
    }

    /// The values, x fastest.
    pub fn values(&self) -> &[f32] {
        &self.values
    }
}

/// Blackbody emission of a grid medium from a temperature grid of the same file, as pbrt-v4's
/// `nanovdb` medium defines it: T' = (T − offset) · scale, and where T' > cutoff the emitted
/// radiance is blackbody_scale · B̂(T'), B̂ the Planck spectrum normalised to 1 at its peak, as
/// linear sRGB (docs/scene-format.md).
#[derive(Clone, Debug, PartialEq)]
pub struct TemperatureDesc {
    /// The float grid holding temperatures (default `temperature`).
    pub grid: String,
    /// Multiplies the temperature after `offset` is subtracted (default 1).
    pub scale: f32,
    /// Subtracted from the grid's values (default 0).
    pub offset: f32,
    /// No emission at or below this temperature, in kelvin after offset and scale (default 100).
    pub cutoff: f32,
    /// Multiplies the blackbody colour (default 1).
    pub blackbody_scale: f32,
}

impl Default for TemperatureDesc {
    fn default() -> Self {
        Self {
            grid: "temperature".into(),
            scale: 1.0,
            offset: 0.0,
            cutoff: 100.0,
            blackbody_scale: 1.0,
        }
    }
}

impl MediumDesc {
    /// A homogeneous medium from its absorption and scattering coefficients (isotropic until
    /// [`Self::g`]).
    pub fn homogeneous(sigma_a: impl IntoRgb, sigma_s: impl IntoRgb) -> Self {
        MediumDesc::Homogeneous {
            sigma_a: sigma_a.into_rgb(),
            sigma_s: sigma_s.into_rgb(),
            g: 0.0,
            emission: Rgb::ZERO,
        }
    }

    /// A grid medium from an OpenVDB file's `density` grid, with σ_a = 0 and σ_s = 1 per unit
    /// density until [`Self::coefficients`] or [`Self::albedo_extinction`] say otherwise.
    pub fn vdb(file: impl Into<PathBuf>) -> Self {
        MediumDesc::Vdb {
            file: file.into(),
            grid: "density".into(),
            density_scale: 1.0,
            sigma_a: Rgb::ZERO,
            sigma_s: Rgb::ONE,
            g: 0.0,
            emission: Rgb::ZERO,
            temperature: None,
            emission_grid: None,
            albedo_grid: None,
            extinction_grid: None,
            layout: GridLayout::Auto,
            transform: Transform::default(),
            voxels: None,
        }
    }

    /// A grid medium from a density grid made in code ([`VoxelGrid`]), with σ_a = 0 and σ_s = 1
    /// per unit density until [`Self::coefficients`] or [`Self::albedo_extinction`] say
    /// otherwise. Needs no file: temperature and colour grids (which are read from files) cannot
    /// be added to it.
    pub fn voxels(grid: VoxelGrid) -> Self {
        let mut d = Self::vdb(PathBuf::new());
        if let MediumDesc::Vdb { voxels, grid: name, .. } = &mut d {
            *voxels = Some(std::sync::Arc::new(grid));
            *name = "(in memory)".into();
        }
        d
    }

    /// Sets the emitted radiance L_e (the medium adds σ_a L_e per unit length; zero by default).
    pub fn emission(mut self, le: impl IntoRgb) -> Self {
        let le = le.into_rgb();
        match &mut self {
            MediumDesc::Homogeneous { emission, .. } | MediumDesc::Vdb { emission, .. } => {
                *emission = le
            }
        }
        self
    }

    /// Grid media: how the grids are stored ([`GridLayout::Auto`] by default: dense where the
    /// active voxels fill their box well, bricks where they do not).
    pub fn layout(mut self, l: GridLayout) -> Self {
        if let MediumDesc::Vdb { layout, .. } = &mut self {
            *layout = l;
        }
        self
    }

    /// Grid media: emitted radiance `scale` × (R, G, B) read from three float grids of the file,
    /// or from the components of a vector grid, named `["Cd[0]", "Cd[1]", "Cd[2]"]`.
    pub fn emission_grid(mut self, grids: [&str; 3], scale: f32) -> Self {
        if let MediumDesc::Vdb { emission_grid, .. } = &mut self {
            *emission_grid = Some(Box::new((grids.map(str::to_string), scale)));
        }
        self
    }

    /// Grid media: single-scattering albedo `scale` × (R, G, B) read from three float grids of
    /// the file or a vector grid's components (`NAME[0]`, `NAME[1]`, `NAME[2]`; each value times
    /// `scale` at most 1), in place of the constant albedo: σ_s(p) = albedo(p) σ_t(p). The extinction σ_t stays as [`Self::coefficients`] or
    /// [`Self::albedo_extinction`] set it.
    pub fn albedo_grid(mut self, grids: [&str; 3], scale: f32) -> Self {
        if let MediumDesc::Vdb { albedo_grid, .. } = &mut self {
            *albedo_grid = Some(Box::new((grids.map(str::to_string), scale)));
        }
        self
    }

    /// Grid media: extinction coloured by `scale` × (R, G, B) read from three float grids of the
    /// file or a vector grid's components (`NAME[0]`, `NAME[1]`, `NAME[2]`): at p, channel c's
    /// σ_t, σ_a and σ_s are those [`Self::coefficients`] or [`Self::albedo_extinction`] set, times
    /// the density and times the field's channel c (the albedo stays). Mitsuba's RGB σ_t
    /// volumes are this with the density grid at 1.
    pub fn extinction_grid(mut self, grids: [&str; 3], scale: f32) -> Self {
        if let MediumDesc::Vdb { extinction_grid, .. } = &mut self {
            *extinction_grid = Some(Box::new((grids.map(str::to_string), scale)));
        }
        self
    }

    /// Grid media: blackbody emission from a temperature grid (see [`TemperatureDesc`]).
    pub fn temperature(mut self, t: TemperatureDesc) -> Self {
        if let MediumDesc::Vdb { temperature, .. } = &mut self {
            *temperature = Some(t);
        }
        self
    }

    /// Sets the Henyey–Greenstein mean cosine.
    pub fn g(mut self, g: f32) -> Self {
        match &mut self {
            MediumDesc::Homogeneous { g: x, .. } | MediumDesc::Vdb { g: x, .. } => *x = g,
        }
        self
    }

    /// Sets the absorption and scattering coefficients.
    pub fn coefficients(mut self, sigma_a: impl IntoRgb, sigma_s: impl IntoRgb) -> Self {
        let (a, s) = (sigma_a.into_rgb(), sigma_s.into_rgb());
        match &mut self {
            MediumDesc::Homogeneous { sigma_a, sigma_s, .. }
            | MediumDesc::Vdb { sigma_a, sigma_s, .. } => (*sigma_a, *sigma_s) = (a, s),
        }
        self
    }

    /// Sets the coefficients from the single-scattering albedo and the extinction:
    /// σ_s = albedo · σ_t, σ_a = σ_t − σ_s.
    pub fn albedo_extinction(self, albedo: impl IntoRgb, sigma_t: impl IntoRgb) -> Self {
        let (albedo, sigma_t) = (albedo.into_rgb(), sigma_t.into_rgb());
        self.coefficients((Rgb::ONE - albedo) * sigma_t, albedo * sigma_t)
    }

    /// Grid media: the grid to read (default `density`).
    pub fn grid(mut self, name: &str) -> Self {
        if let MediumDesc::Vdb { grid, .. } = &mut self {
            *grid = name.to_string();
        }
        self
    }

    /// Grid media: multiplies the grid's values (default 1).
    pub fn density_scale(mut self, scale: f32) -> Self {
        if let MediumDesc::Vdb { density_scale, .. } = &mut self {
            *density_scale = scale;
        }
        self
    }

    /// Grid media: places the grid's world space in the scene.
    pub fn transform(mut self, t: Transform) -> Self {
        if let MediumDesc::Vdb { transform, .. } = &mut self {
            *transform = t;
        }
        self
    }
}

/// The geometry of a shape, before its transform.
#[derive(Clone, Debug, PartialEq)]
pub enum GeometryDesc {
    /// A w × h rectangle in the xy-plane, centred, facing +z.
    Rectangle {
        /// Width and height.
        size: [f32; 2],
    },
    /// An axis-aligned box, centred, faces outward.
    Cuboid {
        /// Size along x, y and z.
        size: Vec3,
    },
    /// A sphere: analytic, or an icosphere of 20·4ⁿ triangles with interpolated normals.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
        /// Subdivision level of the icosphere (0–7), or `None` for the analytic sphere.
        tessellate: Option<u32>,
    },
    /// A triangle mesh.
    Mesh(Mesh),
    /// A Wavefront OBJ file (every object, as one mesh).
    Obj(PathBuf),
    /// A PLY file, ASCII or binary (its `vertex` and `face` elements).
    Ply(PathBuf),
}

/// A shape, as a `[[shapes]]` table describes it: geometry, material, optional emission and the
/// media on its two sides, and a transform.
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeDesc {
    /// The geometry.
    pub geometry: GeometryDesc,
    /// The material (required).
    pub material: Option<MaterialRef>,
    /// Emitted radiance from the front side: the shape becomes an area light.
    pub emission: Option<Rgb>,
    /// The medium behind the surface (inside a closed shape).
    pub interior: Option<MediumRef>,
    /// The medium in front of the surface.
    pub exterior: Option<MediumRef>,
    /// Placement.
    pub transform: Transform,
}

impl ShapeDesc {
    fn of(geometry: GeometryDesc) -> Self {
        Self {
            geometry,
            material: None,
            emission: None,
            interior: None,
            exterior: None,
            transform: Transform::default(),
        }
    }

    /// A w × h rectangle in the xy-plane, centred, facing +z.
    pub fn rectangle(w: f32, h: f32) -> Self {
        Self::of(GeometryDesc::Rectangle { size: [w, h] })
    }

    /// A box of the given size, centred at the origin.
    pub fn cuboid(size: impl Into<Vec3>) -> Self {
        Self::of(GeometryDesc::Cuboid { size: size.into() })
    }

    /// An analytic sphere.
    pub fn sphere(center: impl Into<Vec3>, radius: f32) -> Self {
        Self::of(GeometryDesc::Sphere { center: center.into(), radius, tessellate: None })
    }

    /// A triangle mesh.
    pub fn mesh(mesh: Mesh) -> Self {
        Self::of(GeometryDesc::Mesh(mesh))
    }

    /// The meshes of a Wavefront OBJ file.
    pub fn obj(file: impl Into<PathBuf>) -> Self {
        Self::of(GeometryDesc::Obj(file.into()))
    }

    /// The mesh of a PLY file (ASCII or binary, as pbrt-v4's and Mitsuba's scene collections
    /// store meshes): its `vertex` element's x, y, z (and nx, ny, nz if every vertex has them)
    /// and its `face` element's `vertex_indices`, polygons split into fans.
    pub fn ply(file: impl Into<PathBuf>) -> Self {
        Self::of(GeometryDesc::Ply(file.into()))
    }

    /// Sets the material, by name or id.
    pub fn material(mut self, m: impl Into<MaterialRef>) -> Self {
        self.material = Some(m.into());
        self
    }

    /// Makes the shape an area light of radiance `le` on its front side.
    pub fn emission(mut self, le: impl IntoRgb) -> Self {
        self.emission = Some(le.into_rgb());
        self
    }

    /// Sets the medium inside (behind the surface).
    pub fn interior(mut self, m: impl Into<MediumRef>) -> Self {
        self.interior = Some(m.into());
        self
    }

    /// Sets the medium outside (in front of the surface).
    pub fn exterior(mut self, m: impl Into<MediumRef>) -> Self {
        self.exterior = Some(m.into());
        self
    }

    /// Tessellates a sphere into an icosphere of `level` subdivisions.
    pub fn tessellate(mut self, level: u32) -> Self {
        if let GeometryDesc::Sphere { tessellate, .. } = &mut self.geometry {
            *tessellate = Some(level);
        }
        self
    }

    /// Sets the scale (applied first).
    pub fn scale(mut self, s: impl IntoRgb) -> Self {
        self.transform.scale = s.into_rgb();
        self
    }

    /// Sets the rotation: degrees about x, then y, then z (after the scale).
    pub fn rotate(mut self, degrees: impl Into<Vec3>) -> Self {
        self.transform.rotate = degrees.into();
        self
    }

    /// Sets the translation (applied last).
    pub fn translate(mut self, t: impl Into<Vec3>) -> Self {
        self.transform.translate = t.into();
        self
    }
}

/// A light, as a `[[lights]]` table describes it (area lights are shapes with an emission).
#[derive(Clone, Debug, PartialEq)]
pub struct LightDesc {
    /// What kind of light.
    pub kind: LightKind,
    /// The medium it emits into (vacuum if `None`).
    pub medium: Option<MediumRef>,
}

/// The kinds of light besides area lights.
#[derive(Clone, Debug, PartialEq)]
pub enum LightKind {
    /// Isotropic point light of total power `power` (W).
    Point {
        /// Position.
        position: Vec3,
        /// Total power (W).
        power: Rgb,
    },
    /// Spot light of total power `power` (W), cone half-angle `cone_angle` (degrees) and a
    /// smooth falloff from `falloff_start` (degrees; `None`: a hard edge at the cone).
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
        falloff_start: Option<f32>,
    },
    /// Parallel light travelling along `direction` with irradiance `irradiance` (W/m²).
    Directional {
        /// Direction light travels.
        direction: Vec3,
        /// Irradiance on a perpendicular plane (W/m²).
        irradiance: Rgb,
    },
    /// Radiance arriving from infinitely far away: `radiance` (W/(m²·sr)) from every direction,
    /// or times a latitude–longitude `map` ([`EnvMap`](crate::scene::EnvMap)), turned by
    /// `rotate`. At most one per scene.
    Environment {
        /// The constant radiance, or the map's multiplier.
        radiance: Rgb,
        /// The radiance image, if any.
        map: Option<std::sync::Arc<crate::scene::EnvMap>>,
        /// Euler angles in degrees, about x, then y, then z (as shapes' `rotate`).
        rotate: Vec3,
        /// Whether camera rays that leave the scene see it (light it casts is unchanged).
        visible: bool,
    },
    /// A physical daylight sky (Preetham et al. 1999, `scene/light/sky.rs`) rendered to an
    /// environment map of `resolution` × `resolution / 2` texels, and its sun as a directional
    /// light, both times `scale`. Counts as the scene's environment light.
    Sky {
        /// The sun's position, the turbidity and the ground's albedo.
        params: crate::scene::light::SkyParams,
        /// Multiplies the sky's and the sun's radiance.
        scale: Rgb,
        /// Width of the map in texels (its height is half).
        resolution: u32,
        /// Whether the sun is a light too (false: the sky dome alone).
        sun: bool,
        /// Whether camera rays that leave the scene see the sky.
        visible: bool,
    },
}

impl LightDesc {
    fn of(kind: LightKind) -> Self {
        Self { kind, medium: None }
    }

    /// An isotropic point light of total power `power` (W).
    pub fn point(position: impl Into<Vec3>, power: impl IntoRgb) -> Self {
        Self::of(LightKind::Point { position: position.into(), power: power.into_rgb() })
    }

    /// A spot light of total power `power` (W) with cone half-angle `cone_angle` (degrees) and a
    /// hard edge (see [`Self::falloff_start`]).
    pub fn spot(
        position: impl Into<Vec3>,
        look_at: impl Into<Vec3>,
        power: impl IntoRgb,
        cone_angle: f32,
    ) -> Self {
        Self::of(LightKind::Spot {
            position: position.into(),
            look_at: look_at.into(),
            power: power.into_rgb(),
            cone_angle,
            falloff_start: None,
        })
    }

    /// A parallel light travelling along `direction` with `irradiance` (W/m²).
    pub fn directional(direction: impl Into<Vec3>, irradiance: impl IntoRgb) -> Self {
        Self::of(LightKind::Directional {
            direction: direction.into(),
            irradiance: irradiance.into_rgb(),
        })
    }

    /// An environment of constant radiance `radiance` (W/(m²·sr)) from every direction.
    pub fn environment(radiance: impl IntoRgb) -> Self {
        Self::of(LightKind::Environment {
            radiance: radiance.into_rgb(),
            map: None,
            rotate: Vec3::ZERO,
            visible: true,
        })
    }

    /// An environment whose radiance is the latitude–longitude `map` (times
    /// [`Self::scale`]; [`EnvMap::load`](crate::scene::EnvMap::load) reads one from OpenEXR).
    pub fn environment_map(map: crate::scene::EnvMap) -> Self {
        Self::of(LightKind::Environment {
            radiance: Rgb::ONE,
            map: Some(std::sync::Arc::new(map)),
            rotate: Vec3::ZERO,
            visible: true,
        })
    }

    /// A daylight sky with the sun at `elevation` degrees above the horizon and `azimuth`
    /// degrees from +z towards +x; turbidity 3, ground albedo 0.3, a 512 × 256 map, the sun
    /// included.
    pub fn sky(elevation: f32, azimuth: f32) -> Self {
        Self::sky_towards(crate::scene::light::sky::sun_towards(elevation, azimuth))
    }

    /// [`Self::sky`] with the sun in direction `sun` (towards it; y up).
    pub fn sky_towards(sun: impl Into<Vec3>) -> Self {
        let sun: Vec3 = sun.into();
        let sun = if sun.length_squared() > 0.0 { sun.normalize() } else { sun };
        Self::of(LightKind::Sky {
            params: crate::scene::light::SkyParams {
                sun,
                turbidity: 3.0,
                ground_albedo: Rgb::splat(0.3),
            },
            scale: Rgb::ONE,
            resolution: 512,
            sun: true,
            visible: true,
        })
    }

    /// The width of a sky's map in texels (its height is half; default 512).
    pub fn sky_resolution(mut self, width: u32) -> Self {
        if let LightKind::Sky { resolution, .. } = &mut self.kind {
            *resolution = width;
        }
        self
    }

    /// A sky's turbidity (1.7 … 10).
    pub fn turbidity(mut self, t: f32) -> Self {
        if let LightKind::Sky { params, .. } = &mut self.kind {
            params.turbidity = t;
        }
        self
    }

    /// The albedo of a sky's ground.
    pub fn ground_albedo(mut self, albedo: impl IntoRgb) -> Self {
        if let LightKind::Sky { params, .. } = &mut self.kind {
            params.ground_albedo = albedo.into_rgb();
        }
        self
    }

    /// Whether a sky's sun is a light too (default true).
    pub fn with_sun(mut self, on: bool) -> Self {
        if let LightKind::Sky { sun, .. } = &mut self.kind {
            *sun = on;
        }
        self
    }

    /// Multiplies an environment's or a sky's radiance by `s`.
    pub fn scale(mut self, s: impl IntoRgb) -> Self {
        match &mut self.kind {
            LightKind::Environment { radiance, .. } => *radiance *= s.into_rgb(),
            LightKind::Sky { scale, .. } => *scale *= s.into_rgb(),
            _ => {}
        }
        self
    }

    /// Turns an environment: Euler angles in degrees about x, then y, then z.
    pub fn rotate(mut self, degrees: impl Into<Vec3>) -> Self {
        if let LightKind::Environment { rotate, .. } = &mut self.kind {
            *rotate = degrees.into();
        }
        self
    }

    /// Whether camera rays that leave the scene see the environment or sky (default true).
    pub fn visible(mut self, seen: bool) -> Self {
        if let LightKind::Environment { visible, .. } | LightKind::Sky { visible, .. } =
            &mut self.kind
        {
            *visible = seen;
        }
        self
    }

    /// A spot light's smooth falloff from `degrees` to the cone's edge.
    pub fn falloff_start(mut self, degrees: f32) -> Self {
        if let LightKind::Spot { falloff_start, .. } = &mut self.kind {
            *falloff_start = Some(degrees);
        }
        self
    }

    /// The medium the light emits into.
    pub fn medium(mut self, m: impl Into<MediumRef>) -> Self {
        self.medium = Some(m.into());
        self
    }
}
