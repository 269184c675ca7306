//! Wavefront OBJ import through `tobj`: every face becomes a patch, in file order; faces of
//! more than 4 vertices are split into triangle fans, and a face that is not planar and
//! convex (a non-planar quad, a concave face) into the fan closest to planar
//! ([`polygon::split`]), said once per file with a count; `.mtl` colours become reflectance
//! (`Kd`) and emission (`Ke`); the `g`/`o` and `usemtl` names are kept per patch.
//!
//! Errors name the file and the face: faces are numbered from 1 in file order (as OBJ
//! numbers its vertices), with the line the face is on and the patch id it became, e.g.
//! `scene.obj: face 7 (line 23, patch 9): is not planar: ...`.
//!
//! `tobj` does the parsing. Around it this module does only three small things to the text:
//! it blanks `vt`/`vn` lines (texture coordinates and normals are not used, and dropping
//! them avoids index arithmetic in `tobj` that overflows on bad `vt`/`vn` indices), it
//! notes which `f`/`l` statement is on which line (`tobj` reads both as faces: `l` line
//! elements are skipped, `f` faces of fewer than 3 vertices are errors), and it expands
//! the one-number form `Kd r` of `.mtl` colours to `Kd r r r` (the MTL spec's meaning),
//! which `tobj` would otherwise panic on.

use super::model::{Aabb, Patch, Scene, Spectrum};
use super::polygon;
use crate::error::{shown, Error, Result};
use glam::DVec3;
use std::cell::RefCell;
use std::path::Path;

/// How an OBJ file becomes a scene.
#[derive(Clone, Debug)]
pub struct ImportOptions {
    /// The scene bounds; `None`: the vertices' bounding box (a flat axis padded).
    pub bounds: Option<Aabb>,
    /// Reflectance of faces without a material `Kd` (default 0.5).
    pub reflectance: f64,
    /// Emission of faces without a material `Ke` (default 0).
    pub emission: f64,
}

impl Default for ImportOptions {
    fn default() -> Self {
        ImportOptions {
            bounds: None,
            reflectance: 0.5,
            emission: 0.0,
        }
    }
}

/// What the import did.
#[derive(Clone, Debug, Default)]
pub struct ImportReport {
    /// Faces (`f` statements) read from the file.
    pub faces: usize,
    /// Planar convex faces of more than 4 vertices that were split into triangle fans.
    pub split_faces: usize,
    /// Triangles the split faces became.
    pub split_triangles: usize,
    /// Faces that are not planar and convex, split into the fan closest to planar.
    pub mended_faces: usize,
    /// Of those, quads (split along one diagonal).
    pub mended_quads: usize,
    /// Triangles the mended faces became.
    pub mended_triangles: usize,
    /// The largest fold between neighbouring triangles of a mended face, in degrees.
    pub max_fold_deg: f64,
    /// Patches in the scene.
    pub patches: usize,
    /// Line elements (`l` statements) skipped: they have no area.
    pub skipped_lines: usize,
    /// Things the user should know that did not stop the import (a missing `.mtl`).
    pub warnings: Vec<String>,
}

impl ImportReport {
    /// One line for the user, e.g. "12 faces, 20 patches; 3 faces with more than 4
    /// vertices were split into 11 triangles".
    pub fn summary(&self) -> String {
        let mut s = format!(
            "{} {}, {} {}",
            self.faces,
            plural(self.faces, "face", "faces"),
            self.patches,
            plural(self.patches, "patch", "patches")
        );
        if self.split_faces > 0 {
            s.push_str(&format!(
                "; {} {} with more than 4 vertices {} split into {} triangles",
                self.split_faces,
                plural(self.split_faces, "face", "faces"),
                plural(self.split_faces, "was", "were"),
                self.split_triangles
            ));
        }
        if self.mended_faces > 0 {
            s.push_str(&format!(
                "; {} not planar and convex {} split into {} triangles",
                self.mended_faces,
                plural(self.mended_faces, "face was", "faces were"),
                self.mended_triangles
            ));
        }
        if self.skipped_lines > 0 {
            s.push_str(&format!(
                "; {} line {} (`l`) skipped",
                self.skipped_lines,
                plural(self.skipped_lines, "element", "elements")
            ));
        }
        s
    }
}

fn plural<'a>(n: usize, one: &'a str, many: &'a str) -> &'a str {
    if n == 1 {
        one
    } else {
        many
    }
}

/// Where a patch came from, for error messages.
#[derive(Clone, Copy, Debug)]
struct Origin {
    /// The face, numbered from 1 in file order.
    face: usize,
    /// The line of the `f` statement (1-based), when known.
    line: Option<usize>,
    /// For a split face: this triangle (from 1) and how many the face became.
    fan: Option<(usize, usize)>,
}

impl Origin {
    /// "face 7 (line 23, patch 9)" and the like.
    fn place(&self, patches: &str) -> String {
        let mut s = format!("face {} (", self.face);
        if let Some(line) = self.line {
            s.push_str(&format!("line {line}, "));
        }
        s.push_str(patches);
        if let Some((k, n)) = self.fan {
            s.push_str(&format!(
                ", triangle {k} of the {n} the face was split into"
            ));
        }
        s.push(')');
        s
    }

