//! A temporary directory per test, shared by the unit tests (`src/testing.rs`) and the
//! integration suite (`tests/suite/common.rs`), which include this file.

/// A fresh, empty temporary directory for one test, removed when the test ends — unless it
/// fails (panics), so that what it wrote can be looked at. Derefs to its path.
pub struct TempDir(std::path::PathBuf);

impl TempDir {
    /// `haze-PREFIX-PID-TEST` under the system's temporary directory, emptied.
    pub fn new(prefix: &str, test: &str) -> Self {
        let d = std::env::temp_dir().join(format!("haze-{prefix}-{}-{test}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        TempDir(d)
    }
}

impl std::ops::Deref for TempDir {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.0
    }
}

impl AsRef<std::path::Path> for TempDir {
    fn as_ref(&self) -> &std::path::Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}
