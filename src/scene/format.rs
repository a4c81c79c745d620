//! The scene file format: plain serde data, one struct per kind of TOML table, unknown keys
//! rejected. Tables with a `type` key are dispatched by hand in [`read`] rather than by serde's
//! internally tagged enums, which buffer the table and lose the line of a bad value.
//! Meaning and validation live in [`super::load`]; the user documentation is
//! `docs/scene-format.md`.

use crate::settings::RenderOptions;
use serde::Deserialize;
use serde::de::DeserializeOwned;
use toml::Spanned;
use toml::de::{DeTable, DeValue, ValueDeserializer};

/// An RGB value, or one number for grey.
#[derive(Debug, Clone, Copy)]
pub enum ColorDef {
    Grey(f32),
    Rgb([f32; 3]),
}

/// One number or three, read with a message in the scene format's words (serde's untagged enums
/// would say "data did not match any variant of untagged enum").
struct OneOrThree(&'static str);

impl<'de> serde::de::Visitor<'de> for OneOrThree {
    type Value = (Option<f32>, [f32; 3]);

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(self.0)
    }

    fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Self::Value, E> {
        Ok((Some(v as f32), [v as f32; 3]))
    }

    fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Self::Value, E> {
        self.visit_f64(v as f64)
    }

    fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Self::Value, E> {
        self.visit_f64(v as f64)
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut out = [0.0f32; 3];
        for (i, c) in out.iter_mut().enumerate() {
            *c = seq
                .next_element::<f32>()?
                .ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
        }
        if seq.next_element::<serde::de::IgnoredAny>()?.is_some() {
            return Err(serde::de::Error::invalid_length(4, &self));
        }
        Ok((None, out))
    }
}

