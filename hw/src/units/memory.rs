//! The global memory with its one port and the arbiter in front of it.
//!
//! The arbiter sees one request link per CTU. When the port is free it grants one waiting
//! request: round-robin starts its search after the last requester granted, so with N
//! requesters none waits more than N − 1 grants of the others (fair); fixed priority always
//! takes the lowest-numbered requester (simple, may starve the others — an option for
//! studies). A grant occupies the port for one cycle per word of the patch record; the
//! record reaches the requester's patch buffer `latency + words` cycles after the grant.
//! Records wait in one delivery queue per cluster: a full patch buffer holds back only its
//! own cluster's records, never another cluster's.

use crate::config::ArbiterPolicy;
use crate::link::{Link, UnitId};
use crate::machine::sink::Sink;
use crate::msg::{MemRequest, PatchArrival};
use crate::units::{Around, Unit};
use std::collections::VecDeque;

/// The memory's write ports: each cluster's patch-buffer store (the buffer owns it).
pub trait Stores {
    /// Cluster `cluster`'s store.
    fn store(&mut self, cluster: usize) -> &mut Link<PatchArrival>;
}

impl Stores for [Link<PatchArrival>] {
    fn store(&mut self, cluster: usize) -> &mut Link<PatchArrival> {
        &mut self[cluster]
    }
}

/// Memory and arbiter counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct MemoryStats {
    pub grants: u64,
    /// Σ over grants of the cycles the request waited for it.
    pub wait_cycles: u64,
    pub words: u64,
    /// Cycles the port was occupied by a transfer.
    pub busy_cycles: u64,
    /// Cycles a ready record waited for room in a patch buffer.
    pub delivery_stall_cycles: u64,
}

/// A record on its way to a patch buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct InFlight {
    ready: u64,
    cluster: u16,
    arrival: PatchArrival,
}

/// The global memory and its arbiter.
#[derive(Clone, Debug)]
pub struct Memory {
    policy: ArbiterPolicy,
    latency: u64,
    words: u64,
    port_free_at: u64,
    next: usize,
    /// Records on their way, one queue per cluster (each in grant order).
    inflight: Vec<VecDeque<InFlight>>,
    /// Records in all of `inflight` (the delivery walk is skipped when there are none).
    queued: usize,
    /// The requester granted last (for waveforms); `u32::MAX` before the first grant.
    pub last_grant: u32,
    pub stats: MemoryStats,
}

impl Memory {
    /// The memory's waveform signals: [`Memory::signals`] reports exactly these.
    pub const SIGNALS: usize = 3;
    /// The arbiter's: [`Memory::arbiter_signals`] reports exactly these.
    pub const ARBITER_SIGNALS: usize = 1;

    /// Reports the memory's waveform signals at cycle `now` to `s` under `scope` (a new
    /// signal: one line here, counted in [`Memory::SIGNALS`]).
    #[inline(always)]
    pub(crate) fn signals(&self, s: &mut impl Sink, scope: &str, now: u64) {
        s.bits(scope, "port_busy", 1, self.port_busy(now) as u64);
        s.bits(scope, "in_flight", 16, self.inflight() as u64);
        s.bits(scope, "grants", 32, self.stats.grants);
    }

    /// Reports the arbiter's waveform signals to `s` under `scope` (counted in
    /// [`Memory::ARBITER_SIGNALS`]).
    #[inline(always)]
    pub(crate) fn arbiter_signals(&self, s: &mut impl Sink, scope: &str) {
        s.bits(scope, "last_grant", 16, self.last_grant.min(0xFFFF) as u64);
    }

    /// A memory serving `clusters` clusters, with `latency` cycles and `words` words per
    /// patch record.
    pub fn new(policy: ArbiterPolicy, latency: u32, words: u32, clusters: usize) -> Self {
        Memory {
            policy,
            latency: latency as u64,
            words: words as u64,
            port_free_at: 0,
            next: 0,
            inflight: vec![VecDeque::new(); clusters],
            queued: 0,
            last_grant: u32::MAX,
            stats: MemoryStats::default(),
        }
    }

    /// Records on their way.
    pub fn inflight(&self) -> usize {
        self.queued
    }

    /// True when the port is occupied at cycle `now`.
    pub fn port_busy(&self, now: u64) -> bool {
        now < self.port_free_at
    }

    /// The next cycle (from `now` on) at which the memory acts on its own or its signals
    /// change: the port frees or a record becomes ready. `None` when nothing is pending.
    pub fn timer(&self, now: u64) -> Option<u64> {
        let mut t: Option<u64> = None;
        // The port freeing at `now` itself changes what the waveform shows this cycle.
        if self.port_free_at >= now {
            t = Some(self.port_free_at);
        }
        for q in &self.inflight {
            if let Some(f) = q.front() {
                if f.ready > now {
                    t = Some(t.map_or(f.ready, |x| x.min(f.ready)));
                }
            }
        }
        t
    }

    /// The earliest ready cycle among the queues' oldest records, if one is ready at `now`.
    pub fn inflight_ready(&self, now: u64) -> Option<u64> {
        self.inflight
            .iter()
            .filter_map(|q| q.front())
            .filter(|f| f.ready <= now)
            .map(|f| f.ready)
            .min()
    }

