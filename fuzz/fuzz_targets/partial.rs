//! The partial-render reader (`haze merge`, `--resume`) on arbitrary bytes: the header's TOML and
//! fields, the sums, the checksum. Errors are fine, panics and aborts are not.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    static QUIET: std::sync::Once = std::sync::Once::new();
    QUIET.call_once(|| std::panic::set_hook(Box::new(|_| {})));
    let _ = haze::fuzzing::partial(data);
});
