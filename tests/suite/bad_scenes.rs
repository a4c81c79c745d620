//! Every kind of bad scene file gives its documented error (docs/scene-format.md, "Errors"):
//! naming the file, the key and, where possible, the line. Never a panic.

use crate::common::temp_dir;
use haze::{Error, Scene};
use std::path::Path;

const CAMERA: &str = r#"
[camera]
type = "perspective"
position = [0, 1, 4]
look_at = [0, 1, 0]
fov = 40
resolution = [32, 32]
"#;

const BODY: &str = r#"
[materials.white]
type = "diffuse"
albedo = 0.7

[[shapes]]
type = "rectangle"
size = [2, 2]
material = "white"
transform = { rotate = [-90, 0, 0] }

[[lights]]
type = "point"
position = [0, 1.5, 0]
power = 20
"#;

fn load(text: &str) -> Result<Scene, Error> {
    Scene::from_toml(text, Path::new("bad.toml"), Path::new("."))
}

/// Loads `text`, expects an error, and checks its message contains every one of `needles`.
fn expect_error(text: &str, needles: &[&str]) -> String {
    expect_error_in(Path::new("."), text, needles)
}

/// [`expect_error`] with the scene's files resolved in `dir`.
fn expect_error_in(dir: &Path, text: &str, needles: &[&str]) -> String {
    let msg = match Scene::from_toml(text, Path::new("bad.toml"), dir) {
        Ok(_) => panic!("scene was accepted:\n{text}"),
        Err(e) => e.to_string(),
    };
    for n in needles {
        assert!(msg.contains(n), "error `{msg}` does not mention `{n}`");
    }
    assert!(msg.starts_with("bad.toml"), "error `{msg}` does not name the file");
    msg
}

#[test]
fn the_base_scene_is_valid() {
    let scene = load(&format!("{CAMERA}{BODY}")).unwrap();
    assert_eq!(scene.shape_count(), 1);
}

#[test]
fn unknown_key_names_the_key_and_line() {
    let text = format!("{CAMERA}fvo = 30\n{BODY}");
    expect_error(&text, &["fvo", ":8"]);
    let text = format!("{CAMERA}{BODY}radus = 2\n");
    expect_error(&text, &["radus"]);
}

#[test]
fn wrong_type_names_the_line() {
    let text = format!("{CAMERA}{BODY}").replace("fov = 40", "fov = \"wide\"");
    expect_error(&text, &[":6", "string"]);
}

#[test]
fn nan_and_negative_values_name_the_key_and_line() {
    let text = format!("{CAMERA}{BODY}").replace("albedo = 0.7", "albedo = nan");
    expect_error(&text, &["materials.white.albedo", "finite", ":9"]);
    let text = format!("{CAMERA}{BODY}").replace("power = 20", "power = -20");
    expect_error(&text, &["lights[0].power", "negative", ":19"]);
    let text = format!("{CAMERA}{BODY}").replace("size = [2, 2]", "size = [2, -1]");
    expect_error(&text, &["shapes[0].size", "positive", ":13"]);
    let text = format!("{CAMERA}{BODY}").replace("albedo = 0.7", "albedo = [0.5, 1.5, 0.5]");
    expect_error(&text, &["materials.white.albedo", "exceed"]);
}

#[test]
fn undefined_material_names_the_shape_and_line() {
    let text = format!("{CAMERA}{BODY}").replace("material = \"white\"", "material = \"whte\"");
    expect_error(&text, &["shapes[0].material", "whte", ":13"]);
}

#[test]
fn missing_obj_file_names_the_file() {
    let dir = temp_dir("missing-obj");
    let text = format!(
        "{CAMERA}{BODY}\n[[shapes]]\ntype = \"obj\"\nfile = \"nowhere.obj\"\nmaterial = \"white\"\n"
    );
    let err = Scene::from_toml(&text, Path::new("bad.toml"), &dir).err().expect("accepted");
    let msg = err.to_string();
    assert!(msg.contains("nowhere.obj") && msg.contains("no such file"), "{msg}");
}

#[test]
fn corrupt_obj_file_is_an_error_not_a_panic() {
    let dir = temp_dir("corrupt-obj");
    std::fs::write(dir.join("broken.obj"), "v 0 0 0\nv 1 0 0\nf 1 2 9\n").unwrap();
    let text = format!(
        "{CAMERA}{BODY}\n[[shapes]]\ntype = \"obj\"\nfile = \"broken.obj\"\nmaterial = \"white\"\n"
    );
    let err = Scene::from_toml(&text, Path::new("bad.toml"), &dir).err().expect("accepted");
    assert!(err.to_string().contains("broken.obj"), "{err}");
}

