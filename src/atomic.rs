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
    commit(vec![stage(path, write)?])
}

/// A file written in full beside its target by [`stage`], not yet in place: [`Staged::sync`]
/// flushes it to disk and [`commit`] renames it over its target. Dropped before that (a failure
/// elsewhere), it is removed and the target stays as it was.
pub struct Staged {
    path: PathBuf,
    tmp: PathBuf,
    file: File,
    synced: bool,
    placed: bool,
}

/// The first half of [`write_atomically`]: `write` fills a buffered temporary file beside `path`,
/// flushed to the system but not yet synced to disk nor in place. On failure the temporary file
/// is removed, and the error says that the previous `path` is kept.
pub fn stage(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> std::result::Result<(), String>,
) -> Result<Staged> {
    if path.is_dir() {
        return Err(out_err(path, "is a directory"));
    }
    let tmp = temporary(path);
    let written = (|| -> std::result::Result<File, String> {
        let file =
            OpenOptions::new().write(true).create_new(true).open(&tmp).map_err(|e| {
                format!("cannot create a file in {}: {e}", directory(path).display())
            })?;
        let mut w = BufWriter::new(file);
        write(&mut w)?;
        w.into_inner().map_err(|e| e.error().to_string())
    })();
    match written {
        Ok(file) => {
            Ok(Staged { path: path.to_path_buf(), tmp, file, synced: false, placed: false })
        }
        Err(message) => {
            let _ = std::fs::remove_file(&tmp);
            Err(not_written(path, message))
        }
    }
}

impl Staged {
    /// Flushes the file's bytes to disk (`fsync`); on failure the file is left out of place (and
    /// removed when dropped).
    pub fn sync(&mut self) -> Result<()> {
        self.file.sync_all().map_err(|e| not_written(&self.path, e.to_string()))?;
        self.synced = true;
        Ok(())
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if !self.placed {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// The second half of [`write_atomically`]: syncs each staged file not yet synced, renames it
/// over its target, then makes the renames themselves durable (a power cut must not undo them;
/// best effort where a directory cannot be opened for syncing), each directory once. Every file
/// is synced before any is renamed, so a failure to sync leaves every target as it was.
pub fn commit(mut files: Vec<Staged>) -> Result<()> {
    for f in files.iter_mut().filter(|f| !f.synced) {
        f.sync()?;
    }
    let mut directories: Vec<PathBuf> = Vec::new();
    for f in &mut files {
        std::fs::rename(&f.tmp, &f.path).map_err(|e| not_written(&f.path, e.to_string()))?;
        f.placed = true;
        let dir = directory(&f.path).to_path_buf();
        if !directories.contains(&dir) {
            directories.push(dir);
        }
    }
    for dir in directories {
        if let Ok(dir) = File::open(dir) {
            let _ = dir.sync_all();
        }
    }
    Ok(())
}

/// The error of a file not written: `message`, and whether the previous file is kept.
fn not_written(path: &Path, message: String) -> Error {
    let kept = if path.exists() { "; the previous file is kept" } else { "" };
    out_err(path, format!("not written: {message}{kept}"))
}

/// Writes `bytes` to `path` atomically ([`write_atomically`]).
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomically(path, |w| w.write_all(bytes).map_err(|e| e.to_string()))
}

/// Stages `bytes` to be written to `path` ([`stage`]).
pub fn stage_bytes(path: &Path, bytes: &[u8]) -> Result<Staged> {
    stage(path, |w| w.write_all(bytes).map_err(|e| e.to_string()))
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

    /// Staged files stay out of place until committed: dropped, they leave their targets as
    /// they were and no temporary file; committed together, both are in place.
    #[test]
    fn staged_files_are_in_place_once_committed_and_gone_if_dropped() {
        let d = scratch("staged");
        let (a, b) = (d.join("a.txt"), d.join("b.txt"));
        write_bytes(&a, b"old a").unwrap();
        let staged = [stage_bytes(&a, b"new a").unwrap(), stage_bytes(&b, b"new b").unwrap()];
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 3, "two temporaries beside a.txt");
        assert_eq!(std::fs::read(&a).unwrap(), b"old a");
        drop(staged);
        assert_eq!(std::fs::read(&a).unwrap(), b"old a");
        assert!(!b.exists());
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1, "a temporary file was left");
        let mut first = stage_bytes(&a, b"new a").unwrap();
        first.sync().unwrap();
        commit(vec![first, stage_bytes(&b, b"new b").unwrap()]).unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), b"new a");
        assert_eq!(std::fs::read(&b).unwrap(), b"new b");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 2, "a temporary file was left");
        let e = stage_bytes(&d, b"x").err().unwrap().to_string();
        assert!(e.contains("is a directory"), "{e}");
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
