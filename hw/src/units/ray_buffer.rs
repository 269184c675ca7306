//! The ray buffer: a cluster's bounded queue of pending (ray, patch) jobs feeding its ICU.
//! Each cycle it takes one job from each of its inputs — the CTUs' job links and the link
//! bringing work-items from other clusters — while it has room, starting round-robin so no
//! input is favoured when room runs short. Told to by the balancer, it splits a work-item off
//! the back of its queue for a starving cluster.
//!
//! With `job_source = "bundle"` ([`RayBuffer::tick_bundle`]) it holds descriptors instead
//! (one per arrived patch: the patch against its CTU's remaining rays), takes one per cycle
//! from each input, and expands the front one into jobs at the ICU's input, one per cycle,
//! through a two-job queue. A split order cuts a work-item of up to N jobs off the back of
//! the last descriptor (never the front descriptor's last job) and sends it as a descriptor.

use crate::link::{Link, UnitCode, UnitId};
use crate::machine::sink::Sink;
use crate::msg::{Descriptor, Job, SplitOrder, WorkItem};
use crate::units::ray_pool::RayList;
use crate::units::{Around, Unit};
use std::collections::VecDeque;

/// Ray-buffer counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct RayBufferStats {
    pub jobs_in: u64,
    /// Work-items split off for other clusters, and their jobs.
    pub work_items_given: u64,
    pub jobs_given: u64,
    /// Σ occupancy over cycles (mean occupancy = this / cycles).
    pub occupancy_sum: u64,
    pub max_occupancy: u64,
    /// Descriptors taken in (bundle only; their jobs enter the queue as `jobs_in`).
    pub descriptors_in: u64,
}

/// The ray buffer.
#[derive(Clone, Debug)]
pub struct RayBuffer {
    /// The queue the ICU pops.
    pub queue: Link<Job>,
    next: usize,
    /// Descriptors waiting to be expanded (bundle only), at most `desc_capacity`.
    descs: VecDeque<Descriptor>,
    desc_capacity: usize,
    /// Bundle: expand the descriptor with the most jobs left first (`largest-first`).
    largest_first: bool,
    /// Jobs the descriptors stand for, now and at the last edge (what others may read).
    desc_jobs: u64,
    desc_jobs_registered: u64,
    pub stats: RayBufferStats,
}

/// A bundle ray buffer's ports.
pub struct BundlePorts<'a> {
    /// From each CTU of the cluster.
    pub inputs: &'a mut [Link<Descriptor>],
    /// Split descriptors arriving over the inter-cluster link.
    pub from_network: &'a mut Link<Descriptor>,
    pub orders: &'a mut Link<SplitOrder>,
    pub out: &'a mut Link<WorkItem>,
    /// Every CTU's ray pool, cluster-major (`owner · ctus_per_cluster + ctu`).
    pub pool: &'a [RayList],
    pub ctus_per_cluster: usize,
}

/// A job ray buffer's ports, as [`RayBuffer::tick`] takes them: from each CTU of the cluster,
/// from the inter-cluster link, the balancer's split orders, the work-items back to it.
struct JobPorts<'a> {
    inputs: &'a mut [Link<Job>],
    from_network: &'a mut Link<Job>,
    orders: &'a mut Link<SplitOrder>,
    out: &'a mut Link<WorkItem>,
}

impl RayBuffer {
    /// The ray buffer's own waveform signals (bundle; its queue shows as a link's):
    /// [`RayBuffer::bundle_signals`] reports exactly these.
    pub const BUNDLE_SIGNALS: usize = 6;

    /// Reports the descriptor store's waveform signals to `s` under `scope` (a new signal:
    /// one line here, counted in [`RayBuffer::BUNDLE_SIGNALS`]).
    #[inline(always)]
    pub(crate) fn bundle_signals(&self, s: &mut impl Sink, scope: &str) {
        let (patch, left) = self.expanding().unwrap_or((0, 0));
        s.bits(scope, "descriptors", 16, self.descriptors() as u64);
        s.bits(scope, "jobs_waiting", 32, self.waiting() as u64);
        s.bits(scope, "expanding_patch", 24, patch as u64);
        s.bits(scope, "expanding_left", 32, left as u64);
        s.bits(scope, "descriptors_in", 32, self.stats.descriptors_in);
        s.bits(scope, "splits", 32, self.stats.work_items_given);
    }

