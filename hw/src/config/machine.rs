//! The `[machine]` and `[balance]` tables of hw/configs/*.toml (clusters, CTUs, timing,
//! buffers, arbiter; dynamic balancing), each with its validation.

use super::ConfigError;
use crate::datapath::format::Format;
use serde::{Deserialize, Serialize};

/// How the global-memory arbiter picks among waiting requests.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ArbiterPolicy {
    /// The next requester after the last one granted (no requester waits more than
    /// one round of the others).
    RoundRobin,
    /// The lowest-numbered requester always wins (may starve the others).
    FixedPriority,
}

/// Where a sector's (ray, patch) jobs are made.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum JobSource {
    /// The CTU issues one job per cycle for each arrived patch against every remaining ray.
    #[default]
    Ctu,
    /// The CTU hands its ray buffer one descriptor per arrived patch (the patch and the
    /// sector's remaining rays); the ray buffer expands it into jobs at the ICU's input, one
    /// per cycle, and balancing moves work-items split off waiting descriptors.
    Bundle,
}

impl JobSource {
    /// The name in configuration files and reports.
    pub fn name(self) -> &'static str {
        match self {
            JobSource::Ctu => "ctu",
            JobSource::Bundle => "bundle",
        }
    }

    fn is_ctu(&self) -> bool {
        *self == JobSource::Ctu
    }
}

/// The order in which a bundle ray buffer expands its descriptors.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DescriptorOrder {
    /// In arrival order.
    #[default]
    Fifo,
    /// The descriptor with the most jobs left first (ties in arrival order): the sector with
    /// the most remaining rays — the longest serial chain of joins — is served first.
    LargestFirst,
}

impl DescriptorOrder {
    /// The name in configuration files and reports.
    pub fn name(self) -> &'static str {
        match self {
            DescriptorOrder::Fifo => "fifo",
            DescriptorOrder::LargestFirst => "largest-first",
        }
    }

    fn is_fifo(&self) -> bool {
        *self == DescriptorOrder::Fifo
    }
}

/// Where the host's partitioner may cut sections and sectors (its `--granularity`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PartitionGranularity {
    /// Only at subregion boundaries (the paper's 25 low-resolution sectors).
    #[default]
    Subregion,
    /// Between any two low-resolution ray directions: sectors closer to equal work.
    Ray,
}

impl PartitionGranularity {
    /// The name in configuration files and reports.
    pub fn name(self) -> &'static str {
        match self {
            PartitionGranularity::Subregion => "subregion",
            PartitionGranularity::Ray => "ray",
        }
    }

    fn is_subregion(&self) -> bool {
        *self == PartitionGranularity::Subregion
    }
}

fn is_false(b: &bool) -> bool {
    !*b
}

fn one() -> u32 {
    1
}

fn is_one(v: &u32) -> bool {
    *v == 1
}

/// A length in scene units, or `"auto"`: derived from the scene by the host's stated rule
/// (see the host's `config::resolve`). The machine is only ever built from a resolved
/// configuration (every length a value); serialized, a value is a plain number.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Length {
    /// Derived from the scene.
    Auto,
    /// Given, in scene units.
    Value(f64),
}

impl Length {
    /// The value, `None` while it is `auto`.
    pub fn get(self) -> Option<f64> {
        match self {
            Length::Auto => None,
            Length::Value(v) => Some(v),
        }
    }

    /// The value of a resolved length (the host resolves every `auto` before use; an
    /// unresolved one here is a bug of the host, not bad input).
    pub fn value(self) -> f64 {
        self.get()
            .expect("an `auto` length is resolved by the host before it is used")
    }

    /// The value, or `rule` when it is `auto`.
    pub fn or(self, rule: f64) -> f64 {
        self.get().unwrap_or(rule)
    }
}

impl Serialize for Length {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Length::Auto => s.serialize_str("auto"),
            Length::Value(v) => s.serialize_f64(*v),
        }
    }
}

impl<'de> Deserialize<'de> for Length {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Float(f64),
            Int(i64),
            Text(String),
        }
        match Raw::deserialize(d) {
            Ok(Raw::Float(v)) => Ok(Length::Value(v)),
            Ok(Raw::Int(v)) => Ok(Length::Value(v as f64)),
            Ok(Raw::Text(t)) if t == "auto" => Ok(Length::Auto),
            Ok(Raw::Text(t)) => Err(serde::de::Error::custom(format!(
                "{t:?} is not a length: give a number (scene units) or \"auto\""
            ))),
            Err(_) => Err(serde::de::Error::custom(
                "not a length: give a number (scene units) or \"auto\"",
            )),
        }
    }
}