#[test]
fn obj_file_loads_with_its_normals() {
    let dir = temp_dir("good-obj");
    std::fs::write(
        dir.join("tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\nf 1//1 2//2 3//3\n",
    )
    .unwrap();
    let text = format!(
        "{CAMERA}{BODY}\n[[shapes]]\ntype = \"obj\"\nfile = \"tri.obj\"\nmaterial = \"white\"\n"
    );
    let scene = Scene::from_toml(&text, Path::new("ok.toml"), &dir).unwrap();
    assert_eq!(scene.shape_count(), 2);
}

#[test]
fn impossible_settings_name_the_key() {
    let text = format!("{CAMERA}{BODY}[render]\nalpha = 1.5\n");
    expect_error(&text, &["render.alpha", "between 0 and 1"]);
    let text = format!("{CAMERA}{BODY}[render]\nkernel = \"gauss\"\n");
    expect_error(&text, &["render.kernel", "gauss"]);
    let text = format!("{CAMERA}{BODY}[render]\nradius = 0.1\nradius_fraction = 0.01\n");
    expect_error(&text, &["render.radius", "not both"]);
    let text = format!("{CAMERA}{BODY}[render]\nphotons = 0\n");
    expect_error(&text, &["render.photons"]);
    // The old per-subpath limit points to the whole-path one.
    let text = format!("{CAMERA}{BODY}[render]\nmax_depth = 8\n");
    expect_error(&text, &["render.max_depth", "max_bounces"]);
    let text = format!("{CAMERA}{BODY}[render]\nmax_bounces = 0\n");
    expect_error(&text, &["render.max_bounces"]);
}

#[test]
fn impossible_camera_names_the_key() {
    let text = format!("{CAMERA}{BODY}").replace("look_at = [0, 1, 0]", "look_at = [0, 1, 4]");
    expect_error(&text, &["camera.look_at", "differ"]);
    let text = format!("{CAMERA}{BODY}").replace("fov = 40", "fov = 180");
    expect_error(&text, &["camera.fov"]);
    let text = format!("{CAMERA}{BODY}").replace("[32, 32]", "[0, 32]");
    expect_error(&text, &["camera.resolution"]);
}

#[test]
fn missing_sections_and_bad_syntax_are_parse_errors() {
    expect_error(BODY, &["camera"]);
    expect_error(&format!("{CAMERA}{BODY}[[shapes]\n"), &[":"]);
    expect_error(&format!("{CAMERA}{BODY}").replace("\"rectangle\"", "\"torus\""), &["torus"]);
}

#[test]
fn missing_scene_file_names_the_file() {
    let err = Scene::load("no/such/scene.toml").err().expect("loaded");
    assert!(err.to_string().contains("no/such/scene.toml"), "{err}");
}

const FOG: &str = r#"
[media.fog]
type = "homogeneous"
sigma_a = 0.1
sigma_s = 0.5
g = 0.2
"#;

#[test]
fn bad_media_name_the_key_and_line() {
    let base = format!("{CAMERA}{BODY}{FOG}");
    let text = base.replace("sigma_a = 0.1", "sigma_a = -0.1");
    expect_error(&text, &["media.fog.sigma_a", "negative"]);
    let text = base.replace("g = 0.2", "g = 1.0");
    expect_error(&text, &["media.fog.g", "between -1 and 1"]);
    let text = base.replace("g = 0.2", "g = nan");
    expect_error(&text, &["media.fog.g"]);
    let text = base.replace("sigma_a = 0.1", "sigma_a = 0.1\nalbedo = 0.5");
    expect_error(&text, &["media.fog.sigma_a", "sigma_a, sigma_s and albedo given", "not a mix"]);
    let text = base.replace("sigma_a = 0.1\n", "");
    expect_error(&text, &["media.fog.sigma_s", "only sigma_s given", "either sigma_a and sigma_s"]);
    // What the issue's user wrote: albedo, sigma_t and sigma_s.
    let text = base.replace("sigma_a = 0.1\n", "albedo = 0.9\nsigma_t = 2\n");
    expect_error(&text, &["sigma_s, albedo and sigma_t given", "or albedo and sigma_t"]);
    let text = base.replace("\"homogeneous\"", "\"smoke\"");
    expect_error(&text, &["media.fog.type", "smoke"]);
    let text = base.replace("sigma_a = 0.1\nsigma_s = 0.5", "albedo = 1.5\nsigma_t = 1");
    expect_error(&text, &["media.fog.albedo", "[0, 1]"]);
}

#[test]
fn undefined_or_contradictory_media_are_errors() {
    let base = format!("{CAMERA}{BODY}{FOG}");
    let text = base.replace("resolution = [32, 32]", "resolution = [32, 32]\nmedium = \"smog\"");
    expect_error(&text, &["camera.medium", "undefined medium `smog`"]);
    let text = base.replace("material = \"white\"", "material = \"white\"\ninterior = \"smog\"");
    expect_error(&text, &["shapes[0].interior", "smog"]);
    let text = base.replace("power = 20", "power = 20\nmedium = \"smog\"");
    expect_error(&text, &["lights[0].medium", "smog"]);
    // The camera says it is in fog, but the only medium boundary around it (a closed box of
    // interface material with fog inside, the camera outside) says vacuum.
    let text = format!(
        "{base}\n[materials.glassless]\ntype = \"interface\"\n\n[[shapes]]\ntype = \"box\"\nsize = [1, 1, 1]\nmaterial = \"glassless\"\ninterior = \"fog\"\ntransform = {{ translate = [0, 1, 0] }}\n"
    )
    .replace("resolution = [32, 32]", "resolution = [32, 32]\nmedium = \"fog\"");
    expect_error(&text, &["camera.medium", "shapes[1]", "vacuum"]);
}

#[test]
fn the_documented_complete_example_loads() {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/scene-format.md"))
        .unwrap();
    let start = doc.find("```toml\n").expect("a toml block") + "```toml\n".len();
    let end = start + doc[start..].find("```").unwrap();
    let scene =
        Scene::from_toml(&doc[start..end], Path::new("docs/scene-format.md"), Path::new("."))
            .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.medium_names().len(), 1);
    assert_eq!(scene.shape_count(), 6);
    assert_eq!(scene.light_count(), 2);
}