    fn place_of_patch(&self, id: usize) -> String {
        self.place(&format!("patch {id}"))
    }
}

/// An `f` or `l` statement of the file: tobj reads both as faces, in file order.
#[derive(Clone, Copy, Debug)]
struct Element {
    line: usize,
    is_face: bool,
    /// The group or object name in force (the last `g` or `o`), an index into
    /// [`Prepared::names`].
    group: Option<usize>,
    /// The material in force (the last `usemtl`), an index into [`Prepared::names`].
    material: Option<usize>,
}

/// What [`prepare`] found.
struct Prepared {
    elements: Vec<Element>,
    /// Every distinct name of a `g`, `o` or `usemtl` statement.
    names: Vec<String>,
    /// The text handed to tobj.
    text: String,
    /// Warnings about names: a `g`/`o` with no face after it (an exporter that writes the
    /// group after its faces), a group whose faces use several materials.
    name_warnings: Vec<String>,
}

/// The `f`/`l` statements of `text` with their lines and names, and the text handed to
/// tobj: the same lines with `vt`/`vn` statements blanked. The names are read here rather
/// than from tobj, which loses a `usemtl` name when its library is missing. A name is the
/// rest of its line, trimmed (as tobj reads it); an empty `g`/`o` is no name.
fn prepare(text: &str) -> Prepared {
    let mut elements = Vec::new();
    let mut names: Vec<String> = Vec::new();
    let mut index = std::collections::HashMap::<String, usize>::new();
    let mut intern = |name: &str| -> Option<usize> {
        if name.is_empty() {
            return None;
        }
        Some(*index.entry(name.to_string()).or_insert_with(|| {
            names.push(name.to_string());
            names.len() - 1
        }))
    };
    let (mut group, mut material) = (None, None);
    // The open `g`/`o` statement (its line and name) while no face has followed it yet.
    let mut pending: Option<(usize, String)> = None;
    let mut faceless: Vec<(usize, String)> = Vec::new();
    let mut out = String::with_capacity(text.len());
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let first = words.next();
        let rest = || {
            line.trim_start()
                .get(first.map_or(0, str::len)..)
                .unwrap_or("")
                .trim()
        };
        match first {
            Some("vt") | Some("vn") => {}
            first => {
                match first {
                    Some(kw @ ("f" | "l")) => {
                        pending = None;
                        elements.push(Element {
                            line: i + 1,
                            is_face: kw == "f",
                            group,
                            material,
                        })
                    }
                    Some("g" | "o") => {
                        faceless.extend(pending.take());
                        group = intern(rest());
                        if group.is_some() {
                            pending = Some((i + 1, rest().to_string()));
                        }
                    }
                    Some("usemtl") => material = intern(rest()),
                    _ => {}
                }
                out.push_str(line);
            }
        }
        out.push('\n');
    }
    faceless.extend(pending);
    let mut name_warnings = Vec::new();
    if !faceless.is_empty() {
        let shown: Vec<String> = faceless
            .iter()
            .take(4)
            .map(|(l, n)| format!("line {l} `{}`", crate::error::shown(n)))
            .collect();
        name_warnings.push(format!(
            "{} group or object statement{} with no face after {} ({}{}): a face takes the name of the last `g`/`o` before it, so if the file names its faces after them, every name is off by one",
            faceless.len(),
            if faceless.len() == 1 { "" } else { "s" },
            if faceless.len() == 1 { "it" } else { "them" },
            shown.join(", "),
            if faceless.len() > 4 { ", …" } else { "" }
        ));
    }
    // Groups whose faces use several materials, with the lines where the material changes.
    let mut spans: Vec<(usize, Vec<usize>, Vec<usize>)> = Vec::new(); // group, materials, lines
    for e in elements.iter().filter(|e| e.is_face) {
        let (Some(g), Some(m)) = (e.group, e.material) else {
            continue;
        };
        match spans.iter_mut().find(|s| s.0 == g) {
            Some(s) if !s.1.contains(&m) => {
                s.1.push(m);
                s.2.push(e.line);
            }
            Some(_) => {}
            None => spans.push((g, vec![m], vec![e.line])),
        }
    }
    for (g, ms, lines) in spans.iter().filter(|s| s.1.len() > 1).take(4) {
        let ms: Vec<&str> = ms.iter().map(|&m| names[m].as_str()).collect();
        let lines: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
        name_warnings.push(format!(
            "group `{}` spans {} materials ({}, from lines {}): `--emitter` and `--source` by the group name take all of them",
            crate::error::shown(&names[*g]),
            ms.len(),
            ms.join(", "),
            lines.join(", ")
        ));
    }
    Prepared {
        elements,
        names,
        text: out,
        name_warnings,
    }
}

