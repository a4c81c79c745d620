//! The OBJ loader on arbitrary bytes: errors are fine, panics and aborts are not.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    // haze catches the panics of vdb-rs and obvhs and reports them as errors; libfuzzer-sys's
    // hook would abort on them first. A panic that escapes haze still aborts (libfuzzer-sys
    // checks for it after the call) and is reported as a crash.
    static QUIET: std::sync::Once = std::sync::Once::new();
    QUIET.call_once(|| std::panic::set_hook(Box::new(|_| {})));
    let _ = haze::fuzzing::obj(data);
});
