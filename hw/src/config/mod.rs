//! The machine's configuration: one TOML parse of hw/configs/*.toml into one typed, validated
//! value — the `[machine]` and `[balance]` tables (machine.rs) and the `[datapath]` formats
//! (datapath.rs). `PAPER_TOML`, the paper machine's file, is the one built-in configuration.

pub mod datapath;
pub mod machine;

pub use crate::datapath::format::{Fault, Formats};
pub use datapath::{DatapathConfig, HardwareCost};
pub use machine::{
    ArbiterPolicy, BalanceTable, DescriptorOrder, JobSource, Length, MachineTable,
    PartitionGranularity, VictimPolicy,
};

use serde::{Deserialize, Serialize};

/// The paper machine's configuration file, built in: the one source of the defaults.
pub const PAPER_TOML: &str = include_str!("../../configs/paper.toml");

/// The paper machine's configuration (hw/configs/paper.toml, built in). It is valid — a
/// test parses it — so this never panics in practice.
pub fn paper() -> MachineConfig {
    MachineConfig::from_toml_str(PAPER_TOML).expect("hw/configs/paper.toml is valid")
}

/// The machine samples its progress counters every this many cycles (machine/tick.rs), so
/// the watchdog sees a wait up to twice this late.
pub const WATCHDOG_SAMPLE_CYCLES: u64 = 64;

/// A configuration value that cannot work. `key` names the table and key
/// (`machine.shell_radius`), or for a TOML syntax or type error the place (`line L, column C`).
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("{key}: {what}")]
pub struct ConfigError {
    pub key: String,
    pub what: String,
}

/// A whole machine configuration file. Every table is required; unknown keys are errors.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineConfig {
    pub machine: MachineTable,
    pub balance: BalanceTable,
    pub datapath: DatapathConfig,
}

impl MachineConfig {
    /// Parses and validates a configuration file's text: the one parser of hw/configs/*.toml.
    pub fn from_toml_str(text: &str) -> Result<Self, ConfigError> {
        let cfg: MachineConfig = toml::from_str(text).map_err(|e| ConfigError {
            key: e
                .span()
                .map(|s| line_column(text, s.start))
                .unwrap_or_else(|| "toml".into()),
            what: match e.message().trim() {
                "" => "incomplete: a value or the rest of the statement is missing here".into(),
                m => m.to_string(),
            },
        })?;
        cfg.validate()?;
        cfg.check_watchdog()?;
        Ok(cfg)
    }

