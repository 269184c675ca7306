//! Argument blocks shared by several subcommands (flattened with `#[command(flatten)]`),
//! and the CLI's naming of library errors: a library error names a parameter by its
//! library key (`sections`, `shell_radius`); the user sees the flag (`--sections`).

use crate::config::{self, ConfigSource};
use crate::error::{Error, Result};
use crate::scene::{self, Edits, Flip, Loaded, PatchRef, Scene};
use shellsim_hw::config::MachineConfig;
use shellsim_hw::DatapathConfig;
use std::path::{Path, PathBuf};

/// The input scene and the source patch (default 0).
#[derive(clap::Args, Debug, Clone)]
pub struct SceneSourceArgs {
    #[command(flatten)]
    pub file: SceneFileArg,
    /// The source patch: its id, or the name of its group, object or material (OBJ `g`,
    /// `o`, `usemtl`) when that names one patch.
    #[arg(long, default_value = "0")]
    pub source: PatchRef,
}

impl SceneSourceArgs {
    /// The scene file.
    pub fn path(&self) -> &Path {
        &self.file.scene
    }

    /// Loads the scene (see [`SceneFileArg::load`]) and resolves `--source`.
    pub fn load(&self) -> Result<(Scene, u32)> {
        let scene = self.file.load()?;
        let source = self.source.resolve(&scene, &self.file.scene)?;
        Ok((scene, source))
    }
}

/// Changes to a scene as it is loaded, for files that lack what the model needs.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct SceneEditArgs {
    /// Make the patches of this group, object or material name (OBJ `g`, `o`, `usemtl`)
    /// emitters, with emission 1 (for files without `Ke` in a material library).
    #[arg(long, value_name = "NAME")]
    pub emitter: Option<String>,
    /// Turn faces over (reverse their vertex order): all of them, or those of group,
    /// object or material NAME (`scene info` counts the faces that face outward).
    #[arg(long, value_name = "NAME", num_args = 0..=1)]
    pub flip: Option<Option<String>>,
}

impl SceneEditArgs {
    /// The library's form.
    pub fn edits(&self) -> Edits {
        Edits {
            emitter: self.emitter.clone(),
            flip: self.flip.as_ref().map(|f| match f {
                None => Flip::All,
                Some(name) => Flip::Named(name.clone()),
            }),
        }
    }

    /// Loads `path` with the edits; its warnings (an OBJ file's missing material library,
    /// faces split because they were not planar and convex) are for the caller to show.
    pub fn load_with_warnings(&self, path: &Path) -> Result<Loaded> {
        scene::load_with(path, &self.edits())
    }
}

/// A machine configuration file.
#[derive(clap::Args, Debug, Clone)]
pub struct MachineArgs {
    /// Machine configuration (TOML); default hw/configs/paper.toml (built in).
    #[arg(long)]
    pub hw: Option<PathBuf>,
    /// Grid cell size in scene units, overriding the configuration's `machine.cell_size`
    /// (default `auto`: sized to the scene, its largest extent / max(20, ⌈1.6·∛patches⌉)).
    #[arg(long)]
    pub cell: Option<f64>,
}

impl MachineArgs {
    /// Where the configuration comes from.
    pub fn source(&self) -> ConfigSource {
        ConfigSource::from_path(self.hw.as_deref())
    }

    /// The configuration, with `--cell` applied.
    pub fn load(&self) -> Result<MachineConfig> {
        let mut cfg = config::load(&self.source())?;
        if let Some(c) = self.cell {
            cfg.machine.cell_size = cell_length(c)?;
        }
        Ok(cfg)
    }
}

/// `--cell c` as a length: finite and positive.
fn cell_length(c: f64) -> Result<shellsim_hw::config::Length> {
    if !(c.is_finite() && c > 0.0) {
        return Err(Error::Usage(format!(
            "--cell {}: not a positive length",
            crate::error::shown(&c.to_string())
        )));
    }
    Ok(shellsim_hw::config::Length::Value(c))
}

/// Which datapath formats to use: the `[datapath]` of a machine configuration, validated
/// as a whole the way `run` validates it.
#[derive(clap::Args, Debug, Clone)]
pub struct DatapathArgs {
    /// Machine configuration (TOML); default hw/configs/paper.toml (built in).
    #[arg(long)]
    pub hw: Option<PathBuf>,
    /// A named configuration, resolved when shellsim runs: hw/configs/NAME.toml under the
    /// current directory, else $SHELLSIM_CONFIG_DIR/NAME.toml, else a built-in one (paper,
    /// small).
    #[arg(long, conflicts_with = "hw")]
    pub format: Option<String>,
    /// Override the fractional bits of coordinates, directions and t.
    #[arg(long)]
    pub frac_bits: Option<u32>,
}

impl DatapathArgs {
    /// Where the configuration comes from.
    pub fn source(&self) -> ConfigSource {
        match &self.format {
            Some(name) => ConfigSource::Named(name.clone()),
            None => ConfigSource::from_path(self.hw.as_deref()),
        }
    }

    /// The resolved datapath configuration.
    pub fn resolve(&self) -> Result<DatapathConfig> {
        Ok(self.resolve_config()?.datapath)
    }

    /// The whole resolved configuration, its datapath with `--frac-bits` applied.
    pub fn resolve_config(&self) -> Result<MachineConfig> {
        let mut cfg = config::load(&self.source())?;
        if let Some(b) = self.frac_bits {
            cfg.datapath = config::with_frac_bits(cfg.datapath, b)?;
        }
        Ok(cfg)
    }
}

