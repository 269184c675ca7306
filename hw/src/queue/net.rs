//! The paper's queueing network (Figs 12.4 and 12.5) as an event model driven by the CTUs'
//! traces ([`super::walk`]): one event per request, per arrived patch and per batch (a patch
//! against its remaining rays), never one per job.
//!
//! Service centres, in cycles:
//! - **Cell traversal** (one per CTU): the trace's traversal cycles, request by request; a
//!   request waits for room when `request_queue_capacity` of its CTU's are at the arbiter.
//! - **Global memory**: one port; a grant (round-robin over the CTUs, or fixed priority)
//!   holds it one cycle per word; the record reaches its cluster's patch buffer
//!   `latency + words + 2` cycles after the grant.
//! - **Ray buffer + ICU** (one per cluster): a FIFO of jobs drained one per cycle. A batch
//!   entering at t behind `q` queued jobs has its last result back at `t + q + n + depth`
//!   (the CTU's issuer or the descriptor's expansion feeds one job per cycle, the ICU takes
//!   one per cycle). Batches of the K CTUs queue in the order they start (the machine
//!   interleaves them job by job).
//! - **Joins** (C_Join and R_Join): a subshell joins when its traversal is over, every patch it
//!   requested has arrived and every batch of it is back; the next subshell's traversal starts
//!   the cycle after. With overlapped joins the traversal runs one subshell ahead and a
//!   bundle's arrivals of the next subshell wait for the join before them.
//! - **Balancer** (Split Work, Distribute Work, Sampling Work): a cluster whose queue falls to
//!   the low-water mark (0 jobs, or a work-item's worth with bundles) asks for work; the victim
//!   (most jobs waiting, or round-robin) gives up to `work_item_jobs` from the back of its
//!   queue, which cross the link (`link_latency` + words / width) and come back as results the
//!   same way; a request that finds no victim is retried after `sampling_interval`.
//!
//! All times are integer cycles; events at one time run in the order they were scheduled, so
//! the estimate is deterministic.

use super::walk::CtuTrace;
use crate::config::{ArbiterPolicy, JobSource, MachineConfig, VictimPolicy};
use crate::msg::{DESCRIPTOR_WORDS, JOB_WORDS, RAY_ID_WORDS};
use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};

/// What the network estimates.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Estimate {
    pub cycles: u64,
    pub jobs: u64,
    /// Jobs each ICU computed (its own and work-items it took).
    pub icu_jobs: Vec<u64>,
    /// The cycle each CTU's last join happened.
    pub ctu_finish: Vec<u64>,
    /// Cycles the memory port was held.
    pub memory_busy: u64,
    pub patch_loads: u64,
    pub work_requests: u64,
    pub split_orders: u64,
    pub work_items: u64,
    pub jobs_moved: u64,
    pub retries: u64,
    /// Events the model processed.
    pub events: u64,
}

/// The machine's timing as the network reads it.
#[derive(Clone, Copy, Debug)]
pub struct NetParams {
    pub clusters: usize,
    pub ctus_per_cluster: usize,
    pub depth: u64,
    pub memory_latency: u64,
    pub patch_words: u64,
    pub request_capacity: u32,
    pub patch_buffer_capacity: usize,
    pub ray_buffer_capacity: u64,
    pub fixed_priority: bool,
    pub bundle: bool,
    pub overlap: bool,
    pub balance: bool,
    pub work_item_jobs: u64,
    pub sampling_interval: u64,
    pub link_latency: u64,
    pub link_words_per_cycle: u64,
    pub most_pending: bool,
}

impl NetParams {
    /// The network of `cfg` (hardware units), with patch records of `patch_words` words.
    pub fn of(cfg: &MachineConfig, patch_words: u32) -> Self {
        let m = &cfg.machine;
        let b = &cfg.balance;
        NetParams {
            clusters: m.clusters as usize,
            ctus_per_cluster: m.ctus_per_cluster as usize,
            depth: cfg.pipeline_depth() as u64,
            memory_latency: m.memory_latency as u64,
            patch_words: patch_words as u64,
            request_capacity: m.request_queue_capacity,
            patch_buffer_capacity: m.patch_buffer_capacity.max(1) as usize,
            ray_buffer_capacity: m.ray_buffer_capacity as u64,
            fixed_priority: m.arbiter == ArbiterPolicy::FixedPriority,
            bundle: m.job_source == JobSource::Bundle,
            overlap: m.overlap_joins,
            balance: b.enabled,
            work_item_jobs: b.work_item_jobs as u64,
            sampling_interval: b.sampling_interval as u64,
            link_latency: b.link_latency as u64,
            link_words_per_cycle: b.link_words_per_cycle.max(1) as u64,
            most_pending: b.victim == VictimPolicy::MostPending,
        }
    }

    fn link_cycles(&self, words: u64) -> u64 {
        self.link_latency + words.div_ceil(self.link_words_per_cycle)
    }
}

