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

    /// The process exit status for this error: 2 for bad input or usage, 1 otherwise.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Input { .. } | Error::Usage(_) => 2,
            Error::Io { .. } | Error::Check(_) => 1,
        }
    }
}

pub type Result<T> = std::result::Result<T, Error>;

/// Writes `value` as pretty-printed JSON (ending in a newline) to `path`, atomically.
pub fn write_json(path: &Path, value: &impl serde::Serialize) -> Result<()> {
    let text = serde_json::to_string_pretty(value).expect("our reports serialize");
    write_atomic(path, (text + "\n").as_bytes())
}

/// Writes `bytes` to `path` atomically: a temporary file beside it is renamed into place,
/// so an interrupted or failed run never leaves a half-written file that looks complete.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    use std::io::Write;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::io(path, e));
    }
    Ok(())
}
