//! A constant-density VDB grid renders like the homogeneous medium it stands for. (How grids are
//! read, and delta and ratio tracking through them, are unit tests in src/medium/.)

use crate::common::{mean_and_se, t_critical};
use std::path::Path;

/// Twin scenes (16 × 16 pixels): a medium of coefficients σ_a, σ_s in a pass-through box inside
/// the region where box.vdb's density is exactly 1, as a homogeneous medium and as the grid, over
/// a floor, lit by a point light and by an emitter seen through the medium.
pub(crate) fn twins(
    sigma_a: haze::glam::Vec3,
    sigma_s: haze::glam::Vec3,
) -> (haze::Scene, haze::Scene) {
    use haze::scene::MediumDesc;
    let box_vdb = Path::new(env!("CARGO_MANIFEST_DIR")).join("media/box.vdb");
    twin_scenes(
        MediumDesc::homogeneous(sigma_a, sigma_s),
        MediumDesc::vdb(box_vdb).coefficients(sigma_a, sigma_s),
    )
}

/// [`twins`]' scene with medium `a`, and with medium `b`.
fn twin_scenes(
    a: haze::scene::MediumDesc,
    b: haze::scene::MediumDesc,
) -> (haze::Scene, haze::Scene) {
    use haze::glam::Vec3;
    use haze::scene::{CameraDesc, LightDesc, Material, MediumDesc, SceneBuilder, ShapeDesc};
    let build = |medium: MediumDesc| {
        let fov = 2.0 * 0.15f32.atan().to_degrees();
        let camera = CameraDesc::perspective([0.475, 0.475, 2.0], Vec3::splat(0.475), fov)
            .resolution(16, 16);
        let mut b = SceneBuilder::new(camera);
        let m = b.medium("m", medium).unwrap();
        let air = b.material("air", Material::Interface).unwrap();
        let floor = b.material("floor", Material::diffuse(0.6)).unwrap();
        b.shape(
            ShapeDesc::cuboid([0.75; 3]).material(air).interior(m).translate(Vec3::splat(0.475)),
        )
        .unwrap();
        b.shape(ShapeDesc::rectangle(4.0, 4.0).material(floor).rotate([-90.0, 0.0, 0.0])).unwrap();
        // An emitter behind the medium, seen through it.
        let back = ShapeDesc::rectangle(3.0, 3.0).material(floor).emission(0.2);
        b.shape(back.translate([0.475, 0.475, -0.5])).unwrap();
        b.light(LightDesc::point([0.475, 1.3, 0.475], 5.0)).unwrap();
        b.build().unwrap()
    };
    (build(a), build(b))
}

/// A render of a [`twins`] scene: `iterations` of 20,000 light paths at radii 0.05, seed `seed`.
fn twin_render(
    scene: &haze::Scene,
    estimate: haze::settings::VolumeEstimate,
    iterations: u64,
    seed: u64,
) -> haze::output::Image {
    let s = haze::settings::RenderSettings {
        iterations: Some(iterations),
        photons: 20_000,
        radius: Some(0.05),
        volume_radius: Some(0.05),
        volume_estimate: estimate,
        max_bounces: 32,
        seed,
        // The volume estimate named is the hybrid's (the combined integrator weighs both).
        integrator: haze::settings::Integrator::Hybrid,
        ..haze::settings::RenderSettings::default()
    };
    let stop = std::sync::atomic::AtomicBool::new(false);
    haze::render(scene, &s, &mut haze::progress::Silent, &stop).unwrap()
}