impl<'de> Deserialize<'de> for ColorDef {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = d.deserialize_any(OneOrThree("a colour: one number (grey) or [r, g, b]"))?;
        Ok(match v {
            (Some(g), _) => ColorDef::Grey(g),
            (None, rgb) => ColorDef::Rgb(rgb),
        })
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PerspectiveDef {
    #[serde(rename = "type")]
    pub _kind: String,
    pub position: [f32; 3],
    pub look_at: [f32; 3],
    pub up: Option<[f32; 3]>,
    pub fov: f32,
    pub resolution: [u32; 2],
    pub aperture: Option<f32>,
    pub focus_distance: Option<f32>,
    pub medium: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OrthographicDef {
    #[serde(rename = "type")]
    pub _kind: String,
    pub position: [f32; 3],
    pub look_at: [f32; 3],
    pub up: Option<[f32; 3]>,
    pub height: f32,
    pub resolution: [u32; 2],
    pub medium: Option<String>,
}

#[derive(Debug)]
pub enum CameraDef {
    Perspective(PerspectiveDef),
    Orthographic(OrthographicDef),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HomogeneousDef {
    #[serde(rename = "type")]
    pub _kind: String,
    pub sigma_a: Option<ColorDef>,
    pub sigma_s: Option<ColorDef>,
    pub albedo: Option<ColorDef>,
    pub sigma_t: Option<ColorDef>,
    pub g: Option<f32>,
    pub emission: Option<ColorDef>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TemperatureDef {
    pub grid: Option<String>,
    pub scale: Option<f32>,
    pub offset: Option<f32>,
    pub cutoff: Option<f32>,
    pub blackbody_scale: Option<f32>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmissionGridDef {
    pub grids: GridNames,
    pub scale: Option<f32>,
}

/// Three float grids (R, G, B), or one 3-vector grid whose components are the channels.
#[derive(Debug, Clone)]
pub enum GridNames {
    Channels([String; 3]),
    Vector(String),
}

/// Reads [`GridNames`] with a message in the scene format's words.
struct GridNamesVisitor;

impl<'de> serde::de::Visitor<'de> for GridNamesVisitor {
    type Value = GridNames;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a vector grid's name, or three float grids' names [\"r\", \"g\", \"b\"]")
    }

    fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Self::Value, E> {
        Ok(GridNames::Vector(v.to_string()))
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut out: [String; 3] = Default::default();
        for (i, c) in out.iter_mut().enumerate() {
            *c = seq
                .next_element::<String>()?
                .ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
        }
        if seq.next_element::<serde::de::IgnoredAny>()?.is_some() {
            return Err(serde::de::Error::invalid_length(4, &self));
        }
        Ok(GridNames::Channels(out))
    }
}

impl<'de> Deserialize<'de> for GridNames {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(GridNamesVisitor)
    }
}

impl GridNames {
    /// The three channels' grid names: a vector grid's as `NAME[0]`, `NAME[1]`, `NAME[2]`.
    pub fn channels(&self) -> [String; 3] {
        match self {
            GridNames::Channels(c) => c.clone(),
            GridNames::Vector(n) => [0, 1, 2].map(|k| format!("{n}[{k}]")),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VdbDef {
    #[serde(rename = "type")]
    pub _kind: String,
    pub file: String,
    pub grid: Option<String>,
    pub density_scale: Option<f32>,
    pub sigma_a: Option<ColorDef>,
    pub sigma_s: Option<ColorDef>,
    pub albedo: Option<ColorDef>,
    pub sigma_t: Option<ColorDef>,
    pub g: Option<f32>,
    pub emission: Option<ColorDef>,
    pub temperature: Option<TemperatureDef>,
    pub emission_grid: Option<Box<EmissionGridDef>>,
    pub albedo_grid: Option<Box<EmissionGridDef>>,
    pub extinction_grid: Option<Box<EmissionGridDef>>,
    pub layout: Option<LayoutDef>,
    #[serde(default)]
    pub transform: TransformDef,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LayoutDef {
    Auto,
    Dense,
    Bricks,
}

#[derive(Debug)]
pub enum MediumDef {
    Homogeneous(HomogeneousDef),
    Vdb(VdbDef),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiffuseDef {
    #[serde(rename = "type")]
    pub _kind: String,
    pub albedo: ColorDef,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MirrorDef {
    #[serde(rename = "type")]
    pub _kind: String,
    pub reflectance: Option<ColorDef>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DielectricDef {
    #[serde(rename = "type")]
    pub _kind: String,
    pub ior: f32,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InterfaceDef {
    #[serde(rename = "type")]
    pub _kind: String,
}

#[derive(Debug)]
pub enum MaterialDef {
    Diffuse(DiffuseDef),
    Mirror(MirrorDef),
    Dielectric(DielectricDef),
    Interface,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformDef {
    pub scale: Option<ScaleDef>,
    /// Euler angles in degrees, applied about x, then y, then z.
    pub rotate: Option<[f32; 3]>,
    pub translate: Option<[f32; 3]>,
}

/// A uniform or per-axis scale.
#[derive(Debug, Clone, Copy)]
pub enum ScaleDef {
    Uniform(f32),
    Axes([f32; 3]),
}

impl<'de> Deserialize<'de> for ScaleDef {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = d.deserialize_any(OneOrThree("a scale: one number or [x, y, z]"))?;
        Ok(match v {
            (Some(u), _) => ScaleDef::Uniform(u),
            (None, xyz) => ScaleDef::Axes(xyz),
        })
    }
}

/// Declares a shape table: its own fields plus the keys every shape has.
macro_rules! shape_def {
    ($name:ident { $($field:ident : $ty:ty),* $(,)? }) => {
        #[derive(Debug, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct $name {
            #[serde(rename = "type")]
            pub _kind: String,
            $(pub $field: $ty,)*
            pub material: String,
            pub emission: Option<ColorDef>,
            #[serde(default)]
            pub transform: TransformDef,
            pub interior: Option<String>,
            pub exterior: Option<String>,
        }
    };
}

shape_def!(RectangleDef { size: Option<[f32; 2]> });
shape_def!(BoxDef { size: Option<[f32; 3]> });
shape_def!(SphereDef { center: Option<[f32; 3]>, radius: f32, tessellate: Option<u32> });
shape_def!(MeshDef {
    vertices: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    normals: Option<Vec<[f32; 3]>>,
});
shape_def!(MeshFileDef { file: String });

#[derive(Debug)]
pub enum ShapeDef {
    Rectangle(RectangleDef),
    Box(BoxDef),
    Sphere(SphereDef),
    Mesh(MeshDef),
    Obj(MeshFileDef),
    Ply(MeshFileDef),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointDef {
    #[serde(rename = "type")]
    pub _kind: String,
    pub position: [f32; 3],
    pub power: ColorDef,
    pub medium: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpotDef {
    #[serde(rename = "type")]
    pub _kind: String,
    pub position: [f32; 3],
    pub look_at: [f32; 3],
    pub power: ColorDef,
    pub cone_angle: f32,
    pub falloff_start: Option<f32>,
    pub medium: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DirectionalDef {
    #[serde(rename = "type")]
    pub _kind: String,
    pub direction: [f32; 3],
    pub irradiance: ColorDef,
    pub medium: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentDef {
    #[serde(rename = "type")]
    pub _kind: String,
    pub radiance: Option<ColorDef>,
    pub file: Option<String>,
    pub scale: Option<ColorDef>,
    pub rotate: Option<[f32; 3]>,
    pub visible: Option<bool>,
    pub medium: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SkyDef {
    #[serde(rename = "type")]
    pub _kind: String,
    pub elevation: Option<f32>,
    pub azimuth: Option<f32>,
    pub sun_direction: Option<[f32; 3]>,
    pub turbidity: Option<f32>,
    pub ground_albedo: Option<ColorDef>,
    pub scale: Option<ColorDef>,
    pub sun: Option<bool>,
    pub visible: Option<bool>,
    pub resolution: Option<u32>,
    pub medium: Option<String>,
}

#[derive(Debug)]
pub enum LightDef {
    Point(PointDef),
    Spot(SpotDef),
    Directional(DirectionalDef),
    Environment(EnvironmentDef),
    Sky(SkyDef),
}

/// A whole scene file, with the byte span of every table for error messages.
#[derive(Debug)]
pub struct SceneFile {
    pub camera: (CameraDef, std::ops::Range<usize>),
    pub render: Option<(RenderOptions, std::ops::Range<usize>)>,
    pub materials: Vec<(String, MaterialDef, std::ops::Range<usize>)>,
    pub media: Vec<(String, MediumDef, std::ops::Range<usize>)>,
    pub shapes: Vec<(ShapeDef, std::ops::Range<usize>)>,
    pub lights: Vec<(LightDef, std::ops::Range<usize>)>,
}

/// A format error: the key path, the byte offset of the bad text, and the message.
#[derive(Debug)]
pub struct FormatError {
    pub key: String,
    pub at: Option<usize>,
    pub message: String,
}

type Value<'i> = Spanned<DeValue<'i>>;

fn error(key: &str, at: usize, message: impl Into<String>) -> FormatError {
    FormatError { key: key.to_string(), at: Some(at), message: message.into() }
}

/// Longest quoted value repeated in a message (longer ones are cut).
const MAX_QUOTED: usize = 60;

/// A serde message in the scene format's words: Rust type names become what the file holds
/// ("a number", "a whole number", "an array"), and long quoted values are cut.
pub(crate) fn plain(message: &str) -> String {
    let mut m = message.to_string();
    if let Some(rest) = m.strip_prefix("invalid length ") {
        if let Some((n, tail)) = rest.split_once(',') {
            m = format!("{n} values,{tail}");
        }
    }
    for (rust, words) in [
        ("expected f32", "expected a number"),
        ("expected f64", "expected a number"),
        ("expected u8", "expected a whole number"),
        ("expected u16", "expected a whole number"),
        ("expected u32", "expected a whole number"),
        ("expected u64", "expected a whole number"),
        ("expected usize", "expected a whole number"),
        ("expected i32", "expected a whole number"),
        ("expected i64", "expected a whole number"),
        ("expected a sequence", "expected an array"),
        ("expected a boolean", "expected true or false"),
        ("invalid type: ", ""),
        ("invalid value: ", ""),
        ("integer `", "`"),
        ("floating point `", "`"),
        ("sequence, expected", "an array, expected"),
        (
            "wanted string or table",
            "expected one of its names in quotes (docs/scene-format.md lists them)",
        ),
        ("unknown variant", "unknown value"),
        (
            "expected struct TransformDef",
            "expected a table such as { scale = 2, translate = [0, 1, 0] }",
        ),
        ("expected struct TemperatureDef", "expected a table such as { grid = \"temperature\" }"),
        (
            "expected struct EmissionGridDef",
            "expected a table such as { grids = \"Cd\", scale = 1 }",
        ),
    ] {
        m = m.replace(rust, words);
    }
    // Whatever other Rust type names serde puts in a message: a struct is a table of the scene
    // format, an enum one of its names (as a string).
    m = rust_words(&m, "expected struct ", "expected a table");
    m = rust_words(&m, "expected enum ", "expected one of its names in quotes");
    m = rust_words(&m, "expected tuple struct ", "expected a value of another kind");
    m = rust_words(&m, "expected unit struct ", "expected a value of another kind");
    // A table given an array: serde says how many elements the struct has.
    for n in 1..=16 {
        m = m.replace(&format!("}} with {n} elements"), "}");
        m = m.replace(&format!("a table with {n} elements"), "a table");
    }
    cut_quoted(&crate::error::printable(&m))
}

/// `m` with every `pattern` followed by a Rust type name replaced by `words`.
fn rust_words(m: &str, pattern: &str, words: &str) -> String {
    let mut out = String::with_capacity(m.len());
    let mut rest = m;
    while let Some(i) = rest.find(pattern) {
        out.push_str(&rest[..i]);
        out.push_str(words);
        rest = &rest[i + pattern.len()..];
        let end = rest.find(|c: char| !(c.is_alphanumeric() || c == '_')).unwrap_or(rest.len());
        rest = &rest[end..];
    }
    out.push_str(rest);
    out
}

/// Cuts every "…"-quoted part longer than [`MAX_QUOTED`] characters.
fn cut_quoted(m: &str) -> String {
    let mut out = String::with_capacity(m.len().min(1024));
    let mut parts = m.split('"');
    if let Some(first) = parts.next() {
        out.push_str(first);
    }
    for (i, part) in parts.enumerate() {
        out.push('"');
        let n = part.chars().count();
        if i % 2 == 0 && n > MAX_QUOTED {
            out.extend(part.chars().take(MAX_QUOTED));
            out.push_str(&format!("… ({n} characters)"));
        } else {
            out.push_str(part);
        }
    }
    out
}

/// Deserialises one value, keeping the line of whatever inside it is wrong and, in a table, the
/// key whose value it is.
fn typed<T: DeserializeOwned>(v: &Value<'_>, key: &str) -> Result<T, FormatError> {
    T::deserialize(ValueDeserializer::from(v.clone())).map_err(|e| {
        let at = e.span().map(|s| s.start);
        // The entry of the table whose value holds the error's position, if any.
        let entry = at.and_then(|at| {
            v.get_ref()
                .as_table()?
                .iter()
                .find_map(|(k, val)| val.span().contains(&at).then(|| k.get_ref().to_string()))
        });
        FormatError {
            key: entry.map_or_else(|| key.to_string(), |k| format!("{key}.{k}")),
            at: at.or(Some(v.span().start)),
            message: plain(e.message().trim()),
        }
    })
}

/// The `type` of a table, checked against `kinds`.
fn kind<'a>(v: &'a Value<'_>, key: &str, kinds: &[&str]) -> Result<&'a str, FormatError> {
    let table = v.get_ref().as_table().ok_or_else(|| {
        error(key, v.span().start, format!("expected a table, found {}", v.get_ref().type_str()))
    })?;
    let t = table.get("type").ok_or_else(|| {
        error(key, v.span().start, format!("missing `type` (one of {})", kinds.join(", ")))
    })?;
    let name = t
        .get_ref()
        .as_str()
        .ok_or_else(|| error(key, t.span().start, "`type` must be a string"))?;
    if !kinds.contains(&name) {
        let list = kinds.iter().map(|k| format!("\"{k}\"")).collect::<Vec<_>>().join(", ");
        return Err(error(
            &format!("{key}.type"),
            t.span().start,
            cut_quoted(&format!("unknown type \"{name}\"; expected one of {list}")),
        ));
    }
    Ok(name)
}

fn array<'a, 'i>(v: &'a Value<'i>, key: &str) -> Result<&'a [Value<'i>], FormatError> {
    match v.get_ref() {
        DeValue::Array(a) => Ok(&a[..]),
        other => Err(error(
            key,
            v.span().start,
            format!("expected an array of tables ([[{key}]]), found {}", other.type_str()),
        )),
    }
}

/// How a table is read: `kind` checks its `type` against a list, the table, its key.
type KindOf = for<'a> fn(&'a Value<'_>, &str, &[&str]) -> Result<&'a str, FormatError>;

/// The tables of the section `[section.NAME]`, each read by `parse(kind, table, key)`, with its name
/// and span.
fn named<T>(
    root: &DeTable<'_>,
    section: &str,
    parse: impl Fn(KindOf, &Value<'_>, &str) -> Result<T, FormatError>,
) -> Result<Vec<(String, T, std::ops::Range<usize>)>, FormatError> {
    let Some(m) = root.get(section) else { return Ok(Vec::new()) };
    let table = m.get_ref().as_table().ok_or_else(|| {
        error(section, m.span().start, format!("expected a table of named {section}"))
    })?;
    let mut out = Vec::new();
    for (name, v) in table.iter() {
        let name = name.get_ref().to_string();
        let def = parse(kind, v, &format!("{section}.{name}"))?;
        out.push((name, def, v.span()));
    }
    Ok(out)
}

/// The tables of the array `[[section]]`, each read by `parse(kind, table, key)`, with its span.
fn listed<T>(
    root: &DeTable<'_>,
    section: &str,
    parse: impl Fn(KindOf, &Value<'_>, &str) -> Result<T, FormatError>,
) -> Result<Vec<(T, std::ops::Range<usize>)>, FormatError> {
    let Some(s) = root.get(section) else { return Ok(Vec::new()) };
    let mut out = Vec::new();
    for (i, v) in array(s, section)?.iter().enumerate() {
        out.push((parse(kind, v, &format!("{section}[{i}]"))?, v.span()));
    }
    Ok(out)
}

/// A TOML syntax error as one line, naming the key where the parser only says "duplicate key".
fn parse_error(text: &str, e: &toml::de::Error) -> FormatError {
    let mut message = e.message().trim().to_string();
    if let Some(span) = e.span().filter(|_| message == "duplicate key") {
        if let Some(key) = text.get(span.clone()).filter(|k| !k.is_empty()) {
            message = format!("duplicate key `{}`", key.trim());
        }
    }
    FormatError { key: String::new(), at: e.span().map(|s| s.start), message }
}

/// Refuses a top-level section the format does not have.
fn check_sections(root: &DeTable<'_>) -> Result<(), FormatError> {
    for (k, v) in root.iter() {
        let k = k.get_ref().as_ref();
        if !["camera", "render", "materials", "media", "shapes", "lights"].contains(&k) {
            return Err(error(
                k,
                v.span().start,
                format!(
                    "unknown section `{k}`; expected camera, render, materials, media, shapes or lights"
                ),
            ));
        }
    }
    Ok(())
}

/// Parses scene text into [`SceneFile`].
pub fn read(text: &str) -> Result<SceneFile, FormatError> {
    let root = DeTable::parse(text).map_err(|e| parse_error(text, &e))?;
    let root = root.get_ref();
    check_sections(root)?;
    let camera = root.get("camera").ok_or_else(|| FormatError {
        key: "camera".into(),
        at: None,
        message: "missing [camera] table".into(),
    })?;
    let camera_def = match kind(camera, "camera", &["perspective", "orthographic"])? {
        "perspective" => CameraDef::Perspective(typed(camera, "camera")?),
        _ => CameraDef::Orthographic(typed(camera, "camera")?),
    };
    let render = match root.get("render") {
        Some(r) => {
            if let Some(old) = r.get_ref().as_table().and_then(|t| t.get("max_depth")) {
                return Err(error(
                    "render.max_depth",
                    old.span().start,
                    "replaced by `max_bounces`, which limits the scattering events along the whole \
                     light-to-camera path (max_depth limited light and eye paths separately)",
                ));
            }
            Some((typed::<RenderOptions>(r, "render")?, r.span()))
        }
        None => None,
    };
    let materials = named(root, "materials", |kind, v, key| {
        Ok(match kind(v, key, &["diffuse", "mirror", "dielectric", "interface"])? {
            "diffuse" => MaterialDef::Diffuse(typed(v, key)?),
            "mirror" => MaterialDef::Mirror(typed(v, key)?),
            "dielectric" => MaterialDef::Dielectric(typed(v, key)?),
            _ => {
                typed::<InterfaceDef>(v, key)?;
                MaterialDef::Interface
            }
        })
    })?;
    let media = named(root, "media", |kind, v, key| {
        Ok(match kind(v, key, &["homogeneous", "vdb"])? {
            "homogeneous" => MediumDef::Homogeneous(typed(v, key)?),
            _ => MediumDef::Vdb(typed(v, key)?),
        })
    })?;
    let shapes = listed(root, "shapes", |kind, v, key| {
        Ok(match kind(v, key, &["rectangle", "box", "sphere", "mesh", "obj", "ply"])? {
            "rectangle" => ShapeDef::Rectangle(typed(v, key)?),
            "box" => ShapeDef::Box(typed(v, key)?),
            "sphere" => ShapeDef::Sphere(typed(v, key)?),
            "mesh" => ShapeDef::Mesh(typed(v, key)?),
            "obj" => ShapeDef::Obj(typed(v, key)?),
            _ => ShapeDef::Ply(typed(v, key)?),
        })
    })?;
    let lights = listed(root, "lights", |kind, v, key| {
        Ok(match kind(v, key, &["point", "spot", "directional", "environment", "sky"])? {
            "point" => LightDef::Point(typed(v, key)?),
            "spot" => LightDef::Spot(typed(v, key)?),
            "directional" => LightDef::Directional(typed(v, key)?),
            "environment" => LightDef::Environment(typed(v, key)?),
            _ => LightDef::Sky(typed(v, key)?),
        })
    })?;
    Ok(SceneFile { camera: (camera_def, camera.span()), render, materials, media, shapes, lights })
}