    /// Checks every value; the error names the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let f = self.datapath.formats()?;
        self.machine.validate(f.t)?;
        self.balance.validate(self.machine.ray_buffer_capacity)
    }

    /// Checks that `watchdog_cycles` outlasts the longest legal wait ([`longest_wait`]
    /// plus twice [`WATCHDOG_SAMPLE_CYCLES`]), so a healthy run is never reported as a
    /// deadlock; part of parsing a file ([`MachineConfig::from_toml_str`]). A configuration
    /// built in code may skip it — the watchdog's own test does, to stand in for a deadlock.
    ///
    /// [`longest_wait`]: MachineConfig::longest_wait
    pub fn check_watchdog(&self) -> Result<(), ConfigError> {
        let (min, why) = self.longest_wait();
        let min = min + 2 * WATCHDOG_SAMPLE_CYCLES;
        if self.machine.watchdog_cycles < min {
            return Err(ConfigError {
                key: "machine.watchdog_cycles".into(),
                what: format!(
                    "{} is below this configuration's longest legal wait, {why}, plus twice the watchdog's {WATCHDOG_SAMPLE_CYCLES}-cycle sampling: it must be at least {min}, or a healthy run would be reported as a deadlock",
                    self.machine.watchdog_cycles
                ),
            });
        }
        Ok(())
    }

    /// The longest a healthy machine of this configuration can go without any progress
    /// event (a grant, an arrival, a DDA step, a job or result, a work-item), in cycles,
    /// and which wait it is: the largest of a patch load (memory latency + the patch's
    /// words), a DDA step, the ICU pipeline, the balancer's retry interval and a work-item
    /// over the inter-cluster link. Validation requires `watchdog_cycles` to be at least
    /// this plus twice [`WATCHDOG_SAMPLE_CYCLES`].
    pub fn longest_wait(&self) -> (u64, String) {
        let m = &self.machine;
        let b = &self.balance;
        let words = self
            .datapath
            .formats()
            .map(|f| crate::datapath::record::RecordSizes::of(&f).patch_words as u64)
            .unwrap_or(0);
        let link = b.link_latency as u64
            + (b.work_item_jobs as u64 * crate::msg::JOB_WORDS as u64)
                .div_ceil(b.link_words_per_cycle as u64);
        let waits = [
            (
                m.memory_latency as u64 + words + 1,
                format!(
                    "{} cycles of a patch load (memory_latency {} + {words} words)",
                    m.memory_latency as u64 + words + 1,
                    m.memory_latency
                ),
            ),
            (
                m.dda_cycles_per_step as u64,
                format!("{} cycles of a DDA step", m.dda_cycles_per_step),
            ),
            (
                self.pipeline_depth() as u64,
                format!("{} cycles of the ICU pipeline", self.pipeline_depth()),
            ),
            (
                b.sampling_interval as u64,
                format!(
                    "{} cycles of the balancer's sampling_interval",
                    b.sampling_interval
                ),
            ),
            (
                link,
                format!(
                    "{link} cycles of a work-item over the link (link_latency {} + {} jobs' words)",
                    b.link_latency, b.work_item_jobs
                ),
            ),
        ];
        waits.into_iter().max_by_key(|w| w.0).expect("five waits")
    }

    /// The shell radius, t format raw (validated: it fits and is at least one LSB).
    pub fn shell_raw(&self) -> Result<i64, ConfigError> {
        self.machine.shell_raw(self.datapath.formats()?.t)
    }

    /// Divider stages: the t format's bits over the bits per stage.
    pub fn divider_stages(&self) -> u32 {
        let f = self.datapath.formats().expect("validated");
        f.t.bits().div_ceil(self.machine.divider_bits_per_stage)
    }

    /// ICU pipeline depth: translate, shear, edges, interpolate, the divider's stages, compare.
    pub fn pipeline_depth(&self) -> u32 {
        4 + self.divider_stages() + 1
    }
}