#[test]
fn bad_grid_media_name_the_key_and_the_volume_file() {
    let media = concat!(env!("CARGO_MANIFEST_DIR"), "/media");
    let vdb = |file: &str, extra: &str| {
        format!(
            "{CAMERA}{BODY}\n[media.cloud]\ntype = \"vdb\"\nfile = \"{media}/{file}\"\nsigma_a = 0.1\nsigma_s = 0.9\n{extra}"
        )
    };
    load(&vdb("cloud.vdb", "")).unwrap();
    load(&vdb("half/cloud-zip.vdb", "")).unwrap();
    expect_error(&vdb("bad/affine.vdb", ""), &["media.cloud.file", "AffineMap"]);
    expect_error(&vdb("nowhere.vdb", ""), &["media.cloud.file", "nowhere.vdb"]);
    expect_error(&vdb("cloud.vdb", "grid = \"smoke\"\n"), &["media.cloud.file", "smoke"]);
    expect_error(&vdb("cloud.vdb", "density_scale = -1\n"), &["media.cloud.density_scale"]);
    // A coloured albedo with a grey extinction is fine, f32 rounding included.
    let text = vdb("cloud.vdb", "")
        .replace("sigma_a = 0.1\nsigma_s = 0.9", "albedo = [0.9, 0.5, 0.1]\nsigma_t = 3");
    load(&text).unwrap();
    // Coloured extinction in grids is fine too (spectral tracking).
    let text = vdb("cloud.vdb", "").replace("sigma_s = 0.9", "sigma_s = [0.9, 0.5, 0.9]");
    load(&text).unwrap();
    // Emission: a missing temperature grid is named with the file's grids; emission without
    // absorption, negative or non-finite values are refused with their key.
    expect_error(
        &vdb("cloud.vdb", "temperature = { grid = \"heat\" }\n"),
        &["media.cloud.temperature.grid", "cloud.vdb", "no grid named `heat`", "density"],
    );
    expect_error(
        &vdb("cloud.vdb", "temperature = { scale = nan }\n"),
        &["media.cloud.temperature.scale", "finite"],
    );
    expect_error(
        &vdb("cloud.vdb", "temperature = { blackbody_scale = -2 }\n"),
        &["media.cloud.temperature.blackbody_scale", "non-negative"],
    );
    expect_error(&vdb("cloud.vdb", "emission = -1\n"), &["media.cloud.emission"]);
    expect_error(
        &vdb("cloud.vdb", "emission = 2\n").replace("sigma_a = 0.1", "sigma_a = 0"),
        &["media.cloud.emission", "σ_a = 0"],
    );
    load(&vdb("fire.vdb", "emission = 0.5\ntemperature = { cutoff = 800 }\n")).unwrap();
    // Colour grids: three float grids of the file; a missing one is named with the file's grids.
    let colour =
        "emission_grid = { grids = [\"density\", \"temperature\", \"density\"], scale = 0.01 }\n";
    load(&vdb("fire.vdb", colour)).unwrap();
    expect_error(
        &vdb("cloud.vdb", "emission_grid = { grids = [\"r\", \"g\", \"b\"] }\n"),
        &["media.cloud.emission_grid.grids", "no grid named `r`", "density"],
    );
    expect_error(
        &vdb("cloud.vdb", "emission_grid = { grids = [\"density\", \"density\"] }\n"),
        &["media.cloud.emission_grid"],
    );
    // Albedo grids: values × scale within [0, 1]; missing grids named with the file's grids.
    let albedo = |scale: &str, b: &str| {
        format!("albedo_grid = {{ grids = [\"albedo.r\", \"albedo.g\", \"{b}\"]{scale} }}\n")
    };
    load(&vdb("albedo.vdb", &albedo("", "albedo.b"))).unwrap();
    // Absorption from the albedo grid alone is enough to emit.
    let emitting = vdb("albedo.vdb", &(albedo("", "albedo.b") + "emission = 1\n"));
    load(&emitting.replace("sigma_a = 0.1\nsigma_s = 0.9", "sigma_a = 0\nsigma_s = 2")).unwrap();
    expect_error(
        &vdb("albedo.vdb", &albedo(", scale = 1.5", "albedo.b")),
        &["media.cloud.albedo_grid.scale", "[0, 1]", "1.35"],
    );
    expect_error(
        &vdb("albedo.vdb", &albedo(", scale = -1", "albedo.b")),
        &["media.cloud.albedo_grid.scale", "non-negative"],
    );
    expect_error(
        &vdb("albedo.vdb", &albedo("", "blue")),
        &["media.cloud.albedo_grid.grids", "no grid named `blue`", "albedo.r"],
    );
    // Extinction grids: any non-negative scale; the largest extinction must stay finite.
    load(&vdb("tinted.vdb", "extinction_grid = { grids = \"tint\", scale = 3 }\n")).unwrap();
    expect_error(
        &vdb("tinted.vdb", "extinction_grid = { grids = \"tint\", scale = -1 }\n"),
        &["media.cloud.extinction_grid.scale", "non-negative"],
    );
    expect_error(
        &vdb("tinted.vdb", "extinction_grid = { grids = \"tint\", scale = 3e38 }\n"),
        &["media.cloud.extinction_grid.scale", "overflows"],
    );
    expect_error(
        &vdb("tinted.vdb", "extinction_grid = { grids = \"colour\" }\n"),
        &["media.cloud.extinction_grid.grids", "colour", "tint"],
    );
}