/// The `[machine]` table.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineTable {
    /// Clusters (one per section; each one ICU).
    pub clusters: u32,
    /// CTUs per cluster (one per sector).
    pub ctus_per_cluster: u32,
    /// Cycles one fixed-point DDA step takes.
    pub dda_cycles_per_step: u32,
    /// Global memory: cycles from grant to the first word.
    pub memory_latency: u32,
    /// Jobs the ray buffer holds.
    pub ray_buffer_capacity: u32,
    /// Patches the patch buffer holds (loaded, waiting for their jobs to be issued).
    pub patch_buffer_capacity: u32,
    /// Requests a CTU may have queued for the arbiter.
    pub request_queue_capacity: u32,
    /// Arbiter policy.
    pub arbiter: ArbiterPolicy,
    /// Quotient bits the divider produces per pipeline stage.
    pub divider_bits_per_stage: u32,
    /// A CTU ends a subshell (and joins) once it has loaded this many patches in it.
    pub subshell_max_patches: u32,
    /// Shell radius in scene units, or `auto` (the host's rule gives the paper's 0.289 on
    /// the unit cube). Resolved, it must be representable in the t format (see
    /// [`MachineTable::shell_raw`]).
    pub shell_radius: Length,
    /// Grid cell edge in scene units, or `auto` (the host's rule gives Table 12.1's 0.05 on
    /// the unit cube).
    pub cell_size: Length,
    /// Jump over cycles in which every unit waits on a timer.
    pub cycle_jump: bool,
    /// Stop with a report when nothing progresses for this many cycles.
    pub watchdog_cycles: u64,
    /// Where jobs are made (`ctu` when the key is absent; written only when not `ctu`, so
    /// every configuration written before the key existed reads and writes as it did).
    #[serde(default, skip_serializing_if = "JobSource::is_ctu")]
    pub job_source: JobSource,
    /// A CTU traverses and requests the next subshell's patches while the current
    /// subshell's jobs drain (at most one subshell ahead); rays still retire by the exact
    /// rule, against their position at the end of the subshell that joins. `false` when the
    /// key is absent (written only when `true`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub overlap_joins: bool,
    /// Patch ids of a cell a CTU compares against its loaded set per cycle (the paper's
    /// machine: 1). At most one of them goes out as a request per cycle. `1` when the key is
    /// absent (written only when not 1).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub scan_ids_per_cycle: u32,
    /// The order a bundle ray buffer expands its descriptors in (`fifo` when the key is
    /// absent; written only when not `fifo`; `job_source = "ctu"` ignores it).
    #[serde(default, skip_serializing_if = "DescriptorOrder::is_fifo")]
    pub descriptor_order: DescriptorOrder,
    /// Where the host's partitioner cuts sections and sectors (`subregion`, the paper's,
    /// when the key is absent; written only when not `subregion`). The machine itself only
    /// sees the sectors it is handed.
    #[serde(default, skip_serializing_if = "PartitionGranularity::is_subregion")]
    pub partition_granularity: PartitionGranularity,
}

/// Which busy cluster the balancer asks for work.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VictimPolicy {
    /// The cluster with the most jobs waiting in its ray buffer (ties: lowest id).
    MostPending,
    /// The next cluster with work after the last victim.
    RoundRobin,
}

/// The `[balance]` table: dynamic workload balancing between clusters. The table is required
/// (no `Default`): a built-in default could only differ from paper.toml, the one source.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BalanceTable {
    /// On or off.
    pub enabled: bool,
    /// Jobs in a work-item.
    pub work_item_jobs: u32,
    /// A request that found no work is retried after this many cycles.
    pub sampling_interval: u32,
    /// Inter-cluster link: cycles before the first word arrives.
    pub link_latency: u32,
    /// Inter-cluster link: words per cycle.
    pub link_words_per_cycle: u32,
    /// Which cluster gives work.
    pub victim: VictimPolicy,
}