/// With `job_source = "ctu"`, the jobs of a batch of `orig` its issuer has handed over by the
/// end of cycle `now`: evenly from `start` to the cycle before `issue_end` — one per cycle,
/// or at the ICU's pace while the ray buffer is full (split-off jobs count: they had been
/// handed over).
fn ctu_issued(orig: u64, start: u64, issue_end: u64, now: u64) -> u64 {
    let span = issue_end.saturating_sub(start).max(1);
    let elapsed = (now + 1).saturating_sub(start).min(span);
    (u128::from(orig) * u128::from(elapsed) / u128::from(span)) as u64
}

/// With `job_source = "ctu"`, the jobs of a batch a split may take at `now`: of its `jobs`
/// left, those its issuer has handed over ([`ctu_issued`]) that no earlier split took (`cut`
/// jobs were split off, all of them handed over).
fn ctu_given(jobs: u64, cut: u64, start: u64, issue_end: u64, now: u64) -> u64 {
    ctu_issued(jobs + cut, start, issue_end, now)
        .saturating_sub(cut)
        .min(jobs)
}

/// Records a patch buffer's link to one CTU holds.
const INBOX: usize = 2;

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Ev {
    /// CTU's traversal reaches its next request.
    Request(usize),
    /// CTU's traversal reaches the end of its subshell.
    TravEnd(usize),
    /// The memory port may grant.
    Grant,
    /// A patch of (CTU, subshell) with its jobs leaves the memory for its cluster's patch
    /// buffer.
    Arrive(usize, usize, u32),
    /// CTU's issuer has issued its batch.
    Issued(usize),
    /// A batch (or a moved part of one) is back: (batch, version).
    Back(usize, u32),
    /// A moved batch's first result leaves the thief's ICU: (batch, version).
    HomeStart(usize, u32),
    /// Cluster's queue may have reached its low-water mark: (cluster, version).
    Starve(usize, u32),
    /// Cluster retries its work request.
    Retry(usize),
    /// Victim splits a work-item for thief: (victim, thief).
    Split(usize, usize),
    /// A work-item of (owner CTU, subshell, jobs) reaches thief's queue: (thief, ...).
    Inbound(usize, usize, usize, u64),
}

/// A batch in a cluster's queue.
#[derive(Clone, Copy, Debug)]
struct Batch {
    /// The cluster whose queue it is in.
    cluster: usize,
    ctu: usize,
    sub: usize,
    /// Jobs left to the owner's ICU.
    jobs: u64,
    /// The cycle it entered the queue (its issuer's first job, with `job_source = "ctu"`).
    start: u64,
    back_at: u64,
    /// Cycles from the ICU back to the owner (0, or the link for a moved work-item).
    ret: u64,
    /// The cycle its last result reaches its CTU.
    home: u64,
    /// A moved batch's results hold their place on the owner's return port (from the cycle
    /// its first result leaves the thief's ICU).
    reserved: bool,
    version: u32,
    done: bool,
    /// Jobs split off it so far (off the back of what its issuer had handed over).
    cut: u64,
    /// With `job_source = "ctu"`: the cycle after its issuer hands over its last job (one
    /// per cycle from `start`, at the ICU's pace when the ray buffer is full).
    issue_end: u64,
}

#[derive(Clone, Debug, Default)]
struct CtuRt {
    cluster: usize,
    sub: usize,
    start: u64,
    next: usize,
    at_end: bool,
    stalled_at: Option<u64>,
    queued: u32,
    pend: Vec<u32>,
    open: Vec<u32>,
    joined: usize,
    draining: Option<usize>,
    /// Records in the patch buffer's link to this CTU (at most [`INBOX`]): (subshell, jobs).
    inbox: VecDeque<(usize, u32)>,
    issuing: bool,
    finish: u64,
}

#[derive(Clone, Debug, Default)]
struct ClusterRt {
    backlog: u64,
    last: u64,
    /// The batches in the queue, oldest first (a split cuts the last; served and emptied
    /// ones leave lazily).
    queue: VecDeque<usize>,
    starve_version: u32,
    requesting: bool,
    inbound: u32,
}

struct Net<'a> {
    p: NetParams,
    traces: &'a [CtuTrace],
    now: u64,
    seq: u64,
    heap: BinaryHeap<Reverse<(u64, u64, Ev)>>,
    ctus: Vec<CtuRt>,
    clusters: Vec<ClusterRt>,
    batches: Vec<Batch>,
    /// Per CTU: requests at the arbiter, (ready cycle, subshell, jobs).
    mem_q: Vec<VecDeque<(u64, usize, u32)>>,
    port_free: u64,
    rr: usize,
    grant_pending: bool,
    /// Per cluster: records the memory has ready, waiting for room in the patch buffer, and
    /// the patch buffer's store: (CTU, subshell, jobs).
    delivery: Vec<VecDeque<(usize, usize, u32)>>,
    buffer: Vec<VecDeque<(usize, usize, u32)>>,
    next_victim: usize,
    /// Per cluster: the cycle its return port (moved jobs' results coming home, one per
    /// cycle) is free.
    home_free: Vec<u64>,
    /// Events in the heap other than the balancer's own timers.
    live: u64,
    /// CTUs that have not joined their last subshell.
    unfinished: usize,
    out: Estimate,
}

