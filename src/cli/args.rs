//! Argument blocks shared by several subcommands (flattened with `#[command(flatten)]`),
//! and the CLI's naming of library errors: a library error names a parameter by its
//! library key (`sections`, `shell_radius`); the user sees the flag (`--sections`).

use crate::config::{self, ConfigSource};
use crate::error::{Error, Result};
use crate::scene::Scene;
use shellsim_hw::config::MachineConfig;
use shellsim_hw::DatapathConfig;
use std::path::PathBuf;

/// The input scene and the source patch (default 0).
#[derive(clap::Args, Debug, Clone)]
pub struct SceneSourceArgs {
    /// The scene file (.json or .obj).
    #[arg(long)]
    pub scene: PathBuf,
    /// The source patch id.
    #[arg(long, default_value_t = 0)]
    pub source: u32,
}

/// A machine configuration file.
#[derive(clap::Args, Debug, Clone)]
pub struct MachineArgs {
    /// Machine configuration (TOML); default hw/configs/paper.toml (built in).
    #[arg(long)]
    pub hw: Option<PathBuf>,
}

impl MachineArgs {
    /// Where the configuration comes from.
    pub fn source(&self) -> ConfigSource {
        ConfigSource::from_path(self.hw.as_deref())
    }
}

/// Which datapath formats to use: the `[datapath]` of a machine configuration, validated
/// as a whole the way `run` validates it.
#[derive(clap::Args, Debug, Clone)]
pub struct DatapathArgs {
    #[command(flatten)]
    pub machine: MachineArgs,
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
            None => self.machine.source(),
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
    /// Grid cell size in scene units (default: the configuration's rule, the scene's
    /// largest extent / 20 — 0.05 on the unit cube).
    #[arg(long)]
    pub cell: Option<f64>,
}

impl CellArg {
    /// The cell size for `scene`: the one given, or the built-in configuration's.
    pub fn for_scene(&self, scene: &Scene) -> f64 {
        self.cell.unwrap_or_else(|| {
            config::cell_size(config::built_in().machine.cell_size, scene.bounds.scale())
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
/// `--shell-radius ...`, a bad source patch (place `source`) is reported at `--source`.
pub fn name_flags(e: Error) -> Error {
    match e {
        Error::Param { key, what } => Error::Usage(format!("--{} {what}", key.replace('_', "-"))),
        Error::Input { file, place, what } if place == "source" => Error::Input {
            file,
            place: "--source".into(),
            what,
        },
        e => e,
    }
}
