//! Error type of the host side: bad input (exit status 2) is told apart from internal failures.

use std::path::{Path, PathBuf};

/// Every error the host can report. `Input` errors are the user's to fix (a malformed
/// scene, an impossible option) and end the program with exit status 2.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad input: names the file, the place in it and what is wrong.
    #[error("{}: {place}: {what}", file.display())]
    Input {
        file: PathBuf,
        place: String,
        what: String,
    },
    /// A bad command-line value (not tied to a file).
    #[error("{0}")]
    Usage(String),
    /// A parameter out of range, not tied to a file: `key` is the library's name of it
    /// (`sections`, `shell_radius`), `what` starts with the value. The CLI names its flag
    /// instead (see `cli::args::name_flags`).
    #[error("{key} {what}")]
    Param { key: String, what: String },
    /// A self-check of a run found a disagreement (a model bug, not bad input).
    #[error("check failed: {0}")]
    Check(String),
    /// Reading or writing a file failed.
    #[error("{}: {source}", file.display())]
    Io {
        file: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

impl Error {
    /// Bad input in `file` at `place`.
    pub fn input(file: &Path, place: impl Into<String>, what: impl Into<String>) -> Self {
        Error::Input {
            file: file.to_path_buf(),
            place: place.into(),
            what: what.into(),
        }
    }

    /// A parameter `key` out of range; `what` starts with the value, e.g. `"0 is out of
    /// range (1..=1024)"`.
    pub fn param(key: impl Into<String>, what: impl Into<String>) -> Self {
        Error::Param {
            key: key.into(),
            what: what.into(),
        }
    }

    /// An I/O failure on `file`.
    pub fn io(file: &Path, source: std::io::Error) -> Self {
        Error::Io {
            file: file.to_path_buf(),
            source,
        }
    }

    /// An input file that cannot be read: bad input (exit status 2), like a malformed one.
    pub fn unreadable(file: &Path, source: std::io::Error) -> Self {
        Error::input(file, "file", format!("cannot read it: {source}"))
    }

    /// An error about a grid (file [`GRID`]) as one about the scene `file` it was built
    /// for; any other error unchanged.
    pub fn for_scene(self, file: &Path) -> Self {
        match self {
            Error::Input {
                file: f,
                place,
                what,
            } if f == Path::new(GRID) => Error::Input {
                file: file.to_path_buf(),
                place,
                what,
            },
            e => e,
        }
    }

    /// The process exit status for this error: 2 for bad input or usage, 1 otherwise.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Input { .. } | Error::Usage(_) | Error::Param { .. } => 2,
            Error::Io { .. } | Error::Check(_) => 1,
        }
    }
}

/// The file name of errors about a grid built without its scene's file name at hand
/// (renamed by [`Error::for_scene`]).
pub const GRID: &str = "<grid>";

pub type Result<T> = std::result::Result<T, Error>;

/// `text` with control characters escaped (`\u{1b}`, `\t`), so that a name from a file
/// cannot move the cursor or clear a terminal when printed; line breaks are kept only
/// when `keep_newlines`.
pub fn escape_controls(text: &str, keep_newlines: bool) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        if c.is_control() && !(keep_newlines && c == '\n') {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

/// A name from data as shown in a message: control characters escaped, line breaks too.
pub fn shown(name: &str) -> String {
    escape_controls(name, false)
}

/// A number as a message shows it: short (`1e300`, `-2.5e-12`, not 300 digits), exact
/// for ordinary values (`0.289`, `4.5`, `100000`).
pub fn short(v: f64) -> String {
    let a = v.abs();
    if v.is_finite() && a != 0.0 && !(1e-4..1e9).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}
