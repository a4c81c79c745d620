//! [`SceneBuilder`]: scenes built in code, from the descriptions of [`super::describe`]. The scene
//! loader goes through it too, so a scene built in code gets exactly the checks a scene file gets,
//! with errors naming the item as a key (`shapes[2].emission`, `camera.fov`).

use super::camera::{Camera, CameraDesc};
use super::describe::MAX_COORDINATE;
use super::describe::{
    GeometryDesc, GridLayout, LightDesc, LightKind, MaterialId, MaterialRef, MediumDesc, MediumId,
    MediumRef, ShapeDesc, TemperatureDesc, Transform,
};
use super::light::{self, Emitter, Light};
use super::material::Material;
use super::shape::{self, Mesh};
use super::{GridInfo, MediumInterface, Scene, Shape};
use crate::accel::{Accel, Primitive};
use crate::error::{Error, Result, invalid, quote};
use crate::math::Rgb;
use crate::medium::Medium;
use crate::medium::grid::DensityGrid;
use crate::medium::homogeneous::Homogeneous;
use crate::medium::phase::HenyeyGreenstein;
use crate::medium::vdb::{ColourField, TemperatureField, VdbMedium};
use crate::settings::RenderSettings;
use glam::Vec3;
use std::path::{Path, PathBuf};

/// Most subdivisions of a tessellated sphere (327,680 triangles).
pub const MAX_TESSELLATION: u32 = 7;

/// Geometry after its transform: what the BVH holds.
#[derive(Clone, Debug)]
enum Geometry {
    Mesh(Mesh),
    Sphere { center: Vec3, radius: f32 },
}

/// Builds a [`Scene`] in code. Materials and media are named (shapes and lights refer to them by
/// name or by the ids `material` and `medium` return); every call checks what it is given, and
/// [`Self::build`] checks the camera and the whole.
///
/// ```
/// use haze::scene::{CameraDesc, LightDesc, Material, SceneBuilder, ShapeDesc};
///
/// let mut b = SceneBuilder::new(CameraDesc::perspective([0.0, 1.0, 3.0], [0.0, 0.0, 0.0], 50.0));
/// let grey = b.material("grey", Material::diffuse(0.5))?;
/// b.shape(ShapeDesc::rectangle(4.0, 4.0).material(grey).rotate([-90.0, 0.0, 0.0]))?;
/// b.light(LightDesc::point([0.0, 2.0, 0.0], 30.0))?;
/// let scene = b.build()?;
/// assert_eq!(scene.resolution(), [512, 512]);
/// # Ok::<(), haze::Error>(())
/// ```
pub struct SceneBuilder {
    camera: CameraDesc,
    settings: RenderSettings,
    materials: Vec<(String, Material)>,
    media: Vec<(String, Medium)>,
    shapes: Vec<(Shape, Geometry)>,
    lights: Vec<(LightKind, Option<u32>)>,
    source: Option<PathBuf>,
    grids: Vec<GridInfo>,
    /// Grids loaded so far, by file, name and layout: a grid referenced several times (as
    /// density, temperature and colour channels, or by several media) is read and stored once.
    loaded: std::collections::HashMap<(PathBuf, String, GridLayout), DensityGrid>,
    /// The stored voxels listed in `grids` so far ([`DensityGrid::storage_id`]).
    listed: std::collections::HashSet<usize>,
}

/// The density grid of a [`VoxelGrid`]: voxel centres inside a box of its size centred on the
/// origin.
fn voxel_grid(v: &crate::scene::VoxelGrid) -> std::result::Result<DensityGrid, String> {
    let dims = glam::UVec3::from(v.dims());
    if dims.cmpgt(glam::UVec3::splat(i32::MAX as u32)).any() {
        return Err(format!("{dims} voxels: too many"));
    }
    let size = glam::Vec3::from(v.size());
    if !(size.is_finite() && size.min_element() > 0.0) {
        return Err(format!("a box of size {size}: each side must be positive and finite"));
    }
    let voxel = size / dims.max(glam::UVec3::ONE).as_vec3();
    DensityGrid::from_dense(dims.as_ivec3(), v.values().to_vec(), voxel, 0.5 * voxel - 0.5 * size)
}

/// "defined: `a`, `b`" (at most 20 names, each quoted), or "none defined".
fn defined<'a>(names: impl ExactSizeIterator<Item = &'a str>) -> String {
    let n = names.len();
    if n == 0 {
        return "none defined".into();
    }
    let list: Vec<String> = names.take(20).map(|k| format!("`{}`", quote(k))).collect();
    format!("defined: {}{}", list.join(", "), if n > 20 { ", …" } else { "" })
}

