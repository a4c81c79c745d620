//! EXR output carries linear pixels and the render's metadata; the PNG preview sits beside it.

use crate::common::{scene_path, temp_dir};
use haze::Scene;
use haze::progress::Silent;
use std::sync::atomic::AtomicBool;

#[test]
fn exr_round_trips_pixels_and_metadata() {
    let scene = Scene::load(scene_path("cornell-box.toml")).unwrap();
    let mut settings = scene.settings.clone();
    settings.iterations = Some(2);
    settings.photons = 10_000;
    let image = haze::render(&scene, &settings, &mut Silent, &AtomicBool::new(false)).unwrap();
    let dir = temp_dir("exr");
    let exr_path = dir.join("out.exr");
    let written = image.write(&exr_path, 1.0).unwrap();
    assert_eq!(written, vec![exr_path.clone(), dir.join("out.png")]);
    assert!(written.iter().all(|p| p.is_file()));
    // By extension: a .png alone; anything else is refused before writing.
    assert_eq!(image.write(&dir.join("alone.png"), 1.0).unwrap(), vec![dir.join("alone.png")]);
    assert!(!dir.join("alone.exr").exists());
    let err = image.write(&dir.join("x.tiff"), 1.0).unwrap_err().to_string();
    assert!(err.contains("x.tiff") && err.contains(".exr"), "{err}");
    assert!(!dir.join("x.tiff").exists());

    use exr::prelude::*;
    let w = image.width as usize;
    let read = read_first_rgba_layer_from_file(
        &exr_path,
        |res, _| vec![[0f32; 3]; res.width() * res.height()],
        move |px: &mut Vec<[f32; 3]>, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * w + pos.x()] = [r, g, b]
        },
    )
    .unwrap();
    assert!(read.layer_data.channel_data.pixels == image.pixels);
    // Run-length encoded scan lines (`output.rs`, `ENCODING`: as small as zlib's within 3 % on
    // a render's noise, at a tenth of the time).
    let encoding = &read.layer_data.encoding;
    assert_eq!((encoding.compression, &encoding.blocks), (Compression::RLE, &Blocks::ScanLines));
    let attrs = &read.layer_data.attributes.other;
    let text = |k: &str| match attrs.get(&Text::from(k)) {
        Some(AttributeValue::Text(t)) => t.to_string(),
        other => panic!("{k}: {other:?}"),
    };
    assert_eq!(text("haze:iterations"), "2");
    // The light paths traced: the combined integrator's pilot may choose fewer than `photons`,
    // the same count in each iteration.
    assert_eq!(text("haze:lightPaths"), image.info.light_paths.to_string());
    assert!(image.info.light_paths > 0 && image.info.light_paths <= 20_000);
    assert_eq!(image.info.light_paths % 2, 0);
    // Every setting, in the scene file's syntax: the header reads back as the settings, with
    // the integrator the default (`auto`) stood for in this scene.
    assert_eq!(settings.integrator, haze::settings::Integrator::Auto);
    assert_eq!(text("haze:render.integrator"), "\"combined\"");
    let settings =
        haze::RenderSettings { integrator: haze::settings::Integrator::Combined, ..settings };
    assert_eq!(text("haze:render.seed"), settings.seed.to_string());
    assert_eq!(text("haze:render.kernel"), format!("\"{}\"", settings.kernel));
    let table: String = haze::RenderOptions::KEYS
        .iter()
        .filter_map(|k| match attrs.get(&Text::from(format!("haze:render.{k}").as_str())) {
            Some(AttributeValue::Text(t)) => Some(format!("{k} = {t}\n")),
            _ => None,
        })
        .collect();
    let read_back = haze::RenderSettings::default().with(&toml::from_str(&table).unwrap());
    assert_eq!(read_back, settings);
    assert!(text("haze:scene").ends_with("cornell-box.toml"));
    match attrs.get(&Text::from("haze:radius")) {
        Some(AttributeValue::F64(r)) => assert_eq!(*r, image.info.radius),
        other => panic!("radius: {other:?}"),
    }
}

#[test]
fn stop_flag_before_start_gives_an_empty_render() {
    let scene = Scene::load(scene_path("cornell-box.toml")).unwrap();
    let image = haze::render(&scene, &scene.settings, &mut Silent, &AtomicBool::new(true)).unwrap();
    assert_eq!(image.info.iterations, 0);
}

/// A scene whose photons almost all escape (a 1 m² card 10 m from a point light), so that an
/// iteration of [`haze::settings::MAX_PHOTONS`] light paths stores almost nothing yet takes
/// seconds: at least 20 ns a path on 2 cores makes 0.5 s.
fn escaping_photons() -> (Scene, haze::RenderSettings) {
    use haze::scene::{CameraDesc, LightDesc, Material, SceneBuilder, ShapeDesc};
    let camera = CameraDesc::perspective([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], 40.0).resolution(16, 16);
    let mut b = SceneBuilder::new(camera);
    b.material("card", Material::diffuse(0.5)).unwrap();
    b.shape(ShapeDesc::rectangle(1.0, 1.0).material("card")).unwrap();
    b.light(LightDesc::point([0.0, 0.0, 10.0], 100.0)).unwrap();
    let scene = b.build().unwrap();
    let settings = haze::RenderSettings {
        photons: haze::settings::MAX_PHOTONS,
        ..haze::RenderSettings::default()
    };
    (scene, settings)
}