/// Estimates the machine's cycles from the CTUs' traces (cluster-major: CTU j of cluster c
/// is `traces[c * ctus_per_cluster + j]`).
pub fn estimate(p: NetParams, traces: &[CtuTrace]) -> Result<Estimate, String> {
    assert_eq!(traces.len(), p.clusters * p.ctus_per_cluster);
    let mut net = Net {
        p,
        traces,
        now: 0,
        seq: 0,
        heap: BinaryHeap::new(),
        ctus: traces
            .iter()
            .enumerate()
            .map(|(i, t)| CtuRt {
                cluster: i / p.ctus_per_cluster,
                pend: vec![0; t.subshells.len()],
                open: vec![0; t.subshells.len()],
                // The FSM's first cycle is IDLE, counted in the first subshell's traversal.
                ..CtuRt::default()
            })
            .collect(),
        clusters: vec![ClusterRt::default(); p.clusters],
        batches: Vec::new(),
        mem_q: vec![VecDeque::new(); traces.len()],
        port_free: 0,
        rr: 0,
        grant_pending: false,
        delivery: vec![VecDeque::new(); p.clusters],
        buffer: vec![VecDeque::new(); p.clusters],
        next_victim: 0,
        home_free: vec![0; p.clusters],
        live: 0,
        unfinished: traces.iter().filter(|t| !t.subshells.is_empty()).count(),
        out: Estimate {
            icu_jobs: vec![0; p.clusters],
            ctu_finish: vec![0; traces.len()],
            ..Estimate::default()
        },
    };
    for c in 0..traces.len() {
        net.schedule_traversal(c);
    }
    if p.balance {
        for c in 0..p.clusters {
            net.check_starve(c);
        }
    }
    while let Some(Reverse((t, _, ev))) = net.heap.pop() {
        if matches!(ev, Ev::Retry(_) | Ev::Starve(..)) {
            if net.live == 0 {
                // Only the balancer's own timers are left: nothing can give it work.
                continue;
            }
        } else {
            net.live -= 1;
        }
        net.now = t;
        net.out.events += 1;
        net.handle(ev);
    }
    let stuck: Vec<String> = net
        .ctus
        .iter()
        .zip(traces)
        .enumerate()
        .filter(|(_, (r, t))| r.joined < t.subshells.len())
        .map(|(i, (r, t))| {
            format!(
                "CTU {i}: subshell {} of {}, joined {}, at end {}, draining {:?}, pending {:?}, open {:?}, inbox {:?}, issuing {}",
                r.sub,
                t.subshells.len(),
                r.joined,
                r.at_end,
                r.draining,
                r.pend.get(r.joined),
                r.open.get(r.joined),
                r.inbox,
                r.issuing
            )
        })
        .collect();
    if !stuck.is_empty() {
        return Err(format!(
            "the queueing network stopped with unfinished CTUs at cycle {}: {}",
            net.now,
            stuck.join("; ")
        ));
    }
    let mut out = net.out;
    for (i, c) in net.ctus.iter().enumerate() {
        out.ctu_finish[i] = c.finish;
    }
    // (A batch cut to nothing keeps a stale back time; its CTU's join did not wait for it.)
    let last_back = (net.batches.iter())
        .filter(|b| b.jobs > 0)
        .map(|b| b.home)
        .max()
        .unwrap_or(0);
    out.cycles = out
        .ctu_finish
        .iter()
        .copied()
        .max()
        .unwrap_or(0)
        .max(last_back)
        + 1;
    out.jobs = traces.iter().map(|t| t.jobs).sum();
    out.patch_loads = traces.iter().map(|t| t.patch_requests).sum();
    Ok(out)
}