/// The density grid made in code of grid medium `name` from `voxels`; refused where the medium
/// also names grids of a file (`from_file`: each key and whether it is given), which cannot join
/// it.
fn grid_in_code(
    name: &str,
    voxels: &crate::scene::VoxelGrid,
    from_file: [(&str, bool); 4],
) -> Result<DensityGrid> {
    let key = |k: &str| format!("media.{name}.{k}");
    if let Some((k, _)) = from_file.iter().find(|(_, given)| *given) {
        return Err(invalid(
            key(k),
            "reads grids from the medium's file, and this medium's grid is made in code \
             (MediumDesc::voxels): build it from a file instead",
        ));
    }
    voxel_grid(voxels).map_err(|m| invalid(key("voxels"), m))
}

/// The largest extinction of grid medium `name` (grid maximum × `density_scale` × σ_t's largest
/// channel), which must be a finite f32, or tracking divides ∞ by ∞.
fn peak_extinction(name: &str, max_density: f32, density_scale: f32, sigma_t: Rgb) -> Result<f32> {
    let peak = max_density * density_scale * sigma_t.max_element();
    if !peak.is_finite() {
        return Err(invalid(
            format!("media.{name}.density_scale"),
            format!(
                "the largest extinction, {max_density} (grid maximum) × {density_scale} × σ_t, \
                 overflows single precision; scale the coefficients down"
            ),
        ));
    }
    Ok(peak)
}

/// Why an albedo field is refused: a value above 1 (in 1 + 1e-6: grids written as 1.0 through a
/// scale of exactly 1 pass).
fn albedo_beyond_1(field: &ColourField) -> Option<String> {
    let max = field.max_value();
    (max > 1.0 + 1e-6).then(|| {
        format!(
            "albedo must lie in [0, 1], but the grids reach {max:.3} (their largest value × \
             scale {})",
            field.scale
        )
    })
}

