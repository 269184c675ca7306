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
//!
//! With `job_source = "bundle"` a work-item is a descriptor cut off the victim's last
//! waiting descriptor: it arrives whole `link_latency + ⌈words / link_words_per_cycle⌉`
//! cycles after the split, its words the descriptor's and one per ray id
//! ([`Descriptor::link_words`]), and enters the thief's ray buffer as a descriptor.

use crate::config::{BalanceTable, VictimPolicy};
use crate::link::{Link, UnitId};
use crate::machine::sink::Sink;
use crate::msg::{Descriptor, Job, JobResult, RemoteResult, SplitOrder, WorkItem, JOB_WORDS};
use crate::units::{Around, Unit};
use std::collections::VecDeque;

/// The balancer's end of its links (rule 7).
const ME: UnitId = UnitId::Balancer;

/// Moves each cluster's front entry of `queues` that has arrived by `now` onto its link, if
/// the link is ready (one per cycle per cluster); `queued` counts the entries of all of
/// `queues`, so empty queues are not walked.
fn deliver<T: Copy>(
    now: u64,
    queues: &mut [VecDeque<(u64, T)>],
    links: &mut [Link<T>],
    queued: &mut usize,
) {
    if *queued == 0 {
        return;
    }
    for (q, link) in queues.iter_mut().zip(links) {
        if let Some(&(at, x)) = q.front() {
            if at <= now && link.can_push() {
                link.push(ME, x);
                q.pop_front();
                *queued -= 1;
            }
        }
    }
}

/// True when some queue's front entry has arrived by `now`; `queued` counts the entries of
/// all of `queues`, so empty queues are not walked.
fn arrived<T>(now: u64, queues: &[VecDeque<(u64, T)>], queued: usize) -> bool {
    queued > 0
        && queues
            .iter()
            .any(|q| q.front().is_some_and(|&(a, _)| a <= now))
}

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
    /// Descriptors on their way to each cluster (bundle).
    inbound_desc: Vec<VecDeque<(u64, Descriptor)>>,
    /// Results on their way home to each cluster.
    returns: Vec<VecDeque<(u64, RemoteResult)>>,
    /// Entries of `inbound`, `inbound_desc` and `returns` (all clusters): a family with none
    /// is not walked.
    queued: [usize; 3],
    /// Split orders out (requests `ordered`): only then can a work-item be on its way back.
    orders_out: usize,
    /// Jobs moved whose results have not come back from the ICU that computed them: only
    /// then can a remote result wait at an ICU's link.
    away: u64,
    /// A cluster asks for work when its ray buffer holds at most this many jobs: 0 (empty)
    /// for `job_source = "ctu"`; for `"bundle"` a work-item's worth, so the next one is on
    /// the link while the last is computed.
    low_water: usize,
    pub stats: BalancerStats,
}

/// The links the balancer reaches, one per cluster.
pub struct BalancerPorts<'a> {
    /// Each ray buffer's registered occupancy (committed state).
    pub occupancy: &'a [usize],
    pub orders: &'a mut [Link<SplitOrder>],
    pub items: &'a mut [Link<WorkItem>],
    pub to_ray_buffers: &'a mut [Link<Job>],
    /// Split descriptors to each ray buffer (bundle).
    pub desc_to_ray_buffers: &'a mut [Link<Descriptor>],
    pub from_icus: &'a mut [Link<RemoteResult>],
    /// Per CTU, cluster-major: CTU j of cluster c is `c * ctus_per_cluster + j`.
    pub to_ctus: &'a mut [Link<JobResult>],
    pub ctus_per_cluster: usize,
}

impl Balancer {
    /// The balancer's waveform signals: [`Balancer::signals`] reports exactly these.
    pub const SIGNALS: usize = 3;
    /// Per cluster, in its balance scope: [`Balancer::cluster_signals`] reports these.
    pub const CLUSTER_SIGNALS: usize = 1 + 1;
    /// Per cluster, in its ray buffer's scope (bundle): [`Balancer::ray_buffer_signals`].
    pub const RAY_BUFFER_SIGNALS: usize = 1;