    /// A buffer of `capacity` jobs with `inputs` input ports (CTUs + the network).
    pub fn new(capacity: u32, inputs: usize) -> Self {
        RayBuffer {
            queue: Link::with_ports(capacity as usize, inputs),
            next: 0,
            descs: VecDeque::new(),
            desc_capacity: 0,
            largest_first: false,
            desc_jobs: 0,
            desc_jobs_registered: 0,
            stats: RayBufferStats::default(),
        }
    }

    /// A bundle buffer: `capacity` descriptors, a two-job queue before the ICU; with
    /// `largest_first`, the descriptor with the most jobs left is expanded first.
    pub fn bundle(capacity: u32, largest_first: bool) -> Self {
        RayBuffer {
            descs: VecDeque::with_capacity(capacity as usize),
            desc_capacity: capacity as usize,
            largest_first,
            ..RayBuffer::new(2, 1)
        }
    }

    /// Jobs waiting at the last edge: in the queue and (bundle) in descriptors.
    pub fn waiting(&self) -> usize {
        self.queue.len() + self.desc_jobs_registered as usize
    }

    /// True when the queue and the descriptor store are empty.
    pub fn is_empty(&self) -> bool {
        self.queue.is_empty() && self.descs.is_empty()
    }

    /// Descriptors waiting.
    pub fn descriptors(&self) -> usize {
        self.descs.len()
    }

    /// The descriptor being expanded: its patch and the jobs left in it.
    pub fn expanding(&self) -> Option<(u32, u32)> {
        self.descs.front().map(|d| (d.patch, d.jobs()))
    }

    /// The clock edge of the buffer's own stores, outside a stamping clock ([`Link::commit`]).
    #[inline(always)]
    pub fn commit(&mut self) {
        self.commit_at(u64::MAX);
    }

    /// The clock edge of the buffer's own stores at the end of cycle `now` ([`Link::commit_at`]).
    #[inline(always)]
    pub fn commit_at(&mut self, now: u64) {
        self.queue.commit_at(now);
        self.desc_jobs_registered = self.desc_jobs;
    }

    /// One clock cycle of a bundle buffer: carry out a split order on the last descriptor,
    /// expand one job of the front descriptor into the queue, take one descriptor from the
    /// next input (round-robin) with one waiting while there is room.
    pub fn tick_bundle(&mut self, cluster: u16, io: &mut BundlePorts) {
        let me = UnitCode::from(UnitId::RayBuffer(cluster as usize));
        let occ = self.queue.len() as u64 + self.desc_jobs;
        self.stats.occupancy_sum += occ;
        self.stats.max_occupancy = self.stats.max_occupancy.max(occ);
        if self.descs.is_empty()
            && io.orders.is_empty()
            && io.from_network.is_empty()
            && io.inputs.iter().all(Link::is_empty)
        {
            return;
        }
        if io.orders.peek().is_some() && io.out.can_push() {
            let o = io.orders.pop(me);
            // The front descriptor, when it is the only one, keeps a job for this ICU.
            let keep = (self.descs.len() == 1) as u32;
            let desc = self.descs.back_mut().and_then(|b| {
                let k = o.jobs.min(b.jobs().saturating_sub(keep));
                (k > 0).then(|| {
                    let cut = Descriptor { lo: b.hi - k, ..*b };
                    b.hi -= k;
                    cut
                })
            });
            if self.descs.back().is_some_and(|b| b.jobs() == 0) {
                self.descs.pop_back();
            }
            let k = desc.map_or(0, |d| d.jobs());
            self.desc_jobs -= k as u64;
            self.stats.work_items_given += (k > 0) as u64;
            self.stats.jobs_given += k as u64;
            // Always answer: an empty work-item tells the balancer there was nothing to give.
            io.out.push(
                me,
                WorkItem {
                    from: cluster,
                    to: o.thief,
                    jobs: Vec::new(),
                    desc,
                },
            );
        }
        if self.queue.can_push() {
            if let Some(f) = self.descs.front_mut() {
                let pool = &io.pool[f.owner as usize * io.ctus_per_cluster + f.ctu as usize];
                let (slot, ray) = pool.get(f.list, f.lo);
                self.queue.push(
                    me,
                    Job {
                        ray,
                        slot,
                        patch: f.patch,
                        ctu: f.ctu,
                        owner: f.owner,
                    },
                );
                f.lo += 1;
                if f.lo == f.hi {
                    self.descs.pop_front();
                }
                self.desc_jobs -= 1;
                self.stats.jobs_in += 1;
            }
        }
        let n = io.inputs.len() + 1;
        let mut i = self.next;
        for _ in 0..n {
            if self.descs.len() >= self.desc_capacity {
                break;
            }
            let link = if i < io.inputs.len() {
                &mut io.inputs[i]
            } else {
                &mut *io.from_network
            };
            if link.peek().is_some() {
                let d = link.pop(me);
                self.desc_jobs += d.jobs() as u64;
                if self.largest_first {
                    // Before the first one with fewer jobs left (ties in arrival order).
                    let at = self.descs.iter().position(|w| w.jobs() < d.jobs());
                    self.descs.insert(at.unwrap_or(self.descs.len()), d);
                } else {
                    self.descs.push_back(d);
                }
                self.stats.descriptors_in += 1;
                self.next = if i + 1 == n { 0 } else { i + 1 };
            }
            i = if i + 1 == n { 0 } else { i + 1 };
        }
    }

