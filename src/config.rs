//! The machine configuration, loaded in one place: a TOML file, a configuration NAME, or
//! the built-in hw/configs/paper.toml. The whole file is parsed once, by
//! [`MachineConfig::from_toml_str`]; the datapath formats are its `datapath` table, so
//! every command (`run`, `check`, `sweep`, `experiment`) validates a file the same way.
//!
//! A NAME is resolved when the program runs, in this order: `hw/configs/NAME.toml` under
//! the current directory, then `$SHELLSIM_CONFIG_DIR/NAME.toml`, then the configurations
//! built into the binary ([`BUILT_IN`]: `paper`, `small`).
//!
//! The defaults of everything the configuration holds (the partition's shell radius and
//! subshell threshold among them) come from [`built_in`].

use crate::error::{Error, Result};
use shellsim_hw::config::MachineConfig;
use shellsim_hw::config::PAPER_TOML;
use shellsim_hw::DatapathConfig;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The configurations built into the binary, by name: hw/configs/NAME.toml at build time.
pub const BUILT_IN: [(&str, &str); 2] = [
    ("paper", PAPER_TOML),
    ("small", include_str!("../hw/configs/small.toml")),
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