    /// Reports the balancer's own waveform signals to `s` under `scope` (a new signal: one
    /// line here, counted in [`Balancer::SIGNALS`]).
    #[inline(always)]
    pub(crate) fn signals(&self, s: &mut impl Sink, scope: &str) {
        s.bits(scope, "split_orders", 32, self.stats.split_orders);
        s.bits(scope, "jobs_moved", 32, self.stats.jobs_moved);
        s.bits(scope, "retries", 32, self.stats.retries);
    }

    /// Reports what the balancer holds for cluster `c` to `s` under the cluster's balance
    /// `scope` ([`Balancer::CLUSTER_SIGNALS`]).
    #[inline(always)]
    pub(crate) fn cluster_signals(&self, s: &mut impl Sink, scope: &str, c: usize) {
        s.bits(scope, "work_request", 1, self.requesting(c) as u64);
        s.bits(scope, "jobs_inbound", 16, self.inbound(c) as u64);
    }

    /// Reports the descriptors on their way to cluster `c` to `s` under its ray buffer's
    /// `scope` ([`Balancer::RAY_BUFFER_SIGNALS`]; bundle only).
    #[inline(always)]
    pub(crate) fn ray_buffer_signals(&self, s: &mut impl Sink, scope: &str, c: usize) {
        s.bits(
            scope,
            "descriptors_inbound",
            16,
            self.inbound_descriptors(c) as u64,
        );
    }

    /// A balancer for `clusters` clusters.
    pub fn new(cfg: BalanceTable, clusters: usize) -> Self {
        Balancer {
            cfg,
            requests: vec![None; clusters],
            next_victim: 0,
            inbound: vec![VecDeque::new(); clusters],
            inbound_desc: vec![VecDeque::new(); clusters],
            returns: vec![VecDeque::new(); clusters],
            queued: [0; 3],
            orders_out: 0,
            away: 0,
            low_water: 0,
            stats: BalancerStats::default(),
        }
    }

    /// The same balancer asking for work at `jobs` waiting or fewer (see `low_water`).
    pub fn with_low_water(mut self, jobs: usize) -> Self {
        self.low_water = jobs;
        self
    }

    /// True when nothing is on the link and no split order is out.
    pub fn idle(&self) -> bool {
        self.inbound.iter().all(VecDeque::is_empty)
            && self.inbound_desc.iter().all(VecDeque::is_empty)
            && self.returns.iter().all(VecDeque::is_empty)
            && self.requests.iter().all(|r| !r.is_some_and(|r| r.ordered))
    }

    /// True when cluster `c` would raise a new request this cycle.
    pub fn would_request(&self, c: usize, occupancy: usize, net_in_empty: bool) -> bool {
        self.wants_work(c, occupancy, || net_in_empty)
    }

    /// [`Balancer::would_request`] with the links' test last (read only when needed).
    #[inline(always)]
    fn wants_work(&self, c: usize, occupancy: usize, net_in_empty: impl FnOnce() -> bool) -> bool {
        self.requests[c].is_none()
            && occupancy <= self.low_water
            && self.inbound[c].is_empty()
            && self.inbound_desc[c].is_empty()
            && net_in_empty()
    }

    /// True when cluster `c` has asked for work and not yet got it.
    pub fn requesting(&self, c: usize) -> bool {
        self.requests[c].is_some()
    }

    /// Jobs on their way to cluster `c`.
    pub fn inbound(&self, c: usize) -> usize {
        self.inbound[c].len()
    }