/// No input makes the loader panic: thousands of random corruptions of the documented example
/// (bytes replaced, lines dropped or duplicated, numbers negated or made huge) each load or fail
/// with an error.
#[test]
fn random_corruptions_of_a_scene_never_panic() {
    use crate::common::Rng;
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/scene-format.md"))
        .unwrap();
    let start = doc.find("```toml\n").unwrap() + "```toml\n".len();
    let text = &doc[start..start + doc[start..].find("```").unwrap()];
    let lines: Vec<&str> = text.lines().collect();
    let replacements = ["-1", "nan", "inf", "1e30", "0", "\"x\"", "[", "]", "=", "[[shapes]]", ""];
    for case in 0..20_000u64 {
        let mut s = Rng::new(77, case);
        let mut ls: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
        for _ in 0..1 + (s.next_f32() * 3.0) as usize {
            let i = (s.next_f32() * ls.len() as f32) as usize % ls.len();
            match (s.next_f32() * 4.0) as u32 {
                0 => {
                    ls.remove(i);
                }
                1 => {
                    let l = ls[i].clone();
                    ls.insert(i, l);
                }
                2 => {
                    // Replace the value after '=' with something hostile.
                    if let Some(eq) = ls[i].find('=') {
                        let r = replacements[(s.next_f32() * replacements.len() as f32) as usize
                            % replacements.len()];
                        ls[i] = format!("{} {r}", &ls[i][..=eq]);
                    }
                }
                _ => {
                    // Flip one character.
                    if !ls[i].is_empty() {
                        let mut chars: Vec<char> = ls[i].chars().collect();
                        let j = (s.next_f32() * chars.len() as f32) as usize % chars.len();
                        chars[j] = ['-', '0', '9', 'e', '"', ' ', '.', ','][s.below(8)];
                        ls[i] = chars.into_iter().collect();
                    }
                }
            }
        }
        let text = ls.join("\n");
        let result = std::panic::catch_unwind(|| {
            let scene = Scene::from_toml(&text, Path::new("fuzz.toml"), Path::new("."));
            // Every 40th scene that loads is also rendered, tiny, and must come out finite.
            if let (Ok(mut scene), true) = (scene, case % 40 == 0) {
                scene.set_resolution([4, 3]).unwrap();
                let mut st = scene.settings.clone();
                (st.iterations, st.time_limit, st.photons, st.max_bounces) =
                    (Some(1), None, 500, 8);
                let stop = std::sync::atomic::AtomicBool::new(false);
                let image = haze::render(&scene, &st, &mut haze::progress::Silent, &stop).unwrap();
                assert!(image.pixels.iter().flatten().all(|c| c.is_finite() && *c >= 0.0));
            }
        });
        assert!(result.is_ok(), "panicked on:\n{text}");
    }
}