/// Why an extinction field is refused: times the medium's largest extinction `peak` it
/// overflows single precision.
fn extinction_overflows(peak: f32, field: &ColourField) -> Option<String> {
    let max = field.max_value();
    (!(peak * max).is_finite()).then(|| {
        format!(
            "the largest extinction, {peak} × {max} (the grids' largest value × scale), \
             overflows single precision; scale down"
        )
    })
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

/// The checks of a light's description; `key` makes the key of a field.
fn check_light(kind: &LightKind, key: impl Fn(&str) -> String) -> Result<()> {
    match kind {
        LightKind::Point { position, power } => {
            check_point(key("position"), *position)?;
            check_color(key("power"), *power, None)?;
        }
        LightKind::Spot { position, look_at, power, cone_angle, falloff_start } => {
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
            let start = falloff_start.unwrap_or(*cone_angle);
            if !(start >= 0.0 && start <= *cone_angle) {
                return Err(invalid(
                    key("falloff_start"),
                    format!("must lie in [0, cone_angle = {cone_angle}], got {start}"),
                ));
            }
        }
        LightKind::Directional { direction, irradiance } => {
            check_point(key("direction"), *direction)?;
            if direction.length_squared() == 0.0 {
                return Err(invalid(key("direction"), "must not be zero"));
            }
            check_color(key("irradiance"), *irradiance, None)?;
        }
        LightKind::Environment { radiance, rotate, .. } => {
            check_color(key("radiance"), *radiance, None)?;
            check_point(key("rotate"), *rotate)?;
        }
        LightKind::Sky { params, scale, resolution, .. } => {
            check_sky(params, *scale, *resolution, key)?
        }
    }
    Ok(())
}

/// The checks of a sky's description.
fn check_sky(
    p: &light::SkyParams,
    scale: Rgb,
    resolution: u32,
    key: impl Fn(&str) -> String,
) -> Result<()> {
    check_point(key("sun_direction"), p.sun)?;
    check_color(key("ground_albedo"), p.ground_albedo, Some(1.0))?;
    check_color(key("scale"), scale, None)?;
    p.check().map_err(|(field, m)| invalid(key(field), m))?;
    let widths = light::sky::WIDTHS;
    if !widths.contains(&resolution) {
        return Err(invalid(
            key("resolution"),
            format!("must lie in [{}, {}], got {resolution}", widths.start(), widths.end()),
        ));
    }
    Ok(())
}

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

fn check_transform(t: &Transform, key: &str) -> Result<()> {
    for (k, v) in [("scale", t.scale), ("rotate", t.rotate), ("translate", t.translate)] {
        if !v.is_finite() {
            return Err(invalid(
                format!("{key}.transform.{k}"),
                format!("must be finite, got {v}"),
            ));
        }
    }
    if t.scale.abs().min_element() == 0.0 {
        return Err(invalid(format!("{key}.transform.scale"), "must not be zero"));
    }
    Ok(())
}

impl SceneBuilder {
    /// Starts a scene seen by `camera` (checked by [`Self::build`]), with default settings.
    pub fn new(camera: CameraDesc) -> Self {
        Self {
            camera,
            settings: RenderSettings::default(),
            materials: Vec::new(),
            media: Vec::new(),
            shapes: Vec::new(),
            lights: Vec::new(),
            source: None,
            grids: Vec::new(),
            loaded: Default::default(),
            listed: Default::default(),
        }
    }

    /// `message` about the file at `path`, with where a relative path was resolved: against the
    /// scene file's directory (scene files), or the working directory (scenes built in code).
    fn relative_note(&self, path: &Path, message: String) -> String {
        if path.is_absolute() {
            return message;
        }
        match &self.source {
            Some(_) => format!("{message} (paths in a scene file are relative to its directory)"),
            None => {
                let cwd = std::env::current_dir()
                    .map_or_else(|_| "?".to_string(), |d| d.display().to_string());
                format!(
                    "{message} (a relative path in a scene built in code is resolved against the \
                     working directory, {cwd})"
                )
            }
        }
    }

    /// Checks the camera now (the loader reports a bad camera before anything else).
    pub(crate) fn check_camera(&self) -> Result<()> {
        Camera::from_desc(&self.camera).map(|_| ()).map_err(|(k, m)| invalid(k, m))
    }

    /// Sets the render settings the scene carries (checked).
    pub fn settings(&mut self, settings: RenderSettings) -> Result<()> {
        settings.validate().map_err(|e| invalid(format!("render.{}", e.key), e.message))?;
        self.settings = settings;
        Ok(())
    }

    /// Records the scene file this scene came from.
    pub(crate) fn source(&mut self, path: PathBuf) {
        self.source = Some(path);
    }

    /// Adds a named material; returns its id.
    pub fn material(&mut self, name: &str, m: Material) -> Result<MaterialId> {
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
        Ok(MaterialId(self.materials.len() as u32 - 1))
    }

    /// Adds a named participating medium (reading a grid medium's OpenVDB file); returns its id.
    pub fn medium(&mut self, name: &str, desc: MediumDesc) -> Result<MediumId> {
        if self.media.iter().any(|(n, _)| n == name) {
            return Err(invalid(format!("media.{name}"), "defined twice"));
        }
        if self.media.len() >= u16::MAX as usize {
            return Err(invalid(format!("media.{name}"), "more than 65535 media"));
        }
        let key = |k: &str| format!("media.{name}.{k}");
        let (sigma_a, sigma_s, g, emission) = match &desc {
            MediumDesc::Homogeneous { sigma_a, sigma_s, g, emission }
            | MediumDesc::Vdb { sigma_a, sigma_s, g, emission, .. } => {
                (*sigma_a, *sigma_s, *g, *emission)
            }
        };
        check_color(key("sigma_a"), sigma_a, None)?;
        check_color(key("sigma_s"), sigma_s, None)?;
        check_color(key("emission"), emission, None)?;
        let emits = emission.max_element() > 0.0
            || matches!(&desc, MediumDesc::Vdb { temperature: Some(_), .. })
            || matches!(&desc, MediumDesc::Vdb { emission_grid: Some(_), .. });
        // An albedo grid sets the absorption itself.
        let albedo_grid = matches!(&desc, MediumDesc::Vdb { albedo_grid: Some(_), .. });
        if emits && sigma_a.max_element() <= 0.0 && !albedo_grid {
            return Err(invalid(
                key("emission"),
                "a medium emits σ_a · L_e per unit length, and this one has σ_a = 0: give it \
                 absorption (or albedo below 1)",
            ));
        }
        if !(g > -1.0 && g < 1.0) {
            return Err(invalid(key("g"), format!("must lie strictly between -1 and 1, got {g}")));
        }
        let phase = HenyeyGreenstein { g };
        let medium = match desc {
            MediumDesc::Homogeneous { .. } => {
                Medium::Homogeneous(Homogeneous { sigma_a, sigma_s, phase, emission })
            }
            MediumDesc::Vdb { .. } => self.grid_medium(name, desc, phase)?,
        };
        self.media.push((name.to_string(), medium));
        Ok(MediumId(self.media.len() as u32 - 1))
    }

    /// The grid medium `name` of `desc` (a [`MediumDesc::Vdb`]) with phase function `phase`: its
    /// density grid (from its file or made in code), scaled, with its emission, albedo and
    /// extinction fields, each checked.
    fn grid_medium(
        &mut self,
        name: &str,
        desc: MediumDesc,
        phase: HenyeyGreenstein,
    ) -> Result<Medium> {
        let key = |k: &str| format!("media.{name}.{k}");
        let MediumDesc::Vdb {
            file,
            grid,
            density_scale,
            transform,
            temperature,
            emission_grid,
            albedo_grid,
            extinction_grid,
            layout,
            voxels,
            sigma_a,
            sigma_s,
            emission,
            ..
        } = desc
        else {
            return Err(invalid(format!("media.{name}"), "not a grid medium"));
        };
        if !(density_scale.is_finite() && density_scale >= 0.0) {
            return Err(invalid(
                key("density_scale"),
                format!("must be finite and non-negative, got {density_scale}"),
            ));
        }
        check_transform(&transform, &format!("media.{name}"))?;
        let grid_name = grid;
        let mut grid = match &voxels {
            Some(v) => {
                let from_file = [
                    ("temperature", temperature.is_some()),
                    ("emission_grid", emission_grid.is_some()),
                    ("albedo_grid", albedo_grid.is_some()),
                    ("extinction_grid", extinction_grid.is_some()),
                ];
                grid_in_code(name, v, from_file)?
            }
            None => self
                .load_grid(&file, &grid_name, layout)
                .map_err(|e| invalid(key("file"), self.relative_note(&file, e.to_string())))?,
        };
        let to_scene = transform.matrix();
        let temperature = match temperature {
            Some(t) => Some(self.temperature_field(name, &file, &t, to_scene, layout)?),
            None => None,
        };
        let peak = peak_extinction(name, grid.max_density, density_scale, sigma_a + sigma_s)?;
        // Scaled here (a copy of its own if the grid is shared and the scale is not 1),
        // so that the listing counts the copy.
        grid.scale_values(density_scale);
        self.list_grid(name, &grid_name, &grid);
        if let Some(t) = &temperature {
            self.list_grid(name, &t.name, &t.grid);
        }
        let fields = (file.as_path(), layout, to_scene);
        let colour = self.colour_field(name, "emission_grid", emission_grid, fields, |_| None)?;
        let albedo =
            self.colour_field(name, "albedo_grid", albedo_grid, fields, albedo_beyond_1)?;
        let extinction =
            self.colour_field(name, "extinction_grid", extinction_grid, fields, |f| {
                extinction_overflows(peak, f)
            })?;
        let medium = VdbMedium::new(grid, to_scene, 1.0, sigma_a, sigma_s, phase);
        let medium = medium
            .with_emission(emission, temperature)
            .with_emission_grid(colour)
            .with_albedo_grid(albedo)
            .with_extinction_grid(extinction);
        Ok(Medium::Vdb(Box::new(medium)))
    }

    /// The colour field `given` (three grid names and a scale) of grid medium `name`, for its key
    /// `what` (`emission_grid`, `albedo_grid`, `extinction_grid`), read from `file` in `layout`
    /// and placed by `to_scene`; `check` returns a message against `what.scale` for a field the
    /// key does not allow.
    fn colour_field(
        &mut self,
        name: &str,
        what: &str,
        given: Option<Box<([String; 3], f32)>>,
        (file, layout, to_scene): (&Path, GridLayout, glam::Affine3A),
        check: impl Fn(&ColourField) -> Option<String>,
    ) -> Result<Option<ColourField>> {
        let Some((names, scale)) = given.map(|b| *b) else { return Ok(None) };
        let ekey = |k: &str| format!("media.{name}.{what}.{k}");
        if !(scale.is_finite() && scale >= 0.0) {
            let message = format!("must be finite and non-negative, got {scale}");
            return Err(invalid(ekey("scale"), message));
        }
        let mut grids = Vec::new();
        for n in &names {
            let g = self
                .load_grid(file, n, layout)
                .map_err(|e| invalid(ekey("grids"), self.relative_note(file, e.to_string())))?;
            self.list_grid(name, n, &g);
            grids.push(g);
        }
        let grids: [DensityGrid; 3] = grids.try_into().expect("three grids");
        let field = ColourField::new(grids, names, to_scene, scale);
        match check(&field) {
            Some(message) => Err(invalid(ekey("scale"), message)),
            None => Ok(Some(field)),
        }
    }

    /// Lists grid `grid` of medium `medium` for [`Scene::grids`].
    fn list_grid(&mut self, medium: &str, grid: &str, g: &DensityGrid) {
        let shared = !self.listed.insert(g.storage_id());
        self.grids.push(GridInfo::of(medium, grid, g, shared));
    }

    /// Grid `name` of `file` in `layout`, read once per scene: later references share the first
    /// one's stored voxels.
    fn load_grid(&mut self, file: &Path, name: &str, layout: GridLayout) -> Result<DensityGrid> {
        let path = std::fs::canonicalize(file).unwrap_or_else(|_| file.to_path_buf());
        let key = (path, name.to_string(), layout);
        if let Some(g) = self.loaded.get(&key) {
            return Ok(g.clone());
        }
        let g = DensityGrid::load_with(file, name, layout)?;
        self.loaded.insert(key, g.clone());
        Ok(g)
    }

    /// The temperature field of grid medium `name` (file `file`), checked.
    fn temperature_field(
        &mut self,
        name: &str,
        file: &std::path::Path,
        t: &TemperatureDesc,
        to_scene: glam::Affine3A,
        layout: GridLayout,
    ) -> Result<TemperatureField> {
        let key = |k: &str| format!("media.{name}.temperature.{k}");
        for (k, v) in [("scale", t.scale), ("offset", t.offset), ("cutoff", t.cutoff)] {
            if !v.is_finite() {
                return Err(invalid(key(k), format!("must be finite, got {v}")));
            }
        }
        if !(t.blackbody_scale.is_finite() && t.blackbody_scale >= 0.0) {
            let message = format!("must be finite and non-negative, got {}", t.blackbody_scale);
            return Err(invalid(key("blackbody_scale"), message));
        }
        let grid = self
            .load_grid(file, &t.grid, layout)
            .map_err(|e| invalid(key("grid"), self.relative_note(file, e.to_string())))?;
        let mut field =
            TemperatureField::new(grid, to_scene, t.scale, t.offset, t.cutoff, t.blackbody_scale);
        field.name = t.grid.clone();
        Ok(field)
    }

    fn medium_id(&self, key: String, m: &MediumRef) -> Result<MediumId> {
        match m {
            MediumRef::Id(id) if (id.0 as usize) < self.media.len() => Ok(*id),
            MediumRef::Id(_) => Err(invalid(key, "no such medium")),
            MediumRef::Name(n) => match self.media.iter().position(|(name, _)| name == n) {
                Some(i) => Ok(MediumId(i as u32)),
                None => {
                    let known = defined(self.media.iter().map(|(n, _)| n.as_str()));
                    Err(invalid(key, format!("undefined medium `{}` ({known})", quote(n))))
                }
            },
        }
    }

    fn material_id(&self, key: String, m: &MaterialRef) -> Result<MaterialId> {
        match m {
            MaterialRef::Id(id) if (id.0 as usize) < self.materials.len() => Ok(*id),
            MaterialRef::Id(_) => Err(invalid(key, "no such material")),
            MaterialRef::Name(n) => match self.materials.iter().position(|(name, _)| name == n) {
                Some(i) => Ok(MaterialId(i as u32)),
                None => {
                    let known = defined(self.materials.iter().map(|(n, _)| n.as_str()));
                    Err(invalid(key, format!("undefined material `{}` ({known})", quote(n))))
                }
            },
        }
    }

    /// Adds a shape (reading an OBJ file's meshes).
    pub fn shape(&mut self, desc: ShapeDesc) -> Result<()> {
        let label = format!("shapes[{}]", self.shapes.len());
        let material = match &desc.material {
            Some(m) => self.material_id(format!("{label}.material"), m)?.0,
            None => {
                return Err(invalid(format!("{label}.material"), "every shape needs a material"));
            }
        };
        let side = |k: &str, m: &Option<MediumRef>| -> Result<Option<u32>> {
            m.as_ref().map(|m| self.medium_id(format!("{label}.{k}"), m).map(|id| id.0)).transpose()
        };
        let (interior, exterior) =
            (side("interior", &desc.interior)?, side("exterior", &desc.exterior)?);
        let media = (desc.interior.is_some() || desc.exterior.is_some())
            .then_some(MediumInterface { interior, exterior });
        if let Some(e) = desc.emission {
            check_color(format!("{label}.emission"), e, None)?;
        }
        check_transform(&desc.transform, &label)?;
        let geometry = geometry(&desc.geometry, &desc.transform, &label).map_err(|e| {
            match (&desc.geometry, e) {
                (
                    GeometryDesc::Obj(path) | GeometryDesc::Ply(path),
                    Error::Invalid { path: p, line, key, message },
                ) => Error::Invalid {
                    path: p,
                    line,
                    key,
                    message: self.relative_note(path, message),
                },
                (_, e) => e,
            }
        })?;
        check_geometry(&geometry, &label)?;
        let shape = Shape { label, material, emission: desc.emission, media };
        self.shapes.push((shape, geometry));
        Ok(())
    }

    /// Adds a light.
    pub fn light(&mut self, desc: LightDesc) -> Result<()> {
        let key = |k: &str| format!("lights[{}].{k}", self.lights.len());
        let medium = match &desc.medium {
            Some(m) => Some(self.medium_id(key("medium"), m)?.0),
            None => None,
        };
        check_light(&desc.kind, key)?;
        if matches!(desc.kind, LightKind::Environment { .. } | LightKind::Sky { .. }) {
            let earlier = self.lights.iter().position(|(l, _)| {
                matches!(l, LightKind::Environment { .. } | LightKind::Sky { .. })
            });
            if let Some(i) = earlier {
                return Err(invalid(
                    key("type"),
                    format!(
                        "a scene has at most one environment light (a sky is one), and lights[{i}] \
                         is one"
                    ),
                ));
            }
        }
        self.lights.push((desc.kind, medium));
        Ok(())
    }

    /// Finishes the scene: checks the camera, builds the BVH and the lights.
    pub fn build(self) -> Result<Scene> {
        let camera = Camera::from_desc(&self.camera).map_err(|(k, m)| invalid(k, m))?;
        let camera_medium = match &self.camera.medium {
            Some(m) => Some(self.medium_id("camera.medium".into(), m)?.0),
            None => None,
        };
        let (prims, mut lights, mut light_media) = self.primitives_and_area_lights()?;
        // obvhs asserts on some degenerate inputs; contain that rather than crash.
        let bvh = |prims: &[Primitive], what: &str| {
            std::panic::catch_unwind(|| Accel::build(prims)).map_err(|_| {
                let message = format!("the {what} could not be organised into a BVH (degenerate?)");
                invalid("shapes".into(), message)
            })
        };
        let accel = bvh(&prims, "geometry")?;
        // The emitting shapes alone: a ray that meets none of them cannot reach an emitter, and
        // is known to without a traversal of the whole scene (`direct::emitter_hit`).
        let emitting: Vec<Primitive> = prims
            .iter()
            .filter(|p| self.shapes[p.tag() as usize].0.emission.is_some())
            .cloned()
            .collect();
        let emitters = bvh(&emitting, "emitters")?;
        let (lo, hi) = self.bounds(&prims);
        let light_labels = self.add_table_lights((lo, hi), &mut lights, &mut light_media)?;
        let materials: Vec<Material> = self.materials.into_iter().map(|(_, m)| m).collect();
        let shapes: Vec<Shape> = self.shapes.into_iter().map(|(s, _)| s).collect();
        let passthrough =
            shapes.iter().map(|s| materials[s.material as usize] == Material::Interface).collect();
        let environment =
            lights.iter().position(|l| matches!(l, Light::Environment(_))).map(|i| i as u32);
        let mut area_light = vec![None; shapes.len()];
        for (i, l) in lights.iter().enumerate() {
            if let Light::Area { shape, .. } = l {
                area_light[*shape as usize] = Some(i as u32);
            }
        }
        let scene = Scene {
            camera,
            materials,
            shapes,
            passthrough,
            area_light,
            environment,
            lights,
            light_labels,
            light_media,
            medium_names: self.media.iter().map(|(n, _)| n.clone()).collect(),
            media: self.media.into_iter().map(|(_, m)| m).collect(),
            camera_medium,
            emissive_media: Default::default(),
            grids: self.grids,
            settings: self.settings,
            bounds: (lo, hi),
            source: self.source,
            accel,
            emitters,
            fingerprint: Default::default(),
        };
        debug_assert_eq!(scene.lights.len(), scene.light_media.len());
        scene.check_media()?;
        let mut scene = scene;
        scene.emissive_media = super::light::media::EmissiveMedia::new(&scene);
        Ok(scene)
    }

    /// Appends the lights of the `[[lights]]` tables (for a scene of bounds `bounds`) to the area
    /// lights in `lights`, and their media to `media`; returns every light's label, e.g.
    /// `shapes[7], an area light` or `lights[1], a sky (its sun)`.
    fn add_table_lights(
        &self,
        bounds: (Vec3, Vec3),
        lights: &mut Vec<Light>,
        media: &mut Vec<Option<u32>>,
    ) -> Result<Vec<String>> {
        let area = |l: &Light| match l {
            Light::Area { shape, .. } => {
                format!("{}, an area light", self.shapes[*shape as usize].0.label)
            }
            _ => String::new(),
        };
        let mut labels: Vec<String> = lights.iter().map(area).collect();
        for (k, (l, medium)) in self.lights.iter().enumerate() {
            let made = table_lights(l, bounds).map_err(|m| invalid(format!("lights[{k}]"), m))?;
            for (light, kind) in made {
                media.push(*medium);
                lights.push(light);
                labels.push(format!("lights[{k}], {kind}"));
            }
        }
        Ok(labels)
    }

    /// The BVH's primitives (degenerate triangles dropped), and an area light for every emitting
    /// shape, with the medium it emits into.
    #[allow(clippy::type_complexity)]
    fn primitives_and_area_lights(&self) -> Result<(Vec<Primitive>, Vec<Light>, Vec<Option<u32>>)> {
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
                let emitter = emitter(geometry, &shape.label)?;
                lights.push(Light::Area { shape: tag, radiance, emitter });
                light_media.push(shape.media.and_then(|m| m.exterior));
            }
        }
        Ok((prims, lights, light_media))
    }

    /// Bounds of the geometry and of the point and spot lights.
    fn bounds(&self, prims: &[Primitive]) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for p in prims {
            let b = obvhs::Boundable::aabb(p);
            lo = lo.min(b.min.into());
            hi = hi.max(b.max.into());
        }
        for (l, _) in &self.lights {
            if let LightKind::Point { position, .. } | LightKind::Spot { position, .. } = l {
                lo = lo.min(*position);
                hi = hi.max(*position);
            }
        }
        if !lo.is_finite() {
            lo = Vec3::splat(-1.0);
            hi = Vec3::splat(1.0);
        }
        (lo, hi)
    }
}

