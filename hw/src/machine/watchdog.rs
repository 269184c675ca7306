//! The watchdog: a run that makes no progress for `watchdog_cycles` stops with a report of
//! every unit's state; `activity` is the progress it watches. Both walk the units through the
//! registry ([`Machine::each_unit`]).

use super::Machine;
use std::ops::ControlFlow;

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
    /// The watchdog's report: every unit's state (`Unit::report`), one line each.
    pub(super) fn deadlock(&self) -> Deadlock {
        let mut report = Vec::new();
        let _ = self.each_unit(|id, u| {
            report.push(format!("{id}: {}", u.report(self.cycle)));
            ControlFlow::<()>::Continue(())
        });
        Deadlock {
            cycle: self.cycle,
            report,
        }
    }

    /// A number that grows whenever anything moves: every unit's `Unit::activity` (steps,
    /// grants, transfers) and the memory requests' transfers.
    pub(super) fn activity(&self) -> u64 {
        let mut a = self.links.requests.iter().map(|l| l.transfers).sum::<u64>();
        let _ = self.each_unit(|_, u| {
            a += u.activity();
            ControlFlow::<()>::Continue(())
        });
        a
    }
}