/// Errors speak the scene format, not Rust: no type names (`f32`, `ColorDef`, "untagged enum"),
/// the full key with its line, and long values cut.
#[test]
fn messages_use_the_users_words() {
    let bright = BODY.replace("power = 20", "power = \"bright\"");
    let msg = expect_error(
        &format!("{CAMERA}{bright}"),
        &["lights[0].power", ":22", "\"bright\"", "a colour: one number (grey) or [r, g, b]"],
    );
    assert!(!msg.contains("untagged") && !msg.contains("ColorDef"), "{msg}");
    let two = BODY.replace("power = 20", "power = [1, 2]");
    expect_error(&format!("{CAMERA}{two}"), &["lights[0].power", "2 values"]);
    let msg = expect_error(
        &CAMERA.replace("fov = 40", "fov = \"40\"").to_string(),
        &["camera.fov", ":6", "expected a number"],
    );
    assert!(!msg.contains("f32"), "{msg}");
    let msg = expect_error(
        &CAMERA.replace("resolution = [32, 32]", "resolution = [32.5, 32]"),
        &["camera.resolution", "expected a whole number"],
    );
    assert!(!msg.contains("u32"), "{msg}");
    expect_error(
        &format!("{CAMERA}[render]\nkernel = 3\n{BODY}"),
        &["render.kernel", "expected one of its names in quotes"],
    );
    expect_error(
        &format!("{CAMERA}[render]\nkernel = \"gauss\"\n{BODY}"),
        &["render.kernel", "`gauss`", "`epanechnikov`"],
    );
    let long = "x".repeat(100_000);
    let msg = expect_error(
        &format!("{}{BODY}", CAMERA.replace("fov = 40", &format!("fov = \"{long}\""))),
        &["camera.fov", "(100000 characters)"],
    );
    assert!(msg.len() < 300, "the value was echoed whole ({} bytes)", msg.len());
    let obj = BODY.replace(
        "type = \"rectangle\"\nsize = [2, 2]",
        "type = \"obj\"\nfile = \"no-such-mesh.obj\"",
    );
    expect_error(&format!("{CAMERA}{obj}"), &["shapes[0].file", ":13", "no-such-mesh.obj"]);
}