    /// One clock cycle: carry out a split order (at most `len − 1` jobs off the back, so
    /// never the job the ICU may take), then move one job in from the next input
    /// (round-robin) with one waiting. `cluster` is this buffer's cluster.
    #[inline(always)]
    pub fn tick(
        &mut self,
        cluster: u16,
        inputs: &mut [Link<Job>],
        from_network: &mut Link<Job>,
        orders: &mut Link<SplitOrder>,
        out: &mut Link<WorkItem>,
    ) {
        let occ = self.queue.len() as u64;
        self.stats.occupancy_sum += occ;
        self.stats.max_occupancy = self.stats.max_occupancy.max(occ);
        // Provably idle: no order and nothing at any input — only the occupancy counters move.
        if orders.is_empty() && from_network.is_empty() && inputs.iter().all(Link::is_empty) {
            return;
        }
        self.tick_active(
            cluster,
            JobPorts {
                inputs,
                from_network,
                orders,
                out,
            },
        );
    }

    /// A cycle with an order or a job waiting at an input.
    #[inline(always)]
    fn tick_active(&mut self, cluster: u16, io: JobPorts<'_>) {
        let JobPorts {
            inputs,
            from_network,
            orders,
            out,
        } = io;
        let me = UnitCode::from(UnitId::RayBuffer(cluster as usize));
        if !orders.is_empty() && out.can_push() {
            let o = orders.pop(me);
            let k = (o.jobs as usize).min(self.queue.len().saturating_sub(1));
            // Always answer: an empty work-item tells the balancer there was nothing to give.
            let jobs = if k > 0 {
                self.queue.take_back(me, k)
            } else {
                Vec::new()
            };
            self.stats.work_items_given += (k > 0) as u64;
            self.stats.jobs_given += k as u64;
            out.push(
                me,
                WorkItem {
                    from: cluster,
                    to: o.thief,
                    jobs,
                    desc: None,
                },
            );
        }
        // Inputs 0..K are the CTUs, K the network; the walk starts at `next`: inputs next..K,
        // the network, inputs 0..next. The starting input turns only when a job moves (an
        // idle cycle changes no state, so the machine's cycle jump cannot change the order).
        let (k, start) = (inputs.len(), self.next);
        let (before, from) = inputs.split_at_mut(start.min(k));
        'walk: {
            for (j, link) in from.iter_mut().enumerate() {
                if !self.take(me, link, start + j, k) {
                    break 'walk;
                }
            }
            if !self.take(me, from_network, k, k) {
                break 'walk;
            }
            for (j, link) in before.iter_mut().enumerate() {
                if !self.take(me, link, j, k) {
                    break 'walk;
                }
            }
        }
    }

    /// One input's turn in the walk: its waiting job, if any, moves into the queue and the
    /// next walk starts after it (input `i` of `k` CTU inputs and the network). False when
    /// the queue is full: it stays full for the rest of the cycle, so the walk ends. The
    /// buffer is each input's one consumer, so a valid input shows its front (`peek`).
    #[inline(always)]
    fn take(&mut self, me: UnitCode, link: &mut Link<Job>, i: usize, k: usize) -> bool {
        if !link.valid() {
            return true;
        }
        if !self.queue.can_push() {
            return false;
        }
        let job = link.pop(me);
        self.queue.push(me, job);
        self.stats.jobs_in += 1;
        self.next = if i == k { 0 } else { i + 1 };
        true
    }
}