    /// Accounts `n` skipped cycles (the port stays as it was).
    pub fn skip(&mut self, now: u64, n: u64) {
        let busy_until = self.port_free_at.min(now + n);
        self.stats.busy_cycles += busy_until.saturating_sub(now);
    }

    /// One clock cycle: deliver a ready record, then grant a waiting request if the port is
    /// free. `requests` are indexed by requester (cluster-major); `buffers` by cluster.
    #[inline(always)]
    pub fn tick(
        &mut self,
        now: u64,
        requests: &mut [Link<MemRequest>],
        buffers: &mut (impl Stores + ?Sized),
    ) {
        // Nothing on its way and (the port busy, or nothing asked for): the cycle changes
        // nothing but the busy count.
        if now < self.port_free_at {
            self.stats.busy_cycles += 1;
            if self.queued == 0 {
                return;
            }
        } else if self.queued == 0 && requests.iter().all(Link::is_empty) {
            return;
        }
        self.tick_active(now, requests, buffers);
    }

    /// A cycle with the port busy, a record on its way or a request waiting.
    #[inline(always)]
    fn tick_active(
        &mut self,
        now: u64,
        requests: &mut [Link<MemRequest>],
        buffers: &mut (impl Stores + ?Sized),
    ) {
        // Deliver: each cluster's oldest ready record, if its patch buffer has room.
        let mut stalled = false;
        let walk = if self.queued > 0 {
            self.inflight.len()
        } else {
            0
        };
        for (c, q) in self.inflight[..walk].iter_mut().enumerate() {
            if let Some(f) = q.front() {
                if f.ready <= now {
                    let b = buffers.store(c);
                    if b.can_push() {
                        b.push(UnitId::Memory, f.arrival);
                        q.pop_front();
                        self.queued -= 1;
                    } else {
                        stalled = true;
                    }
                }
            }
        }
        self.stats.delivery_stall_cycles += stalled as u64;
        if now < self.port_free_at {
            return;
        }
        let n = requests.len();
        let start = match self.policy {
            ArbiterPolicy::RoundRobin => self.next,
            ArbiterPolicy::FixedPriority => 0,
        };
        // The first requester waiting from `start` on, wrapping (the memory is every request
        // link's one consumer, so a link that is not empty shows its front).
        let waiting = |l: &Link<MemRequest>| !l.is_empty();
        let Some(i) = requests[start..]
            .iter()
            .position(waiting)
            .map(|p| p + start)
            .or_else(|| requests[..start].iter().position(waiting))
        else {
            return;
        };
        let r = requests[i].pop(UnitId::Memory);
        self.stats.grants += 1;
        self.stats.wait_cycles += now - r.issued;
        self.stats.words += self.words;
        self.port_free_at = now + self.words;
        self.queued += 1;
        self.inflight[r.cluster as usize].push_back(InFlight {
            ready: now + self.latency + self.words,
            cluster: r.cluster,
            arrival: PatchArrival {
                patch: r.patch,
                ctu: r.ctu,
            },
        });
        self.last_grant = i as u32;
        self.next = (i + 1) % n;
    }
}

/// The memory's cold paths: quiet while no record is ready to deliver; its timer is the port
/// freeing or the next record becoming ready.
impl Unit for Memory {
    fn quiet(&self, now: u64, _: &Around) -> bool {
        self.inflight_ready(now).is_none()
    }

    fn timer(&self, now: u64) -> Option<u64> {
        Memory::timer(self, now)
    }

    fn skip(&mut self, now: u64, n: u64) {
        Memory::skip(self, now, n);
    }

    fn activity(&self) -> u64 {
        self.stats.grants
    }

    fn done(&self) -> bool {
        self.inflight() == 0
    }

