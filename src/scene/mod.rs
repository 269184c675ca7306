//! Scenes: the model ([`model`]: patches, scenes, JSON), the one polygon check
//! ([`polygon`]), Wavefront OBJ import ([`obj`]), the deterministic generators ([`gen`]),
//! and [`Scene::load`] / [`load_with`], which read a file by its extension; [`Edits`]
//! (`--emitter`, `--flip`) and [`PatchRef`] (`--source ID|NAME`) use the patches' names.
//!
//! **Invariant:** `model` and `obj` do not import each other; both depend on `polygon`
//! (and `obj` on `model`), and only `load` here knows both formats.

pub mod gen;
pub mod model;
pub mod obj;
pub mod polygon;

pub use model::{Aabb, Patch, Scene, Spectrum, MAX_PATCHES};

use crate::error::{shown, Error, Result};
use std::path::Path;

impl Scene {
    /// Reads a scene by its extension: `.json` (the schema in docs/manual/scenes.md) or `.obj`
    /// (Wavefront, see [`obj`]), and validates it.
    pub fn load(path: &Path) -> Result<Scene> {
        load_with(path, &Edits::default()).map(|l| l.scene)
    }

    /// The distinct names of the patches (group/object and material names), each with the
    /// ids of its patches, in order of first appearance.
    pub fn names(&self) -> Vec<(&str, Vec<u32>)> {
        let mut out: Vec<(&str, Vec<u32>)> = Vec::new();
        let mut index = std::collections::HashMap::new();
        for (id, p) in self.patches.iter().enumerate() {
            let material = p
                .material
                .as_deref()
                .filter(|m| p.name.as_deref() != Some(*m));
            for name in p.name.as_deref().into_iter().chain(material) {
                let k = *index.entry(name).or_insert_with(|| {
                    out.push((name, Vec::new()));
                    out.len() - 1
                });
                out[k].1.push(id as u32);
            }
        }
        out
    }

    /// The ids of the patches named `name` ([`Patch::is_named`]).
    pub fn named(&self, name: &str) -> Vec<u32> {
        (0..self.patches.len() as u32)
            .filter(|&id| self.patches[id as usize].is_named(name))
            .collect()
    }

    /// The error for a name that names no patch, at `place` of `file`, listing some names.
    fn no_such_name(&self, file: &Path, place: &str, name: &str) -> Error {
        let names = self.names();
        let known = if names.is_empty() {
            "the scene has no names (OBJ `g`, `o` or `usemtl`)".to_string()
        } else {
            let mut list: Vec<String> = names.iter().take(12).map(|(n, _)| shown(n)).collect();
            if names.len() > 12 {
                list.push(format!("and {} more", names.len() - 12));
            }
            format!("its names: {}", list.join(", "))
        };
        Error::input(
            file,
            place,
            format!(
                "no group, object or material is named {:?} ({known})",
                shown(name)
            ),
        )
    }
}

/// Emission given to the patches `--emitter` marks (grey; the scene's units of radiosity).
pub const EMITTER_EMISSION: f64 = 1.0;

/// Which faces [`Edits::flip`] turns over.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Flip {
    /// Every patch.
    All,
    /// The patches of one group, object or material name.
    Named(String),
}

/// Changes made to a scene as it is loaded, for files that lack what the model needs.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Edits {
    /// Make the patches of this group, object or material name emitters: emission
    /// [`EMITTER_EMISSION`] where they have none.
    pub emitter: Option<String>,
    /// Turn these faces over (reverse their vertex order).
    pub flip: Option<Flip>,
}

impl Edits {
    /// Applies the edits to `scene` (read from `file`); a name that names no patch is an
    /// error at place `emitter` or `flip`.
    pub fn apply(&self, scene: &mut Scene, file: &Path) -> Result<()> {
        if let Some(flip) = &self.flip {
            let ids: Vec<u32> = match flip {
                Flip::All => (0..scene.patches.len() as u32).collect(),
                Flip::Named(name) => scene.named(name),
            };
            if let (Flip::Named(name), true) = (flip, ids.is_empty()) {
                return Err(scene.no_such_name(file, "flip", name));
            }
            for id in ids {
                scene.patches[id as usize].flip();
            }
        }
        if let Some(name) = &self.emitter {
            let ids = scene.named(name);
            if ids.is_empty() {
                return Err(scene.no_such_name(file, "emitter", name));
            }
            for id in ids {
                let p = &mut scene.patches[id as usize];
                if !p.emission.is_nonzero() {
                    p.emission = Spectrum::Grey(EMITTER_EMISSION);
                }
            }
        }
        Ok(())
    }
}

/// A scene as loaded, with what the user should know that did not stop it.
#[derive(Clone, Debug)]
pub struct Loaded {
    pub scene: Scene,
    /// For an OBJ file: a missing material library, faces split because they were not
    /// planar and convex (one message each, with counts).
    pub warnings: Vec<String>,
}

/// Reads a scene by its extension (as [`Scene::load`]) and applies `edits`.
pub fn load_with(path: &Path, edits: &Edits) -> Result<Loaded> {
    let (mut scene, warnings) = if is_obj(path) {
        let (s, r) = obj::import(path, &obj::ImportOptions::default())?;
        (s, r.warnings)
    } else {
        (Scene::load_json(path)?, Vec::new())
    };
    edits.apply(&mut scene, path)?;
    let mut warnings = warnings;
    warnings.extend(scene.twins_warning());
    Ok(Loaded { scene, warnings })
}

/// True when `path` is read as Wavefront OBJ (extension `.obj`, any case); else JSON.
pub fn is_obj(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.to_string_lossy().eq_ignore_ascii_case("obj"))
}

/// A patch given by id or by name (`--source 3`, `--source light`): a number is an id, any
/// other text a group, object or material name that must name exactly one patch.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PatchRef {
    Id(u32),
    Name(String),
}

impl std::str::FromStr for PatchRef {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        if s.is_empty() {
            return Err("a patch id or a name, not an empty string".into());
        }
        Ok(match s.parse::<u32>() {
            Ok(id) => PatchRef::Id(id),
            Err(_) => PatchRef::Name(s.to_string()),
        })
    }
}

impl std::fmt::Display for PatchRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PatchRef::Id(id) => write!(f, "{id}"),
            PatchRef::Name(n) => f.write_str(n),
        }
    }
}

impl PatchRef {
    /// The patch id in `scene` (read from `file`). An id is returned as it is (its range is
    /// checked with the rays); a name that names no patch, or several, is an error at place
    /// `source`.
    pub fn resolve(&self, scene: &Scene, file: &Path) -> Result<u32> {
        let name = match self {
            PatchRef::Id(id) => return Ok(*id),
            PatchRef::Name(n) => n,
        };
        match scene.named(name)[..] {
            [id] => Ok(id),
            [] => Err(scene.no_such_name(file, "source", name)),
            ref ids => {
                let list: Vec<String> = ids.iter().take(8).map(u32::to_string).collect();
                Err(Error::input(
                    file,
                    "source",
                    format!(
                        "{:?} names {} patches ({}{}): give one by its id",
                        shown(name),
                        ids.len(),
                        list.join(", "),
                        if ids.len() > 8 { ", …" } else { "" }
                    ),
                ))
            }
        }
    }
}
