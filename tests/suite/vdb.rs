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
