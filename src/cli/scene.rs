//! `shellsim scene gen|import|info`.

use super::args::{CellArg, SceneEditArgs};
use crate::error::Result;
use crate::output::{check_outputs, Output};
use crate::reference::orient::outward_faces;
use crate::reference::tracer::Tracer;
use crate::scene::gen::corpus::CorpusKind;
use crate::scene::{self, gen, obj, Aabb};
use clap::Subcommand;
use std::path::{Path, PathBuf};

#[derive(Subcommand, Debug)]
pub enum SceneCmd {
    /// Generate a built-in scene (deterministic for a seed) and write it as JSON.
    Gen {
        /// Which scene: a built-in kind, or a corpus kind (`corpus-*`, closed scenes
        /// nobody tuned for; `--n` sets their size).
        #[arg(value_enum)]
        kind: GenKind,
        /// Seed of the random parts.
        #[arg(long, default_value_t = gen::DEFAULT_SEED)]
        seed: u64,
        /// Size of a corpus kind: tiles per wall side (boxes, Cornell), splits per
        /// triangle side (slanted room), points (convex hull), cells per unit (cell
        /// boundary room). Default: the kind's own.
        #[arg(long)]
        n: Option<usize>,
        /// Output file (JSON; `-` for standard output).
        #[arg(short, long)]
        out: PathBuf,
    },
    /// Convert a Wavefront OBJ file into a validated JSON scene (faces with more than 4
    /// vertices, and faces that are not planar and convex, become triangle fans; the names
    /// are kept).
    Import {
        /// The OBJ file.
        file: PathBuf,
        /// Output file (JSON; `-` for standard output).
        #[arg(short, long)]
        out: PathBuf,
        /// Scene bounds as lo_x,lo_y,lo_z,hi_x,hi_y,hi_z (default: the vertices' bounding box).
        #[arg(long, value_parser = parse_bounds)]
        bounds: Option<Aabb>,
        /// Reflectance of faces without a material.
        #[arg(long, default_value_t = 0.5)]
        reflectance: f64,
        #[command(flatten)]
        edit: SceneEditArgs,
    },
    /// Validate a scene (JSON or OBJ) and print its statistics, its names, and warnings
    /// (an OBJ file's missing material library, its faces split because they were not
    /// planar and convex, its faces that face out of the enclosure).
    Info {
        /// The scene file (.json or .obj).
        file: PathBuf,
        /// The grid for the grid statistics.
        #[command(flatten)]
        grid: CellArg,
        #[command(flatten)]
        edit: SceneEditArgs,
    },
}

/// Runs `shellsim scene ...`.
pub fn run(c: SceneCmd) -> Result<()> {
    match c {
        SceneCmd::Info { file, grid, edit } => info(&file, grid, &edit),
        SceneCmd::Gen { kind, seed, n, out } => {
            check_outputs(&[Output::file("--out", &out)])?;
            let scene = match kind {
                GenKind::Builtin(k) => {
                    if let Some(n) = n {
                        return Err(crate::error::Error::param(
                            "n",
                            format!(
                                "{n}: {} has no size; --n is for the corpus-* kinds",
                                k.name()
                            ),
                        ));
                    }
                    gen::generate(k, seed)
                }
                GenKind::Corpus(k) => k.generate(n, seed)?,
            };
            scene.validate(&out)?;
            scene.save_json(&out)?;
            crate::output::outln!(
                "{}: {} patches (seed {seed}) written to {}",
                scene.name,
                scene.patches.len(),
                out.display()
            );
            Ok(())
        }
        SceneCmd::Import {
            file,
            out,
            bounds,
            reflectance,
            edit,
        } => {
            check_outputs(&[Output::file("--out", &out)])?;
            let opts = obj::ImportOptions {
                bounds,
                reflectance,
                ..Default::default()
            };
            let (mut scene, report) = obj::import(&file, &opts)?;
            edit.edits().apply(&mut scene, &file)?;
            for w in &report.warnings {
                eprintln!("warning: {}", crate::error::shown(w));
            }
            scene.save_json(&out)?;
            crate::output::outln!("{}: {}", file.display(), report.summary());
            crate::output::outln!("written to {}", out.display());
            Ok(())
        }
    }
}

/// What `scene gen` builds: a built-in [`gen::Kind`] or a [`CorpusKind`], one clap value
/// list of both.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GenKind {
    Builtin(gen::Kind),
    Corpus(CorpusKind),
}

const GEN_KINDS: [GenKind; gen::Kind::ALL.len() + CorpusKind::ALL.len()] = {
    let mut all =
        [GenKind::Builtin(gen::Kind::Scene1); gen::Kind::ALL.len() + CorpusKind::ALL.len()];
    let mut i = 0;
    while i < gen::Kind::ALL.len() {
        all[i] = GenKind::Builtin(gen::Kind::ALL[i]);
        i += 1;
    }
    let mut j = 0;
    while j < CorpusKind::ALL.len() {
        all[i + j] = GenKind::Corpus(CorpusKind::ALL[j]);
        j += 1;
    }
    all
};

impl clap::ValueEnum for GenKind {
    fn value_variants<'a>() -> &'a [Self] {
        &GEN_KINDS
    }
    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        match self {
            GenKind::Builtin(k) => k.to_possible_value(),
            GenKind::Corpus(k) => k.to_possible_value(),
        }
    }
}