impl Net<'_> {
    fn at(&mut self, t: u64, ev: Ev) {
        if !matches!(ev, Ev::Retry(_) | Ev::Starve(..)) {
            self.live += 1;
        }
        self.seq += 1;
        self.heap.push(Reverse((t, self.seq, ev)));
    }

    fn handle(&mut self, ev: Ev) {
        match ev {
            Ev::Request(c) => self.request(c),
            Ev::TravEnd(c) => self.trav_end(c),
            Ev::Grant => self.grant(),
            Ev::Arrive(c, s, n) => {
                let k = self.ctus[c].cluster;
                self.delivery[k].push_back((c, s, n));
                self.pump(k);
            }
            Ev::Issued(c) => {
                self.ctus[c].issuing = false;
                self.take(c);
            }
            Ev::Back(b, v) => {
                let bt = self.batches[b];
                if bt.version == v && !bt.done {
                    self.batches[b].done = true;
                    let q = &mut self.clusters[bt.cluster].queue;
                    while q.front().is_some_and(|&f| self.batches[f].done) {
                        q.pop_front();
                    }
                    self.part_back(bt.ctu, bt.sub);
                }
            }
            Ev::HomeStart(b, v) => {
                let bt = self.batches[b];
                if bt.version == v && !bt.done {
                    let oc = self.ctus[bt.ctu].cluster;
                    let h = (bt.back_at + bt.ret).max(self.home_free[oc] + bt.jobs);
                    self.home_free[oc] = h;
                    let bt = &mut self.batches[b];
                    bt.home = h;
                    bt.reserved = true;
                    self.at(h, Ev::Back(b, v));
                }
            }
            Ev::Starve(k, v) => {
                if self.clusters[k].starve_version == v {
                    self.maybe_request(k);
                }
            }
            Ev::Retry(k) => self.find_victim(k),
            Ev::Split(v, thief) => self.split(v, thief),
            Ev::Inbound(k, c, s, n) => {
                self.clusters[k].inbound -= 1;
                let ret = self.p.link_cycles(JOB_WORDS as u64);
                self.submit(k, c, s, n, self.now, ret);
            }
        }
    }

    /// Schedules CTU `c`'s next traversal event in its current subshell.
    fn schedule_traversal(&mut self, c: usize) {
        let r = &self.ctus[c];
        let Some(sub) = self.traces[c].subshells.get(r.sub) else {
            self.maybe_finish(c);
            return;
        };
        let (t, ev) = match sub.requests.get(r.next) {
            Some(&off) => (r.start + off as u64, Ev::Request(c)),
            None => (r.start + sub.cycles as u64, Ev::TravEnd(c)),
        };
        let t = t.max(self.now);
        self.at(t, ev);
    }

    fn request(&mut self, c: usize) {
        let now = self.now;
        if self.ctus[c].queued >= self.p.request_capacity {
            self.ctus[c].stalled_at = Some(now);
            return;
        }
        let r = &mut self.ctus[c];
        let s = r.sub;
        let n = self.traces[c].subshells[s].jobs[r.next];
        r.queued += 1;
        r.pend[s] += 1;
        r.next += 1;
        self.mem_q[c].push_back((now + 1, s, n));
        if !self.grant_pending {
            self.grant_pending = true;
            let t = self.port_free.max(now + 1);
            self.at(t, Ev::Grant);
        }
        self.schedule_traversal(c);
    }

    fn grant(&mut self) {
        let now = self.now;
        self.grant_pending = false;
        if self.port_free > now {
            self.grant_pending = true;
            self.at(self.port_free, Ev::Grant);
            return;
        }
        let n = self.mem_q.len();
        let pick = if self.p.fixed_priority {
            (0..n).find(|&c| self.mem_q[c].front().is_some_and(|q| q.0 <= now))
        } else {
            (0..n)
                .map(|k| (self.rr + k) % n)
                .find(|&c| self.mem_q[c].front().is_some_and(|q| q.0 <= now))
        };
        match pick {
            Some(c) => {
                let (_, s, jobs) = self.mem_q[c].pop_front().expect("picked");
                self.rr = (c + 1) % n;
                let w = self.p.patch_words;
                self.port_free = now + w;
                self.out.memory_busy += w;
                self.at(now + self.p.memory_latency + w + 2, Ev::Arrive(c, s, jobs));
                let r = &mut self.ctus[c];
                r.queued -= 1;
                if let Some(since) = r.stalled_at.take() {
                    // The stalled request goes out the cycle after the room appears.
                    r.start += now + 1 - since;
                    self.schedule_traversal(c);
                }
                if self.mem_q.iter().any(|q| !q.is_empty()) {
                    self.grant_pending = true;
                    self.at(self.port_free, Ev::Grant);
                }
            }
            None => {
                if let Some(t) = self
                    .mem_q
                    .iter()
                    .filter_map(|q| q.front())
                    .map(|q| q.0)
                    .min()
                {
                    self.grant_pending = true;
                    self.at(t, Ev::Grant);
                }
            }
        }
    }

    fn trav_end(&mut self, c: usize) {
        let now = self.now;
        if !self.p.overlap {
            self.ctus[c].at_end = true;
            self.try_join(c);
            return;
        }
        if self.ctus[c].draining.is_none() {
            self.start_drain(c, now);
        } else {
            self.ctus[c].at_end = true;
        }
    }

    /// Overlapped joins: subshell `sub` drains, the traversal goes on with the next.
    fn start_drain(&mut self, c: usize, now: u64) {
        let r = &mut self.ctus[c];
        r.draining = Some(r.sub);
        r.sub += 1;
        r.next = 0;
        r.at_end = false;
        r.start = now + 1;
        self.schedule_traversal(c);
        self.try_drain(c);
    }

    fn try_join(&mut self, c: usize) {
        let now = self.now;
        let r = &mut self.ctus[c];
        if self.p.overlap {
            return self.try_drain(c);
        }
        let s = r.sub;
        if r.at_end && r.pend[s] == 0 && r.open[s] == 0 {
            r.sub += 1;
            r.next = 0;
            r.at_end = false;
            r.start = now + 1;
            r.finish = now;
            self.joined(c, s);
            self.schedule_traversal(c);
        }
    }

    fn try_drain(&mut self, c: usize) {
        let now = self.now;
        let r = &mut self.ctus[c];
        let Some(d) = r.draining else {
            return;
        };
        if r.pend[d] != 0 || r.open[d] != 0 {
            return;
        }
        r.draining = None;
        r.finish = now;
        self.joined(c, d);
        // An arrival held for this join goes to the ray buffer.
        self.take(c);
        if self.ctus[c].at_end {
            self.start_drain(c, now);
        }
    }

    fn maybe_finish(&mut self, c: usize) {
        let r = &mut self.ctus[c];
        if r.joined >= self.traces[c].subshells.len() {
            r.finish = r.finish.max(self.now);
        }
    }

    /// Cluster `k`'s patch buffer: records the memory has ready enter its store while it has
    /// room; the oldest record goes on to its CTU's link while that has room (a record for a
    /// CTU whose link is full holds every record behind it).
    fn pump(&mut self, k: usize) {
        loop {
            let mut moved = false;
            if let Some(&(c, s, n)) = self.buffer[k].front() {
                if self.ctus[c].inbox.len() < INBOX {
                    self.buffer[k].pop_front();
                    self.ctus[c].inbox.push_back((s, n));
                    self.take(c);
                    moved = true;
                }
            }
            if self.buffer[k].len() < self.p.patch_buffer_capacity {
                if let Some(r) = self.delivery[k].pop_front() {
                    self.buffer[k].push_back(r);
                    moved = true;
                }
            }
            if !moved {
                break;
            }
        }
    }

    /// CTU `c` takes arrived records from its link: with `job_source = "ctu"` one when its
    /// issuer is free (it then issues the patch's jobs, one per cycle); with bundles each as a
    /// descriptor, unless it belongs to a subshell after the one draining (it waits for that
    /// join at the head of the link).
    fn take(&mut self, c: usize) {
        let now = self.now;
        let mut took = false;
        loop {
            let r = &mut self.ctus[c];
            let Some(&(s, n)) = r.inbox.front() else {
                break;
            };
            if self.p.bundle {
                if self.p.overlap && r.draining.is_some_and(|d| d != s) {
                    break;
                }
            } else if r.issuing {
                break;
            }
            r.inbox.pop_front();
            r.pend[s] -= 1;
            took = true;
            if n > 0 {
                r.open[s] += 1;
            }
            if !self.p.bundle {
                r.issuing = true;
                let mut end = now + 1 + n as u64;
                if n > 0 {
                    let id = self.submit_own(c, s, n, now + 1);
                    // The ray buffer holds at most its capacity: the issuer hands a job over
                    // only when there is room, so the last one no sooner than `capacity`
                    // cycles before the ICU takes it.
                    let b = &mut self.batches[id];
                    end = end.max(
                        b.back_at
                            .saturating_sub(self.p.depth + self.p.ray_buffer_capacity),
                    );
                    b.issue_end = end;
                }
                self.at(end, Ev::Issued(c));
                break;
            }
            if n > 0 {
                self.submit_own(c, s, n, now + 1);
            }
        }
        if took {
            let k = self.ctus[c].cluster;
            self.pump(k);
            self.try_join(c);
        }
    }

    /// A batch of `n` jobs of (CTU `c`, subshell `s`) enters its cluster's queue at `t`.
    fn submit_own(&mut self, c: usize, s: usize, n: u32, t: u64) -> usize {
        let k = self.ctus[c].cluster;
        self.submit(k, c, s, n as u64, t, 0)
    }

    /// A batch of `n` jobs of (CTU `c`, subshell `s`) enters cluster `k`'s queue at `t`; its
    /// results reach the CTU `ret` cycles after they leave the ICU (the link home for a moved
    /// work-item).
    fn submit(&mut self, k: usize, c: usize, s: usize, n: u64, t: u64, ret: u64) -> usize {
        let id = self.batches.len();
        self.batches.push(Batch {
            cluster: k,
            ctu: c,
            sub: s,
            jobs: n,
            start: t,
            back_at: 0,
            ret,
            home: 0,
            reserved: false,
            version: 0,
            done: false,
            cut: 0,
            issue_end: t + n,
        });
        let back = self.enqueue(k, n, Some((id, t)));
        self.batches[id].back_at = back;
        self.batches[id].home = back;
        self.schedule_return(id);
        self.check_starve(k);
        id
    }

    /// Schedules batch `id`'s return at its current version: its Back when its last result
    /// reaches its CTU, at once when splits left it nothing (its back time counted jobs
    /// ahead of it that later cuts may have taken); a moved batch not yet on its owner's
    /// return port (one result per cycle) first takes its place there, when its first
    /// result leaves the thief's ICU.
    fn schedule_return(&mut self, id: usize) {
        let b = self.batches[id];
        if b.jobs > 0 && b.ret > 0 && !b.reserved {
            let start = b.home.saturating_sub(b.jobs).max(self.now);
            self.at(start, Ev::HomeStart(id, b.version));
        } else {
            let back = if b.jobs == 0 {
                self.now
            } else {
                b.home.max(self.now)
            };
            self.at(back, Ev::Back(id, b.version));
        }
    }

    /// Brings cluster `k`'s queue to now.
    fn advance(&mut self, k: usize, t: u64) {
        let cl = &mut self.clusters[k];
        if t > cl.last {
            cl.backlog -= cl.backlog.min(t - cl.last);
            cl.last = t;
        }
        if cl.backlog == 0 {
            cl.queue.clear();
        }
    }

    /// Puts `n` jobs at the back of cluster `k`'s queue (at `at.1`, else now) and returns the
    /// cycle the last result is back.
    fn enqueue(&mut self, k: usize, n: u64, at: Option<(usize, u64)>) -> u64 {
        let t = at.map_or(self.now, |a| a.1);
        self.advance(k, self.now);
        let cl = &mut self.clusters[k];
        // Jobs entering later than now: the queue drains until then.
        let ahead = cl.backlog.saturating_sub(t - self.now);
        let back = t + ahead + n + self.p.depth;
        cl.backlog += n;
        if let Some((id, _)) = at {
            cl.queue.push_back(id);
        }
        self.out.icu_jobs[k] += n;
        back
    }

    fn part_back(&mut self, c: usize, s: usize) {
        let r = &mut self.ctus[c];
        r.open[s] -= 1;
        self.try_join(c);
    }

    /// Schedules cluster `k`'s low-water check.
    fn check_starve(&mut self, k: usize) {
        if !self.p.balance {
            return;
        }
        self.advance(k, self.now);
        let low = if self.p.bundle {
            self.p.work_item_jobs
        } else {
            0
        };
        let cl = &mut self.clusters[k];
        cl.starve_version += 1;
        let v = cl.starve_version;
        let t = self.now + cl.backlog.saturating_sub(low);
        self.at(t, Ev::Starve(k, v));
    }

    fn maybe_request(&mut self, k: usize) {
        let cl = &self.clusters[k];
        if cl.requesting || cl.inbound > 0 || !self.work_left() {
            return;
        }
        self.clusters[k].requesting = true;
        self.out.work_requests += 1;
        self.find_victim(k);
    }

    /// True while some CTU has not finished (requests stop once all have).
    fn work_left(&self) -> bool {
        self.unfinished > 0
    }

    /// CTU `c` has joined subshell `s`.
    fn joined(&mut self, c: usize, s: usize) {
        self.ctus[c].joined = s + 1;
        if s + 1 == self.traces[c].subshells.len() {
            self.unfinished -= 1;
        }
    }

    fn find_victim(&mut self, thief: usize) {
        let now = self.now;
        let n = self.clusters.len();
        for v in 0..n {
            self.advance(v, now);
        }
        let ok = |net: &Self, v: usize| v != thief && net.clusters[v].backlog >= 2;
        let victim = if self.p.most_pending {
            (0..n)
                .filter(|&v| ok(self, v))
                .max_by_key(|&v| (self.clusters[v].backlog, Reverse(v)))
        } else {
            let v = (0..n)
                .map(|i| (self.next_victim + i) % n)
                .find(|&v| ok(self, v));
            if let Some(v) = v {
                self.next_victim = (v + 1) % n;
            }
            v
        };
        match victim {
            Some(v) => {
                self.out.split_orders += 1;
                self.at(now + 2, Ev::Split(v, thief))
            }
            None => {
                if self.work_left() {
                    self.out.retries += 1;
                    self.at(now + self.p.sampling_interval, Ev::Retry(thief));
                } else {
                    self.clusters[thief].requesting = false;
                }
            }
        }
    }

    /// The victim had nothing to give: the thief asks again after the sampling interval.
    fn split_failed(&mut self, thief: usize) {
        self.out.retries += 1;
        self.clusters[thief].requesting = true;
        self.at(self.now + self.p.sampling_interval, Ev::Retry(thief));
    }

    /// Victim `v` cuts a work-item for `thief` off the back of its queue.
    fn split(&mut self, v: usize, thief: usize) {
        let now = self.now;
        self.advance(v, now);
        self.clusters[thief].requesting = false;
        let cl = &mut self.clusters[v];
        while let Some(&b) = cl.queue.back() {
            if self.batches[b].jobs == 0 || self.batches[b].done {
                cl.queue.pop_back();
            } else {
                break;
            }
        }
        let Some(&last) = cl.queue.back() else {
            return self.split_failed(thief);
        };
        // The work-item: (batch, jobs) parts, from the back of the queue.
        let mut parts: Vec<(usize, u64)> = Vec::new();
        if self.p.bundle {
            let queued = self.batches[last].jobs.min(cl.backlog);
            let keep = u64::from(cl.backlog == queued);
            let w = self.p.work_item_jobs.min(queued.saturating_sub(keep));
            if w > 0 {
                parts.push((last, w));
            }
        } else {
            // The ray buffer holds what the issuers have handed over and the ICU has not
            // taken, at most its capacity; a split takes the back of it — the latest
            // handed-over jobs, batch by batch from the last — and leaves one job.
            let unissued = |x: &Batch| {
                if x.ret == 0 {
                    let orig = x.jobs + x.cut;
                    orig - ctu_issued(orig, x.start, x.issue_end, now)
                } else {
                    0
                }
            };
            let held: u64 = cl.queue.iter().map(|&x| unissued(&self.batches[x])).sum();
            let waiting = cl
                .backlog
                .saturating_sub(held)
                .min(self.p.ray_buffer_capacity);
            let mut want = self.p.work_item_jobs.min(waiting.saturating_sub(1));
            for &x in cl.queue.iter().rev() {
                if want == 0 {
                    break;
                }
                let bt = &self.batches[x];
                if bt.done || bt.jobs == 0 {
                    continue;
                }
                let given = if bt.ret == 0 {
                    ctu_given(bt.jobs, bt.cut, bt.start, bt.issue_end, now)
                } else {
                    bt.jobs
                };
                let take = given.min(want);
                if take > 0 {
                    parts.push((x, take));
                    want -= take;
                }
            }
        }
        if parts.is_empty() {
            return self.split_failed(thief);
        }
        let total: u64 = parts.iter().map(|p| p.1).sum();
        let words = if self.p.bundle {
            DESCRIPTOR_WORDS as u64 + total * RAY_ID_WORDS as u64
        } else {
            total * JOB_WORDS as u64
        };
        let t = now + 1 + self.p.link_cycles(words);
        self.out.work_items += 1;
        self.out.jobs_moved += total;
        for (b, w) in parts {
            let batch = self.batches[b];
            // The batch loses its last w jobs here: its own part is back w cycles sooner.
            let bt = &mut self.batches[b];
            bt.jobs -= w;
            bt.cut += w;
            bt.version += 1;
            bt.back_at -= w;
            let old_home = bt.home;
            bt.home = if bt.ret == 0 {
                bt.back_at
            } else if bt.reserved {
                (bt.back_at + bt.ret).max(bt.home - w)
            } else {
                bt.back_at
            };
            let home = bt.home;
            let oc = self.ctus[batch.ctu].cluster;
            if batch.reserved && self.home_free[oc] == old_home {
                self.home_free[oc] = home;
            }
            self.schedule_return(b);
            self.clusters[v].backlog -= w;
            self.out.icu_jobs[v] -= w;
            self.ctus[batch.ctu].open[batch.sub] += 1;
            self.clusters[thief].inbound += 1;
            self.at(t, Ev::Inbound(thief, batch.ctu, batch.sub, w));
        }
        self.check_starve(v);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::queue::walk::Subshell;

    fn params(clusters: usize, ctus: usize) -> NetParams {
        NetParams {
            clusters,
            ctus_per_cluster: ctus,
            depth: 20,
            memory_latency: 8,
            patch_words: 4,
            request_capacity: 4,
            patch_buffer_capacity: 8,
            ray_buffer_capacity: 256,
            fixed_priority: false,
            bundle: false,
            overlap: false,
            balance: false,
            work_item_jobs: 32,
            sampling_interval: 32,
            link_latency: 4,
            link_words_per_cycle: 1,
            most_pending: true,
        }
    }

    /// A CTU walking `subs` subshells of `cycles` traversal cycles, each requesting patches
    /// at `requests` against `jobs` rays each.
    fn trace(subs: usize, cycles: u32, requests: &[u32], jobs: u32) -> CtuTrace {
        let sub = Subshell {
            cycles,
            requests: requests.to_vec(),
            jobs: vec![jobs; requests.len()],
        };
        CtuTrace {
            subshells: vec![sub; subs],
            jobs: (subs * requests.len()) as u64 * jobs as u64,
            patch_requests: (subs * requests.len()) as u64,
            ..CtuTrace::default()
        }
    }

    #[test]
    fn one_patch_goes_through_memory_buffer_issuer_and_icu_in_sequence() {
        let p = params(1, 1);
        let e = estimate(p, &[trace(1, 10, &[2], 5)]).unwrap();
        // Request at 2, granted at 3, arrives L + W + 2 later, issued from the next cycle,
        // the last of 5 jobs back after the pipeline; the join is that cycle, cycles = +1.
        let arrive = 3 + p.memory_latency + p.patch_words + 2;
        assert_eq!(e.cycles, arrive + 1 + 5 + p.depth + 1);
        assert_eq!((e.jobs, e.icu_jobs.clone(), e.memory_busy), (5, vec![5], 4));
    }

    #[test]
    fn two_ctus_share_their_clusters_icu() {
        let alone = estimate(params(1, 1), &[trace(1, 10, &[0], 100)]).unwrap();
        let shared = estimate(
            params(1, 2),
            &[trace(1, 10, &[0], 100), trace(1, 10, &[0], 100)],
        )
        .unwrap();
        // The second batch waits for the first (less the memory port's offset of one grant).
        assert!(
            shared.cycles >= alone.cycles + 100 - 4,
            "{shared:?} vs {alone:?}"
        );
        assert_eq!(shared.icu_jobs, vec![200]);
        // Two clusters do not share.
        let apart = estimate(
            params(2, 1),
            &[trace(1, 10, &[0], 100), trace(1, 10, &[0], 100)],
        )
        .unwrap();
        assert!(apart.cycles < alone.cycles + 10, "{apart:?} vs {alone:?}");
    }

    #[test]
    fn balancing_shares_a_lone_busy_cluster_and_cut_batches_do_not_hold_joins() {
        // Cluster 0's two CTUs have all the work, in many batches; cluster 1's none.
        let requests: Vec<u32> = (0..40).map(|i| i * 3).collect();
        let busy = trace(3, 200, &requests, 400);
        let idle = trace(1, 1, &[], 0);
        let traces = [busy.clone(), busy, idle.clone(), idle];
        for bundle in [false, true] {
            let mut p = params(2, 2);
            p.bundle = bundle;
            p.overlap = bundle;
            let off = estimate(p, &traces).unwrap();
            p.balance = true;
            let on = estimate(p, &traces).unwrap();
            assert_eq!(on.icu_jobs.iter().sum::<u64>(), on.jobs);
            assert!(on.work_items > 0, "{on:?}");
            // A job source's ICU share follows what the link brings: a work-item of jobs
            // crosses it 2 words a job, a descriptor's ray ids 1 word a job. A batch cut to
            // nothing keeps no stale time that holds its join (it did once: +50 %). With
            // `ctu` the two issuers wait for room in the ray buffer, so a thief finds only
            // its capacity's worth waiting there, not the whole batch.
            let (lo, hi) = if bundle { (0.5, 0.6) } else { (0.85, 0.95) };
            let ratio = on.cycles as f64 / off.cycles as f64;
            assert!(
                (lo..hi).contains(&ratio),
                "bundle {bundle}: {ratio} ({on:?})"
            );
        }
    }

    #[test]
    fn an_issuer_hands_over_one_job_a_cycle_or_at_the_icus_pace() {
        // 100 jobs from cycle 0, one a cycle (the last at 99): 50 by the end of cycle 49.
        assert_eq!(ctu_issued(100, 0, 100, 49), 50);
        assert_eq!(ctu_issued(100, 0, 100, 99), 100);
        assert_eq!(ctu_issued(100, 0, 100, 500), 100);
        // Nothing before it starts.
        assert_eq!(ctu_issued(100, 60, 160, 49), 0);
        // A full buffer: the same 100 jobs over 400 cycles, one every 4.
        assert_eq!(ctu_issued(100, 0, 400, 199), 50);
    }

    #[test]
    fn a_split_takes_only_handed_over_jobs_that_no_split_took() {
        // 50 of 100 handed over by cycle 49; 20 of them split off: 30 left to take, a cycle
        // later 31.
        assert_eq!(ctu_given(100, 0, 0, 100, 49), 50);
        assert_eq!(ctu_given(80, 20, 0, 100, 49), 30);
        assert_eq!(ctu_given(80, 20, 0, 100, 50), 31);
        // All that is left once the issue is over; nothing before it starts.
        assert_eq!(ctu_given(80, 20, 0, 100, 120), 80);
        assert_eq!(ctu_given(100, 0, 60, 160, 49), 0);
    }

    #[test]
    fn moved_results_come_home_one_per_cycle() {
        // Six idle clusters take a busy one's work: its results can come home no faster than
        // its own ICU's one per cycle plus the return port's one per cycle.
        let requests: Vec<u32> = (0..40).map(|i| i * 3).collect();
        let mut traces = vec![trace(2, 200, &requests, 400)];
        traces.extend((0..6).map(|_| trace(1, 1, &[], 0)));
        let mut p = params(7, 1);
        // Descriptors: a patch's jobs wait in the ray buffer at once (a CTU's issuer hands
        // them over one per cycle, and a lone CTU's ICU takes each at once: none to move).
        p.bundle = true;
        p.balance = true;
        let e = estimate(p, &traces).unwrap();
        assert!(e.cycles >= e.jobs / 2, "{e:?}");
        assert!(e.jobs_moved > e.jobs / 3, "{e:?}");
    }
}