/// A constant-density grid renders like the equivalent homogeneous medium: box.vdb holds density
/// 1 on [0, 15/16]³ (voxel centres), and the medium sits in a pass-through box inside that
/// region, so both scenes have exactly the same coefficients everywhere. The photon-mapping bias
/// is then the same for both, and the image means must agree within noise (Welch-style t-test
/// with the smaller sample's degrees of freedom), for both volume estimators.
#[test]
fn constant_density_grid_renders_like_the_homogeneous_medium() {
    use haze::glam::Vec3;
    use haze::settings::VolumeEstimate;

    // Optically thin (τ ≈ 0.75 across the box), so the image depends strongly on the density.
    let (sigma_a, sigma_s) = (Vec3::splat(0.4), Vec3::splat(0.6));
    let (homogeneous, grid) = twins(sigma_a, sigma_s);
    for estimate in [VolumeEstimate::Beam, VolumeEstimate::Point] {
        let means = |scene: &haze::Scene| -> Vec<f64> {
            (0..8).map(|seed| twin_render(scene, estimate, 3, seed).mean()).collect()
        };
        let (h, g) = (means(&homogeneous), means(&grid));
        let ((mh, sh), (mg, sg)) = (mean_and_se(&h), mean_and_se(&g));
        let t = t_critical(h.len().min(g.len()));
        assert!(
            (mh - mg).abs() <= t * (sh * sh + sg * sg).sqrt(),
            "{estimate:?}: homogeneous {mh:.6} ± {sh:.6} vs grid {mg:.6} ± {sg:.6}"
        );
        assert!(mh > 0.0);
    }
}

/// A grid medium whose extinction is coloured by a constant colour grid renders like the
/// homogeneous medium of the coloured coefficients: tinted.vdb holds box.vdb's density beside a
/// vector grid `tint` = (0.4, 1, 2) on the same voxels (its largest value above 1, so the
/// normalisation into σ_t is exercised), so σ_a = 0.25 · tint and σ_s = 0.35 · tint everywhere
/// in the medium's box. Per channel and volume estimator, the image means over 24 seeds agree by
/// a Welch-style t-test at the suite's significance, Šidák-corrected over the three channels.
#[test]
fn a_constant_extinction_colour_grid_renders_like_the_coloured_homogeneous_medium() {
    use haze::glam::Vec3;
    use haze::scene::MediumDesc;
    use haze::settings::VolumeEstimate;
    let tint = Vec3::new(0.4, 1.0, 2.0);
    let (sigma_a, sigma_s) = (Vec3::splat(0.25), Vec3::splat(0.35));
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("media/tinted.vdb");
    let (homogeneous, grid) = twin_scenes(
        MediumDesc::homogeneous(sigma_a * tint, sigma_s * tint),
        MediumDesc::vdb(file)
            .coefficients(sigma_a, sigma_s)
            .extinction_grid(["tint[0]", "tint[1]", "tint[2]"], 1.0),
    );
    let alpha = 1.0 - (1.0 - crate::common::SIGNIFICANCE).powf(1.0 / 3.0);
    for estimate in [VolumeEstimate::Beam, VolumeEstimate::Point] {
        let means = |scene: &haze::Scene| -> Vec<[f64; 3]> {
            (0..24)
                .map(|seed| {
                    let image = twin_render(scene, estimate, 4, seed);
                    let n = image.pixels.len() as f64;
                    [0, 1, 2].map(|c| image.pixels.iter().map(|p| p[c] as f64).sum::<f64>() / n)
                })
                .collect()
        };
        let (h, g) = (means(&homogeneous), means(&grid));
        let t = crate::common::t_critical_at(h.len().min(g.len()), alpha);
        for c in 0..3 {
            let channel = |xs: &[[f64; 3]]| xs.iter().map(|x| x[c]).collect::<Vec<_>>();
            let ((mh, sh), (mg, sg)) = (mean_and_se(&channel(&h)), mean_and_se(&channel(&g)));
            assert!(
                (mh - mg).abs() <= t * (sh * sh + sg * sg).sqrt(),
                "{estimate:?}, channel {c}: homogeneous {mh:.6} ± {sh:.6} vs grid {mg:.6} ± {sg:.6}"
            );
            assert!(mh > 0.0);
        }
    }
}

