//! The cycle jump: when every link and pipeline is empty and every unit waits on a timer, the
//! clock moves to the earliest timer and each unit accounts the skipped cycles. Both walk
//! the units through the registry ([`Machine::each_unit`], the `Unit` trait).

use super::Machine;
use crate::units::Around;
use std::ops::ControlFlow;

impl Machine<'_> {
    /// The cycle the clock may jump to from `now`: every link empty, every unit quiet
    /// (`Unit::quiet`), and a timer ahead (the earliest `Unit::timer`). `None` when something
    /// can act at `now`. `busy`: the run's hint of a busy cluster
    /// ([`Machine::some_cluster_busy`]).
    pub(super) fn quiet_until(&self, now: u64, busy: &mut usize) -> Option<u64> {
        // The cheapest tests that fail while the machine works come first (all of them are
        // pure reads): a cluster holding work, then a message on a link.
        if self.some_cluster_busy(busy) || !self.links.all_empty() {
            return None;
        }
        let waiting = |c: usize| self.clusters[c].ray_buffer.waiting();
        let around = Around {
            links: &self.links,
            waiting: &waiting,
        };
        let mut t: Option<u64> = None;
        let quiet = self.each_unit(|_, u| {
            if !u.quiet(now, &around) {
                return ControlFlow::Break(());
            }
            if let Some(x) = u.timer(now) {
                t = Some(t.map_or(x, |y: u64| y.min(x)));
            }
            ControlFlow::Continue(())
        });
        // Only a jump of at least one cycle is worth it.
        t.filter(|&t| quiet.is_continue() && t > now + 1)
    }

    /// Accounts `n` skipped cycles in every unit.
    pub(super) fn skip(&mut self, n: u64) {
        let now = self.cycle;
        self.each_unit_mut(|_, u| u.skip(now, n));
        self.last_progress_cycle += n;
        self.skipped_cycles += n;
    }
}
