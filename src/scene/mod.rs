//! Scenes: the model ([`model`]: patches, scenes, JSON), the one polygon check
//! ([`polygon`]), Wavefront OBJ import ([`obj`]), the deterministic generators ([`gen`]),
//! and [`Scene::load`], which reads a file by its extension.
//!
//! **Invariant:** `model` and `obj` do not import each other; both depend on `polygon`
//! (and `obj` on `model`), and only `load` here knows both formats.

pub mod gen;
pub mod model;
pub mod obj;
pub mod polygon;

pub use model::{Aabb, Patch, Scene, Spectrum, MAX_PATCHES};

use crate::error::Result;
use std::path::Path;

impl Scene {
    /// Reads a scene by its extension: `.json` (the schema in README.md) or `.obj`
    /// (Wavefront, see [`obj`]), and validates it.
    pub fn load(path: &Path) -> Result<Scene> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("obj") => obj::import(path, &obj::ImportOptions::default()).map(|(s, _)| s),
            _ => Scene::load_json(path),
        }
    }
}