/// The layout is storage only: vdb-edges (holes.vdb) and the fire (density and temperature
/// grids, emission) render to the same pixels, bit for bit, whether their grids are stored dense
/// or in bricks, with the hybrid and the path tracer; and a scene asks for either by name.
#[test]
fn dense_and_brick_layouts_render_the_same_image() {
    use haze::progress::Silent;
    use haze::settings::Integrator;
    use std::sync::atomic::AtomicBool;
    let dir = crate::common::scene_path("");
    for (file, medium) in [("vdb-edges.toml", "holes"), ("fire.toml", "fire")] {
        let text = std::fs::read_to_string(dir.join(file)).unwrap();
        let table = format!("[media.{medium}]\n");
        assert!(text.contains(&table), "{file}");
        let render = |layout: &str, integrator| {
            let text = text.replace(&table, &format!("{table}layout = \"{layout}\"\n"));
            let mut scene = haze::Scene::from_toml(&text, &dir.join(file), &dir).unwrap();
            let want = if layout == "dense" {
                haze::scene::GridLayout::Dense
            } else {
                haze::scene::GridLayout::Bricks
            };
            assert!(scene.grids().iter().all(|g| g.layout == want), "{file}: {:?}", scene.grids());
            scene.set_resolution([48, 32]).unwrap();
            let mut s = scene.settings.clone();
            s.iterations = Some(2);
            s.photons = 20_000;
            s.integrator = integrator;
            haze::render(&scene, &s, &mut Silent, &AtomicBool::new(false)).unwrap()
        };
        for integrator in [Integrator::Hybrid, Integrator::Path] {
            let (a, b) = (render("dense", integrator), render("bricks", integrator));
            assert!(a.mean() > 0.0);
            let same = a
                .pixels
                .iter()
                .flatten()
                .zip(b.pixels.iter().flatten())
                .all(|(x, y)| x.to_bits() == y.to_bits());
            assert!(same, "{file} {integrator:?}: {} vs {}", a.mean(), b.mean());
        }
    }
    let text = std::fs::read_to_string(dir.join("vdb-edges.toml")).unwrap();
    let text = text.replace("[media.holes]\n", "[media.holes]\nlayout = \"sparse\"\n");
    let err = haze::Scene::from_toml(&text, Path::new("edges.toml"), &dir).err().expect("loaded");
    let msg = err.to_string();
    assert!(
        msg.contains("edges.toml") && msg.contains("sparse") && msg.contains("bricks"),
        "{msg}"
    );
}

/// A colour grid given as one 3-vector grid (`grids = "albedo"`, media/vector.vdb, as Houdini and
/// Blender write colour) renders the same pixels, bit for bit, as the same channels given as
/// three float grids (media/albedo.vdb), with the hybrid and the path tracer; a float grid where
/// a vector grid is named is refused with the key.
#[test]
fn a_vector_grid_is_a_colour_grid() {
    use haze::progress::Silent;
    use haze::settings::Integrator;
    use std::sync::atomic::AtomicBool;
    let media = Path::new(env!("CARGO_MANIFEST_DIR")).join("media");
    let scene = |file: &str, grids: &str| {
        let text = format!(
            "[camera]\ntype = \"perspective\"\nposition = [0.5, 0.5, 2.5]\nlook_at = [0.5, 0.5, 0.5]\n\
             fov = 30\nresolution = [24, 24]\n\n\
             [media.m]\ntype = \"vdb\"\nfile = \"{file}\"\nsigma_a = 1\nsigma_s = 3\n\
             albedo_grid = {{ grids = {grids} }}\n\n\
             [materials.air]\ntype = \"interface\"\n\n\
             [[shapes]]\ntype = \"box\"\nsize = [1, 1, 1]\nmaterial = \"air\"\ninterior = \"m\"\n\
             transform = {{ translate = [0.5, 0.5, 0.5] }}\n\n\
             [[lights]]\ntype = \"point\"\nposition = [0.5, 2, 1.5]\npower = 40\n"
        );
        haze::Scene::from_toml(&text, &media.join("vector.toml"), &media)
    };
    let three = scene("albedo.vdb", "[\"albedo.r\", \"albedo.g\", \"albedo.b\"]").unwrap();
    let vector = scene("vector.vdb", "\"albedo\"").unwrap();
    for integrator in [Integrator::Hybrid, Integrator::Path] {
        let render = |scene: &haze::Scene| {
            let mut s = scene.settings.clone();
            s.iterations = Some(2);
            s.photons = 20_000;
            s.integrator = integrator;
            haze::render(scene, &s, &mut Silent, &AtomicBool::new(false)).unwrap()
        };
        let (a, b) = (render(&three), render(&vector));
        assert!(a.mean() > 0.0);
        let same = a.pixels.iter().flatten().zip(b.pixels.iter().flatten()).all(|(x, y)| x == y);
        assert!(same, "{integrator:?}: {} vs {}", a.mean(), b.mean());
    }
    let err = scene("vector.vdb", "\"density\"").err().expect("a float grid was taken as a vector");
    let msg = err.to_string();
    assert!(
        msg.contains("media.m.albedo_grid.grids") && msg.contains("not a vector grid"),
        "{msg}"
    );
}

