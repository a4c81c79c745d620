//! Scene-file loading: TOML → [`format`] structs → [`SceneBuilder`]. Every error names the file,
//! the key and the line of the table it sits in.

use super::camera::{Camera, Projection};
use super::format::{
    self, BoxDef, CameraDef, ColorDef, HomogeneousDef, LightDef, MaterialDef, MediumDef, MeshDef,
    ObjDef, OrthographicDef, PerspectiveDef, RectangleDef, ScaleDef, SceneFile, ShapeDef,
    SphereDef, TransformDef, VdbDef,
};
use super::material::Material;
use super::shape::{self, Mesh};
use super::{Geometry, LightDesc, MediumInterface, Scene, SceneBuilder};
use crate::error::{Error, Result};
use crate::math::Rgb;
use crate::medium::Medium;
use crate::medium::grid::DensityGrid;
use crate::medium::homogeneous::Homogeneous;
use crate::medium::phase::HenyeyGreenstein;
use crate::medium::vdb::VdbMedium;
use crate::settings::{RenderOptions, RenderSettings};
use glam::Vec3;
use std::ops::Range;
use std::path::{Path, PathBuf};

pub(super) fn load_file(path: &Path) -> Result<Scene> {
    let text = std::fs::read_to_string(path)
        .map_err(|source| Error::Io { path: path.to_path_buf(), error: source })?;
    let base = path.parent().unwrap_or(Path::new("."));
    load_str(&text, path, base)
}

/// 1-based line of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    text[..at.min(text.len())].bytes().filter(|&b| b == b'\n').count() + 1
}

/// Maps builder errors (keys without a place) to the file and the line of the table they came
/// from.
struct Places<'a> {
    text: &'a str,
    path: &'a Path,
    tables: Vec<(String, Range<usize>)>,
}

impl Places<'_> {
    fn locate(&self, e: Error) -> Error {
        match e {
            Error::Invalid { key, message, .. } => {
                let line = self
                    .tables
                    .iter()
                    .filter(|(prefix, _)| {
                        key == *prefix
                            || key.starts_with(&format!("{prefix}."))
                            || key.starts_with(&format!("{prefix}["))
                    })
                    .max_by_key(|(prefix, _)| prefix.len())
                    .map(|(_, span)| line_of(self.text, span.start));
                Error::Invalid { path: self.path.to_path_buf(), line, key, message }
            }
            other => other,
        }
    }

    fn error(&self, key: String, message: impl Into<String>) -> Error {
        self.locate(Error::Invalid {
            path: PathBuf::new(),
            line: None,
            key,
            message: message.into(),
        })
    }
}

fn color(c: ColorDef) -> Rgb {
    match c {
        ColorDef::Grey(v) => Vec3::splat(v),
        ColorDef::Rgb(v) => Vec3::from(v),
    }
}

pub(super) fn load_str(text: &str, path: &Path, base_dir: &Path) -> Result<Scene> {
    let file = format::read(text).map_err(|e| Error::Parse {
        path: path.to_path_buf(),
        line: e.at.map(|at| line_of(text, at)),
        message: if e.key.is_empty() { e.message } else { format!("{}: {}", e.key, e.message) },
    })?;
    let mut places = Places { text, path, tables: Vec::new() };
    places.tables.push(("camera".into(), file.camera.1.clone()));
    if let Some((_, span)) = &file.render {
        places.tables.push(("render".into(), span.clone()));
    }
    for (name, _, span) in &file.materials {
        places.tables.push((format!("materials.{name}"), span.clone()));
    }
    for (name, _, span) in &file.media {
        places.tables.push((format!("media.{name}"), span.clone()));
    }
    for (i, (_, span)) in file.shapes.iter().enumerate() {
        places.tables.push((format!("shapes[{i}]"), span.clone()));
    }
    for (i, (_, span)) in file.lights.iter().enumerate() {
        places.tables.push((format!("lights[{i}]"), span.clone()));
    }
    build(file, &places, base_dir).map_err(|e| places.locate(e))
}

