//! The environment-map loader (OpenEXR header check, the exr crate, texel checks) on arbitrary
//! bytes: errors are fine, panics and aborts are not.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    // haze catches the exr crate's panics and reports them as errors; libfuzzer-sys's hook would
    // abort on them first.
    static QUIET: std::sync::Once = std::sync::Once::new();
    QUIET.call_once(|| std::panic::set_hook(Box::new(|_| {})));
    let _ = haze::fuzzing::envmap(data);
});
