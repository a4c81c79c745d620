//! Reading input files (scenes, meshes, grids) without being made to hang or to exhaust memory.

use crate::error::{Error, Result};
use std::path::Path;

/// Reads the file at `path` whole, refusing anything but a regular file (a FIFO would block, a
/// device such as /dev/zero never end) and files larger than `max` bytes. `what` names the kind
/// of file in messages, e.g. "a scene file".
pub(crate) fn read_bounded(path: &Path, max: u64, what: &str) -> Result<Vec<u8>> {
    use std::io::Read;
    let io = |error: std::io::Error| Error::Io { path: path.to_path_buf(), error };
    let len = check_file(path, max, what)?;
    let file = std::fs::File::open(path).map_err(io)?;
    // A large file (a sparse one can claim terabytes) must not abort the process by its size.
    let mut bytes = Vec::new();
    bytes.try_reserve_exact(len as usize).map_err(|_| {
        refusal(path, format!("is {len} bytes, more than this machine can hold to read {what}"))
    })?;
    file.take(max + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > max {
        return Err(refusal(path, format!("grew past {max} bytes while being read")));
    }
    Ok(bytes)
}

/// Checks that `path` is a regular file of at most `max` bytes (`what` names it in messages) and
/// returns its length.
pub(crate) fn check_file(path: &Path, max: u64, what: &str) -> Result<u64> {
    let io = |error: std::io::Error| Error::Io { path: path.to_path_buf(), error };
    // stat first: opening a FIFO for reading would block until a writer came.
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        let kind = if meta.is_dir() { "a directory" } else { "not a regular file" };
        return Err(refusal(path, format!("is {kind}; {what} must be a regular file")));
    }
    if meta.len() > max {
        return Err(refusal(
            path,
            format!("{} bytes is more than haze reads as {what} ({max} bytes)", meta.len()),
        ));
    }
    Ok(meta.len())
}

fn refusal(path: &Path, message: String) -> Error {
    Error::Io {
        path: path.to_path_buf(),
        error: std::io::Error::new(std::io::ErrorKind::InvalidInput, message),
    }
}