/// The first statement tobj cannot read, found again with its line (tobj's errors have
/// none): a vertex with a coordinate that is not a number, or a face whose vertex index is
/// not a number, zero, or beyond the vertices. `None` when the scan finds nothing.
fn locate(text: &str) -> Option<(String, String)> {
    let positions = text
        .lines()
        .filter(|l| l.split_whitespace().next() == Some("v"))
        .count() as i64;
    let (mut seen, mut face) = (0i64, 0usize);
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                seen += 1;
                let coords: Vec<&str> = words.collect();
                if coords.len() < 3 {
                    return Some((
                        format!("line {}", i + 1),
                        format!("vertex {} has {} coordinates, not 3", seen, coords.len()),
                    ));
                }
                if let Some(w) = coords.iter().find(|w| w.parse::<f64>().is_err()) {
                    return Some((
                        format!("line {}", i + 1),
                        format!("vertex {seen}: {:?} is not a number", shown(w)),
                    ));
                }
            }
            Some(kw @ ("f" | "l")) => {
                face += 1;
                for w in words {
                    let idx = w.split('/').next().unwrap_or("");
                    let bad = match idx.parse::<i64>() {
                        Err(_) => Some(format!("{:?} is not a vertex index", shown(w))),
                        Ok(0) => Some("vertex index 0 (OBJ counts from 1)".into()),
                        Ok(k) if k > positions || -k > seen => Some(format!(
                            "vertex index {k} is beyond the {} vertices",
                            if k > 0 { positions } else { seen }
                        )),
                        Ok(_) => None,
                    };
                    if let Some(what) = bad {
                        let element = if kw == "f" { "face" } else { "line element" };
                        return Some((format!("line {}, {element} {face}", i + 1), what));
                    }
                }
            }
            _ => {}
        }
    }
    None
}

/// `.mtl` text with `Ka`/`Kd`/`Ks`/`Ke r` expanded to `... r r r`; `Err` names a colour
/// statement of 0 or 2 numbers (on which tobj would panic).
fn prepare_mtl(text: &str) -> std::result::Result<String, String> {
    let mut out = String::with_capacity(text.len());
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some(kw @ ("Ka" | "Kd" | "Ks" | "Ke")) => {
                let rest: Vec<&str> = words.collect();
                let numeric = rest.iter().all(|w| w.parse::<f64>().is_ok());
                if rest.len() == 1 && numeric {
                    out.push_str(&format!("{kw} {0} {0} {0}", rest[0]));
                } else if rest.len() < 3 && numeric {
                    return Err(format!(
                        "line {}: `{kw}` has {} numbers; a colour is 1 (grey) or 3 (r g b)",
                        i + 1,
                        rest.len()
                    ));
                } else {
                    out.push_str(line);
                }
            }
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    Ok(out)
}

/// Reads an OBJ file into a validated scene.
pub fn import(path: &Path, opts: &ImportOptions) -> Result<(Scene, ImportReport)> {
    import_bytes(crate::limits::read_input(path)?, path, opts)
}

