//! Every link of the machine, in one table: its message, how many there are, its capacity,
//! its producer and consumer (wired once, checked on every push and pop — rule 7 of `link`),
//! where the waveform shows it, and whether it `waits` for its cluster (an input of the
//! cluster's ray buffer: a message on it is work for the cluster). `commit_all`, `all_empty`,
//! `waiting_for` (is anything waiting for cluster c), `memory_estimate`, `probe` and the
//! wiring are generated from the table, so adding a link touches this table and nothing else.
//!
//! The clock edge commits only the links touched in the cycle: each family has its own touch
//! words, link i of a family raising bit i % 64 of its family's word i / 64 when a push, pop
//! or take-back stages something, and `commit_all` takes each family's words in table order
//! and commits the links whose bits are up — a few of the table's links a cycle, found
//! without testing the rest and reached without a dispatch on the family (an indirect jump
//! per touched link, mispredicted as often as the touched families change from cycle to
//! cycle).
//!
//! The two buffers' stores (the ray buffer's queue, the patch buffer's store) are the units'
//! own state, not links of this table; `Cluster::commit` clocks them.

use super::sink::Sink;
use crate::config::MachineTable;
use crate::link::{Link, TouchWord, UnitId};
use crate::msg::{Descriptor, Job, JobResult, MemRequest, RemoteResult, SplitOrder, WorkItem};

/// Where a link family appears in the waveform (the probe calls it at that point, so the
/// signal order of every waveform stays as it is).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Section {
    /// After the arbiter's signals: every link of the family.
    Arbiter,
    /// In cluster c's balance scope (balancing on only).
    Balance(usize),
    /// After cluster c's ray buffer (`job_source = "bundle"` only).
    BundleCluster(usize),
    /// After CTU (c, j)'s links (`job_source = "bundle"` only).
    BundleCtu(usize, usize),
    /// After CTU (c, j)'s signals.
    Ctu(usize, usize),
    /// Not shown.
    Hidden,
}

/// How many links a family has and how index `i` maps to (cluster, CTU).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shape {
    /// One per CTU, cluster-major: i = c·k + j.
    PerCtu,
    /// One per cluster: i = c (j = 0).
    PerCluster,
}