fn build(file: SceneFile, places: &Places, base_dir: &Path) -> Result<Scene> {
    let camera_def = &file.camera.0;
    let camera = camera(camera_def, places)?;
    let mut b = SceneBuilder::new(camera);
    b.source(places.path.to_path_buf());
    let settings = settings(file.render.as_ref().map(|r| &r.0), places)?;
    b.settings(settings)?;
    for (name, m, _) in &file.materials {
        let m = match m {
            MaterialDef::Diffuse(d) => Material::Diffuse { albedo: color(d.albedo) },
            MaterialDef::Mirror(d) => {
                Material::Mirror { reflectance: d.reflectance.map(color).unwrap_or(Vec3::ONE) }
            }
            MaterialDef::Dielectric(d) => Material::Dielectric { ior: d.ior },
            MaterialDef::Interface => Material::Interface,
        };
        b.material(name, m)?;
    }
    for (name, m, _) in &file.media {
        let key = format!("media.{name}");
        let medium = match m {
            MediumDef::Homogeneous(d) => homogeneous(d, &key, places)?,
            MediumDef::Vdb(d) => vdb(d, &key, places, base_dir)?,
        };
        b.medium(name, medium)?;
    }
    let known_media: Vec<&String> = file.media.iter().map(|(n, _, _)| n).collect();
    let medium = |key: String, name: Option<&String>| -> Result<Option<u32>> {
        match name {
            None => Ok(None),
            Some(n) => b.medium_index(n).map(Some).ok_or_else(|| {
                places.error(key, format!("undefined medium `{n}` (defined: {known_media:?})"))
            }),
        }
    };
    let camera_medium = match camera_def {
        CameraDef::Perspective(d) => d.medium.as_ref(),
        CameraDef::Orthographic(d) => d.medium.as_ref(),
    };
    let camera_medium = medium("camera.medium".into(), camera_medium)?;
    let mut shapes = Vec::new();
    for (i, (s, _)) in file.shapes.iter().enumerate() {
        let label = format!("shapes[{i}]");
        let (interior, exterior) = s.media();
        let interface = if interior.is_none() && exterior.is_none() {
            None
        } else {
            Some(MediumInterface {
                interior: medium(format!("{label}.interior"), interior)?,
                exterior: medium(format!("{label}.exterior"), exterior)?,
            })
        };
        shapes.push(interface);
    }
    let mut light_media = Vec::new();
    for (i, (l, _)) in file.lights.iter().enumerate() {
        let name = match l {
            LightDef::Point(d) => d.medium.as_ref(),
            LightDef::Spot(d) => d.medium.as_ref(),
            LightDef::Directional(d) => d.medium.as_ref(),
        };
        light_media.push(medium(format!("lights[{i}].medium"), name)?);
    }
    b.camera_medium(camera_medium)?;
    for (i, ((s, _), interface)) in file.shapes.iter().zip(shapes).enumerate() {
        let label = format!("shapes[{i}]");
        let (geometry, material, emission) = shape(s, &label, places, base_dir)?;
        let m = b.material_index(material).ok_or_else(|| {
            let known: Vec<&String> = file.materials.iter().map(|(n, _, _)| n).collect();
            places.error(
                format!("{label}.material"),
                format!("undefined material `{material}` (defined: {known:?})"),
            )
        })?;
        b.shape_with_media(geometry, m, emission.map(color), interface)?;
    }
    for ((l, _), medium) in file.lights.iter().zip(light_media) {
        let desc = match l {
            LightDef::Point(d) => {
                LightDesc::Point { position: d.position.into(), power: color(d.power) }
            }
            LightDef::Spot(d) => LightDesc::Spot {
                position: d.position.into(),
                look_at: d.look_at.into(),
                power: color(d.power),
                cone_angle: d.cone_angle,
                falloff_start: d.falloff_start.unwrap_or(d.cone_angle),
            },
            LightDef::Directional(d) => LightDesc::Directional {
                direction: d.direction.into(),
                irradiance: color(d.irradiance),
            },
        };
        b.light_in(desc, medium)?;
    }
    b.build()
}