/// A grid referenced several times — as the density, the temperature and the three channels of
/// the emission, by two media — is read and stored once (issue 37: a 512³ dense grid referenced
/// five times took five copies, 3.5 GB): every listing of it after the first says it is shared,
/// and a `density_scale` other than 1 gives the density a scaled copy of its own, listed as such.
#[test]
fn a_grid_referenced_several_times_is_stored_once() {
    let media = Path::new(env!("CARGO_MANIFEST_DIR")).join("media");
    let medium = |name: &str, scale: f32| {
        format!(
            "[media.{name}]\ntype = \"vdb\"\nfile = \"gradient.vdb\"\nsigma_a = 1\nsigma_s = 1\n\
             density_scale = {scale}\ntemperature = {{ grid = \"density\", scale = 1000 }}\n\
             emission_grid = {{ grids = [\"density\", \"density\", \"density\"] }}\n"
        )
    };
    let text = format!(
        "[camera]\ntype = \"perspective\"\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\nfov = 40\n\
         resolution = [8, 8]\n\n[render]\niterations = 1\n\n{}{}",
        medium("a", 1.0),
        medium("b", 2.0)
    );
    let scene = haze::Scene::from_toml(&text, &media.join("shared.toml"), &media).unwrap();
    let grids = scene.grids();
    let shared: Vec<(&str, bool)> = grids.iter().map(|g| (g.medium.as_str(), g.shared)).collect();
    // a: density, temperature, 3 emission channels — one storage; b: its scaled density is a
    // copy of its own, its temperature and emission share a's.
    assert_eq!(
        shared,
        [
            ("a", false),
            ("a", true),
            ("a", true),
            ("a", true),
            ("a", true),
            ("b", false),
            ("b", true),
            ("b", true),
            ("b", true),
            ("b", true)
        ],
        "{grids:?}"
    );
    assert!(grids[1].to_string().contains("stored once"), "{}", grids[1]);
}