/// Issue 37's messages: serde's words for grid keys, transforms and temperatures ("untagged enum
/// GridNames", "expected struct TransformDef", "with 3 elements") in the scene format's words; a
/// multi-line string echoed on one line; a 100 kB undefined material's name cut; control
/// characters from the scene escaped.
#[test]
fn grid_keys_transforms_and_names_are_told_in_the_formats_words() {
    let media = concat!(env!("CARGO_MANIFEST_DIR"), "/media");
    let vdb = |extra: &str| {
        format!(
            "{CAMERA}{BODY}\n[media.cloud]\ntype = \"vdb\"\nfile = \"{media}/tinted.vdb\"\nsigma_t = 1\nalbedo = 0.5\n{extra}\n"
        )
    };
    load(&vdb("extinction_grid = { grids = \"tint\" }")).unwrap();
    let cases: [(&str, &[&str]); 7] = [
        (
            "extinction_grid = { grids = [\"a\", \"b\"] }",
            &["media.cloud.extinction_grid", "2 values", "a vector grid's name, or three"],
        ),
        ("transform = \"\"", &["media.cloud.transform", "expected a table such as { scale"]),
        ("transform = [1]", &["media.cloud.transform", "1 values", "expected a table"]),
        ("temperature = 1", &["media.cloud.temperature", "`1`", "expected a table such as"]),
        ("emission_grid = 3", &["media.cloud.emission_grid", "expected a table such as"]),
        ("layout = \"sparse\"", &["media.cloud.layout", "unknown value `sparse`", "`dense`"]),
        ("layout = 1", &["media.cloud.layout", "expected one of its names in quotes"]),
    ];
    for (extra, needles) in cases {
        let msg = expect_error(&vdb(extra), needles);
        for rust in ["struct ", "enum ", "variant", "Def", "GridNames", "elements"] {
            assert!(!msg.contains(rust), "{extra}: `{msg}` says `{rust}`");
        }
    }
    // A multi-line string as a type: one line, the line break shown as \n.
    let msg = expect_error(
        &CAMERA.replace("type = \"perspective\"", "type = \"\"\"per\nspective\"\"\""),
        &["camera.type", "per\\nspective"],
    );
    assert_eq!(msg.lines().count(), 1, "{msg}");
    // An undefined material of 100,000 characters: cut, and the defined ones listed.
    let long = "m".repeat(100_000);
    let msg = expect_error(
        &format!(
            "{CAMERA}{}",
            BODY.replace("material = \"white\"", &format!("material = \"{long}\""))
        ),
        &["shapes[0].material", "undefined material", "(100000 characters)", "`white`"],
    );
    assert!(msg.len() < 300, "the name was echoed whole ({} bytes)", msg.len());
    // An escape sequence written in the scene (TOML's \u001b) is shown escaped.
    let msg = expect_error(
        &format!("{CAMERA}{}", BODY.replace("material = \"white\"", "material = \"a\\u001b[2Jb\"")),
        &["undefined material `a\\u{1b}[2Jb`"],
    );
    assert!(!msg.contains('\u{1b}'), "{msg:?}");
}