/// [`import`] of OBJ text already read from `path` (which names the file in errors and
/// whose directory holds its material libraries).
pub fn import_bytes(
    bytes: Vec<u8>,
    path: &Path,
    opts: &ImportOptions,
) -> Result<(Scene, ImportReport)> {
    let text = String::from_utf8(bytes).map_err(|e| {
        Error::input(
            path,
            "file",
            format!(
                "not an OBJ file: not UTF-8 text (bad byte at offset {})",
                e.utf8_error().valid_up_to()
            ),
        )
    })?;
    let Prepared {
        elements,
        names,
        text,
        name_warnings,
    } = prepare(&text);

    let dir = path.parent().unwrap_or(Path::new(""));
    let mut report = ImportReport::default();
    let warnings = RefCell::new(Vec::new());
    let mtl_error: RefCell<Option<Error>> = RefCell::new(None);
    let load = tobj::LoadOptions {
        triangulate: false,
        single_index: false,
        // Points and lines are kept so that `f` statements of 1 or 2 vertices are reported
        // (tobj reads `f` and `l` alike); `l` elements are then skipped below.
        ignore_points: false,
        ignore_lines: false,
    };
    let loaded = tobj::load_obj_buf(&mut text.as_bytes(), &load, |mtl: &Path| {
        let full = dir.join(mtl);
        let fail = |e: Error| {
            mtl_error.borrow_mut().get_or_insert(e);
            Err(tobj::LoadError::MaterialParseError)
        };
        let text = match std::fs::metadata(&full) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                warnings.borrow_mut().push(format!(
                    "material library {} not found: every face gets the default material (reflectance {}, emission {})",
                    full.display(),
                    opts.reflectance,
                    opts.emission
                ));
                return Err(tobj::LoadError::OpenFileFailed);
            }
            Ok(m) if m.is_dir() => {
                return fail(Error::input(
                    &full,
                    "material library",
                    "is a directory, not a material library (.mtl file)",
                ))
            }
            // Capped, refused when it is a FIFO or device, or one of the outputs.
            _ => crate::limits::read_regular(&full).and_then(|b| {
                String::from_utf8(b).map_err(|_| {
                    Error::input(&full, "file", "not a material library: not UTF-8 text")
                })
            }),
        };
        match text {
            Err(e) => fail(e),
            Ok(t) => match prepare_mtl(&t) {
                Err(what) => fail(Error::input(&full, "material library", what)),
                Ok(t) => match tobj::load_mtl_buf(&mut t.as_bytes()) {
                    Ok(r) => Ok(r),
                    Err(e) => fail(Error::input(
                        &full,
                        "material library",
                        format!("not a readable material library: {e}"),
                    )),
                },
            },
        }
    });
    if let Some(e) = mtl_error.into_inner() {
        return Err(e);
    }
    report.warnings = warnings.into_inner();
    let (models, materials) = loaded.map_err(|e| match locate(&text) {
        Some((place, what)) => Error::input(
            path,
            place,
            format!("not a readable OBJ file: {what} ({e})"),
        ),
        None => Error::input(path, "file", format!("not a readable OBJ file: {e}")),
    })?;
    // Only a missing library can have failed here; its warning is already in the report.
    let materials = materials.unwrap_or_default();

    // tobj yields one face per `f`/`l` statement, in file order; if the count does not
    // match the scan (it always should), faces are numbered without lines.
    let arities = |m: &tobj::Mesh| -> Vec<usize> {
        if m.face_arities.is_empty() {
            vec![3; m.indices.len() / 3]
        } else {
            m.face_arities.iter().map(|&a| a as usize).collect()
        }
    };
    let total: usize = models.iter().map(|m| arities(&m.mesh).len()).sum();
    let elements = (total == elements.len()).then_some(elements);

    let mut patches: Vec<Patch> = Vec::new();
    let mut origins: Vec<Origin> = Vec::new();
    let mut k = 0; // index among tobj's faces
    for model in &models {
        let mesh = &model.mesh;
        let material = mesh.material_id.and_then(|id| materials.get(id));
        let reflectance = material
            .and_then(|m| m.diffuse)
            .map_or(Spectrum::Grey(opts.reflectance), Spectrum::Rgb);
        let emission = material
            .and_then(|m| m.emissive)
            .map_or(Spectrum::Grey(opts.emission), Spectrum::Rgb);
        let mut start = 0;
        for arity in arities(mesh) {
            let element = elements.as_ref().map(|e| e[k]);
            k += 1;
            let idx = mesh.indices.get(start..start + arity);
            start += arity;
            if element.is_some_and(|e| !e.is_face) {
                report.skipped_lines += 1;
                continue;
            }
            report.faces += 1;
            let origin = Origin {
                face: report.faces,
                line: element.map(|e| e.line),
                fan: None,
            };
            let vertices: Option<Vec<DVec3>> = idx.and_then(|idx| {
                idx.iter()
                    .map(|&i| {
                        let i = i as usize * 3;
                        mesh.positions
                            .get(i..i + 3)
                            .map(|p| DVec3::new(p[0], p[1], p[2]))
                    })
                    .collect()
            });
            let Some(vertices) = vertices else {
                return Err(Error::input(
                    path,
                    origin.place_of_patch(patches.len()),
                    "tobj returned a face whose vertices are missing",
                ));
            };
            if arity < 3 {
                return Err(Error::input(
                    path,
                    origin.place_of_patch(patches.len()),
                    format!(
                        "has {arity} {}; a face needs at least 3",
                        plural(arity, "vertex", "vertices")
                    ),
                ));
            }
            let name = |k: Option<usize>| k.map(|k| names[k].clone());
            let patch = |vertices: Vec<DVec3>| Patch {
                vertices,
                emission,
                reflectance,
                name: name(element.and_then(|e| e.group)),
                material: name(element.and_then(|e| e.material)),
            };
            // Every face passes the one polygon check, or is split into the fan that mends
            // it: the fan of a face that is neither planar nor convex has triangles that
            // overlap or face the wrong way, each of them valid alone.
            let fan = polygon::split(&vertices).map_err(|what| {
                let first = patches.len();
                let place = if arity <= 4 {
                    format!("patch {first}")
                } else {
                    format!("patches {first} to {}", first + arity - 3)
                };
                Error::input(path, origin.place(&place), what)
            })?;
            let fan = match fan {
                None if arity <= 4 => {
                    origins.push(origin);
                    patches.push(patch(vertices));
                    continue;
                }
                None if arity > polygon::BALANCED_FROM => {
                    report.split_faces += 1;
                    report.split_triangles += arity - 2;
                    let tris = polygon::balanced(arity);
                    let n = tris.len();
                    for (j, [a, b, c]) in tris.into_iter().enumerate() {
                        origins.push(Origin {
                            fan: Some((j + 1, n)),
                            ..origin
                        });
                        patches.push(patch(vec![vertices[a], vertices[b], vertices[c]]));
                    }
                    continue;
                }
                None => {
                    report.split_faces += 1;
                    report.split_triangles += arity - 2;
                    polygon::Fan { apex: 0, fold: 0.0 }
                }
                Some(fan) => {
                    report.mended_faces += 1;
                    report.mended_quads += usize::from(arity == 4);
                    report.mended_triangles += arity - 2;
                    report.max_fold_deg = report.max_fold_deg.max(fan.fold.to_degrees());
                    fan
                }
            };
            let n = arity - 2;
            for (j, [a, b, c]) in fan.triangles(arity).enumerate() {
                origins.push(Origin {
                    fan: Some((j + 1, n)),
                    ..origin
                });
                patches.push(patch(vec![vertices[a], vertices[b], vertices[c]]));
            }
        }
    }
    if report.mended_faces > 0 {
        report.warnings.push(mended_warning(&report));
    }
    report.warnings.extend(name_warnings);
    report.patches = patches.len();
    if patches.is_empty() {
        let what = if report.skipped_lines > 0 {
            "has no faces (`f` statements), only line elements (`l`)"
        } else {
            "has no faces (`f` statements): not an OBJ scene"
        };
        return Err(Error::input(path, "file", what));
    }
    // Each patch's own geometry and materials first, so that a bad vertex is reported at
    // its face rather than as bad bounds.
    for (id, (p, o)) in patches.iter().zip(&origins).enumerate() {
        p.check()
            .map_err(|what| Error::input(path, o.place_of_patch(id), what))?;
    }
    let bounds = opts.bounds.unwrap_or_else(|| bounding_box(&patches));
    let name = path
        .file_stem()
        .map_or_else(|| "obj".to_string(), |s| s.to_string_lossy().into_owned());
    let scene = Scene {
        name,
        bounds,
        patches,
    };
    scene.validate(path).map_err(|e| name_face(e, &origins))?;
    Ok((scene, report))
}

