//! The cycle jump: when every link and pipeline is empty and every unit waits on a timer, the
//! clock moves to the earliest timer and each unit accounts the skipped cycles.

use super::Machine;

impl Machine<'_> {
    /// The cycle the clock may jump to from `now`: every link empty, every ICU empty, every
    /// CTU quiet, and a timer ahead. `None` when something can act at `now`. `busy`: the
    /// run's hint of a busy cluster ([`Machine::some_cluster_busy`]).
    pub(super) fn quiet_until(&self, now: u64, busy: &mut usize) -> Option<u64> {
        // The cheapest test that fails while the machine works comes first, and each test
        // runs only when the ones before it passed (all of them are pure reads).
        if self.some_cluster_busy(busy) || !self.links.all_empty() {
            return None;
        }
        let balancer_acts = self.cfg.balance.enabled
            && (self.balancer.due(now)
                || (0..self.clusters.len()).any(|c| {
                    self.balancer.would_request(
                        c,
                        self.clusters[c].ray_buffer.waiting(),
                        self.links.net_in[c].is_empty() && self.links.net_desc[c].is_empty(),
                    )
                }));
        if balancer_acts
            || !self
                .clusters
                .iter()
                .flat_map(|c| &c.ctus)
                .all(|c| c.quiet(now))
        {
            return None;
        }
        let mut t = self.memory.timer(now);
        if let Some(x) = self.balancer.timer(now) {
            t = Some(t.map_or(x, |y: u64| y.min(x)));
        }
        for c in self.clusters.iter().flat_map(|c| &c.ctus) {
            if let Some(x) = c.timer(now) {
                t = Some(t.map_or(x, |y: u64| y.min(x)));
            }
        }
        // Only a jump of at least one cycle is worth it; a pending delivery acts at once.
        t.filter(|&t| t > now + 1 && self.memory.inflight_ready(now).is_none())
    }

    /// Accounts `n` skipped cycles in every unit.
    pub(super) fn skip(&mut self, n: u64) {
        let now = self.cycle;
        self.memory.skip(now, n);
        for cl in &mut self.clusters {
            cl.icu.skip(n);
            for c in &mut cl.ctus {
                c.skip(n);
            }
        }
        self.last_progress_cycle += n;
        self.skipped_cycles += n;
    }
}
