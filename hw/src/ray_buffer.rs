//! The ray buffer: a cluster's bounded queue of pending (ray, patch) jobs feeding its ICU.
//! It takes at most one job per cycle from its CTUs' job links, round-robin among those
//! with a job waiting.

use crate::link::Link;
use crate::msg::Job;

/// Ray-buffer counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct RayBufferStats {
    pub jobs_in: u64,
    /// Σ occupancy over cycles (mean occupancy = this / cycles).
    pub occupancy_sum: u64,
    pub max_occupancy: u64,
}

/// The ray buffer.
#[derive(Clone, Debug)]
pub struct RayBuffer {
    /// The queue the ICU pops.
    pub queue: Link<Job>,
    next: usize,
    pub stats: RayBufferStats,
}

impl RayBuffer {
    /// A buffer of `capacity` jobs.
    pub fn new(capacity: u32) -> Self {
        RayBuffer {
            queue: Link::new(capacity as usize),
            next: 0,
            stats: RayBufferStats::default(),
        }
    }

    /// One clock cycle: move one job from the next CTU (round-robin) with one waiting.
    pub fn tick(&mut self, inputs: &mut [Link<Job>]) {
        let occ = self.queue.len() as u64;
        self.stats.occupancy_sum += occ;
        self.stats.max_occupancy = self.stats.max_occupancy.max(occ);
        if !self.queue.can_push() {
            return;
        }
        let n = inputs.len();
        for k in 0..n {
            let i = (self.next + k) % n;
            if inputs[i].peek().is_some() {
                let job = inputs[i].pop();
                self.queue.push(job);
                self.stats.jobs_in += 1;
                self.next = (i + 1) % n;
                return;
            }
        }
    }
}
