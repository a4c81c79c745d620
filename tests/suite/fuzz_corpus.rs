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

/// Every message a scene error gives speaks the scene format, not Rust, and is one safe line:
/// no serde type words, no control character.
fn assert_plain_message(result: haze::Result<()>) {
    if let Err(e) = result {
        let msg = e.to_string();
        for rust in ["struct ", "enum ", "variant", "untagged"] {
            assert!(!msg.contains(rust), "`{msg}` says `{rust}`");
        }
        assert!(!msg.chars().any(char::is_control), "{msg:?}");
    }
}

#[test]
fn scene_corpus_and_its_mutations_never_panic() {
    replay("scene", 300, |b| {
        if let Ok(text) = std::str::from_utf8(b) {
            assert_plain_message(haze::fuzzing::scene(text));
        }
    });
}

/// The scene target's entry with files resolved in media/: the grid-keys seed loads whole (so
/// that mutations of it reach every grid key), and its mutations never panic and say nothing in
/// Rust's words.
#[test]
fn grid_keys_seed_loads_and_its_mutations_never_panic() {
    let seed = corpus("scene").into_iter().find(|(n, _)| n.ends_with("grid-keys.toml")).unwrap();
    let text = std::str::from_utf8(&seed.1).unwrap();
    haze::fuzzing::scene_with_media(text).unwrap();
    let step = seed.1.len() / 150;
    for (k, i) in (0..seed.1.len()).step_by(step).enumerate() {
        let mut m = seed.1.clone();
        m[i] = [0x00, b'9', b'"', b'[', b'-', b'\n'][k % 6];
        if let Ok(text) = std::str::from_utf8(&m) {
            let r = std::panic::catch_unwind(|| haze::fuzzing::scene_with_media(text));
            assert!(r.is_ok(), "grid-keys.toml with byte {i} changed to {:#x}: panicked", m[i]);
            assert_plain_message(r.unwrap());
        }
    }
}

#[test]
fn partial_corpus_and_its_mutations_never_panic() {
    haze::fuzzing::partial(&corpus("partial")[0].1).unwrap();
    replay("partial", 300, |b| {
        let _ = haze::fuzzing::partial(b);
    });
}

/// A partial render's header replaced by `header` (its length field mended; the checksum, read
/// last, is not).
fn with_header(bytes: &[u8], header: impl Fn(&str) -> String) -> Vec<u8> {
    let n = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    let old = std::str::from_utf8(&bytes[20..20 + n]).unwrap();
    let new = header(old);
    let mut out = bytes[..12].to_vec();
    out.extend_from_slice(&(new.len() as u64).to_le_bytes());
    out.extend_from_slice(new.as_bytes());
    out.extend_from_slice(&bytes[20 + n..]);
    out
}

/// A change to a partial render's header text.
type HeaderEdit = dyn Fn(&str) -> String;

/// Issue 37: a header whose TOML does not parse gave toml's five-line diagnostic, and `radius =
/// -1` was reported as "`radius` missing". Each is one line naming what is wrong.
#[test]
fn partial_render_headers_are_reported_in_one_line() {
    let seed = corpus("partial").remove(0).1;
    let cases: [(&HeaderEdit, &[&str]); 5] = [
        (&|h| h.replacen("width = 4", "width = = 4", 1), &["header: line", "(corrupt file)"]),
        (
            &|h| h.replacen("\nradius = 0.03", "\nradius = -1 # 0.03", 1),
            &["`radius` is -1", "non-negative"],
        ),
        (
            &|h| h.replacen("\nradius = 0.03", "\nradius = \"x\" # 0.03", 1),
            &["`radius` is a string"],
        ),
        (&|h| h.replacen("width = 4", "width = -4", 1), &["`width` is -4", "whole number"]),
        (&|h| h.replacen("width = 4", "", 1), &["`width` missing"]),
    ];
    for (edit, needles) in cases {
        let msg = haze::fuzzing::partial(&with_header(&seed, edit)).unwrap_err().to_string();
        assert_eq!(msg.lines().count(), 1, "{msg}");
        for n in needles {
            assert!(msg.contains(n), "`{msg}` does not say `{n}`");
        }
    }
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

#[test]
fn envmap_corpus_and_its_mutations_never_panic() {
    haze::fuzzing::envmap(&corpus("envmap")[0].1).unwrap();
    replay("envmap", 300, |b| {
        let _ = haze::fuzzing::envmap(b);
    });
}