/// Parses `lo_x,lo_y,lo_z,hi_x,hi_y,hi_z`.
fn parse_bounds(s: &str) -> std::result::Result<Aabb, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>().map_err(|e| format!("{x:?}: {e}")))
        .collect::<std::result::Result<_, _>>()?;
    if v.len() != 6 {
        return Err(format!("expected 6 numbers, got {}", v.len()));
    }
    Ok(Aabb {
        lo: glam::DVec3::new(v[0], v[1], v[2]),
        hi: glam::DVec3::new(v[3], v[4], v[5]),
    })
}

fn info(file: &Path, grid: CellArg, edit: &SceneEditArgs) -> Result<()> {
    let loaded = edit.load_with_warnings(file)?;
    let scene = &loaded.scene;
    let tracer = Tracer::new(scene, grid.for_scene(scene)).map_err(|e| e.for_scene(file))?;
    let g = tracer.grid();
    let tris = scene
        .patches
        .iter()
        .filter(|p| p.vertices.len() == 3)
        .count();
    let emitters = scene
        .patches
        .iter()
        .filter(|p| p.emission.is_nonzero())
        .count();
    crate::output::outln!("scene        {}", crate::error::shown(&scene.name));
    crate::output::outln!(
        "bounds       {:?} - {:?}",
        scene.bounds.lo.to_array(),
        scene.bounds.hi.to_array()
    );
    crate::output::outln!(
        "patches      {} ({} triangles, {} quads, {} emitting)",
        scene.patches.len(),
        tris,
        scene.patches.len() - tris,
        emitters
    );
    crate::output::outln!("total area   {:.6}", scene.total_area());
    crate::output::outln!(
        "grid         {}×{}×{} cells of {}, {} nonempty, {} cell entries ({:.2} per patch)",
        g.dims[0],
        g.dims[1],
        g.dims[2],
        // Six decimals, trailing zeros dropped: 0.05, 0.045455, 27.75.
        format!("{:.6}", g.cell_size)
            .trim_end_matches('0')
            .trim_end_matches('.'),
        g.nonempty_cells(),
        g.entries(),
        g.entries() as f64 / scene.patches.len() as f64
    );
    let probe = crate::reference::orient::closure(scene, &tracer);
    crate::output::outln!(
        "closed       {}: {} of {} probe rays escaped ({} Malley rays from each patch's front){}",
        if probe.closed() { "yes" } else { "no" },
        probe.escaped,
        probe.rays,
        crate::reference::orient::ORIENT_RAYS,
        probe
            .open_at
            .map_or(String::new(), |p| format!(", the first from patch {p}"))
    );
    // Groups (and objects) apart from materials: a patch has one of each.
    for (label, of) in [
        (
            "groups     ",
            (|p| p.name.as_deref()) as fn(&crate::scene::Patch) -> Option<&str>,
        ),
        ("materials  ", |p| p.material.as_deref()),
    ] {
        let mut names: Vec<(&str, Vec<u32>)> = Vec::new();
        let mut index = std::collections::HashMap::new();
        for (id, p) in scene.patches.iter().enumerate() {
            if let Some(n) = of(p) {
                let k = *index.entry(n).or_insert_with(|| {
                    names.push((n, Vec::new()));
                    names.len() - 1
                });
                names[k].1.push(id as u32);
            }
        }
        if !names.is_empty() {
            crate::output::outln!("{label}  {}", names_line(&names));
        }
    }
    for w in &loaded.warnings {
        crate::output::outln!("warning      {}", crate::error::shown(w));
    }
    // Only OBJ files: their winding is whatever the modeller left; JSON scenes come from
    // shellsim's generators (the stress scenes orient faces at random on purpose) or from
    // `scene import`, whose OBJ file this warned about.
    let outward = if scene::is_obj(file) {
        outward_faces(scene, &tracer)
    } else {
        Vec::new()
    };
    if !outward.is_empty() {
        crate::output::outln!(
            "warning      {} of {} faces face out of the enclosure (patches {}): turn them over with --flip NAME, or --flip for all",
            outward.len(),
            scene.patches.len(),
            ranges(&outward, 24)
        );
    }
    Ok(())
}

/// Most names `scene info` lists.
const NAMES_SHOWN: usize = 24;

/// `floor 0; leftWall 5-6; ...`: each name with its patches.
fn names_line(names: &[(&str, Vec<u32>)]) -> String {
    let mut parts: Vec<String> = names
        .iter()
        .take(NAMES_SHOWN)
        .map(|(n, ids)| format!("{} {}", crate::error::shown(n), ranges(ids, 8)))
        .collect();
    if names.len() > NAMES_SHOWN {
        parts.push(format!("and {} more names", names.len() - NAMES_SHOWN));
    }
    parts.join("; ")
}

/// Ascending ids as ranges, `0, 3-5, 9`, the first `most` ranges and a count of the rest.
fn ranges(ids: &[u32], most: usize) -> String {
    let mut runs: Vec<(u32, u32)> = Vec::new();
    for &id in ids {
        match runs.last_mut() {
            Some((_, hi)) if *hi + 1 == id => *hi = id,
            _ => runs.push((id, id)),
        }
    }
    let mut parts: Vec<String> = runs
        .iter()
        .take(most)
        .map(|&(lo, hi)| {
            if lo == hi {
                lo.to_string()
            } else {
                format!("{lo}-{hi}")
            }
        })
        .collect();
    if runs.len() > most {
        parts.push(format!("… ({} more)", runs.len() - most));
    }
    parts.join(", ")
}