/// (σ_a, σ_s) from either (σ_a, σ_s) or (albedo, σ_t).
fn coefficients(
    pairs: (Option<ColorDef>, Option<ColorDef>, Option<ColorDef>, Option<ColorDef>),
    key: &str,
    places: &Places,
) -> Result<(Vec3, Vec3)> {
    let err = |k: &str, m: &str| places.error(format!("{key}.{k}"), m.to_string());
    Ok(match pairs {
        (Some(a), Some(s), None, None) => (color(a), color(s)),
        (None, None, Some(albedo), Some(t)) => {
            let (albedo, t) = (color(albedo), color(t));
            if !albedo.is_finite() || albedo.min_element() < 0.0 || albedo.max_element() > 1.0 {
                return Err(err("albedo", &format!("must lie in [0, 1], got {albedo}")));
            }
            if !t.is_finite() || t.min_element() < 0.0 {
                return Err(err("sigma_t", &format!("must be finite and non-negative, got {t}")));
            }
            ((Vec3::ONE - albedo) * t, albedo * t)
        }
        (None, None, None, None) => {
            return Err(err("sigma_s", "give sigma_a and sigma_s, or albedo and sigma_t"));
        }
        (Some(_), None, ..) => return Err(err("sigma_s", "sigma_a needs sigma_s")),
        (None, Some(_), ..) => return Err(err("sigma_a", "sigma_s needs sigma_a")),
        (None, None, Some(_), None) => return Err(err("sigma_t", "albedo needs sigma_t")),
        (None, None, None, Some(_)) => return Err(err("albedo", "sigma_t needs albedo")),
        _ => {
            return Err(err(
                "albedo",
                "give either sigma_a and sigma_s, or albedo and sigma_t, not both pairs",
            ));
        }
    })
}

/// A homogeneous medium.
fn homogeneous(d: &HomogeneousDef, key: &str, places: &Places) -> Result<Medium> {
    let (sigma_a, sigma_s) =
        coefficients((d.sigma_a, d.sigma_s, d.albedo, d.sigma_t), key, places)?;
    let g = d.g.unwrap_or(0.0);
    Ok(Medium::Homogeneous(Homogeneous { sigma_a, sigma_s, phase: HenyeyGreenstein { g } }))
}

/// A grid medium: the OpenVDB file is read here, relative to the scene file.
fn vdb(d: &VdbDef, key: &str, places: &Places, base_dir: &Path) -> Result<Medium> {
    let (sigma_a, sigma_s) =
        coefficients((d.sigma_a, d.sigma_s, d.albedo, d.sigma_t), key, places)?;
    let scale = d.density_scale.unwrap_or(1.0);
    if !(scale.is_finite() && scale >= 0.0) {
        return Err(places.error(
            format!("{key}.density_scale"),
            format!("must be finite and non-negative, got {scale}"),
        ));
    }
    let to_scene = transform(&d.transform, key, places)?;
    let path = base_dir.join(&d.file);
    let grid = DensityGrid::load(&path, d.grid.as_deref().unwrap_or("density"))
        .map_err(|e| places.error(format!("{key}.file"), e.to_string()))?;
    let phase = HenyeyGreenstein { g: d.g.unwrap_or(0.0) };
    Ok(Medium::Vdb(Box::new(VdbMedium::new(grid, to_scene, scale, sigma_a, sigma_s, phase))))
}

/// Largest image: 64 Mpixel (the film holds 24 bytes per pixel).
const MAX_PIXELS: u64 = 1 << 26;