    /// Descriptors on their way to cluster `c` (bundle).
    pub fn inbound_descriptors(&self, c: usize) -> usize {
        self.inbound_desc[c].len()
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
        for q in &self.inbound_desc {
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
            || arrived(now, &self.inbound, self.queued[0])
            || arrived(now, &self.returns, self.queued[2])
            || arrived(now, &self.inbound_desc, self.queued[1])
    }

    fn link_cycles(&self, words: u64) -> u64 {
        self.cfg.link_latency as u64 + words.div_ceil(self.cfg.link_words_per_cycle as u64)
    }

    /// One clock cycle.
    pub fn tick(&mut self, now: u64, io: &mut BalancerPorts) {
        let n = self.requests.len();
        // Work-items from victims go onto the link (or, empty, send their thief to wait).
        for c in 0..if self.orders_out > 0 { n } else { 0 } {
            if io.items[c].valid() {
                let item = io.items[c].pop(ME);
                self.orders_out -= 1;
                let thief = item.to as usize;
                if let Some(d) = item.desc {
                    let words = d.link_words();
                    let at = now + self.link_cycles(words);
                    self.inbound_desc[thief].push_back((at, d));
                    self.queued[1] += 1;
                    self.stats.work_items += 1;
                    self.stats.jobs_moved += d.jobs() as u64;
                    self.away += d.jobs() as u64;
                    self.stats.link_words += words;
                    self.requests[thief] = None;
                } else if item.jobs.is_empty() {
                    self.requests[thief] = Some(Request {
                        next_try: now + self.cfg.sampling_interval as u64,
                        ordered: false,
                    });
                    self.stats.retries += 1;
                } else {
                    for (i, job) in item.jobs.iter().enumerate() {
                        let at = now + self.link_cycles((i as u64 + 1) * JOB_WORDS as u64);
                        self.inbound[thief].push_back((at, *job));
                        self.queued[0] += 1;
                    }
                    self.stats.work_items += 1;
                    self.stats.jobs_moved += item.jobs.len() as u64;
                    self.away += item.jobs.len() as u64;
                    self.stats.link_words += item.jobs.len() as u64 * JOB_WORDS as u64;
                    self.requests[thief] = None;
                }
            }
        }
        // Deliver arrived jobs and descriptors, one of each per cycle per cluster.
        deliver(
            now,
            &mut self.inbound,
            io.to_ray_buffers,
            &mut self.queued[0],
        );
        deliver(
            now,
            &mut self.inbound_desc,
            io.desc_to_ray_buffers,
            &mut self.queued[1],
        );
        // Results of moved jobs go home.
        for c in 0..if self.away > 0 { n } else { 0 } {
            if io.from_icus[c].valid() {
                let r = io.from_icus[c].pop(ME);
                self.away -= 1;
                let at = now + self.link_cycles(JOB_WORDS as u64);
                self.returns[r.owner as usize].push_back((at, r));
                self.queued[2] += 1;
                self.stats.link_words += JOB_WORDS as u64;
            }
        }
        let returning = self.queued[2] > 0;
        for c in (0..n).filter(|_| returning) {
            if let Some(&(at, r)) = self.returns[c].front() {
                let port = &mut io.to_ctus[c * io.ctus_per_cluster + r.ctu as usize];
                if at <= now && port.can_push() {
                    port.push(ME, r.result);
                    self.returns[c].pop_front();
                    self.queued[2] -= 1;
                    self.stats.results_returned += 1;
                }
            }
        }
        // Per cluster: a new request from one whose ray buffer ran empty with nothing on its
        // way, then due requests served (one split order per victim per cycle). Serving
        // cluster c touches nothing a later cluster's request reads, so one walk does both.
        for c in 0..n {
            let r = match self.requests[c] {
                Some(r) if r.ordered || r.next_try > now => continue,
                Some(r) => r,
                None => {
                    let net_empty =
                        || io.to_ray_buffers[c].is_empty() && io.desc_to_ray_buffers[c].is_empty();
                    if !self.wants_work(c, io.occupancy[c], net_empty) {
                        continue;
                    }
                    let r = Request {
                        next_try: now,
                        ordered: false,
                    };
                    self.requests[c] = Some(r);
                    self.stats.work_requests += 1;
                    r
                }
            };
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
                    self.orders_out += 1;
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

/// The balancer's cold paths: it acts when a request, a job, a descriptor or a result is due,
/// or when a cluster would ask for work (only when balancing is on: otherwise it never
/// ticks); its timer is the next of those.
impl Unit for Balancer {
    fn quiet(&self, now: u64, around: &Around) -> bool {
        !self.cfg.enabled
            || !(self.due(now)
                || (0..self.requests.len()).any(|c| {
                    self.would_request(c, (around.waiting)(c), !around.links.waiting_for(c))
                }))
    }

    fn timer(&self, now: u64) -> Option<u64> {
        Balancer::timer(self, now)
    }

    fn activity(&self) -> u64 {
        self.stats.jobs_moved + self.stats.results_returned
    }

    fn done(&self) -> bool {
        self.idle()
    }

    fn report(&self, _now: u64) -> String {
        format!(
            "{}, {} requests open, {} split orders out, {} jobs away, {} on the link",
            if self.cfg.enabled { "on" } else { "off" },
            self.requests.iter().flatten().count(),
            self.orders_out,
            self.away,
            self.queued.iter().sum::<usize>()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(victim: VictimPolicy) -> BalanceTable {
        BalanceTable {
            enabled: true,
            work_item_jobs: 3,
            sampling_interval: 10,
            link_latency: 4,
            link_words_per_cycle: 1,
            victim,
        }
    }

    /// The balancer's links for `n` clusters of one CTU each.
    struct Net {
        orders: Vec<Link<SplitOrder>>,
        items: Vec<Link<WorkItem>>,
        net_in: Vec<Link<Job>>,
        net_desc: Vec<Link<Descriptor>>,
        remote_out: Vec<Link<RemoteResult>>,
        remote_in: Vec<Link<JobResult>>,
    }

    impl Net {
        fn new(n: usize) -> Self {
            Net {
                orders: (0..n).map(|_| Link::new(1)).collect(),
                items: (0..n).map(|_| Link::new(1)).collect(),
                net_in: (0..n).map(|_| Link::new(2)).collect(),
                net_desc: (0..n).map(|_| Link::new(2)).collect(),
                remote_out: (0..n).map(|_| Link::new(2)).collect(),
                remote_in: (0..n).map(|_| Link::new(2)).collect(),
            }
        }

        fn tick(&mut self, b: &mut Balancer, now: u64, occupancy: &[usize]) {
            let mut io = BalancerPorts {
                occupancy,
                orders: &mut self.orders,
                items: &mut self.items,
                to_ray_buffers: &mut self.net_in,
                desc_to_ray_buffers: &mut self.net_desc,
                from_icus: &mut self.remote_out,
                to_ctus: &mut self.remote_in,
                ctus_per_cluster: 1,
            };
            b.tick(now, &mut io);
            self.commit();
        }

        fn commit(&mut self) {
            self.orders.iter_mut().for_each(Link::commit);
            self.items.iter_mut().for_each(Link::commit);
            self.net_in.iter_mut().for_each(Link::commit);
            self.net_desc.iter_mut().for_each(Link::commit);
            self.remote_out.iter_mut().for_each(Link::commit);
            self.remote_in.iter_mut().for_each(Link::commit);
        }

        /// The split order waiting at cluster `v`'s ray buffer, taken.
        fn order(&mut self, v: usize) -> Option<SplitOrder> {
            let o = self.orders[v]
                .peek()
                .is_some()
                .then(|| self.orders[v].pop(UnitId::RayBuffer(v)));
            self.orders[v].commit();
            o
        }
    }

    fn job(ray: u32) -> Job {
        Job {
            ray,
            slot: ray,
            patch: 0,
            ctu: 0,
            owner: 0,
        }
    }

    #[test]
    fn an_empty_cluster_asks_and_the_most_pending_cluster_gets_the_split_order() {
        let mut b = Balancer::new(cfg(VictimPolicy::MostPending), 4);
        let mut net = Net::new(4);
        // Cluster 1 is empty; 2 and 3 tie on most jobs: the lower id is the victim.
        net.tick(&mut b, 0, &[5, 0, 9, 9]);
        assert_eq!(b.stats.work_requests, 1);
        assert!(b.requesting(1));
        assert_eq!(net.order(2), Some(SplitOrder { thief: 1, jobs: 3 }));
        assert_eq!(net.order(3), None);
    }

    #[test]
    fn a_low_water_mark_asks_before_the_buffer_runs_empty() {
        let mut b = Balancer::new(cfg(VictimPolicy::MostPending), 2).with_low_water(3);
        let mut net = Net::new(2);
        net.tick(&mut b, 0, &[4, 9]);
        assert_eq!(b.stats.work_requests, 0);
        net.tick(&mut b, 1, &[3, 9]);
        assert!(b.requesting(0));
        assert_eq!(net.order(1), Some(SplitOrder { thief: 0, jobs: 3 }));
    }

    #[test]
    fn a_split_descriptor_crosses_the_link_as_one_message_costed_in_words() {
        let mut b = Balancer::new(cfg(VictimPolicy::MostPending), 2);
        let mut net = Net::new(2);
        net.tick(&mut b, 0, &[0, 50]);
        net.order(1).unwrap();
        let d = Descriptor {
            patch: 7,
            ctu: 0,
            owner: 1,
            list: 0,
            lo: 10,
            hi: 15,
        };
        net.items[1].push(
            UnitId::RayBuffer(1),
            WorkItem {
                from: 1,
                to: 0,
                jobs: vec![],
                desc: Some(d),
            },
        );
        net.commit();
        let mut arrived = None;
        for now in 1..40 {
            net.tick(&mut b, now, &[1, 40]);
            if net.net_desc[0].peek().is_some() {
                arrived = Some((now, net.net_desc[0].pop(UnitId::RayBuffer(0))));
                net.net_desc[0].commit();
            }
        }
        // 2 descriptor words + 5 ray ids at 1 word per cycle after the 4-cycle latency.
        assert_eq!(arrived, Some((1 + 4 + 7, d)));
        assert_eq!((b.stats.jobs_moved, b.stats.link_words), (5, 7));
    }

    #[test]
    fn round_robin_victims_turn() {
        let mut b = Balancer::new(cfg(VictimPolicy::RoundRobin), 3);
        let mut net = Net::new(3);
        net.tick(&mut b, 0, &[0, 4, 4]);
        assert_eq!(net.order(1).map(|o| o.thief), Some(0));
        // The work-item comes back empty: cluster 0 waits the sampling interval and asks
        // again; the next victim after 1 is 2.
        net.items[1].push(
            UnitId::RayBuffer(1),
            WorkItem {
                from: 1,
                to: 0,
                jobs: vec![],
                desc: None,
            },
        );
        net.commit();
        net.tick(&mut b, 1, &[0, 4, 4]);
        for now in 2..11 {
            net.tick(&mut b, now, &[0, 4, 4]);
            assert_eq!((net.order(1), net.order(2)), (None, None), "cycle {now}");
        }
        net.tick(&mut b, 11, &[0, 4, 4]);
        assert_eq!(net.order(2).map(|o| o.thief), Some(0));
    }

    #[test]
    fn no_victim_retries_after_the_sampling_interval() {
        let mut b = Balancer::new(cfg(VictimPolicy::MostPending), 2);
        let mut net = Net::new(2);
        // Nobody has two jobs to spare: the request is retried 10 cycles later.
        net.tick(&mut b, 0, &[0, 1]);
        assert_eq!(b.stats.retries, 1);
        assert_eq!(b.timer(0), Some(10));
        for now in 1..10 {
            net.tick(&mut b, now, &[0, 1]);
            assert_eq!(b.stats.retries, 1, "cycle {now}");
        }
        net.tick(&mut b, 10, &[0, 5]);
        assert_eq!(net.order(1), Some(SplitOrder { thief: 0, jobs: 3 }));
        assert_eq!(b.stats.split_orders, 1);
    }

    #[test]
    fn a_work_item_crosses_the_link_word_by_word_to_the_thief() {
        let mut b = Balancer::new(cfg(VictimPolicy::MostPending), 2);
        let mut net = Net::new(2);
        net.tick(&mut b, 0, &[0, 5]);
        net.order(1).unwrap();
        net.items[1].push(
            UnitId::RayBuffer(1),
            WorkItem {
                from: 1,
                to: 0,
                jobs: vec![job(7), job(8)],
                desc: None,
            },
        );
        net.commit();
        let mut arrived = vec![];
        for now in 1..30 {
            net.tick(&mut b, now, &[1, 3]);
            if net.net_in[0].peek().is_some() {
                arrived.push((now, net.net_in[0].pop(UnitId::RayBuffer(0)).ray));
                net.net_in[0].commit();
            }
        }
        // Job i arrives link_latency + (i+1)·JOB_WORDS cycles after the split (taken at 1),
        // and enters the thief's link at that cycle's edge.
        let w = JOB_WORDS as u64;
        assert_eq!(arrived, vec![(1 + 4 + w, 7), (1 + 4 + 2 * w, 8)]);
        assert_eq!(b.stats.jobs_moved, 2);
        assert!(!b.requesting(0));
    }

    #[test]
    fn the_results_of_moved_jobs_go_home_each_after_its_link_time() {
        // Cluster 1 gives two jobs to cluster 0, whose ICU sends both results back.
        let mut b = Balancer::new(cfg(VictimPolicy::MostPending), 2);
        let mut net = Net::new(2);
        net.tick(&mut b, 0, &[0, 5]);
        net.order(1).unwrap();
        let moved = |ray| Job {
            owner: 1,
            ..job(ray)
        };
        net.items[1].push(
            UnitId::RayBuffer(1),
            WorkItem {
                from: 1,
                to: 0,
                jobs: vec![moved(7), moved(8)],
                desc: None,
            },
        );
        net.commit();
        let result = |slot| RemoteResult {
            owner: 1,
            ctu: 0,
            result: JobResult {
                slot,
                patch: 0,
                t: Some(slot as i64),
            },
        };
        let mut home = vec![];
        for now in 1..60 {
            // The ICU answers at cycles 20 and 21.
            if now == 20 || now == 21 {
                net.remote_out[0].push(UnitId::Icu(0), result(now as u32));
            }
            net.tick(&mut b, now, &[1, 3]);
            if net.remote_in[1].peek().is_some() {
                home.push((now, net.remote_in[1].pop(UnitId::Ctu(1, 0)).slot));
                net.remote_in[1].commit();
            }
        }
        // Taken the cycle after it was sent, then link_latency + one job's words.
        let at = 4 + JOB_WORDS as u64;
        assert_eq!(home, vec![(21 + at, 20), (22 + at, 21)]);
        assert_eq!(b.stats.results_returned, 2);
        assert!(b.idle());
    }

    #[test]
    fn the_balancer_reports_its_signal_counts() {
        use crate::machine::sink::Count;
        let b = Balancer::new(cfg(VictimPolicy::MostPending), 2);
        let mut n = [Count::default(), Count::default(), Count::default()];
        b.signals(&mut n[0], "");
        b.cluster_signals(&mut n[1], "", 1);
        b.ray_buffer_signals(&mut n[2], "", 1);
        let want = [
            Balancer::SIGNALS,
            Balancer::CLUSTER_SIGNALS,
            Balancer::RAY_BUFFER_SIGNALS,
        ];
        assert_eq!(n.map(|c| c.0), want);
    }
}
