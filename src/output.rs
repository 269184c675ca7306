//! Writing outputs: every file shellsim writes goes through a [`TempFile`] beside its
//! target that is renamed into place when complete, so an interrupted or failed run never
//! leaves a half-written file that looks complete. JSON reports are pretty-printed with a
//! final newline.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A temporary file beside its target (`.NAME.PID.tmp`, created with its directory).
/// [`TempFile::persist`] renames it into place; dropped without that, it is removed.
#[derive(Debug)]
pub struct TempFile {
    path: PathBuf,
    tmp: PathBuf,
    persisted: bool,
}

impl TempFile {
    /// Creates the temporary file for `path`; returns it and the open file to write.
    pub fn create(path: &Path) -> Result<(TempFile, File)> {
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
        let f = File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
        Ok((
            TempFile {
                path: path.to_path_buf(),
                tmp,
                persisted: false,
            },
            f,
        ))
    }

    /// The target path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The temporary file's path.
    pub fn tmp_path(&self) -> &Path {
        &self.tmp
    }

    /// Renames the temporary file into place (write and sync it first). On an error the
    /// temporary file is removed and nothing appears at the target path.
    pub fn persist(mut self) -> Result<()> {
        if let Err(e) = std::fs::rename(&self.tmp, &self.path) {
            return Err(Error::io(&self.path, e));
        }
        self.persisted = true;
        Ok(())
    }
}

impl Drop for TempFile {
    /// A temporary file never renamed into place is removed.
    fn drop(&mut self) {
        if !self.persisted {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Writes `bytes` to `path` atomically (a [`TempFile`] renamed into place).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let (tmp, mut f) = TempFile::create(path)?;
    f.write_all(bytes)
        .and_then(|()| f.sync_all())
        .map_err(|e| Error::io(path, e))?;
    drop(f);
    tmp.persist()
}

/// `value` as pretty-printed JSON ending in a newline.
pub fn json_string(value: &impl serde::Serialize) -> String {
    serde_json::to_string_pretty(value).expect("our reports serialize") + "\n"
}

/// Writes `value` as pretty-printed JSON (ending in a newline) to `path`, atomically.
pub fn write_json(path: &Path, value: &impl serde::Serialize) -> Result<()> {
    write_atomic(path, json_string(value).as_bytes())
}