/// The surface of an emitting shape, sampled by area.
fn emitter(geometry: &Geometry, label: &str) -> Result<Emitter> {
    Ok(match geometry {
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
                return Err(invalid(format!("{label}.emission"), "the emitting mesh has no area"));
            }
            Emitter::Triangles { triangles, cdf }
        }
        Geometry::Sphere { center, radius } => Emitter::Sphere { center: *center, radius: *radius },
    })
}

/// The lights a described `[[lights]]` table makes in a scene of bounds `bounds`, each with what
/// it is for its label: one light, or for a sky the dome (an environment light) and its sun (a
/// directional light, unless left out or below the horizon). A directional light's photons
/// cover the bounds; an environment's leave a disc around them.
fn table_lights(
    l: &LightKind,
    bounds: (Vec3, Vec3),
) -> std::result::Result<Vec<(Light, &'static str)>, String> {
    let one = match *l {
        LightKind::Point { position, power } => {
            let intensity = power / (4.0 * std::f32::consts::PI);
            (Light::Point { position, intensity }, "a point light")
        }
        LightKind::Spot { position, look_at, power, cone_angle, falloff_start } => {
            let cos_max = cone_angle.to_radians().cos();
            let cos_start = falloff_start.unwrap_or(cone_angle).to_radians().cos();
            let omega = light::spot_solid_angle(cos_max, cos_start);
            let spot = Light::Spot {
                position,
                frame: crate::math::Frame::new((look_at - position).normalize()),
                intensity: power / omega,
                cos_max,
                cos_start,
            };
            (spot, "a spot light")
        }
        LightKind::Directional { direction, irradiance } => {
            (Light::directional(direction.normalize(), irradiance, bounds), "a directional light")
        }
        LightKind::Environment { radiance, ref map, rotate, visible } => {
            let turn = glam::Mat3::from(shape::affine(Vec3::ONE, rotate, Vec3::ZERO).matrix3);
            let env = light::Environment::new(map.clone(), radiance, turn, visible, bounds);
            (Light::Environment(Box::new(env)), "an environment light")
        }
        LightKind::Sky { params, scale, resolution, sun, visible } => {
            let (map, irradiance) = light::EnvMap::sky(&params, resolution, false)?;
            let map = Some(std::sync::Arc::new(map));
            let dome = light::Environment::new(map, scale, glam::Mat3::IDENTITY, visible, bounds);
            let mut lights = vec![(Light::Environment(Box::new(dome)), "a sky (its dome)")];
            let irradiance = irradiance * scale;
            if sun && irradiance.max_element() > 0.0 {
                let sun = Light::directional(-params.sun.normalize(), irradiance, bounds);
                lights.push((sun, "a sky (its sun)"));
            }
            return Ok(lights);
        }
    };
    Ok(vec![one])
}