/// The one message about the faces that were not planar and convex.
fn mended_warning(r: &ImportReport) -> String {
    let others = r.mended_faces - r.mended_quads;
    let mut what = Vec::new();
    if r.mended_quads > 0 {
        what.push(format!(
            "{} {} along the diagonal of smaller fold",
            r.mended_quads,
            plural(r.mended_quads, "quad", "quads")
        ));
    }
    if others > 0 {
        what.push(format!(
            "{others} {} into the fan of smallest fold",
            plural(others, "face of more vertices", "faces of more vertices")
        ));
    }
    format!(
        "{} {} not planar and convex: split into {} triangles ({}); largest fold {:.3}°",
        r.mended_faces,
        plural(r.mended_faces, "face is", "faces are"),
        r.mended_triangles,
        what.join(", "),
        r.max_fold_deg
    )
}

/// The patches' bounding box, an axis of zero extent padded by 1% of the largest extent on
/// each side.
fn bounding_box(patches: &[Patch]) -> Aabb {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for v in patches.iter().flat_map(|p| &p.vertices) {
        lo = lo.min(*v);
        hi = hi.max(*v);
    }
    let ext = hi - lo;
    let pad = 0.01 * ext.max_element();
    for a in 0..3 {
        if ext[a] == 0.0 {
            lo[a] -= pad;
            hi[a] += pad;
        }
    }
    Aabb { lo, hi }
}

