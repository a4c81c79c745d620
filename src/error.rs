//! The library's error type. Every error that can come from user input names where it came from:
//! the file, the key (as a dotted path such as `shapes[2].radius`) and, where known, the line.

use std::path::PathBuf;

/// Errors returned by haze's library API.
///
/// Messages are one line, and safe to print: every control character (from a file's names, a
/// scene's strings or a path) is shown escaped, as `\u{1b}`, never written raw to a terminal
/// ([`printable`]). `Debug` prints the same one-line message as `Display`, so that `fn main() -> Result<(),
/// haze::Error>` shows users `Error: scenes/fog.toml:12: media.fog.sigma_s: …` rather than the
/// enum's fields; match on the variants for the parts.
pub enum Error {
    /// A file could not be read or written.
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying I/O error (part of the message, so not also a `source`).
        error: std::io::Error,
    },
    /// The scene file is not valid TOML or does not match the scene format.
    Parse {
        /// The scene file.
        path: PathBuf,
        /// 1-based line of the offending text, when known.
        line: Option<usize>,
        /// What is wrong, naming the key.
        message: String,
    },
    /// The scene file (or a scene built in code) describes something impossible.
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
    Mesh {
        /// The mesh file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A volume (OpenVDB) file could not be used.
    Volume {
        /// The volume file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// An input image (an environment map) could not be used.
    Image {
        /// The image file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A render or output setting is impossible.
    Settings(String),
    /// Writing an image failed.
    Output {
        /// The image file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

impl Error {
    /// The message as built, before [`printable`].
    fn raw(&self) -> String {
        match self {
            Error::Io { path, error } => format!("{}: {error}", path.display()),
            Error::Parse { path, line, message } => {
                let line = line.map(|l| format!(":{l}")).unwrap_or_default();
                format!("{}{line}: {message}", path.display())
            }
            Error::Invalid { path, line, key, message } => {
                format!("{}{key}: {message}", place(path, *line))
            }
            Error::Mesh { path, message }
            | Error::Volume { path, message }
            | Error::Image { path, message }
            | Error::Output { path, message } => format!("{}: {message}", path.display()),
            Error::Settings(message) => message.clone(),
        }
    }
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&printable(&self.raw()))
    }
}

impl std::error::Error for Error {}

/// `s` with every character that could act on a terminal or hide text escaped as Rust writes it
/// (`\u{1b}`, `\n`, `\0`): the C0 and C1 controls, DEL, and the bidirectional overrides and
/// isolates. Everything else, `σ` and `³` included, is kept.
pub fn printable(s: &str) -> std::borrow::Cow<'_, str> {
    let unsafe_char =
        |c: char| c.is_control() || matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}');
    if !s.chars().any(unsafe_char) {
        return std::borrow::Cow::Borrowed(s);
    }
    let mut out = String::with_capacity(s.len() + 16);
    for c in s.chars() {
        if unsafe_char(c) {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    std::borrow::Cow::Owned(out)
}

/// Longest text from a file or a scene repeated in a message; longer text is cut.
pub const MAX_QUOTED: usize = 60;

/// Text from a file (a grid or map name, a type string) or a scene value, for a message:
/// [`printable`], and cut after [`MAX_QUOTED`] characters with the full length said.
pub fn quote(s: &str) -> String {
    let n = s.chars().count();
    let cut: String = s.chars().take(MAX_QUOTED).collect();
    let mut out = printable(&cut).into_owned();
    if n > MAX_QUOTED {
        out.push_str(&format!("… ({n} characters)"));
    }
    out
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

/// An invalid value of the scene field `key` (the loader adds the file and line).
pub(crate) fn invalid(key: String, message: impl Into<String>) -> Error {
    Error::Invalid { path: std::path::PathBuf::new(), line: None, key, message: message.into() }
}

/// Result type of the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;