/// The geometry a description asks for, transformed into the scene.
fn geometry(g: &GeometryDesc, t: &Transform, key: &str) -> Result<Geometry> {
    let m = t.matrix();
    let positive = |k: &str, v: &[f32]| -> Result<()> {
        if v.iter().all(|x| x.is_finite() && *x > 0.0) {
            Ok(())
        } else {
            Err(invalid(format!("{key}.{k}"), format!("must be positive, got {v:?}")))
        }
    };
    Ok(match g {
        GeometryDesc::Rectangle { size: [w, h] } => {
            positive("size", &[*w, *h])?;
            Geometry::Mesh(shape::rectangle(*w, *h).transformed(&m))
        }
        GeometryDesc::Cuboid { size } => {
            positive("size", &size.to_array())?;
            Geometry::Mesh(shape::cuboid(*size).transformed(&m))
        }
        GeometryDesc::Sphere { center, radius, tessellate } => {
            positive("radius", &[*radius])?;
            check_point(format!("{key}.center"), *center)?;
            match tessellate {
                Some(level) if *level > MAX_TESSELLATION => {
                    return Err(invalid(
                        format!("{key}.tessellate"),
                        format!(
                            "at most {MAX_TESSELLATION} subdivisions (327,680 triangles), got {level}"
                        ),
                    ));
                }
                Some(level) => {
                    Geometry::Mesh(shape::icosphere(*center, *radius, *level).transformed(&m))
                }
                None => {
                    let s = Vec3::new(
                        m.matrix3.x_axis.length(),
                        m.matrix3.y_axis.length(),
                        m.matrix3.z_axis.length(),
                    );
                    if (s.max_element() - s.min_element()) > 1e-5 * s.max_element() {
                        return Err(invalid(
                            format!("{key}.transform.scale"),
                            "an analytic sphere takes only a uniform scale (use `tessellate` for ellipsoids)",
                        ));
                    }
                    Geometry::Sphere { center: m.transform_point3(*center), radius: radius * s.x }
                }
            }
        }
        GeometryDesc::Mesh(mesh) => Geometry::Mesh(mesh.clone().transformed(&m)),
        GeometryDesc::Obj(path) => Geometry::Mesh(
            shape::load_obj(path)
                .map_err(|e| invalid(format!("{key}.file"), e.to_string()))?
                .transformed(&m),
        ),
        GeometryDesc::Ply(path) => Geometry::Mesh(
            shape::load_ply(path)
                .map_err(|e| invalid(format!("{key}.file"), e.to_string()))?
                .transformed(&m),
        ),
    })
}