/// Rewrites a "patch M" place of `scene.validate` to name the face as well.
fn name_face(e: Error, origins: &[Origin]) -> Error {
    match e {
        Error::Input { file, place, what } => {
            let place = place
                .strip_prefix("patch ")
                .and_then(|id| id.parse::<usize>().ok())
                .and_then(|id| origins.get(id).map(|o| o.place_of_patch(id)))
                .unwrap_or(place);
            Error::Input { file, place, what }
        }
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    /// Writes `files` (name, text) into a fresh directory; returns it and the first path.
    fn write(files: &[(&str, &str)]) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        for (name, text) in files {
            std::fs::write(dir.path().join(name), text).unwrap();
        }
        let first = dir.path().join(files[0].0);
        (dir, first)
    }

    fn import_str(text: &str) -> Result<(Scene, ImportReport)> {
        let (_dir, path) = write(&[("t.obj", text)]);
        import(&path, &ImportOptions::default())
    }

    fn err_str(text: &str) -> String {
        import_str(text).unwrap_err().to_string()
    }

    fn v(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    const SQUARE: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

    #[test]
    fn quad_is_one_patch_in_order() {
        let (s, r) = import_str(&format!("{SQUARE}f 1 2 3 4\n")).unwrap();
        assert_eq!(s.name, "t");
        assert_eq!(s.patches.len(), 1);
        assert_eq!(
            s.patches[0].vertices,
            vec![v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)]
        );
        assert_eq!(s.patches[0].reflectance, Spectrum::Grey(0.5));
        assert_eq!(s.patches[0].emission, Spectrum::Grey(0.0));
        assert_eq!((r.faces, r.split_faces, r.patches), (1, 0, 1));
        // Rotated vertex order is kept as written (negative indices too).
        let (s, _) = import_str(&format!("{SQUARE}f -2 -1 -4 -3\n")).unwrap();
        assert_eq!(
            s.patches[0].vertices,
            vec![v(1., 1., 0.), v(0., 1., 0.), v(0., 0., 0.), v(1., 0., 0.)]
        );
    }

    #[test]
    fn pentagon_is_split_into_a_fan() {
        let text = "v 0 0 0\nv 2 0 0\nv 3 1 0\nv 1 2 0\nv -1 1 0\nf 1 2 3 4 5\n";
        let (s, r) = import_str(text).unwrap();
        assert_eq!(
            (r.faces, r.split_faces, r.split_triangles, r.patches),
            (1, 1, 3, 3)
        );
        let p: Vec<_> = s.patches.iter().map(|p| p.vertices.clone()).collect();
        let (a, b, c, d, e) = (
            v(0., 0., 0.),
            v(2., 0., 0.),
            v(3., 1., 0.),
            v(1., 2., 0.),
            v(-1., 1., 0.),
        );
        assert_eq!(p, vec![vec![a, b, c], vec![a, c, d], vec![a, d, e]]);
        assert_eq!(
            r.summary(),
            "1 face, 3 patches; 1 face with more than 4 vertices was split into 3 triangles"
        );
    }

    #[test]
    fn non_planar_and_concave_faces_are_split_and_said_once() {
        // Three non-planar quads (vertex 3 lifted by 0.1, 0.2, 0.3), a concave quad (a
        // dart) and a non-planar hexagon: split, with one warning for the file.
        let mut t = String::new();
        for (k, h) in [0.1, 0.2, 0.3].iter().enumerate() {
            let z = 2.0 * k as f64;
            t += &format!(
                "v 0 0 {z}\nv 1 0 {z}\nv 1 1 {}\nv 0 1 {z}\nf -4 -3 -2 -1\n",
                z + h
            );
        }
        t += "v 0 0 9\nv 1 0 9\nv 0.3 0.3 9\nv 0 1 9\nf -4 -3 -2 -1\n";
        t += "v 0 0 12\nv 2 0 12\nv 3 1 12.5\nv 2 2 12\nv 0 2 12\nv -1 1 12\nf -6 -5 -4 -3 -2 -1\n";
        let (s, r) = import_str(&t).unwrap();
        assert_eq!(
            (r.faces, r.mended_faces, r.mended_quads, r.mended_triangles),
            (5, 5, 4, 12)
        );
        assert_eq!(s.patches.len(), 12);
        assert_eq!(r.warnings.len(), 1, "{:?}", r.warnings);
        let w = &r.warnings[0];
        assert!(w.starts_with("5 faces are not planar and convex: split into 12 triangles (4 quads along the diagonal of smaller fold, 1 face of more vertices into the fan of smallest fold)"), "{w}");
        // The lifted quads are creased through the two vertices that stayed (the diagonal
        // 1-3: the fan from vertex 1), the dart through its reflex vertex.
        let (a, b, c, d) = (v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.1), v(0., 1., 0.));
        assert_eq!(s.patches[0].vertices, vec![b, c, d]);
        assert_eq!(s.patches[1].vertices, vec![b, d, a]);
        assert_eq!(
            s.patches[6].vertices,
            vec![v(0., 0., 9.), v(1., 0., 9.), v(0.3, 0.3, 9.)]
        );
        assert!(s.patches.iter().all(|p| p.vertices.len() == 3));
        // The largest fold is the quad lifted most: cos = 1 / √(1 + 2h²).
        let want = (1.0 / (1.0f64 + 2.0 * 0.09).sqrt()).acos().to_degrees();
        assert!(r.max_fold_deg >= want - 1e-9, "{} {want}", r.max_fold_deg);
        // The area is kept: the split triangles cover the dart exactly.
        let dart: f64 = s.patches[6..8].iter().map(|p| p.area()).sum();
        assert!((dart - 0.3).abs() < 1e-12, "{dart}");
    }

    #[test]
    fn negative_indices_count_back_from_the_vertices_read_so_far() {
        // `-1` is the last vertex defined *before the face*, not the file's last vertex.
        let t = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 0 0 5\nv 1 0 5\nv 0 1 5\nf -3 -2 -1\nf -6 -5 -4\nf 4 5 -1\n";
        let (s, _) = import_str(t).unwrap();
        let z: Vec<Vec<f64>> = s
            .patches
            .iter()
            .map(|p| p.vertices.iter().map(|v| v.z).collect())
            .collect();
        assert_eq!(z, vec![vec![0.; 3], vec![5.; 3], vec![0.; 3], vec![5.; 3]]);
        // Beyond the vertices read so far is an error naming the line.
        let e = err_str("v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n");
        assert!(e.contains("line 3, face 1") && e.contains("beyond"), "{e}");
    }

    #[test]
    fn group_object_and_material_names_are_kept_per_patch() {
        // No material library: the `usemtl` names are kept all the same.
        let mut t = format!("{SQUARE}f 1 2 3 4\ng floor\nusemtl white\nf 1 2 3 4\n");
        t += "o lamp\nf 1 2 3 4\nusemtl  hot lamp \nf 1 2 3\ng\nf 1 3 4\n";
        let (s, _) = import_str(&t).unwrap();
        let names: Vec<(Option<&str>, Option<&str>)> = s
            .patches
            .iter()
            .map(|p| (p.name.as_deref(), p.material.as_deref()))
            .collect();
        assert_eq!(
            names,
            vec![
                (None, None),
                (Some("floor"), Some("white")),
                (Some("lamp"), Some("white")),
                (Some("lamp"), Some("hot lamp")),
                (None, Some("hot lamp")),
            ]
        );
        assert_eq!(
            s.names(),
            vec![
                ("floor", vec![1]),
                ("white", vec![1, 2]),
                ("lamp", vec![2, 3]),
                ("hot lamp", vec![3, 4]),
            ]
        );
        // Names survive the JSON form; a scene without names writes none.
        let back = Scene::from_json_str(&s.to_json_string(), Path::new("t.json")).unwrap();
        assert_eq!(back, s);
        let (plain, _) = import_str(&format!("{SQUARE}f 1 2 3 4\n")).unwrap();
        assert!(
            !plain.to_json_string().contains("name\": \"")
                || !plain.to_json_string().contains("\"material\"")
        );
        assert!(!plain.to_json_string().contains("material"));
    }

    #[test]
    fn file_order_is_kept_across_models() {
        // Four unit squares at z = 0..3, spread over objects, groups and materials; the
        // patch ids must follow the file, and the hexagon's fan takes consecutive ids.
        let mut t = String::from("mtllib m.mtl\n");
        for z in 0..4 {
            t += &format!("v 0 0 {z}\nv 1 0 {z}\nv 1 1 {z}\nv 0 1 {z}\n");
        }
        t += "v 0 0 9\nv 2 0 9\nv 3 1 9\nv 2 2 9\nv 0 2 9\nv -1 1 9\n";
        t += "o a\nusemtl red\nf 1 2 3 4\ng b\nusemtl grey\nf 5 6 7 8\n";
        t += "usemtl red\nf 17 18 19 20 21 22\nl 1 2\no c\nf 9 10 11 12\nf 13 14 15 16\n";
        let mtl = "newmtl red\nKd 0.8 0.1 0.1\nnewmtl grey\nKd 0.3\n";
        let (_d, path) = write(&[("t.obj", &t), ("m.mtl", mtl)]);
        let (s, r) = import(&path, &ImportOptions::default()).unwrap();
        let z: Vec<f64> = s.patches.iter().map(|p| p.vertices[0].z).collect();
        assert_eq!(z, vec![0., 1., 9., 9., 9., 9., 2., 3.]);
        assert_eq!(
            (r.faces, r.split_faces, r.patches, r.skipped_lines),
            (5, 1, 8, 1)
        );
        assert_eq!(s.patches[1].reflectance, Spectrum::Rgb([0.3; 3]));
        assert_eq!(s.patches[4].reflectance, Spectrum::Rgb([0.8, 0.1, 0.1]));
        // `usemtl` holds across objects, as in OBJ.
        assert_eq!(s.patches[6].reflectance, Spectrum::Rgb([0.8, 0.1, 0.1]));
    }

    #[test]
    fn default_bounds_pad_a_flat_axis() {
        let text = "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\nf 1 2 3 4\n";
        let (s, _) = import_str(text).unwrap();
        assert_eq!(s.bounds.lo, v(0., 0., -0.02));
        assert_eq!(s.bounds.hi, v(2., 1., 0.02));
    }

    #[test]
    fn given_bounds_are_used_and_checked() {
        let (_d, path) = write(&[("t.obj", &format!("{SQUARE}f 1 2 3 4\nf 1 2 3\n"))]);
        let b = Aabb {
            lo: DVec3::splat(-1.0),
            hi: DVec3::splat(2.0),
        };
        let opts = ImportOptions {
            bounds: Some(b),
            ..Default::default()
        };
        assert_eq!(import(&path, &opts).unwrap().0.bounds, b);
        let opts = ImportOptions {
            bounds: Some(Aabb {
                lo: DVec3::splat(-1.0),
                hi: v(2.0, 0.5, 2.0),
            }),
            ..Default::default()
        };
        let e = import(&path, &opts).unwrap_err().to_string();
        assert!(
            e.contains("face 1 (line 5, patch 0)") && e.contains("outside the bounds"),
            "{e}"
        );
    }

    #[test]
    fn materials_give_reflectance_and_emission() {
        let t = format!("mtllib m.mtl\n{SQUARE}usemtl lamp\nf 1 2 3 4\n");
        let mtl = "newmtl lamp\nKd 0.25 0.5 0.75\nKe 10 9 8\n";
        let (_d, path) = write(&[("t.obj", &t), ("m.mtl", mtl)]);
        let (s, r) = import(&path, &ImportOptions::default()).unwrap();
        assert_eq!(s.patches[0].reflectance, Spectrum::Rgb([0.25, 0.5, 0.75]));
        assert_eq!(s.patches[0].emission, Spectrum::Rgb([10., 9., 8.]));
        assert!(r.warnings.is_empty());
    }

    #[test]
    fn a_missing_mtl_gives_defaults_and_a_warning() {
        let t = format!("mtllib gone.mtl\n{SQUARE}usemtl lamp\nf 1 2 3 4\n");
        let (_d, path) = write(&[("t.obj", &t)]);
        let opts = ImportOptions {
            reflectance: 0.7,
            emission: 2.0,
            ..Default::default()
        };
        let (s, r) = import(&path, &opts).unwrap();
        assert_eq!(s.patches[0].reflectance, Spectrum::Grey(0.7));
        assert_eq!(s.patches[0].emission, Spectrum::Grey(2.0));
        assert!(r.warnings[0].contains("gone.mtl"), "{:?}", r.warnings);
    }

    #[test]
    fn a_broken_mtl_is_an_error_not_a_panic() {
        for mtl in [
            "newmtl a\nKd 0.5 0.5\n",
            "newmtl a\nKd\n",
            "newmtl a\nKd x y z\n",
        ] {
            let t = format!("mtllib m.mtl\n{SQUARE}usemtl a\nf 1 2 3 4\n");
            let (_d, path) = write(&[("t.obj", &t), ("m.mtl", mtl)]);
            let e = import(&path, &ImportOptions::default())
                .unwrap_err()
                .to_string();
            assert!(e.contains("m.mtl"), "{e}");
        }
        // Kd above 1 is caught by the patch check and names the face.
        let t = format!("mtllib m.mtl\n{SQUARE}usemtl a\nf 1 2 3 4\n");
        let (_d, path) = write(&[("t.obj", &t), ("m.mtl", "newmtl a\nKd 1.5\n")]);
        let e = import(&path, &ImportOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("face 1 (line 7, patch 0)") && e.contains("reflectance"),
            "{e}"
        );
    }

    #[test]
    fn bad_faces_name_face_line_and_patch() {
        let good = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
        let cases = [
            ("f 1 2\n", "has 2 vertices"),
            ("f 1\n", "has 1 vertex"),
            ("f 1 2 1\n", "coincide"),
            ("v 2 0 0\nf 1 2 9\n", "zero area"),
            // A bow tie (with lobes of unequal area): no fan mends it.
            ("v 2 0 0\nf 1 9 4 3\n", "no fan"),
        ];
        for (bad, what) in cases {
            let e = err_str(&format!("{good}f 1 2 3\nf 1 3 4\n{bad}"));
            let line = good.lines().count() + 2 + bad.lines().count();
            let place = format!("face 3 (line {line}, patch");
            assert!(e.contains(&place) && e.contains(what), "{bad:?}: {e}");
            assert!(e.contains("t.obj"), "{e}");
        }
    }

    #[test]
    fn nan_and_infinite_vertices_are_errors() {
        for bad in ["nan", "NaN", "inf", "1e999"] {
            let e = err_str(&format!("v {bad} 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"));
            assert!(
                e.contains("face 1 (line 4, patch 0)") && e.contains("not a finite point"),
                "{e}"
            );
        }
    }

    #[test]
    fn tobj_errors_and_garbage_are_input_errors() {
        for (text, what) in [
            (format!("{SQUARE}f 1 2 7\n"), "out of bounds"),
            (format!("{SQUARE}f 1 2 0\n"), "out of bounds"),
            (format!("{SQUARE}f 1 2 -9\n"), "out of bounds"),
            (format!("{SQUARE}f 1 2 x\n"), "face parse error"),
            ("v 1 2\n".to_string(), "position parse error"),
            (
                "hello world\nthis is not an obj file\n".to_string(),
                "no faces",
            ),
            (format!("{SQUARE}l 1 2 3 4\n"), "only line elements"),
            (String::new(), "no faces"),
        ] {
            let e = import_str(&text).unwrap_err();
            assert_eq!(e.exit_code(), 2, "{e}");
            assert!(e.to_string().contains(what), "{text:?}: {e}");
        }
        // An unreadable file is bad input too.
        let e = import(Path::new("/nonexistent/x.obj"), &ImportOptions::default()).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert!(e.to_string().contains("cannot read"), "{e}");
    }

    #[test]
    fn texture_and_normal_indices_are_ignored() {
        let t = format!("{SQUARE}vt 0 0\nvn 0 0 1\nf 1/1/1 2/0/5 3//-9 4/-5\n");
        let (s, _) = import_str(&t).unwrap();
        assert_eq!(s.patches.len(), 1);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]
        /// Any mix of OBJ-like statements gives a scene or an error, never a panic.
        #[test]
        fn never_panics(lines in proptest::collection::vec(
            proptest::sample::select(vec![
                "v 0 0 0", "v 1 0 0", "v 0 1 0", "v 1 1 0", "v nan 0 0", "v 1 2", "v 1 1 1 0",
                "v 1 1 1 1 1 1", "vt 0 0", "vn 0 0 1", "f 1 2 3", "f 1 2 3 4", "f 1 2",
                "f 1", "f", "f 1/1 2/2 3/3", "f -1 -2 -3", "f 0 1 2", "f 1 2 3 4 5 6",
                "f 1//9 2//-99 3//0", "f 1/-5 2/-1 3/1", "vt 0 0 0 0", "l 1 2", "l 1 2 3", "p 1", "o", "g x", "usemtl",
                "usemtl m", "mtllib", "mtllib nothere.mtl", "s 1", "# c", "garbage", "",
                "f 1/2/3/4 1 2", "f 99999999999999999999 1 2",
            ]),
            0..24,
        )) {
            let _ = import_str(&lines.join("\n"));
        }
    }
}
