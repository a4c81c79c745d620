//! The fuzz targets' seed corpora (tests/fuzz-corpus/, used by `cargo fuzz` in fuzz/) replayed
//! through the same entry points on the stable toolchain, with deterministic single-byte
//! mutations of each file: every input must give a result (a value or an error), never a panic
//! or an abort. Coverage-guided fuzzing itself runs in CI where a nightly toolchain exists
//! (docs/fuzzing.md).

use std::path::Path;

fn corpus(target: &str) -> Vec<(String, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-corpus").join(target);
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| (p.display().to_string(), std::fs::read(&p).unwrap()))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "{} is empty", dir.display());
    files
}

/// Runs `f` on every corpus file and on `mutations` single-byte changes of each, spread evenly.
fn replay(target: &str, mutations: usize, f: impl Fn(&[u8])) {
    for (name, bytes) in corpus(target) {
        f(&bytes);
        let step = (bytes.len() / mutations).max(1);
        for (k, i) in (0..bytes.len()).step_by(step).enumerate() {
            let mut m = bytes.clone();
            m[i] = [0x00, 0xff, b'"', b'[', b'9', b'\n'][k % 6];
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(&m)));
            assert!(r.is_ok(), "{name} with byte {i} changed to {:#x}: panicked", m[i]);
        }
    }
}

#[test]
fn scene_corpus_and_its_mutations_never_panic() {
    replay("scene", 300, |b| {
        if let Ok(text) = std::str::from_utf8(b) {
            let _ = haze::fuzzing::scene(text);
        }
    });
}

#[test]
fn obj_corpus_and_its_mutations_never_panic() {
    replay("obj", 300, |b| {
        let _ = haze::fuzzing::obj(b);
    });
}

#[test]
fn vdb_corpus_and_its_mutations_never_panic() {
    replay("vdb", 300, |b| {
        let _ = haze::fuzzing::vdb(b);
    });
}
