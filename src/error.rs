//! The library's error type. Every error that can come from user input names where it came from:
//! the file, the key (as a dotted path such as `shapes[2].radius`) and, where known, the line.

use std::path::PathBuf;

/// Errors returned by haze's library API.
///
/// `Debug` prints the same one-line message as `Display`, so that `fn main() -> Result<(),
/// haze::Error>` shows users `Error: scenes/fog.toml:12: media.fog.sigma_s: …` rather than the
/// enum's fields; match on the variants for the parts.
#[derive(thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{path}: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying I/O error (part of the message, so not also a `source`).
        error: std::io::Error,
    },
    /// The scene file is not valid TOML or does not match the scene format.
    #[error("{path}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Parse {
        /// The scene file.
        path: PathBuf,
        /// 1-based line of the offending text, when known.
        line: Option<usize>,
        /// What is wrong, naming the key.
        message: String,
    },
    /// The scene file (or a scene built in code) describes something impossible.
    #[error("{}{key}: {message}", place(path, *line))]
    Invalid {
        /// The scene file (empty for scenes built in code).
        path: PathBuf,
        /// 1-based line of the table holding the key, when known.
        line: Option<usize>,
        /// Dotted path of the offending key, e.g. `shapes[1].material`.
        key: String,
        /// What is wrong.
        message: String,
    },
    /// A mesh file (Wavefront OBJ) could not be loaded.
    #[error("{path}: {message}")]
    Mesh {
        /// The mesh file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A volume (OpenVDB) file could not be used.
    #[error("{path}: {message}")]
    Volume {
        /// The volume file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A render or output setting is impossible.
    #[error("{0}")]
    Settings(String),
    /// Writing an image failed.
    #[error("{path}: {message}")]
    Output {
        /// The image file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

impl std::fmt::Debug for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(self, f)
    }
}

/// "FILE:LINE: " or "FILE: " before a key, or nothing for a scene built in code.
fn place(path: &std::path::Path, line: Option<usize>) -> String {
    if path.as_os_str().is_empty() {
        return String::new();
    }
    match line {
        Some(l) => format!("{}:{l}: ", path.display()),
        None => format!("{}: ", path.display()),
    }
}

/// Result type of the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;