/// The ray buffer's cold paths: quiet and done when its queue and descriptor store are
/// empty; it counts nothing of its own in a jump.
impl Unit for RayBuffer {
    fn quiet(&self, _now: u64, _: &Around) -> bool {
        self.is_empty()
    }

    fn done(&self) -> bool {
        self.is_empty()
    }

    fn report(&self, _now: u64) -> String {
        format!(
            "{}/{} jobs, {} descriptors",
            self.queue.len(),
            self.queue.capacity(),
            self.descriptors()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(ray: u32) -> Job {
        Job {
            ray,
            slot: ray,
            patch: 0,
            ctu: 0,
            owner: 0,
        }
    }

    /// A buffer holding jobs 0..n (CTU 0's link fed them in).
    fn filled(n: u32) -> (RayBuffer, Vec<Link<Job>>) {
        let mut b = RayBuffer::new(16, 2);
        let mut inputs = vec![Link::new(2)];
        let mut net = Link::new(2);
        let mut orders = Link::new(1);
        let mut out = Link::new(1);
        for r in 0..n {
            inputs[0].push(UnitId::Ctu(0, 0), job(r));
            inputs[0].commit();
            b.tick(0, &mut inputs, &mut net, &mut orders, &mut out);
            inputs[0].commit();
            b.queue.commit();
        }
        assert_eq!(b.queue.len(), n as usize);
        (b, inputs)
    }

    fn split(b: &mut RayBuffer, inputs: &mut [Link<Job>], jobs: u32, icu_pops: bool) -> WorkItem {
        let mut net = Link::new(2);
        let mut orders = Link::new(1);
        let mut out = Link::new(1);
        orders.push(UnitId::Balancer, SplitOrder { thief: 1, jobs });
        orders.commit();
        if icu_pops {
            b.queue.pop(UnitId::Icu(0));
        }
        b.tick(0, inputs, &mut net, &mut orders, &mut out);
        b.queue.commit();
        out.commit();
        out.pop(UnitId::Balancer)
    }

    #[test]
    fn the_inputs_take_turns_and_a_full_queue_stops_the_walk() {
        // Two CTU inputs and the network hold two jobs each; the queue holds 2, and its ICU
        // pops one per cycle from cycle 1 on.
        let mut b = RayBuffer::new(2, 3);
        let mut inputs = vec![Link::new(2), Link::new(2)];
        let mut net = Link::new(2);
        let (mut orders, mut out) = (Link::new(1), Link::new(1));
        for k in 0..2 {
            inputs[0].push(UnitId::Ctu(0, 0), job(10 + k));
            inputs[1].push(UnitId::Ctu(0, 1), job(20 + k));
            net.push(UnitId::Balancer, job(30 + k));
            inputs.iter_mut().for_each(Link::commit);
            net.commit();
        }
        let (mut taken, mut per_cycle) = (vec![], vec![]);
        for cycle in 0..8 {
            let before = b.stats.jobs_in;
            b.tick(0, &mut inputs, &mut net, &mut orders, &mut out);
            per_cycle.push(b.stats.jobs_in - before);
            if cycle >= 1 && b.queue.peek().is_some() {
                taken.push(b.queue.pop(UnitId::Icu(0)).ray);
            }
            inputs.iter_mut().for_each(Link::commit);
            net.commit();
            b.commit();
        }
        // Cycle 0 fills the queue from inputs 0 and 1; at 1 it is full (a staged pop frees
        // nothing); then one job a cycle, each from the input whose turn it is: the network
        // (skipped while full), input 0, input 1, the network.
        assert_eq!(per_cycle, vec![2, 0, 1, 1, 1, 1, 0, 0]);
        assert_eq!(taken, vec![10, 20, 30, 11, 21, 31]);
    }

    #[test]
    fn a_split_takes_jobs_from_the_back() {
        let (mut b, mut inputs) = filled(5);
        let w = split(&mut b, &mut inputs, 3, false);
        assert_eq!(
            w.jobs.iter().map(|j| j.ray).collect::<Vec<_>>(),
            vec![2, 3, 4]
        );
        assert_eq!((w.from, w.to), (0, 1));
        assert_eq!(b.queue.len(), 2);
        assert_eq!(b.queue.peek().map(|j| j.ray), Some(0));
    }

    #[test]
    fn a_split_never_takes_the_front_job_even_while_the_icu_pops_it() {
        let (mut b, mut inputs) = filled(4);
        let w = split(&mut b, &mut inputs, 100, true);
        // At most len − 1: job 0 went to the ICU this cycle, jobs 1..4 to the thief.
        assert_eq!(
            w.jobs.iter().map(|j| j.ray).collect::<Vec<_>>(),
            vec![1, 2, 3]
        );
        assert!(b.queue.is_empty());
        assert_eq!(b.stats.jobs_given, 3);
    }

    #[test]
    fn a_bundle_buffer_expands_descriptors_in_order_and_splits_the_last_one() {
        let pool = vec![RayList::new(&[100, 101, 102, 103, 104, 105])];
        let mut b = RayBuffer::bundle(4, false);
        let mut inputs = vec![Link::new(2)];
        let mut net = Link::new(2);
        let mut orders = Link::new(1);
        let mut out = Link::new(1);
        let desc = |patch, lo, hi| Descriptor {
            patch,
            ctu: 0,
            owner: 0,
            list: 0,
            lo,
            hi,
        };
        let mut jobs = vec![];
        let mut item = None;
        for now in 0..20 {
            if now < 2 {
                inputs[0].push(UnitId::Ctu(0, 0), desc(now as u32 + 1, 0, 6));
            }
            if now == 4 {
                orders.push(UnitId::Balancer, SplitOrder { thief: 1, jobs: 4 });
            }
            let mut io = BundlePorts {
                inputs: &mut inputs,
                from_network: &mut net,
                orders: &mut orders,
                out: &mut out,
                pool: &pool,
                ctus_per_cluster: 1,
            };
            b.tick_bundle(0, &mut io);
            if b.queue.peek().is_some() {
                let j = b.queue.pop(UnitId::Icu(0));
                jobs.push((j.patch, j.ray));
            }
            if out.peek().is_some() {
                item = Some(out.pop(UnitId::Balancer));
            }
            for l in [&mut inputs[0], &mut net] {
                l.commit();
            }
            orders.commit();
            out.commit();
            b.commit();
        }
        // Patch 2's last 4 rays went to the thief as a descriptor; the rest expanded in order.
        let w = item.expect("a work-item");
        assert_eq!(w.desc, Some(desc(2, 2, 6)));
        let want: Vec<(u32, u32)> = (100..106)
            .map(|r| (1, r))
            .chain([(2, 100), (2, 101)])
            .collect();
        assert_eq!(jobs, want);
        assert_eq!((b.stats.descriptors_in, b.stats.jobs_given), (2, 4));
        assert!(b.is_empty());
    }

    #[test]
    fn a_split_of_a_single_job_answers_empty() {
        let (mut b, mut inputs) = filled(1);
        let w = split(&mut b, &mut inputs, 4, false);
        assert!(w.jobs.is_empty());
        assert_eq!(b.queue.len(), 1);
        assert_eq!(b.stats.work_items_given, 0);
    }

    #[test]
    fn the_ray_buffer_reports_its_signal_count() {
        let mut n = crate::machine::sink::Count::default();
        RayBuffer::new(4, 1).bundle_signals(&mut n, "");
        assert_eq!(n.0, RayBuffer::BUNDLE_SIGNALS);
    }
}