/// The grid's cell size, for the subcommands that build a grid without a machine.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct CellArg {
    /// Grid cell size in scene units (default: sized to the scene, its largest extent /
    /// max(20, ⌈1.6·∛patches⌉) — 0.05 on the unit cube of up to 1,953 patches).
    #[arg(long)]
    pub cell: Option<f64>,
}

impl CellArg {
    /// The cell size for `scene`: the one given, or the built-in configuration's.
    pub fn for_scene(&self, scene: &Scene) -> f64 {
        self.cell.unwrap_or_else(|| {
            config::cell_size(config::built_in().machine.cell_size, scene.size())
        })
    }
}

/// On or off.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum OnOff {
    On,
    Off,
}

/// Names the flag in a library error about a parameter: `Error::Param` `shell_radius` becomes
/// `--shell-radius ...`, a bad source patch (place `source`) is reported at `--source`, an
/// unknown name at `--emitter` or `--flip`.
pub fn name_flags(e: Error) -> Error {
    match e {
        Error::Param { key, what } => Error::Usage(format!("--{} {what}", key.replace('_', "-"))),
        Error::Input { file, place, what } if FLAG_PLACES.contains(&place.as_str()) => {
            Error::Input {
                file,
                place: format!("--{place}"),
                what,
            }
        }
        e => e,
    }
}

/// The places of a library error that are a flag's value: a bad source patch, a name of
/// `--emitter` or `--flip` that names no patch.
const FLAG_PLACES: &[&str] = &["source", "emitter", "flip"];

/// Which rays a form-factor matrix job casts and on which configuration (`matrix`,
/// `radiosity`).
#[derive(clap::Args, Debug, Clone)]
pub struct MatrixRaysArgs {
    /// Rays per source patch.
    #[arg(long, conflicts_with = "ratio")]
    pub rays: Option<usize>,
    /// Rays per source as the paper's Hi_Low_Ratio: ratio × 969 (default 1: 969 rays).
    #[arg(long)]
    pub ratio: Option<usize>,
    /// Ray directions over each source's hemisphere.
    #[arg(long, value_enum, default_value_t = crate::reference::rays::Directions::Rings)]
    pub directions: crate::reference::rays::Directions,
    /// Seed of the ray origins (and of random directions).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[command(flatten)]
    pub machine: MachineArgs,
    /// The machine's clock for its time in the summary, MHz.
    #[arg(long, default_value_t = 50.0)]
    pub clock_mhz: f64,
}

impl MatrixRaysArgs {
    /// The rays per source: `--rays`, else `--ratio` × 969.
    pub fn rays_per_source(&self) -> Result<usize> {
        match (self.rays, self.ratio) {
            (Some(n), _) => Ok(n),
            (None, r) => {
                let r = r.unwrap_or(1);
                if r == 0 {
                    return Err(Error::Usage("--ratio 0 must be at least 1".into()));
                }
                Ok(r.saturating_mul(crate::paper::PAPER_RAYS))
            }
        }
    }

    /// The matrix specification for `model` over the rows `sources` (FROM, TO excluded;
    /// all of a scene of `n` patches by default).
    pub fn spec(
        &self,
        model: crate::radiosity::matrix::Model,
        sources: Option<(u32, u32)>,
        n: usize,
    ) -> Result<crate::radiosity::matrix::MatrixSpec> {
        let (a, b) = sources.unwrap_or((0, n as u32));
        Ok(crate::radiosity::matrix::MatrixSpec {
            model,
            rays: self.rays_per_source()?,
            directions: self.directions,
            seed: self.seed,
            sources: a..b,
        })
    }
}

/// Parses `FROM..TO` (patch ids).
pub fn parse_range(s: &str) -> std::result::Result<(u32, u32), String> {
    parse_pair(s, "FROM..TO", "a patch id")
}

/// Parses `A..B` (fractional bits).
pub fn parse_bits_range(s: &str) -> std::result::Result<(u32, u32), String> {
    parse_pair(s, "A..=B", "a number of bits")
}

/// Parses two numbers joined by `..`; `form` and `what` name them in the error.
fn parse_pair(s: &str, form: &str, what: &str) -> std::result::Result<(u32, u32), String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("{s:?} is not {form}"))?;
    // An inclusive range may say so (`A..=B`); `FROM..TO` ranges of ids have no `=` form.
    let b = match b.strip_prefix('=') {
        Some(b) if form.contains("..=") => b,
        Some(_) => return Err(format!("{s:?} is not {form} (TO is excluded: no `=`)")),
        None => b,
    };
    let p = |x: &str| {
        x.trim()
            .parse::<u32>()
            .map_err(|_| format!("{x:?} in {s:?} is not {what}"))
    };
    Ok((p(a)?, p(b)?))
}

/// The input scene alone.
#[derive(clap::Args, Debug, Clone)]
pub struct SceneFileArg {
    /// The scene file (.json or .obj).
    #[arg(long)]
    pub scene: PathBuf,
    #[command(flatten)]
    pub edit: SceneEditArgs,
}

impl SceneFileArg {
    /// Loads the scene with the edits; warnings go to standard error, once each.
    pub fn load(&self) -> Result<Scene> {
        load_scene(&self.scene, &self.edit)
    }
}

/// Loads `path` with `edit`, the warnings on standard error.
pub fn load_scene(path: &Path, edit: &SceneEditArgs) -> Result<Scene> {
    let loaded = edit.load_with_warnings(path)?;
    for w in &loaded.warnings {
        eprintln!("warning: {}: {}", path.display(), crate::error::shown(w));
    }
    Ok(loaded.scene)
}