fn camera(def: &CameraDef, places: &Places) -> Result<Camera> {
    let (position, look_at, up, resolution) = match def {
        CameraDef::Perspective(d) => (d.position, d.look_at, d.up, d.resolution),
        CameraDef::Orthographic(d) => (d.position, d.look_at, d.up, d.resolution),
    };
    let (position, look_at, up) = (Vec3::from(position), Vec3::from(look_at), up.map(Vec3::from));
    let up = up.unwrap_or(Vec3::Y);
    let err = |k: &str, m: String| places.error(format!("camera.{k}"), m);
    for (k, v) in [("position", position), ("look_at", look_at), ("up", up)] {
        if !v.is_finite() {
            return Err(err(k, format!("must be finite, got {v}")));
        }
        if v.abs().max_element() > super::MAX_COORDINATE {
            return Err(err(k, format!("{v} lies outside ±{}", super::MAX_COORDINATE)));
        }
    }
    let dist = (look_at - position).length();
    if dist == 0.0 {
        return Err(err("look_at", "must differ from position".into()));
    }
    if (look_at - position).normalize().cross(up).length() < 1e-6 {
        return Err(err("up", "must not be parallel to the viewing direction".into()));
    }
    let pixels = resolution[0] as u64 * resolution[1] as u64;
    if resolution[0] == 0 || resolution[1] == 0 || pixels > MAX_PIXELS {
        return Err(err(
            "resolution",
            format!("needs 1 to {MAX_PIXELS} pixels in all, got {resolution:?}"),
        ));
    }
    let projection = match def {
        CameraDef::Perspective(PerspectiveDef { fov, aperture, focus_distance, .. }) => {
            if !(*fov > 0.0 && *fov < 180.0) {
                return Err(err("fov", format!("must lie in (0, 180) degrees, got {fov}")));
            }
            let lens_radius = aperture.unwrap_or(0.0);
            if !(lens_radius.is_finite() && lens_radius >= 0.0) {
                return Err(err(
                    "aperture",
                    format!("must be a non-negative radius, got {lens_radius}"),
                ));
            }
            let focus_distance = focus_distance.unwrap_or(dist);
            if !(focus_distance.is_finite() && focus_distance > 0.0) {
                return Err(err(
                    "focus_distance",
                    format!("must be positive, got {focus_distance}"),
                ));
            }
            Projection::Perspective {
                tan_half_fov: (fov.to_radians() * 0.5).tan(),
                lens_radius,
                focus_distance,
            }
        }
        CameraDef::Orthographic(OrthographicDef { height, .. }) => {
            if !(height.is_finite() && *height > 0.0) {
                return Err(err("height", format!("must be positive, got {height}")));
            }
            Projection::Orthographic { height: *height }
        }
    };
    Ok(Camera::new(projection, position, look_at, up, resolution))
}

/// The scene's settings: the defaults with the `[render]` table laid over them.
fn settings(options: Option<&RenderOptions>, places: &Places) -> Result<RenderSettings> {
    let mut s = RenderSettings::default();
    if let Some(o) = options {
        o.check_pairs().map_err(|e| places.error(format!("render.{}", e.key), e.message))?;
        s.apply(o);
    }
    Ok(s)
}

fn transform(t: &TransformDef, key: &str, places: &Places) -> Result<glam::Affine3A> {
    let scale = match t.scale {
        None => Vec3::ONE,
        Some(ScaleDef::Uniform(s)) => Vec3::splat(s),
        Some(ScaleDef::Axes(a)) => Vec3::from(a),
    };
    let rotate = Vec3::from(t.rotate.unwrap_or([0.0; 3]));
    let translate = Vec3::from(t.translate.unwrap_or([0.0; 3]));
    for (k, v) in [("scale", scale), ("rotate", rotate), ("translate", translate)] {
        if !v.is_finite() {
            return Err(
                places.error(format!("{key}.transform.{k}"), format!("must be finite, got {v}"))
            );
        }
    }
    if scale.abs().min_element() == 0.0 {
        return Err(places.error(format!("{key}.transform.scale"), "must not be zero"));
    }
    Ok(shape::affine(scale, rotate, translate))
}

type ShapeParts<'a> = (Geometry, &'a str, Option<ColorDef>);