    fn report(&self, now: u64) -> String {
        format!(
            "port {}, {} in flight, {} grants",
            if self.port_busy(now) { "busy" } else { "free" },
            self.inflight(),
            self.stats.grants
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Requesters that always have a request queued; returns the grant order over `cycles`.
    fn grants(policy: ArbiterPolicy, requesters: usize, words: u32, cycles: u64) -> Vec<u32> {
        let mut m = Memory::new(policy, 0, words, 1);
        let mut req: Vec<Link<MemRequest>> = (0..requesters)
            .map(|j| Link::new(1).wired(UnitId::Ctu(0, j), UnitId::Memory))
            .collect();
        let mut store = vec![Link::new(64)];
        let mut out = vec![];
        for now in 0..cycles {
            for (j, l) in req.iter_mut().enumerate() {
                if l.can_push() {
                    let r = MemRequest {
                        patch: j as u32,
                        cluster: 0,
                        ctu: j as u16,
                        issued: now,
                    };
                    l.push(UnitId::Ctu(0, j), r);
                }
            }
            let before = m.stats.grants;
            m.tick(now, &mut req, store.as_mut_slice());
            if m.stats.grants > before {
                out.push(m.last_grant);
            }
            if store[0].peek().is_some() {
                store[0].pop(UnitId::PatchBuffer(0));
            }
            req.iter_mut().for_each(Link::commit);
            store[0].commit();
        }
        out
    }

    #[test]
    fn round_robin_no_requester_waits_more_than_one_round_of_the_others() {
        let g = grants(ArbiterPolicy::RoundRobin, 3, 1, 40);
        assert!(g.len() >= 12, "{g:?}");
        for w in g.windows(3) {
            let mut s = w.to_vec();
            s.sort();
            assert_eq!(
                s,
                vec![0, 1, 2],
                "every window of 3 grants serves all: {g:?}"
            );
        }
    }

    #[test]
    fn fixed_priority_the_lowest_requester_wins() {
        let g = grants(ArbiterPolicy::FixedPriority, 3, 1, 40);
        assert!(!g.is_empty());
        // Requester 0 re-queues at once (its link has room after each grant's edge), so it
        // takes every grant it is waiting for; 2 never wins while 0 or 1 waits.
        assert!(g.iter().all(|&x| x != 2), "{g:?}");
        assert_eq!(g[0], 0);
    }

    #[test]
    fn records_count_in_flight_until_delivered_and_a_full_store_holds_them_back() {
        // Latency 2, one word: grants at cycles 0, 1, 2 are ready at 3, 4, 5. Cluster 0's
        // store holds one record and is not read until cycle 20.
        let mut m = Memory::new(ArbiterPolicy::RoundRobin, 2, 1, 2);
        let mut req: Vec<Link<MemRequest>> = (0..2)
            .map(|c| Link::new(2).wired(UnitId::Ctu(c, 0), UnitId::Memory))
            .collect();
        for (c, patch) in [(0, 1), (1, 3), (0, 2)] {
            let r = MemRequest {
                patch,
                cluster: c as u16,
                ctu: 0,
                issued: 0,
            };
            req[c].push(UnitId::Ctu(c, 0), r);
            req[c].commit();
        }
        let mut store = vec![Link::new(1), Link::new(4)];
        let mut inflight = vec![];
        for now in 0..30u64 {
            m.tick(now, &mut req, store.as_mut_slice());
            inflight.push(m.inflight());
            if store[1].peek().is_some() {
                store[1].pop(UnitId::PatchBuffer(1));
            }
            if now >= 20 && store[0].peek().is_some() {
                store[0].pop(UnitId::PatchBuffer(0));
            }
            req.iter_mut().for_each(Link::commit);
            store.iter_mut().for_each(Link::commit);
        }
        assert_eq!(&inflight[..5], &[1, 2, 3, 2, 1]);
        // Patch 2 is ready at 5 but waits for room until the pop at 20 frees it at 21.
        assert!(inflight[5..=20].iter().all(|&n| n == 1), "{inflight:?}");
        assert!(inflight[21..].iter().all(|&n| n == 0), "{inflight:?}");
        assert_eq!(m.stats.delivery_stall_cycles, 16);
        assert_eq!(m.stats.grants, 3);
        assert_eq!(m.timer(30), None, "nothing pending");
    }

    #[test]
    fn a_grant_takes_latency_plus_one_cycle_per_word() {
        let (latency, words) = (5u32, 3u32);
        let mut m = Memory::new(ArbiterPolicy::RoundRobin, latency, words, 1);
        let me = UnitId::Ctu(0, 0);
        let mut req = vec![Link::new(2).wired(me, UnitId::Memory)];
        let mut store = vec![Link::new(4)];
        for patch in [7, 8] {
            req[0].push(
                me,
                MemRequest {
                    patch,
                    cluster: 0,
                    ctu: 0,
                    issued: 0,
                },
            );
            req[0].commit();
        }
        let mut arrivals = vec![];
        let mut grant_cycles = vec![];
        for now in 0..40u64 {
            let g = m.stats.grants;
            m.tick(now, &mut req, store.as_mut_slice());
            if m.stats.grants > g {
                grant_cycles.push(now);
            }
            req[0].commit();
            store[0].commit();
            if let Some(a) = store[0].peek() {
                arrivals.push((now, a.patch));
                store[0].pop(UnitId::PatchBuffer(0));
                store[0].commit();
            }
        }
        // The port is busy one cycle per word: the second grant waits `words` cycles.
        assert_eq!(grant_cycles, vec![0, words as u64]);
        // A record is delivered `latency + words` cycles after its grant (visible at that
        // cycle's edge).
        let l = (latency + words) as u64;
        assert_eq!(arrivals, vec![(l, 7), (words as u64 + l, 8)]);
        assert_eq!(m.stats.words, 2 * words as u64);
        assert_eq!(m.stats.wait_cycles, words as u64);
    }

    #[test]
    fn the_memory_reports_its_signal_counts() {
        use crate::machine::sink::Count;
        let m = Memory::new(ArbiterPolicy::RoundRobin, 2, 1, 2);
        let (mut a, mut b) = (Count::default(), Count::default());
        m.signals(&mut a, "", 0);
        m.arbiter_signals(&mut b, "");
        assert_eq!((a.0, b.0), (Memory::SIGNALS, Memory::ARBITER_SIGNALS));
    }
}
