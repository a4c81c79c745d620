//! The scene parser and builder on arbitrary text: errors are fine, panics and aborts are not.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    // haze catches the panics of vdb-rs and obvhs and reports them as errors; libfuzzer-sys's
    // hook would abort on them first. A panic that escapes haze still aborts (libfuzzer-sys
    // checks for it after the call) and is reported as a crash.
    static QUIET: std::sync::Once = std::sync::Once::new();
    QUIET.call_once(|| std::panic::set_hook(Box::new(|_| {})));
    // Files resolve against the repository's media/ (the bundled scenes' "../media/…" too), so
    // that every grid key reaches a real grid (tests/fuzz-corpus/scene/grid-keys.toml).
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = haze::fuzzing::scene_with_media(text);
    }
});
