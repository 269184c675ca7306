//! Wavefront OBJ import (placeholder signature, replaced by the OBJ work).

use crate::error::{Error, Result};
use crate::scene::{Aabb, Scene};
use std::path::Path;

/// How an OBJ file becomes a scene.
#[derive(Clone, Debug, Default)]
pub struct ImportOptions {
    /// The scene bounds; `None`: the vertices' bounding box (a flat axis padded).
    pub bounds: Option<Aabb>,
}

/// What the import did.
#[derive(Clone, Debug, Default)]
pub struct ImportReport {
    /// Faces read from the file.
    pub faces: usize,
    /// Faces of more than 4 vertices that were split into triangles.
    pub split_faces: usize,
    /// Patches in the scene.
    pub patches: usize,
}

/// Reads an OBJ file into a validated scene.
pub fn import(path: &Path, _opts: &ImportOptions) -> Result<(Scene, ImportReport)> {
    Err(Error::input(path, "file", "OBJ import is not built yet"))
}
