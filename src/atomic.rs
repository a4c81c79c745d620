//! Atomic file output. Every file haze writes (images, previews, snapshots, charts, tables) goes
//! to a temporary file beside its target, is flushed to disk, and is renamed over the target, so a
//! reader — or the next run after a crash, a `kill -9` or a full disk — finds either the old
//! complete file or the new complete file, never a truncated one.

use crate::error::{Error, Result};
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

fn out_err(path: &Path, message: impl ToString) -> Error {
    Error::Output { path: path.to_path_buf(), message: message.to_string() }
}

/// The directory a path's file lives in (`.` for a bare file name).
fn directory(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// A fresh temporary name beside `path`: `.NAME.haze-PID-N.tmp` (hidden, and unique within and
/// across processes).
fn temporary(path: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    directory(path).join(format!(".{name}.haze-{}-{n}.tmp", std::process::id()))
}

/// Writes `path` atomically: `write` fills a buffered temporary file beside it, which is synced
/// and renamed over `path` only if everything succeeded. On any failure the temporary file is
/// removed, the previous `path` (if any) is untouched, and the error says so.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> std::result::Result<(), String>,
) -> Result<()> {
    if path.is_dir() {
        return Err(out_err(path, "is a directory"));
    }
    let tmp = temporary(path);
    let result = (|| -> std::result::Result<(), String> {
        let file =
            OpenOptions::new().write(true).create_new(true).open(&tmp).map_err(|e| {
                format!("cannot create a file in {}: {e}", directory(path).display())
            })?;
        let mut w = BufWriter::new(file);
        write(&mut w)?;
        let file = w.into_inner().map_err(|e| e.error().to_string())?;
        file.sync_all().map_err(|e| e.to_string())?;
        std::fs::rename(&tmp, path).map_err(|e| e.to_string())?;
        // Make the rename itself durable (a power cut must not undo it); best effort where a
        // directory cannot be opened for syncing.
        if let Ok(dir) = File::open(directory(path)) {
            let _ = dir.sync_all();
        }
        Ok(())
    })();
    result.map_err(|message| {
        let _ = std::fs::remove_file(&tmp);
        let kept = if path.exists() { "; the previous file is kept" } else { "" };
        out_err(path, format!("not written: {message}{kept}"))
    })
}

/// Writes `bytes` to `path` atomically ([`write_atomically`]).
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomically(path, |w| w.write_all(bytes).map_err(|e| e.to_string()))
}

/// Checks, before any work, that a file can be created in `path`'s directory (by creating and
/// removing a temporary file there), so that a long render cannot end with nowhere to write.
pub fn check_writable(path: &Path) -> Result<()> {
    let dir = directory(path);
    if !dir.is_dir() {
        return Err(out_err(path, format!("directory {} does not exist", dir.display())));
    }
    if path.is_dir() {
        return Err(out_err(path, "is a directory"));
    }
    let tmp = temporary(path);
    match OpenOptions::new().write(true).create_new(true).open(&tmp) {
        Ok(_) => {
            let _ = std::fs::remove_file(&tmp);
            Ok(())
        }
        Err(e) => Err(out_err(path, format!("cannot write in {}: {e}", dir.display()))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> crate::testing::TempDir {
        crate::testing::temp_dir(&format!("atomic-{name}"))
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_leaves_no_temporary() {
        let d = scratch("fail");
        let p = d.join("out.txt");
        write_bytes(&p, b"old").unwrap();
        let e = write_atomically(&p, |w| {
            w.write_all(b"half of the new").unwrap();
            Err("disk full".into())
        })
        .unwrap_err()
        .to_string();
        assert!(e.contains("disk full") && e.contains("previous file is kept"), "{e}");
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1, "a temporary file was left");
        write_bytes(&p, b"new").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
    }

    #[test]
    fn unwritable_places_are_found_before_work() {
        let d = scratch("check");
        assert!(check_writable(&d.join("x.exr")).is_ok());
        let e = check_writable(&d.join("missing/x.exr")).unwrap_err().to_string();
        assert!(e.contains("does not exist"), "{e}");
        let e = check_writable(&d).unwrap_err().to_string();
        assert!(e.contains("is a directory"), "{e}");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0);
    }
}
