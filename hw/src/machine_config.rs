//! The machine's configuration: the `[machine]` table of hw/configs/*.toml (clusters, CTUs,
//! timing, buffers, arbiter) with the `[datapath]` formats, validated into one typed value.

use crate::config::{ConfigError, DatapathConfig};
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
    /// Shell radius (in units of the scene; the paper's 0.289).
    pub shell_radius: f64,
    /// Jump over cycles in which every unit waits on a timer.
    pub cycle_jump: bool,
    /// Stop with a report when nothing progresses for this many cycles.
    pub watchdog_cycles: u64,
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

/// The `[balance]` table: dynamic workload balancing between clusters.
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

impl Default for BalanceTable {
    fn default() -> Self {
        BalanceTable {
            enabled: false,
            work_item_jobs: 16,
            sampling_interval: 32,
            link_latency: 4,
            link_words_per_cycle: 1,
            victim: VictimPolicy::MostPending,
        }
    }
}

/// A whole machine configuration file.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineConfig {
    pub machine: MachineTable,
    #[serde(default)]
    pub balance: BalanceTable,
    pub datapath: DatapathConfig,
}

impl MachineConfig {
    /// Parses and validates a configuration file's text.
    pub fn from_toml_str(text: &str) -> Result<Self, ConfigError> {
        let cfg: MachineConfig = toml::from_str(text).map_err(|e| ConfigError {
            key: e
                .span()
                .map(|s| format!("bytes {}..{}", s.start, s.end))
                .unwrap_or_else(|| "toml".into()),
            what: e.message().to_string(),
        })?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Checks every value; the error names the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.datapath.formats()?;
        let m = &self.machine;
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
        range("clusters", m.clusters as u64, 1, 256)?;
        range("ctus_per_cluster", m.ctus_per_cluster as u64, 1, 64)?;
        range("dda_cycles_per_step", m.dda_cycles_per_step as u64, 1, 1000)?;
        range("memory_latency", m.memory_latency as u64, 0, 100_000)?;
        range(
            "ray_buffer_capacity",
            m.ray_buffer_capacity as u64,
            1,
            1 << 20,
        )?;
        range(
            "patch_buffer_capacity",
            m.patch_buffer_capacity as u64,
            1,
            1 << 16,
        )?;
        range(
            "request_queue_capacity",
            m.request_queue_capacity as u64,
            1,
            1 << 16,
        )?;
        range(
            "divider_bits_per_stage",
            m.divider_bits_per_stage as u64,
            1,
            64,
        )?;
        range(
            "subshell_max_patches",
            m.subshell_max_patches as u64,
            1,
            1 << 24,
        )?;
        range("watchdog_cycles", m.watchdog_cycles, 10, 1 << 40)?;
        let b = &self.balance;
        let berr = |key: &str, what: String| ConfigError {
            key: format!("balance.{key}"),
            what,
        };
        if b.work_item_jobs < 1 || b.work_item_jobs > m.ray_buffer_capacity {
            return Err(berr(
                "work_item_jobs",
                format!(
                    "{} is outside 1..=ray_buffer_capacity ({})",
                    b.work_item_jobs, m.ray_buffer_capacity
                ),
            ));
        }
        if !(1..=1 << 20).contains(&b.sampling_interval) {
            return Err(berr(
                "sampling_interval",
                format!("{} is outside 1..=2^20", b.sampling_interval),
            ));
        }
        if b.link_latency > 100_000 {
            return Err(berr(
                "link_latency",
                format!("{} is absurdly large", b.link_latency),
            ));
        }
        if !(1..=64).contains(&b.link_words_per_cycle) {
            return Err(berr(
                "link_words_per_cycle",
                format!("{} is outside 1..=64", b.link_words_per_cycle),
            ));
        }
        if !(m.shell_radius.is_finite() && m.shell_radius > 0.0 && m.shell_radius <= 1e6) {
            return Err(err(
                "shell_radius",
                format!("{} must be a positive length", m.shell_radius),
            ));
        }
        Ok(())
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
