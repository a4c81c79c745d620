//! Scene-file loading: TOML → [`format`] structs → [`SceneBuilder`]. Every error names the file,
//! the key and the line of the table it sits in.

use super::camera::{CameraDesc, Lens};
use super::describe::{
    GeometryDesc, LightDesc, LightKind, MaterialRef, MediumDesc, MediumRef, ShapeDesc,
    TemperatureDesc, Transform,
};
use super::format::{
    self, CameraDef, ColorDef, HomogeneousDef, LayoutDef, LightDef, MaterialDef, MediumDef,
    ScaleDef, SceneFile, ShapeDef, TransformDef, VdbDef,
};
use super::material::Material;
use super::shape::Mesh;
use super::{Scene, SceneBuilder};
use crate::error::{Error, Result};
use crate::math::Rgb;
use crate::medium::grid::Layout as GridLayout;
use crate::settings::{RenderOptions, RenderSettings};
use glam::Vec3;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Largest scene file read (bytes): far more than any hand-written scene.
pub const MAX_SCENE_BYTES: u64 = 16 << 20;

pub(super) fn load_file(path: &Path) -> Result<Scene> {
    let bytes = crate::input::read_bounded(path, MAX_SCENE_BYTES, "a scene file")?;
    let text = String::from_utf8(bytes).map_err(|e| Error::Parse {
        path: path.to_path_buf(),
        line: None,
        message: format!(
            "not UTF-8 text (invalid byte at offset {})",
            e.utf8_error().valid_up_to()
        ),
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    load_str(&text, path, base)
}

/// 1-based line of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    // Bytes, not a string slice: an offset inside a character must not panic.
    text.as_bytes()[..at.min(text.len())].iter().filter(|&&b| b == b'\n').count() + 1
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
    let mut b = SceneBuilder::new(camera(&file.camera.0));
    b.check_camera()?;
    b.source(places.path.to_path_buf());
    b.settings(settings(file.render.as_ref().map(|r| &r.0), places)?)?;
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
    for (s, _) in &file.shapes {
        b.shape(shape(s, base_dir))?;
    }
    for (i, (l, _)) in file.lights.iter().enumerate() {
        b.light(light(l, &format!("lights[{i}]"), places, base_dir)?)?;
    }
    b.build()
}

/// A `[[lights]]` table as a description (an environment's map read from its file).
fn light(l: &LightDef, key: &str, places: &Places, base_dir: &Path) -> Result<LightDesc> {
    let (kind, medium) = match l {
        LightDef::Point(d) => {
            (LightKind::Point { position: d.position.into(), power: color(d.power) }, &d.medium)
        }
        LightDef::Spot(d) => (
            LightKind::Spot {
                position: d.position.into(),
                look_at: d.look_at.into(),
                power: color(d.power),
                cone_angle: d.cone_angle,
                falloff_start: d.falloff_start,
            },
            &d.medium,
        ),
        LightDef::Directional(d) => (
            LightKind::Directional {
                direction: d.direction.into(),
                irradiance: color(d.irradiance),
            },
            &d.medium,
        ),
        LightDef::Environment(d) => (environment(d, key, places, base_dir)?, &d.medium),
        LightDef::Sky(d) => (sky(d, key, places)?, &d.medium),
    };
    Ok(LightDesc { kind, medium: medium.clone().map(MediumRef::Name) })
}

/// A `sky` light's table: the sun by `elevation` and `azimuth` (degrees) or by `sun_direction`.
fn sky(d: &crate::scene::format::SkyDef, key: &str, places: &Places) -> Result<LightKind> {
    let sky = match (d.elevation, d.azimuth, d.sun_direction) {
        (Some(e), a, None) => {
            crate::scene::sky::check_elevation(e)
                .map_err(|m| places.error(format!("{key}.elevation"), m))?;
            LightDesc::sky(e, a.unwrap_or(0.0))
        }
        (None, None, Some(dir)) => LightDesc::sky_towards(dir),
        (None, None, None) | (None, Some(_), None) => {
            let m = "a sky needs the sun's `elevation` (and `azimuth`), or `sun_direction`";
            return Err(places.error(format!("{key}.elevation"), m));
        }
        _ => {
            let m = "give the sun's `elevation` and `azimuth`, or `sun_direction`, not both";
            return Err(places.error(format!("{key}.sun_direction"), m));
        }
    };
    let mut sky = sky
        .scale(d.scale.map_or(Rgb::ONE, color))
        .with_sun(d.sun.unwrap_or(true))
        .visible(d.visible.unwrap_or(true));
    if let Some(t) = d.turbidity {
        sky = sky.turbidity(t);
    }
    if let Some(a) = d.ground_albedo {
        sky = sky.ground_albedo(color(a));
    }
    if let Some(w) = d.resolution {
        sky = sky.sky_resolution(w);
    }
    Ok(sky.kind)
}

/// An `environment` light's table: a constant `radiance` or a map `file`, times `scale`.
fn environment(
    d: &crate::scene::format::EnvironmentDef,
    key: &str,
    places: &Places,
    base_dir: &Path,
) -> Result<LightKind> {
    let scale = d.scale.map_or(Rgb::ONE, color);
    let (radiance, map) = match (&d.radiance, &d.file) {
        (Some(r), None) => (color(*r) * scale, None),
        (None, Some(f)) => {
            let map = crate::scene::EnvMap::load(&base_dir.join(f))
                .map_err(|e| places.error(format!("{key}.file"), e.to_string()))?;
            (scale, Some(std::sync::Arc::new(map)))
        }
        (Some(_), Some(_)) => {
            let m = "give either `radiance` (a constant environment) or `file` (a map), not both";
            return Err(places.error(format!("{key}.file"), m));
        }
        (None, None) => {
            let m = "an environment needs `radiance` (a constant) or `file` (an OpenEXR map)";
            return Err(places.error(format!("{key}.radiance"), m));
        }
    };
    Ok(LightKind::Environment {
        radiance,
        map,
        rotate: d.rotate.map_or(glam::Vec3::ZERO, Into::into),
        visible: d.visible.unwrap_or(true),
    })
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
        _ => {
            // Name what was written and what is allowed.
            let written: Vec<&str> = ["sigma_a", "sigma_s", "albedo", "sigma_t"]
                .into_iter()
                .zip([pairs.0.is_some(), pairs.1.is_some(), pairs.2.is_some(), pairs.3.is_some()])
                .filter_map(|(k, given)| given.then_some(k))
                .collect();
            let allowed = "a medium takes either sigma_a and sigma_s, or albedo and sigma_t";
            return Err(match written[..] {
                [] => err("sigma_s", &format!("no coefficients given: {allowed}")),
                [one] => err(one, &format!("only {one} given: {allowed}")),
                ref many => {
                    err(many[0], &format!("{} given: {allowed}, not a mix", and_list(many)))
                }
            });
        }
    })
}