/// Checks a shape's geometry in the scene: coordinates in range, indices and normals valid.
fn check_geometry(geometry: &Geometry, label: &str) -> Result<()> {
    match geometry {
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
                return Err(invalid(label.to_string(), "mesh has no triangles"));
            }
            let n = mesh.positions.len();
            for (i, p) in mesh.positions.iter().enumerate() {
                check_point(format!("{label}.vertices[{i}] (after the transform)"), *p)?;
            }
            if let Some(t) = mesh.triangles.iter().position(|t| t.iter().any(|&i| i as usize >= n))
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
                    return Err(invalid(format!("{label}.normals"), "must be finite and non-zero"));
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{CameraDesc, VoxelGrid};
    use glam::Vec3;

    fn builder() -> SceneBuilder {
        SceneBuilder::new(CameraDesc::perspective([0.0, 0.0, 4.0], [0.0, 0.0, 0.0], 40.0))
    }

    fn vdb_of(m: &Medium) -> &crate::medium::vdb::VdbMedium {
        match m {
            Medium::Vdb(v) => v,
            _ => panic!("not a grid medium"),
        }
    }

    /// A grid made in code equals the file it copies: media/box.vdb (16³ voxels of 1, voxel i's
    /// centre at i/16 as OpenVDB places it) against a `VoxelGrid` of 16³ ones over a unit box
    /// (centred on the origin) moved by 0.5 − 1/32 — the same density at points inside, on the
    /// interpolation's ramp at the faces, and outside.
    #[test]
    fn a_voxel_grid_is_placed_and_interpolated_as_the_file_it_copies() {
        let mut b = builder();
        let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("media/box.vdb");
        let a = b.medium("file", MediumDesc::vdb(file)).unwrap();
        let ones = VoxelGrid::from_fn([16, 16, 16], [1.0, 1.0, 1.0], |_| 1.0);
        let code = b
            .medium(
                "code",
                MediumDesc::voxels(ones).transform(crate::scene::Transform {
                    translate: Vec3::splat(0.5 - 1.0 / 32.0),
                    ..Default::default()
                }),
            )
            .unwrap();
        let (a, code) = (vdb_of(&b.media[a.0 as usize].1), vdb_of(&b.media[code.0 as usize].1));
        let mut rng = crate::rng::Sampler::new(7, crate::rng::Purpose::Photon, 0, 0);
        for _ in 0..2000 {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1.4 - 0.2;
            assert!(
                (a.density(p) - code.density(p)).abs() < 1e-5,
                "{p}: {} {}",
                a.density(p),
                code.density(p)
            );
        }
        assert!(b.grids[1].grid.contains("in memory"), "{}", b.grids[1]);
    }

    /// What a grid made in code cannot be: values of the wrong count, NaN or negative, all zero,
    /// a box without size, or joined by grids that come from files.
    #[test]
    fn bad_voxel_grids_name_what_is_wrong() {
        let cases: [(VoxelGrid, &str); 5] = [
            (VoxelGrid::new([2, 2, 2], [1.0; 3], vec![1.0; 7]), "7 values for 2×2×2 voxels"),
            (VoxelGrid::new([1, 1, 2], [1.0; 3], vec![1.0, f32::NAN]), "voxel [0, 0, 1] is NaN"),
            (VoxelGrid::new([1, 1, 1], [1.0; 3], vec![0.0]), "every value is zero"),
            (VoxelGrid::new([1, 1, 1], [0.0, 1.0, 1.0], vec![1.0]), "each side must be positive"),
            (VoxelGrid::new([0, 1, 1], [1.0; 3], vec![]), "each axis needs at least one"),
        ];
        for (grid, needle) in cases {
            let e = builder().medium("m", MediumDesc::voxels(grid)).unwrap_err().to_string();
            assert!(e.starts_with("media.m.voxels: ") && e.contains(needle), "{e}");
        }
        let ball = VoxelGrid::from_fn([4, 4, 4], [1.0; 3], |p| 1.0 - p.length());
        let hot =
            MediumDesc::voxels(ball).coefficients(0.5, 0.5).emission_grid(["r", "g", "b"], 1.0);
        let e = builder().medium("m", hot).unwrap_err().to_string();
        assert!(e.starts_with("media.m.emission_grid: ") && e.contains("made in code"), "{e}");
    }
}
