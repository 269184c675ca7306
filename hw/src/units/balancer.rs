//! Dynamic workload balancing (the paper's Distribute Work and Sampling Work nodes) and the
//! inter-cluster link.
//!
//! A cluster whose ray buffer was empty at the last edge, with no work on its way, raises a
//! work request. The balancer serves requests in cluster order: it picks a victim — the
//! cluster with the most jobs waiting (or, as an option, the next one round-robin with
//! work) — and orders its ray buffer to split off a work-item of up to `work_item_jobs`
//! jobs from the back of its queue. The work-item crosses the inter-cluster link: job i
//! arrives `link_latency + ⌈(i+1)·JOB_WORDS / link_words_per_cycle⌉` cycles after the split
//! and enters the thief's ray buffer. Results of moved jobs travel back over the link
//! (latency plus one word-time) to the owner's CTU, which keeps the nearest hit and joins
//! its shell as usual. A request that finds no work is retried after `sampling_interval`.
//! Every job is computed exactly once: a split removes jobs from the victim's queue.

use crate::config::{BalanceTable, VictimPolicy};
use crate::link::{Link, UnitId};
use crate::msg::{Job, JobResult, RemoteResult, SplitOrder, WorkItem, JOB_WORDS};
use std::collections::VecDeque;

/// The balancer's end of its links (rule 7).
const ME: UnitId = UnitId::Balancer;

/// A cluster's work request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Request {
    /// Next cycle the balancer looks for a victim.
    next_try: u64,
    /// A split order is out; waiting for the work-item.
    ordered: bool,
}

/// Balancer counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct BalancerStats {
    pub work_requests: u64,
    pub split_orders: u64,
    /// Work-items that carried jobs.
    pub work_items: u64,
    /// Requests answered with no work, retried after the sampling interval.
    pub retries: u64,
    pub jobs_moved: u64,
    pub link_words: u64,
    pub results_returned: u64,
}

/// The balancer and the inter-cluster link.
#[derive(Clone, Debug)]
pub struct Balancer {
    cfg: BalanceTable,
    requests: Vec<Option<Request>>,
    next_victim: usize,
    /// Jobs on their way to each cluster: (arrival cycle, job).
    inbound: Vec<VecDeque<(u64, Job)>>,
    /// Results on their way home to each cluster.
    returns: Vec<VecDeque<(u64, RemoteResult)>>,
    pub stats: BalancerStats,
}

/// The links the balancer reaches, one per cluster.
pub struct BalancerPorts<'a> {
    /// Each ray buffer's registered occupancy (committed state).
    pub occupancy: &'a [usize],
    pub orders: &'a mut [Link<SplitOrder>],
    pub items: &'a mut [Link<WorkItem>],
    pub to_ray_buffers: &'a mut [Link<Job>],
    pub from_icus: &'a mut [Link<RemoteResult>],
    /// Per CTU, cluster-major: CTU j of cluster c is `c * ctus_per_cluster + j`.
    pub to_ctus: &'a mut [Link<JobResult>],
    pub ctus_per_cluster: usize,
}

impl Balancer {
    /// A balancer for `clusters` clusters.
    pub fn new(cfg: BalanceTable, clusters: usize) -> Self {
        Balancer {
            cfg,
            requests: vec![None; clusters],
            next_victim: 0,
            inbound: vec![VecDeque::new(); clusters],
            returns: vec![VecDeque::new(); clusters],
            stats: BalancerStats::default(),
        }
    }

    /// True when nothing is on the link and no split order is out.
    pub fn idle(&self) -> bool {
        self.inbound.iter().all(VecDeque::is_empty)
            && self.returns.iter().all(VecDeque::is_empty)
            && self.requests.iter().all(|r| !r.is_some_and(|r| r.ordered))
    }

    /// True when cluster `c` would raise a new request this cycle.
    pub fn would_request(&self, c: usize, occupancy: usize, net_in_empty: bool) -> bool {
        self.requests[c].is_none() && occupancy == 0 && self.inbound[c].is_empty() && net_in_empty
    }

    /// True when cluster `c` has asked for work and not yet got it.
    pub fn requesting(&self, c: usize) -> bool {
        self.requests[c].is_some()
    }

    /// Jobs on their way to cluster `c`.
    pub fn inbound(&self, c: usize) -> usize {
        self.inbound[c].len()
    }

    /// The earliest cycle after `now` at which the balancer acts on its own.
    pub fn timer(&self, now: u64) -> Option<u64> {
        let mut t: Option<u64> = None;
        let mut take = |x: u64| {
            if x > now {
                t = Some(t.map_or(x, |y| y.min(x)));
            }
        };
        for r in self.requests.iter().flatten() {
            if !r.ordered {
                take(r.next_try);
            }
        }
        for q in &self.inbound {
            if let Some(&(a, _)) = q.front() {
                take(a);
            }
        }
        for q in &self.returns {
            if let Some(&(a, _)) = q.front() {
                take(a);
            }
        }
        t
    }