/// A box as a Wavefront OBJ file and as PLY files (binary little- and big-endian with double
/// positions, float normals and uchar/int index lists, and ASCII with quads): the same mesh, so
/// the same image, bit for bit (issue 38: the scene collections users bring store meshes as
/// binary PLY). Then broken PLY files are one-line errors naming the file.
#[test]
fn a_ply_mesh_renders_as_the_same_mesh_from_obj() {
    let dir = temp_dir("ply-mesh");
    // A unit cube's 8 corners (normals pointing out from the centre) and its 6 faces as quads.
    let corners: Vec<[f64; 3]> =
        (0..8).map(|i| [(i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2) as f64]).collect();
    let normal = |c: [f64; 3]| {
        let v = c.map(|x| (x - 0.5) as f32);
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|x| x / l)
    };
    let quads: [[u32; 4]; 6] =
        [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    // OBJ: the quads as the same fans of two triangles.
    let mut obj = String::new();
    for c in &corners {
        obj += &format!("v {} {} {}\n", c[0], c[1], c[2]);
        let n = normal(*c);
        obj += &format!("vn {:?} {:?} {:?}\n", n[0], n[1], n[2]);
    }
    for q in &quads {
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            obj += &format!("f {0}//{0} {1}//{1} {2}//{2}\n", t[0] + 1, t[1] + 1, t[2] + 1);
        }
    }
    std::fs::write(dir.join("cube.obj"), obj).unwrap();
    let binary = |big: bool| {
        let format = if big { "binary_big_endian" } else { "binary_little_endian" };
        let mut b = format!(
            "ply\nformat {format} 1.0\ncomment a cube\nelement vertex 8\nproperty double x\n\
             property double y\nproperty double z\nproperty float nx\nproperty float ny\n\
             property float nz\nelement face 6\nproperty list uchar int vertex_indices\nend_header\n"
        )
        .into_bytes();
        for c in &corners {
            for x in c {
                b.extend(if big { x.to_be_bytes() } else { x.to_le_bytes() });
            }
            for x in normal(*c) {
                b.extend(if big { x.to_be_bytes() } else { x.to_le_bytes() });
            }
        }
        for q in &quads {
            b.push(4);
            for i in q {
                b.extend(if big { (*i as i32).to_be_bytes() } else { (*i as i32).to_le_bytes() });
            }
        }
        b
    };
    std::fs::write(dir.join("le.ply"), binary(false)).unwrap();
    std::fs::write(dir.join("be.ply"), binary(true)).unwrap();
    let mut ascii = String::from(
        "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\n\
         property float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
         element face 6\nproperty list uchar uint vertex_indices\nend_header\n",
    );
    for c in &corners {
        let n = normal(*c);
        ascii += &format!("{} {} {} {:?} {:?} {:?}\n", c[0], c[1], c[2], n[0], n[1], n[2]);
    }
    for q in &quads {
        ascii += &format!("4 {} {} {} {}\n", q[0], q[1], q[2], q[3]);
    }
    std::fs::write(dir.join("ascii.ply"), ascii).unwrap();
    let scene = |kind: &str, file: &str| {
        let text = format!(
            "{CAMERA}{BODY}\n[[shapes]]\ntype = \"{kind}\"\nfile = \"{file}\"\nmaterial = \"white\"\n\
             transform = {{ translate = [-0.5, 0.2, -0.5], rotate = [0, 30, 0] }}\n\
             [render]\niterations = 2\nphotons = 2000\n"
        );
        Scene::from_toml(&text, Path::new("cube.toml"), &dir).unwrap()
    };
    let image = |s: &Scene| {
        let stop = std::sync::atomic::AtomicBool::new(false);
        haze::render(s, &s.settings, &mut haze::progress::Silent, &stop).unwrap()
    };
    let want = image(&scene("obj", "cube.obj"));
    assert!(want.mean() > 0.0);
    for file in ["le.ply", "be.ply", "ascii.ply"] {
        let got = image(&scene("ply", file));
        assert!(got.pixels == want.pixels, "{file}: the image differs from the OBJ's");
    }
    // Broken files: one line, naming the file and what is wrong.
    let cases: [(&str, Vec<u8>, &str); 4] = [
        ("truncated.ply", binary(false)[..300].to_vec(), "not a readable PLY file"),
        ("range.ply", ascii_with(&dir, "4 0 1 2 9"), "vertex index 9 out of range"),
        ("notply.ply", b"solid cube\nendsolid\n".to_vec(), "not a readable PLY file"),
        ("empty.ply", b"ply\nformat ascii 1.0\nend_header\n".to_vec(), "contains no faces"),
    ];
    for (name, bytes, needle) in cases {
        std::fs::write(dir.join(name), bytes).unwrap();
        let text = format!(
            "{CAMERA}{BODY}\n[[shapes]]\ntype = \"ply\"\nfile = \"{name}\"\nmaterial = \"white\"\n"
        );
        let err = Scene::from_toml(&text, Path::new("bad.toml"), &dir).err().expect(name);
        let msg = err.to_string();
        assert!(msg.contains(name) && msg.contains(needle), "{msg}");
        assert_eq!(msg.lines().count(), 1, "{msg}");
    }
    expect_error(
        &format!(
            "{CAMERA}{BODY}\n[[shapes]]\ntype = \"ply\"\nfile = \"nowhere.ply\"\nmaterial = \"white\"\n"
        ),
        &["shapes[1].file", "nowhere.ply", "no such file"],
    );
}

/// The ASCII cube of the test above with its last face replaced by `face`.
fn ascii_with(dir: &Path, face: &str) -> Vec<u8> {
    let text = std::fs::read_to_string(dir.join("ascii.ply")).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    *lines.last_mut().unwrap() = face;
    (lines.join("\n") + "\n").into_bytes()
}