/// An independent reference for the bundled scenes with a medium in a box (grid and homogeneous):
/// each scene's own medium (its grid,
/// transform, density scale and coloured coefficients, as the scene file gives them), made a pure
/// absorber (σ_t kept, albedo 0, emission removed) in its own container, in front of a wall emitting L_e = 1, seen
/// by an orthographic camera along −z. The path tracer's image is then L_e · T along each ray, and
/// the test integrates T = exp(−∫ σ_t dz) itself: a composite midpoint rule through the
/// container on 600 and 1,200 points along each of 128 × 128 rays of the camera's window, one
/// uniformly placed in each cell of a 128 × 128 grid (stratified: unbiased for the window's mean
/// of T, with a standard error from the differences of neighbouring cells' rays, an upper
/// bound), σ_t from [`haze::Scene::extinction`] (the trilinear density the renderer looks up) —
/// no tracking, majorant, DDA, interface crossing or light transport of the renderer's takes
/// part. The two quadratures' difference (its error bound) is an allowance; the render's image
/// mean (variance layer, pixels independent) and the reference's (spread of its rays) are
/// compared per channel by a z-test at the suite's significance (Šidák over scenes and
/// channels). The test also requires that a 2 % error in a channel be detectable on every scene
/// (at power 0.9; the detectable shift is printed).
#[test]
fn grid_scenes_transmit_as_a_quadrature_of_their_density() {
    use crate::common::{Rng, SIGNIFICANCE};
    use haze::glam::Vec3;
    use haze::progress::Silent;
    use haze::settings::{Integrator, RenderSettings};
    use statrs::distribution::{ContinuousCDF, Normal};
    // Every bundled scene whose medium sits in a box container: the grid scenes, the Cornell
    // clouds (grid and homogeneous) and the spotlight's fog. (The Cornell-box fogs fill the room
    // behind a rectangle and the caustic scenes' gas too: no box to look through.)
    let scenes = [
        ("vdb-cloud", "cloud"),
        ("cumulus", "cloud"),
        ("cumulus-sky", "cloud"),
        ("coloured-smoke", "smoke"),
        ("smoke-plume", "smoke"),
        ("vdb-edges", "holes"),
        ("fire", "fire"),
        ("campfire", "fire"),
        ("cornell-cloud", "cloud"),
        ("cornell-cloud-homogeneous", "cloud"),
        ("spotlight-fog", "fog"),
    ];
    let tests = 3 * scenes.len();
    let per_test = 1.0 - (1.0 - SIGNIFICANCE).powf(1.0 / tests as f64);
    let z_crit = Normal::new(0.0, 1.0).unwrap().inverse_cdf(1.0 - per_test / 2.0);
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    // A TOML number, integer or float.
    let num = |v: &toml::Value| v.as_float().or(v.as_integer().map(|i| i as f64)).unwrap();
    let mut failures = Vec::new();
    for (name, medium) in scenes {
        let text = std::fs::read_to_string(dir.join(format!("{name}.toml"))).unwrap();
        let table: toml::Table = text.parse().unwrap();
        // The medium, made a pure absorber of the same extinction and without emission.
        let mut m = table["media"][medium].as_table().unwrap().clone();
        for key in ["emission", "temperature", "emission_grid"] {
            m.remove(key);
        }
        if m.contains_key("albedo") {
            m.insert("albedo".into(), 0.into());
        } else {
            let rgb = |v: &toml::Value| -> [f64; 3] {
                match v {
                    toml::Value::Array(a) => [0, 1, 2].map(|i| num(&a[i])),
                    v => [num(v); 3],
                }
            };
            let (a, s) = (rgb(&m["sigma_a"]), rgb(&m["sigma_s"]));
            let t: Vec<toml::Value> = (0..3).map(|i| (a[i] + s[i]).into()).collect();
            m.insert("sigma_a".into(), t.into());
            m.insert("sigma_s".into(), 0.into());
        }
        // Its container: a box whose interior is the medium.
        let shapes = table["shapes"].as_array().unwrap();
        let container = shapes
            .iter()
            .find(|s| s.get("interior").and_then(|i| i.as_str()) == Some(medium))
            .unwrap()
            .as_table()
            .unwrap();
        let size = container["size"].as_array().unwrap();
        let size = [0, 1, 2].map(|i| num(&size[i]) as f32);
        let at = container
            .get("transform")
            .and_then(|t| t.get("translate"))
            .and_then(|t| t.as_array())
            .map_or([0.0; 3], |a| [0, 1, 2].map(|i| num(&a[i]) as f32));
        let centre = Vec3::from(at);
        let window = size[0].min(size[1]);
        let (z0, z1) = (centre.z - size[2] / 2.0, centre.z + size[2] / 2.0);
        let mut scene_text = format!(
            "[camera]\ntype = \"orthographic\"\nposition = [{}, {}, {}]\nlook_at = [{}, {}, {}]\nheight = {window}\nresolution = [48, 48]\n\n[materials.air]\ntype = \"interface\"\n\n[materials.black]\ntype = \"diffuse\"\nalbedo = 0\n\n[[shapes]]\ntype = \"box\"\nsize = [{}, {}, {}]\nmaterial = \"air\"\ninterior = \"{medium}\"\ntransform = {{ translate = [{}, {}, {}] }}\n\n[[shapes]]\ntype = \"rectangle\"\nsize = [{}, {}]\nmaterial = \"black\"\nemission = 1\ntransform = {{ translate = [{}, {}, {}] }}\n\n",
            centre.x,
            centre.y,
            z1 + 1.0,
            centre.x,
            centre.y,
            centre.z,
            size[0],
            size[1],
            size[2],
            centre.x,
            centre.y,
            centre.z,
            4.0 * window,
            4.0 * window,
            centre.x,
            centre.y,
            z0 - 0.5,
        );
        let mut media = toml::Table::new();
        media.insert(medium.into(), m.into());
        let mut wrap = toml::Table::new();
        wrap.insert("media".into(), media.into());
        scene_text.push_str(&toml::to_string(&wrap).unwrap());
        let scene =
            haze::Scene::from_toml(&scene_text, &dir.join(format!("{name}-absorber.toml")), &dir)
                .unwrap();
        let s = RenderSettings {
            integrator: Integrator::Path,
            iterations: Some(128),
            seed: 11,
            ..scene.settings.clone()
        };
        let image =
            haze::render(&scene, &s, &mut Silent, &std::sync::atomic::AtomicBool::new(false))
                .unwrap();
        let n = image.pixels.len() as f64;
        let variance = image.variance.as_deref().unwrap();
        // The reference: T along uniformly random rays of the window.
        let transmittance = |x: f32, y: f32, points: usize| -> [f64; 3] {
            let h = (z1 - z0) as f64 / points as f64;
            let mut tau = [0.0f64; 3];
            for k in 0..points {
                let z = z0 as f64 + (k as f64 + 0.5) * h;
                let e = scene.extinction(medium, Vec3::new(x, y, z as f32)).unwrap();
                for c in 0..3 {
                    tau[c] += e[c] as f64 * h;
                }
            }
            tau.map(|t| (-t).exp())
        };
        let mut rng = Rng::new(5, 0);
        let cells = 128usize;
        let rays = cells * cells;
        let (mut sum, mut pairs, mut quadrature_error) = ([0.0f64; 3], [0.0f64; 3], [0.0f64; 3]);
        for j in 0..cells {
            let mut previous = [0.0f64; 3];
            for i in 0..cells {
                let x = centre.x + window * ((i as f32 + rng.next_f32()) / cells as f32 - 0.5);
                let y = centre.y + window * ((j as f32 + rng.next_f32()) / cells as f32 - 0.5);
                let (fine, coarse) = (transmittance(x, y, 1200), transmittance(x, y, 600));
                for c in 0..3 {
                    sum[c] += fine[c];
                    quadrature_error[c] += (fine[c] - coarse[c]).abs();
                    // Collapsed strata: each pair of neighbouring cells (i odd with i − 1)
                    // estimates the two cells' variance by (x_a − x_b)², an upper bound.
                    if i % 2 == 1 {
                        pairs[c] += (fine[c] - previous[c]).powi(2);
                    }
                }
                previous = fine;
            }
        }
        for c in 0..3 {
            let reference = sum[c] / rays as f64;
            let ref_se = pairs[c].sqrt() / rays as f64;
            let mean = image.pixels.iter().map(|p| p[c] as f64).sum::<f64>() / n;
            let se = variance.iter().map(|v| v[c] as f64).sum::<f64>().sqrt() / n;
            let allowance = quadrature_error[c] / rays as f64;
            let se_all = (se * se + ref_se * ref_se).sqrt();
            let z = ((mean - reference).abs() - allowance).max(0.0) / se_all;
            let detectable = (allowance + (z_crit + 1.2816) * se_all) / reference;
            let line = format!(
                "{name} channel {c}: render {mean:.5} ± {se:.5}, quadrature {reference:.5} ± \
                 {ref_se:.5} (rule error ≤ {allowance:.1e}), z {z:.2} (critical {z_crit:.2}); \
                 detectable shift {:.2} %",
                100.0 * detectable
            );
            eprintln!("{line}");
            if z > z_crit || detectable > 0.02 {
                failures.push(line);
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