impl MachineTable {
    /// Checks every value against `t`, the datapath's t format; the error names the key
    /// (`machine.…`).
    pub fn validate(&self, t: Format) -> Result<(), ConfigError> {
        let err = |key: &str, what: String| ConfigError {
            key: format!("machine.{key}"),
            what,
        };
        let range = |key: &str, v: u64, lo: u64, hi: u64| {
            if v < lo || v > hi {
                Err(err(key, format!("{v} is outside {lo}..={hi}")))
            } else {
                Ok(())
            }
        };
        range("clusters", self.clusters as u64, 1, 256)?;
        range("ctus_per_cluster", self.ctus_per_cluster as u64, 1, 64)?;
        range(
            "dda_cycles_per_step",
            self.dda_cycles_per_step as u64,
            1,
            1000,
        )?;
        range("memory_latency", self.memory_latency as u64, 0, 100_000)?;
        range("scan_ids_per_cycle", self.scan_ids_per_cycle as u64, 1, 64)?;
        range(
            "ray_buffer_capacity",
            self.ray_buffer_capacity as u64,
            1,
            1 << 20,
        )?;
        range(
            "patch_buffer_capacity",
            self.patch_buffer_capacity as u64,
            1,
            1 << 16,
        )?;
        range(
            "request_queue_capacity",
            self.request_queue_capacity as u64,
            1,
            1 << 16,
        )?;
        range(
            "divider_bits_per_stage",
            self.divider_bits_per_stage as u64,
            1,
            64,
        )?;
        range(
            "subshell_max_patches",
            self.subshell_max_patches as u64,
            1,
            1 << 24,
        )?;
        range("watchdog_cycles", self.watchdog_cycles, 10, 1 << 40)?;
        if self.shell_radius != Length::Auto {
            self.shell_raw(t)?;
        }
        if let Length::Value(c) = self.cell_size {
            if !(c.is_finite() && c > 0.0) {
                return Err(err(
                    "cell_size",
                    format!("{c:?} must be a finite length above 0"),
                ));
            }
        }
        Ok(())
    }

    /// The shell radius quantized to the t format `t` (raw, at least one LSB): the host's
    /// one conversion of it. A radius that is not a positive length, rounds to zero, or does
    /// not fit `t` is an error naming `machine.shell_radius` — never clamped.
    pub fn shell_raw(&self, t: Format) -> Result<i64, ConfigError> {
        let err = |what: String| ConfigError {
            key: "machine.shell_radius".into(),
            what,
        };
        let Length::Value(r) = self.shell_radius else {
            return Err(err(
                "auto: the host resolves it from the scene before the machine is built".into(),
            ));
        };
        if !(r.is_finite() && r > 0.0) {
            return Err(err(format!("{r:?} must be a positive length")));
        }
        match t.quantize(r) {
            Some(raw) if raw >= 1 => Ok(raw),
            Some(_) => Err(err(format!(
                "{r:?} rounds to 0 in the t format {t} (its LSB is {})",
                t.lsb()
            ))),
            None => Err(err(format!(
                "{r:?} does not fit the t format {t} (at most {})",
                t.to_f64(t.max_raw())
            ))),
        }
    }
}

impl BalanceTable {
    /// Checks every value; `ray_buffer_capacity` bounds a work-item. The error names the
    /// key (`balance.…`).
    pub fn validate(&self, ray_buffer_capacity: u32) -> Result<(), ConfigError> {
        let berr = |key: &str, what: String| ConfigError {
            key: format!("balance.{key}"),
            what,
        };
        if self.work_item_jobs < 1 || self.work_item_jobs > ray_buffer_capacity {
            return Err(berr(
                "work_item_jobs",
                format!(
                    "{} is outside 1..=ray_buffer_capacity ({})",
                    self.work_item_jobs, ray_buffer_capacity
                ),
            ));
        }
        if !(1..=1 << 20).contains(&self.sampling_interval) {
            return Err(berr(
                "sampling_interval",
                format!("{} is outside 1..=2^20", self.sampling_interval),
            ));
        }
        if self.link_latency > 100_000 {
            return Err(berr(
                "link_latency",
                format!("{} is absurdly large", self.link_latency),
            ));
        }
        if !(1..=64).contains(&self.link_words_per_cycle) {
            return Err(berr(
                "link_words_per_cycle",
                format!("{} is outside 1..=64", self.link_words_per_cycle),
            ));
        }
        Ok(())
    }
}
