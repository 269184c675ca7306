//! The machine configuration, loaded in one place: a TOML file, a configuration NAME, or
//! the built-in hw/configs/paper.toml. The whole file is parsed once, by
//! [`MachineConfig::from_toml_str`]; the datapath formats are its `datapath` table, so
//! every command (`run`, `check`, `sweep`, `experiment`) validates a file the same way.
//!
//! A NAME is resolved when the program runs, in this order: `hw/configs/NAME.toml` under
//! the current directory, then `$SHELLSIM_CONFIG_DIR/NAME.toml`, then the configurations
//! built into the binary ([`BUILT_IN`]: `paper`, `small`, `balanced`).
//!
//! The defaults of everything the configuration holds (the partition's shell radius and
//! subshell threshold among them) come from [`built_in`].
//!
//! Lengths may be `"auto"`: [`resolve`] derives them from the scene's scale (its largest
//! extent) by the rules below, whose result on the unit cube is Table 12.1's — an explicit
//! number in the file or on the command line wins. The resolved configuration is what runs
//! and what is written beside results; the hardware gets it in its own units
//! ([`in_hardware_units`]: lengths over the scale).

use crate::error::{Error, Result};
use shellsim_hw::config::PAPER_TOML;
use shellsim_hw::config::{Length, MachineConfig};
use shellsim_hw::DatapathConfig;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The configurations built into the binary, by name: hw/configs/NAME.toml at build time.
pub const BUILT_IN: [(&str, &str); 3] = [
    ("paper", PAPER_TOML),
    ("small", include_str!("../hw/configs/small.toml")),
    ("balanced", include_str!("../hw/configs/balanced.toml")),
];

/// The environment variable naming a directory of NAME.toml configurations.
pub const CONFIG_DIR_VAR: &str = "SHELLSIM_CONFIG_DIR";

/// Where a configuration comes from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ConfigSource {
    /// The built-in hw/configs/paper.toml.
    BuiltIn,
    /// A TOML file.
    File(PathBuf),
    /// A name, resolved at run time (see the module's documentation).
    Named(String),
}

impl ConfigSource {
    /// `File(p)` for `Some(p)`, else `BuiltIn`.
    pub fn from_path(path: Option<&Path>) -> ConfigSource {
        path.map_or(ConfigSource::BuiltIn, |p| {
            ConfigSource::File(p.to_path_buf())
        })
    }
}

/// The label a built-in configuration is named by in errors.
fn built_in_label(name: &str) -> PathBuf {
    PathBuf::from(format!("<built-in hw/configs/{name}.toml>"))
}

/// Parses and validates a configuration's text; an error names `file` and the key.
pub fn parse(text: &str, file: &Path) -> Result<MachineConfig> {
    MachineConfig::from_toml_str(text).map_err(|e| Error::input(file, e.key, e.what))
}

/// Reads and validates the configuration file `path`.
pub fn from_file(path: &Path) -> Result<MachineConfig> {
    let text = crate::limits::read_input_string(path)?;
    parse(&text, path)
}

/// The built-in hw/configs/paper.toml, parsed once.
pub fn built_in() -> &'static MachineConfig {
    static CFG: OnceLock<MachineConfig> = OnceLock::new();
    CFG.get_or_init(|| {
        parse(PAPER_TOML, &built_in_label("paper")).expect("hw/configs/paper.toml is valid")
    })
}

/// Resolves configuration `name` (see the module's documentation).
pub fn named(name: &str) -> Result<MachineConfig> {
    let file = format!("{name}.toml");
    let mut tried = Vec::new();
    let local = Path::new("hw/configs").join(&file);
    if local.is_file() {
        return from_file(&local);
    }
    tried.push(local.display().to_string());
    match std::env::var_os(CONFIG_DIR_VAR) {
        Some(dir) => {
            let p = PathBuf::from(dir).join(&file);
            if p.is_file() {
                return from_file(&p);
            }
            tried.push(p.display().to_string());
        }
        None => tried.push(format!(
            "${CONFIG_DIR_VAR}/{file} (${CONFIG_DIR_VAR} is not set)"
        )),
    }
    if let Some((n, text)) = BUILT_IN.iter().find(|(n, _)| *n == name) {
        return parse(text, &built_in_label(n));
    }
    let known: Vec<&str> = BUILT_IN.iter().map(|(n, _)| *n).collect();
    Err(Error::input(
        Path::new(name),
        "configuration name",
        format!(
            "no configuration of this name: tried {}; built-in names: {}",
            tried.join(", "),
            known.join(", ")
        ),
    ))
}

/// Loads the configuration `src` names.
pub fn load(src: &ConfigSource) -> Result<MachineConfig> {
    match src {
        ConfigSource::BuiltIn => Ok(*built_in()),
        ConfigSource::File(p) => from_file(p),
        ConfigSource::Named(n) => named(n),
    }
}

/// The configuration file `path`, or the built-in paper.toml for `None` (tests, benches).
pub fn machine(path: Option<&Path>) -> Result<MachineConfig> {
    load(&ConfigSource::from_path(path))
}

