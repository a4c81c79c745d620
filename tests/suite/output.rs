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
    let attrs = &read.layer_data.attributes.other;
    let text = |k: &str| match attrs.get(&Text::from(k)) {
        Some(AttributeValue::Text(t)) => t.to_string(),
        other => panic!("{k}: {other:?}"),
    };
    assert_eq!(text("haze:iterations"), "2");
    assert_eq!(text("haze:lightPaths"), "20000");
    // Every setting, in the scene file's syntax: the header reads back as the settings.
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
