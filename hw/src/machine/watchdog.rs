//! The watchdog: a run that makes no progress for `watchdog_cycles` stops with a report of
//! every unit's state.

use super::Machine;

/// Why a run stopped without finishing.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Deadlock {
    pub cycle: u64,
    /// One line per unit: its state.
    pub report: Vec<String>,
}

impl std::fmt::Display for Deadlock {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "no progress for the watchdog's cycles; at cycle {}:",
            self.cycle
        )?;
        for l in &self.report {
            writeln!(f, "  {l}")?;
        }
        Ok(())
    }
}

impl Machine<'_> {
    /// The watchdog's report: every unit's state.
    pub(super) fn deadlock(&self) -> Deadlock {
        let mut report = vec![format!(
            "memory: port {}, {} in flight, {} grants",
            if self.memory.port_busy(self.cycle) {
                "busy"
            } else {
                "free"
            },
            self.memory.inflight(),
            self.memory.stats.grants
        )];
        for (i, cl) in self.clusters.iter().enumerate() {
            report.push(format!(
                "cluster {i}: icu {} of {} stages full, ray buffer {}/{}, patch buffer {}",
                cl.icu.occupied(),
                cl.icu.depth(),
                cl.ray_buffer.queue.len(),
                cl.ray_buffer.queue.capacity(),
                cl.patch_buffer.store.len()
            ));
            for (j, c) in cl.ctus.iter().enumerate() {
                report.push(format!(
                    "cluster {i} ctu {j}: {} shell {} remaining {} outstanding {} pending loads {}",
                    c.state.name(),
                    c.shell(),
                    c.remaining(),
                    c.outstanding(),
                    c.pending_loads()
                ));
            }
        }
        Deadlock {
            cycle: self.cycle,
            report,
        }
    }
}