/// `cfg` with `bits` fractional bits for coordinates, directions and t; an error names the
/// parameter `frac_bits`, the value and the key it makes impossible.
pub fn with_frac_bits(mut cfg: DatapathConfig, bits: u32) -> Result<DatapathConfig> {
    cfg.frac_bits = bits;
    cfg.t_frac_bits = bits;
    cfg.formats()
        .map_err(|e| Error::param("frac_bits", format!("{bits}: {}: {}", e.key, e.what)))?;
    Ok(cfg)
}

/// The fewest grid cells along the scene's largest extent when `cell_size` is `auto`
/// (Table 12.1: the unit cube in cells of 0.05): the paper's scenes keep the paper's grid.
pub const AUTO_CELLS_PER_SCALE: f64 = 20.0;

/// The most grid cells along the scene's largest extent when `cell_size` is `auto` (a
/// 512³ grid is 134 M cells; a finer one is asked for with `--cell`).
pub const AUTO_CELLS_MAX: f64 = 512.0;

/// What the `auto` lengths are derived from: the scene's largest extent and its patch
/// count (`Scene::size`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneSize {
    /// The largest extent of the scene's bounds.
    pub scale: f64,
    /// Patches.
    pub patches: usize,
}

impl SceneSize {
    /// A scene of largest extent `scale` whose grid is the paper's (no patches counted).
    pub fn of_scale(scale: f64) -> SceneSize {
        SceneSize { scale, patches: 0 }
    }

    /// Grid cells along the largest extent under the `auto` rule: about
    /// [`AUTO_CELLS_PER_CBRT_PATCH`]` · ∛N` for N patches — a grid of O(N) cells, the
    /// optimum for well-behaved models (Cleary & Wyvill 1988; Ize, Shirley & Parker, "Grid
    /// creation strategies for efficient ray tracing", RT 2007; pbrt's GridAccel takes
    /// 3∛N) — never coarser than the paper's 20 nor finer than 512. The constant sits in
    /// this tracer's measured optimum on subdivided Cornell rooms of 5k–100k patches (flat
    /// between 1.3∛N and 2∛N; BENCHMARKS.md) and keeps every scene of up to 1,953 patches
    /// (all committed scenes but stress-dense) on the paper's grid.
    pub fn auto_cells(&self) -> f64 {
        let r = (AUTO_CELLS_PER_CBRT_PATCH * (self.patches as f64).cbrt()).ceil();
        r.clamp(AUTO_CELLS_PER_SCALE, AUTO_CELLS_MAX)
    }
}

/// Cells along the largest extent per cube root of the patch count under the `auto` rule.
pub const AUTO_CELLS_PER_CBRT_PATCH: f64 = 1.6;

/// The shell radius over the scene's scale when `shell_radius` is `auto`: Table 12.1's
/// 0.289 for the unit cube (its diagonal over 6, √3/6 = 0.2887, to the paper's three digits).
pub const AUTO_SHELL_PER_SCALE: f64 = 0.289;

/// The cell size of `cell_size` for a scene of `size`: the value given, or the rule's
/// ([`SceneSize::auto_cells`]).
pub fn cell_size(cell: Length, size: SceneSize) -> f64 {
    cell.or(size.scale / size.auto_cells())
}

/// The shell radius of `shell_radius` for a scene of `scale`.
pub fn shell_radius(radius: Length, scale: f64) -> f64 {
    radius.or(AUTO_SHELL_PER_SCALE * scale)
}

/// `cfg` with every `auto` length derived for a scene of `size`, in scene units. It is
/// validated as the hardware will see it ([`in_hardware_units`]): the shell radius over the
/// scale must fit the t format; an error names the key.
pub fn resolve(cfg: &MachineConfig, size: SceneSize) -> Result<MachineConfig> {
    let scale = size.scale;
    let mut r = *cfg;
    r.machine.cell_size = Length::Value(cell_size(cfg.machine.cell_size, size));
    r.machine.shell_radius = Length::Value(shell_radius(cfg.machine.shell_radius, scale));
    scaled(&r, scale).validate().map_err(|e| {
        Error::input(
            Path::new("<configuration resolved for the scene>"),
            e.key,
            format!(
                "{} (in units of the scene's largest extent, {scale})",
                e.what
            ),
        )
    })?;
    Ok(r)
}

/// A resolved configuration in the hardware's units: lengths over the scene's `scale`
/// (the hardware's coordinates are the scene's, relative to the grid origin, over the
/// scale). On the unit cube (scale 1) it is the resolved `cfg` itself.
pub fn in_hardware_units(cfg: &MachineConfig, size: SceneSize) -> Result<MachineConfig> {
    Ok(scaled(&resolve(cfg, size)?, size.scale))
}

/// `r` (resolved) with its lengths over `scale`.
fn scaled(r: &MachineConfig, scale: f64) -> MachineConfig {
    let mut h = *r;
    h.machine.cell_size = Length::Value(r.machine.cell_size.value() / scale);
    h.machine.shell_radius = Length::Value(r.machine.shell_radius.value() / scale);
    h
}