fn shape<'a>(
    def: &'a ShapeDef,
    key: &str,
    places: &Places,
    base_dir: &Path,
) -> Result<ShapeParts<'a>> {
    let positive = |k: &str, v: &[f32]| -> Result<()> {
        if v.iter().all(|x| x.is_finite() && *x > 0.0) {
            Ok(())
        } else {
            Err(places.error(format!("{key}.{k}"), format!("must be positive, got {v:?}")))
        }
    };
    Ok(match def {
        ShapeDef::Rectangle(RectangleDef { size, material, emission, transform: t, .. }) => {
            let [w, h] = size.unwrap_or([1.0, 1.0]);
            positive("size", &[w, h])?;
            let m = transform(t, key, places)?;
            (Geometry::Mesh(shape::rectangle(w, h).transformed(&m)), material, *emission)
        }
        ShapeDef::Box(BoxDef { size, material, emission, transform: t, .. }) => {
            let s = size.unwrap_or([1.0; 3]);
            positive("size", &s)?;
            let m = transform(t, key, places)?;
            (Geometry::Mesh(shape::cuboid(s.into()).transformed(&m)), material, *emission)
        }
        ShapeDef::Sphere(SphereDef {
            center,
            radius,
            tessellate,
            material,
            emission,
            transform: t,
            ..
        }) => {
            positive("radius", &[*radius])?;
            let center = Vec3::from(center.unwrap_or([0.0; 3]));
            let m = transform(t, key, places)?;
            let geometry = match tessellate {
                Some(level) => {
                    if *level > 7 {
                        return Err(places.error(
                            format!("{key}.tessellate"),
                            format!("at most 7 subdivisions (327,680 triangles), got {level}"),
                        ));
                    }
                    Geometry::Mesh(shape::icosphere(center, *radius, *level).transformed(&m))
                }
                None => {
                    let s = Vec3::new(
                        m.matrix3.x_axis.length(),
                        m.matrix3.y_axis.length(),
                        m.matrix3.z_axis.length(),
                    );
                    if (s.max_element() - s.min_element()) > 1e-5 * s.max_element() {
                        return Err(places.error(
                            format!("{key}.transform.scale"),
                            "an analytic sphere takes only a uniform scale (use `tessellate` for ellipsoids)",
                        ));
                    }
                    Geometry::Sphere { center: m.transform_point3(center), radius: radius * s.x }
                }
            };
            (geometry, material, *emission)
        }
        ShapeDef::Mesh(MeshDef {
            vertices,
            triangles,
            normals,
            material,
            emission,
            transform: t,
            ..
        }) => {
            let m = transform(t, key, places)?;
            let mesh = Mesh {
                positions: vertices.iter().map(|&v| Vec3::from(v)).collect(),
                normals: normals.as_ref().map(|n| n.iter().map(|&v| Vec3::from(v)).collect()),
                triangles: triangles.clone(),
            };
            (Geometry::Mesh(mesh.transformed(&m)), material, *emission)
        }
        ShapeDef::Obj(ObjDef { file, material, emission, transform: t, .. }) => {
            let m = transform(t, key, places)?;
            let mesh = load_obj(&base_dir.join(file))?;
            (Geometry::Mesh(mesh.transformed(&m)), material, *emission)
        }
    })
}

/// Loads every object of a Wavefront OBJ file as one triangle mesh.
fn load_obj(path: &Path) -> Result<Mesh> {
    let mesh_err = |message: String| Error::Mesh { path: path.to_path_buf(), message };
    if !path.is_file() {
        return Err(mesh_err("no such file (OBJ paths are relative to the scene file)".into()));
    }
    let opts = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
    let (models, _) = tobj::load_obj(path, &opts).map_err(|e| mesh_err(e.to_string()))?;
    let mut mesh = Mesh::default();
    let mut all_normals = true;
    let mut normals = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let base = mesh.positions.len() as u32;
        let count = m.positions.len() / 3;
        mesh.positions.extend(m.positions.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
        if m.normals.len() == m.positions.len() {
            normals.extend(m.normals.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
        } else {
            all_normals = false;
        }
        for t in m.indices.chunks_exact(3) {
            if t.iter().any(|&i| i as usize >= count) {
                return Err(mesh_err(format!(
                    "face index out of range in object `{}`",
                    model.name
                )));
            }
            mesh.triangles.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    if mesh.triangles.is_empty() {
        return Err(mesh_err("contains no faces".into()));
    }
    if all_normals {
        // Zero-length normals in the file would give NaN shading normals: ignore the normals then.
        if normals.iter().all(|n| n.is_finite() && n.length_squared() > 0.0) {
            mesh.normals = Some(normals.iter().map(|n| n.normalize()).collect());
        }
    }
    Ok(mesh)
}
