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