/// An environment light's table: a constant or a map, not both, not neither; one per scene;
/// finite, non-negative radiance; a map file that exists, is OpenEXR, and holds finite,
/// non-negative radiance — each error naming the scene, the key and the line (and the map).
#[test]
fn bad_environment_lights_name_the_key_and_line() {
    let dir = temp_dir("bad-environment");
    let scene =
        |light: &str| format!("{CAMERA}{BODY}\n[[lights]]\ntype = \"environment\"\n{light}\n");
    let load_in = |text: &str| Scene::from_toml(text, Path::new("bad.toml"), &dir);
    let expect = |text: &str, needles: &[&str]| {
        expect_error_in(&dir, text, needles);
    };
    load_in(&scene("radiance = [0.2, 0.3, 0.5]")).unwrap();
    expect(&scene(""), &["lights[1].radiance", "needs", ":24"]);
    expect(&scene("radiance = 1\nfile = \"sky.exr\""), &["lights[1].file", "not both"]);
    expect(&scene("radiance = -1"), &["lights[1].radiance", "negative"]);
    expect(&scene("radiance = nan"), &["lights[1].radiance", "finite"]);
    expect(&scene("radiance = 1\nrotate = [0, inf, 0]"), &["lights[1].rotate", "finite"]);
    expect(&scene("radiance = 1\nvisible = 3"), &["visible"]);
    let two =
        format!("{}[[lights]]\ntype = \"environment\"\nradiance = 2\n", scene("radiance = 1"));
    expect(&two, &["lights[2].type", "at most one environment", "lights[1]"]);
    expect(&scene("file = \"missing.exr\""), &["lights[1].file", "missing.exr"]);
    std::fs::write(dir.join("junk.exr"), b"not an exr at all").unwrap();
    expect(&scene("file = \"junk.exr\""), &["lights[1].file", "junk.exr", "OpenEXR"]);
    // A map with a negative texel, written by haze's own EXR writer.
    let base = load(&format!("{CAMERA}{BODY}")).unwrap();
    let settings =
        haze::settings::RenderSettings { iterations: Some(1), photons: 100, ..Default::default() };
    let stop = std::sync::atomic::AtomicBool::new(false);
    let mut img = haze::render(&base, &settings, &mut haze::progress::Silent, &stop).unwrap();
    img.pixels[37] = [0.5, -1.0, 0.5];
    img.write_exr(&dir.join("negative.exr")).unwrap();
    expect(&scene("file = \"negative.exr\""), &["lights[1].file", "texel (5, 1)", "non-negative"]);
}

/// A sky's table: the sun by elevation (and azimuth) or by direction, above the horizon; the
/// model's turbidity range; an albedo in [0, 1]; one environment per scene, a sky counting as
/// one.
#[test]
fn bad_skies_name_the_key_and_line() {
    let scene = |light: &str| format!("{CAMERA}{BODY}\n[[lights]]\ntype = \"sky\"\n{light}\n");
    let sky = load(&scene("elevation = 30\nazimuth = 120\nturbidity = 4")).unwrap();
    assert_eq!(sky.light_count(), 3, "the point light, the sky dome and its sun");
    let labels: Vec<String> = (0..3).map(|i| sky.light_label(i)).collect();
    assert_eq!(
        labels,
        ["lights[0], a point light", "lights[1], a sky (its dome)", "lights[1], a sky (its sun)"]
    );
    let no_sun = load(&scene("sun_direction = [0, 1, 1]\nsun = false")).unwrap();
    assert_eq!(no_sun.light_count(), 2);
    expect_error(&scene(""), &["lights[1].elevation", "needs the sun", ":24"]);
    expect_error(&scene("elevation = 95"), &["lights[1].elevation", "[0, 90]"]);
    expect_error(
        &scene("elevation = 30\nsun_direction = [0, 1, 0]"),
        &["lights[1].sun_direction", "not both"],
    );
    expect_error(&scene("sun_direction = [0, -1, 1]"), &["lights[1].sun_direction", "horizon"]);
    expect_error(&scene("sun_direction = [0, 0, 0]"), &["lights[1].sun_direction", "horizon"]);
    expect_error(&scene("elevation = 30\nturbidity = 20"), &["lights[1].turbidity", "[1.7, 10]"]);
    expect_error(
        &scene("elevation = 30\nground_albedo = 2"),
        &["lights[1].ground_albedo", "exceed"],
    );
    expect_error(&scene("elevation = 30\nresolution = 4"), &["lights[1].resolution", "[16, 8192]"]);
    expect_error(&scene("elevation = 30\nscale = -1"), &["lights[1].scale", "negative"]);
    let two =
        format!("{}[[lights]]\ntype = \"environment\"\nradiance = 1\n", scene("elevation = 30"));
    expect_error(&two, &["lights[2].type", "at most one environment"]);
}