    /// True when something is due at `now` (the clock must not jump).
    pub fn due(&self, now: u64) -> bool {
        self.requests
            .iter()
            .flatten()
            .any(|r| !r.ordered && r.next_try <= now)
            || self
                .inbound
                .iter()
                .any(|q| q.front().is_some_and(|&(a, _)| a <= now))
            || self
                .returns
                .iter()
                .any(|q| q.front().is_some_and(|&(a, _)| a <= now))
    }

    fn link_cycles(&self, words: u64) -> u64 {
        self.cfg.link_latency as u64 + words.div_ceil(self.cfg.link_words_per_cycle as u64)
    }

    /// One clock cycle.
    pub fn tick(&mut self, now: u64, io: &mut BalancerPorts) {
        let n = self.requests.len();
        // Work-items from victims go onto the link (or, empty, send their thief to wait).
        for c in 0..n {
            if io.items[c].peek().is_some() {
                let item = io.items[c].pop(ME);
                let thief = item.to as usize;
                if item.jobs.is_empty() {
                    self.requests[thief] = Some(Request {
                        next_try: now + self.cfg.sampling_interval as u64,
                        ordered: false,
                    });
                    self.stats.retries += 1;
                } else {
                    for (i, job) in item.jobs.iter().enumerate() {
                        let at = now + self.link_cycles((i as u64 + 1) * JOB_WORDS as u64);
                        self.inbound[thief].push_back((at, *job));
                    }
                    self.stats.work_items += 1;
                    self.stats.jobs_moved += item.jobs.len() as u64;
                    self.stats.link_words += item.jobs.len() as u64 * JOB_WORDS as u64;
                    self.requests[thief] = None;
                }
            }
        }
        // Deliver arrived jobs, one per cycle per cluster.
        for c in 0..n {
            if let Some(&(at, job)) = self.inbound[c].front() {
                if at <= now && io.to_ray_buffers[c].can_push() {
                    io.to_ray_buffers[c].push(ME, job);
                    self.inbound[c].pop_front();
                }
            }
        }
        // Results of moved jobs go home.
        for c in 0..n {
            if io.from_icus[c].peek().is_some() {
                let r = io.from_icus[c].pop(ME);
                let at = now + self.link_cycles(JOB_WORDS as u64);
                self.returns[r.owner as usize].push_back((at, r));
                self.stats.link_words += JOB_WORDS as u64;
            }
        }
        for c in 0..n {
            if let Some(&(at, r)) = self.returns[c].front() {
                let port = &mut io.to_ctus[c * io.ctus_per_cluster + r.ctu as usize];
                if at <= now && port.can_push() {
                    port.push(ME, r.result);
                    self.returns[c].pop_front();
                    self.stats.results_returned += 1;
                }
            }
        }
        // New requests from clusters whose ray buffer ran empty with nothing on its way.
        for c in 0..n {
            if self.would_request(c, io.occupancy[c], io.to_ray_buffers[c].is_empty()) {
                self.requests[c] = Some(Request {
                    next_try: now,
                    ordered: false,
                });
                self.stats.work_requests += 1;
            }
        }
        // Serve due requests: one split order per victim per cycle.
        for c in 0..n {
            let Some(r) = self.requests[c] else { continue };
            if r.ordered || r.next_try > now {
                continue;
            }
            match self.victim(c, io) {
                Some(v) => {
                    io.orders[v].push(
                        ME,
                        SplitOrder {
                            thief: c as u16,
                            jobs: self.cfg.work_item_jobs,
                        },
                    );
                    self.requests[c] = Some(Request { ordered: true, ..r });
                    self.stats.split_orders += 1;
                }
                None => {
                    self.requests[c] = Some(Request {
                        next_try: now + self.cfg.sampling_interval as u64,
                        ordered: false,
                    });
                    self.stats.retries += 1;
                }
            }
        }
    }

    /// A victim for `thief`: a cluster with at least two jobs waiting (one stays for its own
    /// ICU) whose order link is free this cycle.
    fn victim(&mut self, thief: usize, io: &BalancerPorts) -> Option<usize> {
        let n = self.requests.len();
        let ok = |v: usize| v != thief && io.occupancy[v] >= 2 && io.orders[v].can_push();
        match self.cfg.victim {
            VictimPolicy::MostPending => (0..n)
                .filter(|&v| ok(v))
                .max_by_key(|&v| (io.occupancy[v], std::cmp::Reverse(v))),
            VictimPolicy::RoundRobin => {
                let v = (0..n)
                    .map(|k| (self.next_victim + k) % n)
                    .find(|&v| ok(v))?;
                self.next_victim = (v + 1) % n;
                Some(v)
            }
        }
    }
}