/// A time limit of 0.05 s must end such an iteration inside it (the iteration is discarded)
/// rather than wait for it: the render returns with no iteration. (Before stop requests and time
/// limits were honoured inside iterations, it returned one.)
#[test]
fn a_time_limit_ends_a_long_iteration_inside_it() {
    let (scene, settings) = escaping_photons();
    let settings = haze::RenderSettings { iterations: None, time_limit: Some(0.05), ..settings };
    let image = haze::render(&scene, &settings, &mut Silent, &AtomicBool::new(false)).unwrap();
    assert_eq!(image.info.iterations, 0);
}

/// The same for a stop raised from another thread during the first iteration.
#[test]
fn a_stop_request_ends_a_long_iteration_inside_it() {
    let (scene, settings) = escaping_photons();
    let settings = haze::RenderSettings { iterations: Some(1), ..settings };
    let stop = AtomicBool::new(false);
    let image = std::thread::scope(|s| {
        s.spawn(|| {
            std::thread::sleep(std::time::Duration::from_millis(50));
            stop.store(true, std::sync::atomic::Ordering::Relaxed);
        });
        haze::render(&scene, &settings, &mut Silent, &stop).unwrap()
    });
    assert_eq!(image.info.iterations, 0);
}

/// `techniques` (the combined integrator): one layer per technique, each the mean over the
/// iterations of what that technique added, weighted, so that they sum to the image — in a fog
/// lit by an area light (where every weighted technique contributes) and in the campfire (an
/// emitting grid, whose light the `emitted` layer holds); the layers reach the EXR file; and
/// the option is refused by another integrator and by a range.
#[test]
fn technique_layers_sum_to_the_image() {
    use haze::settings::Integrator;
    for (name, size) in [("cornell-fog.toml", [32, 32]), ("campfire.toml", [40, 24])] {
        let mut scene = Scene::load(scene_path(name)).unwrap();
        scene.set_resolution(size).unwrap();
        let settings = haze::RenderSettings {
            integrator: Integrator::Combined,
            techniques: true,
            iterations: Some(3),
            photons: 20_000,
            ..scene.settings.clone()
        };
        let image = haze::render(&scene, &settings, &mut Silent, &AtomicBool::new(false)).unwrap();
        let layers = image.techniques.as_ref().expect("technique layers");
        let names: Vec<&str> = layers.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["hit", "nee", "surface", "point", "beam", "emitted"], "{name}");
        let mut worst = 0.0f64;
        for (i, p) in image.pixels.iter().enumerate() {
            for c in 0..3 {
                let sum: f64 = layers.iter().map(|(_, l)| l[i][c] as f64).sum();
                // The film's exact fixed-point mean against the layers' f64 sums of f32 values.
                let err = (sum - p[c] as f64).abs() / (p[c] as f64).abs().max(1e-3);
                worst = worst.max(err);
            }
        }
        assert!(worst < 1e-4, "{name}: the layers sum to the image within {worst:e}");
        // Each layer carries light where its technique does: every weighted technique in the
        // fog; the campfire's light in its `emitted` layer.
        let total =
            |k: usize| layers[k].1.iter().map(|p| p.iter().sum::<f32>() as f64).sum::<f64>();
        if name == "cornell-fog.toml" {
            for (k, n) in names.iter().enumerate().take(5) {
                assert!(total(k) > 0.0, "{name}: the {n} layer is black");
            }
        } else {
            assert!(total(5) > 0.0, "{name}: the emitted layer is black");
        }
        let dir = temp_dir("techniques");
        let path = dir.join("t.exr");
        image.write(&path, 1.0).unwrap();
        let meta = exr::meta::MetaData::read_from_file(&path, false).unwrap();
        let written: Vec<String> = meta
            .headers
            .iter()
            .filter_map(|h| h.own_attributes.layer_name.as_ref().map(|n| n.to_string()))
            .collect();
        for n in &names {
            assert!(written.contains(&format!("technique_{n}")), "{name}: {written:?}");
        }
    }
    let scene = Scene::load(scene_path("cornell-box.toml")).unwrap();
    let hybrid = haze::RenderSettings {
        techniques: true,
        integrator: Integrator::Hybrid,
        ..scene.settings.clone()
    };
    let refused = haze::render(&scene, &hybrid, &mut Silent, &AtomicBool::new(false));
    assert!(refused.unwrap_err().to_string().contains("techniques"));
    let combined = haze::RenderSettings {
        integrator: Integrator::Combined,
        iterations: Some(3),
        photons: 1_000,
        ..hybrid
    };
    let range = haze::render_partial(
        &scene,
        &combined,
        haze::Start::At(2),
        &mut Silent,
        &AtomicBool::new(false),
    );
    assert!(range.unwrap_err().to_string().contains("one process"));
}