/// "a", "a and b", "a, b and c".
fn and_list(words: &[&str]) -> String {
    match words {
        [] => String::new(),
        [one] => one.to_string(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    }
}

/// A homogeneous medium.
fn homogeneous(d: &HomogeneousDef, key: &str, places: &Places) -> Result<MediumDesc> {
    let (sigma_a, sigma_s) =
        coefficients((d.sigma_a, d.sigma_s, d.albedo, d.sigma_t), key, places)?;
    let emission = d.emission.map_or(Rgb::ZERO, color);
    Ok(MediumDesc::Homogeneous { sigma_a, sigma_s, g: d.g.unwrap_or(0.0), emission })
}

/// A grid medium; its file is relative to the scene file.
fn vdb(d: &VdbDef, key: &str, places: &Places, base_dir: &Path) -> Result<MediumDesc> {
    let (sigma_a, sigma_s) =
        coefficients((d.sigma_a, d.sigma_s, d.albedo, d.sigma_t), key, places)?;
    Ok(MediumDesc::Vdb {
        file: base_dir.join(&d.file),
        grid: d.grid.clone().unwrap_or_else(|| "density".into()),
        density_scale: d.density_scale.unwrap_or(1.0),
        sigma_a,
        sigma_s,
        g: d.g.unwrap_or(0.0),
        emission: d.emission.map_or(Rgb::ZERO, color),
        temperature: d.temperature.as_ref().map(|t| {
            let default = TemperatureDesc::default();
            TemperatureDesc {
                grid: t.grid.clone().unwrap_or(default.grid),
                scale: t.scale.unwrap_or(default.scale),
                offset: t.offset.unwrap_or(default.offset),
                cutoff: t.cutoff.unwrap_or(default.cutoff),
                blackbody_scale: t.blackbody_scale.unwrap_or(default.blackbody_scale),
            }
        }),
        emission_grid: d
            .emission_grid
            .as_ref()
            .map(|e| Box::new((e.grids.channels(), e.scale.unwrap_or(1.0)))),
        albedo_grid: d
            .albedo_grid
            .as_ref()
            .map(|e| Box::new((e.grids.channels(), e.scale.unwrap_or(1.0)))),
        extinction_grid: d
            .extinction_grid
            .as_ref()
            .map(|e| Box::new((e.grids.channels(), e.scale.unwrap_or(1.0)))),
        layout: match d.layout {
            None | Some(LayoutDef::Auto) => GridLayout::Auto,
            Some(LayoutDef::Dense) => GridLayout::Dense,
            Some(LayoutDef::Bricks) => GridLayout::Bricks,
        },
        transform: transform(&d.transform),
        voxels: None,
    })
}

/// The `[camera]` table as a description.
fn camera(def: &CameraDef) -> CameraDesc {
    let (position, look_at, up, resolution, medium, lens) = match def {
        CameraDef::Perspective(d) => (
            d.position,
            d.look_at,
            d.up,
            d.resolution,
            &d.medium,
            Lens::Perspective {
                fov: d.fov,
                aperture: d.aperture.unwrap_or(0.0),
                focus_distance: d.focus_distance,
            },
        ),
        CameraDef::Orthographic(d) => (
            d.position,
            d.look_at,
            d.up,
            d.resolution,
            &d.medium,
            Lens::Orthographic { height: d.height },
        ),
    };
    CameraDesc {
        position: position.into(),
        look_at: look_at.into(),
        up: up.map_or(Vec3::Y, Vec3::from),
        resolution,
        lens,
        medium: medium.clone().map(MediumRef::Name),
    }
}

fn settings(options: Option<&RenderOptions>, places: &Places) -> Result<RenderSettings> {
    let mut s = RenderSettings::default();
    if let Some(o) = options {
        o.check_pairs().map_err(|e| places.error(format!("render.{}", e.key), e.message))?;
        s.apply(o);
    }
    Ok(s)
}

fn transform(t: &TransformDef) -> Transform {
    Transform {
        scale: match t.scale {
            None => Vec3::ONE,
            Some(ScaleDef::Uniform(s)) => Vec3::splat(s),
            Some(ScaleDef::Axes(a)) => Vec3::from(a),
        },
        rotate: Vec3::from(t.rotate.unwrap_or([0.0; 3])),
        translate: Vec3::from(t.translate.unwrap_or([0.0; 3])),
    }
}

/// A `[[shapes]]` table as a description; an OBJ file is relative to the scene file.
fn shape(def: &ShapeDef, base_dir: &Path) -> ShapeDesc {
    let (geometry, material, emission, t, interior, exterior) = match def {
        ShapeDef::Rectangle(d) => (
            GeometryDesc::Rectangle { size: d.size.unwrap_or([1.0, 1.0]) },
            &d.material,
            d.emission,
            &d.transform,
            &d.interior,
            &d.exterior,
        ),
        ShapeDef::Box(d) => (
            GeometryDesc::Cuboid { size: Vec3::from(d.size.unwrap_or([1.0; 3])) },
            &d.material,
            d.emission,
            &d.transform,
            &d.interior,
            &d.exterior,
        ),
        ShapeDef::Sphere(d) => (
            GeometryDesc::Sphere {
                center: Vec3::from(d.center.unwrap_or([0.0; 3])),
                radius: d.radius,
                tessellate: d.tessellate,
            },
            &d.material,
            d.emission,
            &d.transform,
            &d.interior,
            &d.exterior,
        ),
        ShapeDef::Mesh(d) => (
            GeometryDesc::Mesh(Mesh {
                positions: d.vertices.iter().map(|&v| Vec3::from(v)).collect(),
                normals: d.normals.as_ref().map(|n| n.iter().map(|&v| Vec3::from(v)).collect()),
                triangles: d.triangles.clone(),
            }),
            &d.material,
            d.emission,
            &d.transform,
            &d.interior,
            &d.exterior,
        ),
        ShapeDef::Obj(d) | ShapeDef::Ply(d) => {
            let file = base_dir.join(&d.file);
            let geometry = match def {
                ShapeDef::Ply(_) => GeometryDesc::Ply(file),
                _ => GeometryDesc::Obj(file),
            };
            (geometry, &d.material, d.emission, &d.transform, &d.interior, &d.exterior)
        }
    };
    ShapeDesc {
        geometry,
        material: Some(MaterialRef::Name(material.clone())),
        emission: emission.map(color),
        interior: interior.clone().map(MediumRef::Name),
        exterior: exterior.clone().map(MediumRef::Name),
        transform: transform(t),
    }
}

impl Scene {
    /// Loads and validates a scene file.
    pub fn load(path: impl AsRef<Path>) -> Result<Scene> {
        load_file(path.as_ref())
    }

    /// Parses and validates scene text; relative file references resolve against `base_dir`.
    pub fn from_toml(text: &str, origin: &Path, base_dir: &Path) -> Result<Scene> {
        load_str(text, origin, base_dir)
    }
}