macro_rules! links {
    ($(
        $(#[doc = $doc:literal])*
        $name:ident: $t:ty, $shape:ident,
            capacity $cap:expr,
            $from:expr => $to:expr,
            probe $section:expr,
            scope $scope:expr,
            waits $waits:literal;
    )*) => {
        /// Every link of the machine (see the table in machine/links.rs). Not `Clone`: its
        /// links record their touches in its touch words, which a copy would share.
        #[derive(Debug)]
        pub struct Links {
            $( $(#[doc = $doc])* pub $name: Vec<Link<$t>>, )*
            /// CTUs per cluster.
            k: usize,
            /// Waveform scope of each link, per family (built once).
            scopes: Scopes,
            /// Each family's touch words: its link i raises bit i % 64 of word i / 64.
            touch: Touch,
        }

        /// The touch words of each family.
        #[derive(Debug, Default)]
        struct Touch {
            $( $name: Vec<TouchWord>, )*
        }

        #[derive(Clone, Debug, Default)]
        struct Scopes {
            $( $name: Vec<String>, )*
        }

        /// Per family, whether a waveform shows each link ([`Links::shown`]): the
        /// sampler's, not the model's.
        #[derive(Clone, Debug, Default)]
        pub(super) struct LinkShown {
            $( $name: Vec<bool>, )*
        }

        impl LinkShown {
            /// True when the waveform shows every link.
            pub(super) fn all(&self) -> bool {
                true $( && self.$name.iter().all(|&x| x) )*
            }
        }

        impl Links {
            /// Every link, wired, for the machine `m`.
            pub fn new(m: &MachineTable) -> Self {
                let nc = m.clusters as usize;
                let k = m.ctus_per_cluster as usize;
                let ends = |shape: Shape| -> Vec<(usize, usize)> {
                    match shape {
                        Shape::PerCtu => (0..nc * k).map(|i| (i / k, i % k)).collect(),
                        Shape::PerCluster => (0..nc).map(|c| (c, 0)).collect(),
                    }
                };
                let mut scopes = Scopes::default();
                let mut touch = Touch::default();
                $(
                    let cap: fn(&MachineTable) -> usize = $cap;
                    let from: fn(usize, usize) -> UnitId = $from;
                    let to: fn(usize, usize) -> UnitId = $to;
                    let scope: fn(usize, usize) -> String = $scope;
                    let at = ends(Shape::$shape);
                    scopes.$name = at.iter().map(|&(c, j)| scope(c, j)).collect();
                    let mut $name: Vec<Link<$t>> = at
                        .iter()
                        .map(|&(c, j)| Link::new(cap(m)).wired(from(c, j), to(c, j)))
                        .collect();
                    touch.$name = (0..$name.len().div_ceil(64)).map(|_| TouchWord::default()).collect();
                    for (i, l) in $name.iter_mut().enumerate() {
                        l.log_touches(&touch.$name[i / 64], (i % 64) as u32);
                    }
                )*
                Links { $( $name, )* k, scopes, touch }
            }

            /// Which links a waveform that `wants` some scopes shows: those whose scope
            /// it wants.
            pub(super) fn shown(&self, wants: &dyn Fn(&str) -> bool) -> LinkShown {
                LinkShown {
                    $( $name: self.scopes.$name.iter().map(|s| wants(s)).collect(), )*
                }
            }

            /// The clock edge of every link: those touched this cycle commit, the others
            /// have nothing to do.
            pub fn commit_all(&mut self, now: u64) {
                $( commit_family(&mut self.$name, &self.touch.$name, now); )*
            }

            /// True when every link is empty.
            pub fn all_empty(&self) -> bool {
                true $( && self.$name.iter().all(Link::is_empty) )*
            }

            /// True when a message waits on a link into cluster `c`: one of the families
            /// marked `waits` (the cluster's inputs), at the last edge. The link part of "is
            /// anything waiting for cluster c" — the idle cluster's test in the forward tick
            /// and the balancer's request test in the cycle jump.
            #[inline(always)]
            pub fn waiting_for(&self, c: usize) -> bool {
                false $( || ($waits && !self.of(Shape::$shape, &self.$name, c).iter().all(Link::is_empty)) )*
            }

            /// Bytes every link takes for the machine `m`: per family its count of links,
            /// each a [`Link`] and its slots, from the capacities [`Links::new`] gives them
            /// (tested against what it allocates).
            pub fn memory_estimate(m: &MachineTable) -> u64 {
                let (nc, k) = (m.clusters as u64, m.ctus_per_cluster as u64);
                0 $( + {
                    let cap: fn(&MachineTable) -> usize = $cap;
                    let n = match Shape::$shape {
                        Shape::PerCtu => nc * k,
                        Shape::PerCluster => nc,
                    };
                    n * Link::<$t>::bytes(cap(m))
                } )*
            }

            /// Bytes the links take as built: every link's [`Link::allocated_bytes`].
            #[cfg(test)]
            fn allocated_bytes(&self) -> u64 {
                0 $( + self.$name.iter().map(Link::allocated_bytes).sum::<u64>() )*
            }

            /// Reports the links of `section` to `p`, family by family in table order (when
            /// `FILTERED`, those `shown` only).
            #[inline(always)]
            pub(super) fn probe<S: Sink, const FILTERED: bool>(
                &self,
                p: &mut S,
                section: Section,
                shown: &LinkShown,
            ) {
                $(
                    let want: Section = $section;
                    let shape = Shape::$shape;
                    match (want, section) {
                        (Section::Arbiter, Section::Arbiter) => {
                            for (i, (l, s)) in self.$name.iter().zip(&self.scopes.$name).enumerate() {
                                if !FILTERED || shown.$name[i] {
                                    probe_link(p, s, l);
                                }
                            }
                        }
                        (Section::Balance(_), Section::Balance(c))
                        | (Section::BundleCluster(_), Section::BundleCluster(c)) => {
                            let i = self.index(shape, c, 0);
                            if !FILTERED || shown.$name[i] {
                                probe_link(p, &self.scopes.$name[i], &self.$name[i]);
                            }
                        }
                        (Section::Ctu(..), Section::Ctu(c, j))
                        | (Section::BundleCtu(..), Section::BundleCtu(c, j)) => {
                            let i = self.index(shape, c, j);
                            if !FILTERED || shown.$name[i] {
                                probe_link(p, &self.scopes.$name[i], &self.$name[i]);
                            }
                        }
                        _ => {}
                    }
                )*
            }
        }
    };
}

links! {
    /// CTU (c, j) → the memory's arbiter: patch-load requests.
    requests: MemRequest, PerCtu,
        capacity |m| m.request_queue_capacity as usize,
        |c, j| UnitId::Ctu(c, j) => |_, _| UnitId::Memory,
        probe Section::Arbiter,
        scope |c, j| format!("machine.memory.arbiter.req_{c}_{j}"),
        waits false;
    /// CTU (c, j) → ray buffer c: jobs (a skid buffer).
    jobs: Job, PerCtu,
        capacity |_| 2,
        |c, j| UnitId::Ctu(c, j) => |c, _| UnitId::RayBuffer(c),
        probe Section::Ctu(0, 0),
        scope |c, j| format!("machine.cluster_{c}.ctu_{j}.jobs"),
        waits true;
    /// ICU c → CTU (c, j): results of its own jobs.
    results: JobResult, PerCtu,
        capacity |_| 2,
        |c, _| UnitId::Icu(c) => |c, j| UnitId::Ctu(c, j),
        probe Section::Ctu(0, 0),
        scope |c, j| format!("machine.cluster_{c}.ctu_{j}.results"),
        waits false;
    /// Patch buffer c → CTU (c, j): arrived patch records.
    arrivals: crate::msg::PatchArrival, PerCtu,
        capacity |_| 2,
        |c, _| UnitId::PatchBuffer(c) => |c, j| UnitId::Ctu(c, j),
        probe Section::Ctu(0, 0),
        scope |c, j| format!("machine.cluster_{c}.ctu_{j}.arrivals"),
        waits false;
    /// Balancer → ray buffer c: split orders.
    orders: SplitOrder, PerCluster,
        capacity |_| 1,
        |_, _| UnitId::Balancer => |c, _| UnitId::RayBuffer(c),
        probe Section::Balance(0),
        scope |c, _| format!("machine.cluster_{c}.balance.split_order"),
        waits true;
    /// Ray buffer c → balancer: work-items split off.
    items: WorkItem, PerCluster,
        capacity |_| 1,
        |c, _| UnitId::RayBuffer(c) => |_, _| UnitId::Balancer,
        probe Section::Balance(0),
        scope |c, _| format!("machine.cluster_{c}.balance.work_item"),
        waits false;
    /// Balancer → ray buffer c: jobs arriving over the inter-cluster link.
    net_in: Job, PerCluster,
        capacity |_| 2,
        |_, _| UnitId::Balancer => |c, _| UnitId::RayBuffer(c),
        probe Section::Balance(0),
        scope |c, _| format!("machine.cluster_{c}.balance.net_in"),
        waits true;
    /// ICU c → balancer: results of other clusters' jobs.
    remote_out: RemoteResult, PerCluster,
        capacity |_| 2,
        |c, _| UnitId::Icu(c) => |_, _| UnitId::Balancer,
        probe Section::Balance(0),
        scope |c, _| format!("machine.cluster_{c}.balance.remote_out"),
        waits false;
    /// Balancer → CTU (c, j): results of its jobs computed elsewhere.
    remote_in: JobResult, PerCtu,
        capacity |_| 2,
        |_, _| UnitId::Balancer => |c, j| UnitId::Ctu(c, j),
        probe Section::Hidden,
        scope |c, j| format!("machine.cluster_{c}.ctu_{j}.remote_in"),
        waits false;
    /// CTU (c, j) → ray buffer c: descriptors (`job_source = "bundle"`).
    descs: Descriptor, PerCtu,
        capacity |_| 2,
        |c, j| UnitId::Ctu(c, j) => |c, _| UnitId::RayBuffer(c),
        probe Section::BundleCtu(0, 0),
        scope |c, j| format!("machine.cluster_{c}.ctu_{j}.descriptors"),
        waits true;
    /// Balancer → ray buffer c: split descriptors over the inter-cluster link (bundle).
    net_desc: Descriptor, PerCluster,
        capacity |_| 2,
        |_, _| UnitId::Balancer => |c, _| UnitId::RayBuffer(c),
        probe Section::BundleCluster(0),
        scope |c, _| format!("machine.cluster_{c}.ray_buffer.net_descriptors"),
        waits true;
}

impl Links {
    /// Cluster `c`'s links of a family of `shape`.
    #[inline(always)]
    fn of<'a, T>(&self, shape: Shape, family: &'a [Link<T>], c: usize) -> &'a [Link<T>] {
        match shape {
            Shape::PerCtu => &family[c * self.k..(c + 1) * self.k],
            Shape::PerCluster => std::slice::from_ref(&family[c]),
        }
    }

    /// The index in a family of `shape` of the link at (cluster `c`, CTU `j`).
    fn index(&self, shape: Shape, c: usize, j: usize) -> usize {
        match shape {
            Shape::PerCtu => c * self.k + j,
            Shape::PerCluster => c,
        }
    }

    /// CTUs per cluster (per-CTU families are cluster-major: `c * k + j`).
    pub fn ctus_per_cluster(&self) -> usize {
        self.k
    }

    /// Cluster `c`'s slice of a per-CTU family.
    pub fn of_cluster<T>(family: &mut [Link<T>], k: usize, c: usize) -> &mut [Link<T>] {
        &mut family[c * k..(c + 1) * k]
    }
}

/// The clock edge of a family's links whose bits are up in its touch `words` (one whose
/// bit is up but that has nothing staged commits nothing).
#[inline(always)]
fn commit_family<T: Clone>(family: &mut [Link<T>], words: &[TouchWord], now: u64) {
    for (w, word) in words.iter().enumerate() {
        let mut bits = word.take();
        while bits != 0 {
            let i = w * 64 + bits.trailing_zeros() as usize;
            bits &= bits - 1;
            if let Some(l) = family.get_mut(i) {
                l.commit_at(now);
            }
        }
    }
}

/// Reports a link's registered valid, ready, occupancy and transfer count (a filler skips
/// them when no edge touched the link since the last sample).
pub(super) fn probe_link<T: Clone, S: Sink>(p: &mut S, scope: &str, l: &Link<T>) {
    let moved = p.link_moved(l.stamp());
    if !p.skip_unchanged(moved, Link::<T>::SIGNALS) {
        l.signals(p, scope);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::MemRequest;

    /// 40 clusters of the paper's 2 CTUs: 80 links a per-CTU family (two touch words, links
    /// 64.. in the second), 40 a per-cluster family (one).
    fn links() -> Links {
        let mut m = crate::config::paper().machine;
        m.clusters = 40;
        Links::new(&m)
    }

    /// The estimate is what `new` allocates, for configurations of every shape and capacity.
    #[test]
    fn the_memory_estimate_is_what_the_links_allocate() {
        for (clusters, ctus, queue) in
            [(1, 1, 1), (4, 2, 8), (40, 2, 0), (3, 7, 200), (256, 64, 16)]
        {
            let mut m = crate::config::paper().machine;
            (m.clusters, m.ctus_per_cluster, m.request_queue_capacity) = (clusters, ctus, queue);
            let l = Links::new(&m);
            assert_eq!(
                Links::memory_estimate(&m),
                l.allocated_bytes(),
                "{clusters} × {ctus}, queue {queue}"
            );
        }
    }

    /// Cluster c waits exactly while one of the ray buffer's inputs of cluster c holds a
    /// message: its CTUs' jobs and descriptors, its split order, its jobs and descriptors
    /// from the network; nothing else.
    #[test]
    fn waiting_for_a_cluster_is_a_message_on_one_of_its_inputs() {
        let mut l = links();
        assert!((0..40).all(|c| !l.waiting_for(c)));
        let at = |l: &mut Links, f: &dyn Fn(&mut Links)| {
            f(l);
            l.commit_all(0);
            let w: Vec<usize> = (0..40).filter(|&c| l.waiting_for(c)).collect();
            *l = links();
            w
        };
        let ctu = UnitId::Ctu(33, 1);
        assert_eq!(at(&mut l, &|l| l.jobs[67].push(ctu, Job::default())), [33]);
        assert_eq!(
            at(&mut l, &|l| l.descs[67].push(ctu, Descriptor::default())),
            [33]
        );
        let bal = UnitId::Balancer;
        assert_eq!(
            at(&mut l, &|l| l.orders[5].push(bal, SplitOrder::default())),
            [5]
        );
        assert_eq!(
            at(&mut l, &|l| l.net_in[39].push(bal, Job::default())),
            [39]
        );
        assert_eq!(
            at(&mut l, &|l| l.net_desc[0].push(bal, Descriptor::default())),
            [0]
        );
        let none: [usize; 0] = [];
        assert_eq!(
            at(&mut l, &|l| l.requests[67].push(ctu, MemRequest::default())),
            none
        );
        assert_eq!(
            at(&mut l, &|l| l.results[67]
                .push(UnitId::Icu(33), JobResult::default())),
            none
        );
        assert_eq!(
            at(&mut l, &|l| l.remote_in[67].push(bal, JobResult::default())),
            none
        );
        let pb = UnitId::PatchBuffer(33);
        assert_eq!(
            at(&mut l, &|l| l.arrivals[67]
                .push(pb, crate::msg::PatchArrival::default())),
            none
        );
        assert_eq!(
            at(&mut l, &|l| l.items[7]
                .push(UnitId::RayBuffer(7), WorkItem::default())),
            none
        );
        assert_eq!(
            at(&mut l, &|l| l.remote_out[7]
                .push(UnitId::Icu(7), RemoteResult::default())),
            none
        );
    }

    #[test]
    fn the_edge_commits_the_touched_links_in_every_touch_word_and_no_others() {
        let mut l = links();
        assert_eq!(l.requests.len(), 80);
        let touched = [0, 5, 63, 64, 79];
        for &i in &touched {
            l.requests[i].push(UnitId::Ctu(i / 2, i % 2), MemRequest::default());
        }
        l.orders[3].push(UnitId::Balancer, SplitOrder::default());
        l.commit_all(1);
        for (i, r) in l.requests.iter().enumerate() {
            assert!(r.is_settled(), "request link {i} committed");
            assert_eq!(r.len(), touched.contains(&i) as usize, "request link {i}");
        }
        assert_eq!(
            l.orders.iter().map(Link::len).collect::<Vec<_>>()[..5],
            [0, 0, 0, 1, 0]
        );
        assert!(l.jobs.iter().all(|j| j.is_settled() && j.is_empty()));
        // A pop is a touch too; a link untouched since its last edge keeps its state.
        assert_eq!(l.requests[64].pop(UnitId::Memory), MemRequest::default());
        l.commit_all(2);
        assert!(l.requests[64].is_empty() && l.requests[64].stamp() == 2);
        assert_eq!(l.requests[64].transfers, 1);
        assert!(l.requests[63].stamp() == 1 && l.requests[63].len() == 1);
        l.commit_all(3);
        assert_eq!(
            l.requests[64].stamp(),
            2,
            "an edge with nothing staged changes nothing"
        );
    }
}