/// "line L, column C" (both from 1, columns in characters) of byte offset `at` in `text`.
fn line_column(text: &str, at: usize) -> String {
    let mut at = at.min(text.len());
    while !text.is_char_boundary(at) {
        at -= 1;
    }
    let before = &text[..at];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().unwrap_or("").chars().count() + 1;
    format!("line {line}, column {column}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_and_small_parse() {
        let p = paper();
        assert_eq!(p.machine.cell_size, Length::Auto);
        assert_eq!(p.machine.shell_radius, Length::Auto);
        assert!(p.balance.enabled);
        let s = MachineConfig::from_toml_str(include_str!("../../configs/small.toml")).unwrap();
        assert_eq!(s.machine.cell_size, Length::Auto);
        assert_eq!(s.datapath, p.datapath);
    }

    #[test]
    fn a_syntax_error_names_line_and_column() {
        let text = PAPER_TOML.replace("clusters = 4 ", "clusters = = 4 ");
        let e = MachineConfig::from_toml_str(&text).unwrap_err();
        let line = PAPER_TOML
            .lines()
            .position(|l| l.starts_with("clusters = 4"))
            .unwrap()
            + 1;
        assert!(e.key.starts_with(&format!("line {line}, column ")), "{e:?}");
        assert!(!e.key.contains("bytes"), "{e:?}");
    }

    #[test]
    fn line_column_counts_from_one() {
        assert_eq!(line_column("ab\ncd", 0), "line 1, column 1");
        assert_eq!(line_column("ab\ncd", 4), "line 2, column 2");
        assert_eq!(line_column("é\nx", 3), "line 2, column 1");
    }

    #[test]
    fn a_missing_balance_table_is_an_error() {
        let i = PAPER_TOML.find("[balance]").unwrap();
        let j = PAPER_TOML.find("[datapath]").unwrap();
        let text = format!("{}{}", &PAPER_TOML[..i], &PAPER_TOML[j..]);
        let e = MachineConfig::from_toml_str(&text).unwrap_err();
        assert!(e.what.contains("balance"), "{e:?}");
    }

    fn with_radius(r: &str) -> Result<MachineConfig, ConfigError> {
        MachineConfig::from_toml_str(
            &PAPER_TOML.replace("shell_radius = \"auto\"", &format!("shell_radius = {r}")),
        )
    }

    #[test]
    fn a_shell_radius_beyond_the_t_format_is_an_error_not_a_clamp() {
        // paper.toml's t is Q3.12: [-4, 4).
        let e = with_radius("4.5").unwrap_err();
        assert_eq!(e.key, "machine.shell_radius", "{e:?}");
        let e = with_radius("1e-9").unwrap_err();
        assert_eq!(e.key, "machine.shell_radius", "{e:?}");
        let e = with_radius("-1.0").unwrap_err();
        assert_eq!(e.key, "machine.shell_radius", "{e:?}");
        let c = with_radius("0.289").unwrap();
        assert_eq!(c.shell_raw().unwrap(), (0.289f64 * 4096.0).round() as i64);
        // `auto` validates, but a machine cannot be built from it before the host resolves it.
        let a = with_radius("\"auto\"").unwrap();
        assert_eq!(a.shell_raw().unwrap_err().key, "machine.shell_radius");
    }

    #[test]
    fn a_length_is_a_number_or_auto() {
        for (v, want) in [
            ("2", Length::Value(2.0)),
            ("0.5", Length::Value(0.5)),
            ("\"auto\"", Length::Auto),
        ] {
            let text = PAPER_TOML.replace("cell_size = \"auto\"", &format!("cell_size = {v}"));
            assert_eq!(
                MachineConfig::from_toml_str(&text)
                    .unwrap()
                    .machine
                    .cell_size,
                want,
                "{v}"
            );
        }
        let text = PAPER_TOML.replace("cell_size = \"auto\"", "cell_size = \"big\"");
        let e = MachineConfig::from_toml_str(&text).unwrap_err();
        assert!(e.what.contains("not a length"), "{e:?}");
    }

    #[test]
    fn a_watchdog_below_the_longest_legal_wait_is_an_error() {
        // Regression: watchdog_cycles 10..~70, or one long legal wait reaching it, reported
        // a deadlock on a healthy run.
        let text = PAPER_TOML.replace("memory_latency = 8 ", "memory_latency = 100000 ");
        let e = MachineConfig::from_toml_str(&text).unwrap_err();
        assert_eq!(e.key, "machine.watchdog_cycles", "{e:?}");
        assert!(e.what.contains("memory_latency 100000"), "{e:?}");
        let need = MachineConfig::from_toml_str(
            &text.replace("watchdog_cycles = 100000", "watchdog_cycles = 1000000"),
        )
        .unwrap()
        .longest_wait()
        .0;
        assert!(need > 100_000, "{need}");
        let text = PAPER_TOML.replace("watchdog_cycles = 100000", "watchdog_cycles = 70");
        let e = MachineConfig::from_toml_str(&text).unwrap_err();
        assert_eq!(e.key, "machine.watchdog_cycles", "{e:?}");
        let p = paper();
        assert!(p.machine.watchdog_cycles >= p.longest_wait().0 + 2 * WATCHDOG_SAMPLE_CYCLES);
    }

    #[test]
    fn a_bad_cell_size_is_an_error() {
        for v in ["0.0", "-0.05", "nan", "inf"] {
            let text = PAPER_TOML.replace("cell_size = \"auto\"", &format!("cell_size = {v}"));
            let e = MachineConfig::from_toml_str(&text).unwrap_err();
            assert_eq!(e.key, "machine.cell_size", "{v}: {e:?}");
        }
    }
}
