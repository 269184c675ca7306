//! The trace of one CTU's walk, taken from the CTU itself: the unit runs alone against an
//! ideal environment (a memory that answers each request in one cycle, an ICU that answers
//! every job at once) and the trace records what it did — per subshell, its traversal cycles,
//! the traversal cycle each patch request went out on, and the jobs each arrived patch was
//! issued against. The event network (`queue::net`) re-times that trace under contention.
//!
//! The ICU's answers come from an oracle: each ray's nearest hit from the untimed model, and
//! no hit for every other patch. A ray's hit so far then differs from the machine's before
//! its nearest patch is tested, but the joins retire the same rays: a join retires a ray only
//! on its final hit (or none), else the machine would disagree with the untimed model — which
//! the cycle model checks on every run. The oracle costs one comparison per job instead of
//! the datapath.
//!
//! **Invariant:** without overlapped joins the trace is timing-free — the same requests in
//! the same order and the same jobs per patch as in any machine, and the traversal cycles
//! the CTU spends outside JOIN against a memory that takes each request the cycle after it
//! (the network adds the stalls of a full request queue). With overlapped joins the traversal skips rays whose hit so
//! far already retires them, which depends on when results come back; the trace is the
//! walk with results at once (the network's error includes this).

use crate::datapath::record::{CellTable, RayRecord};
use crate::datapath::FixedHit;
use crate::link::{Link, UnitId};
use crate::msg::{Descriptor, Job, JobResult, PatchArrival};
use crate::units::ctu::{Ctu, CtuParams, CtuPorts, CtuState};
use crate::units::ray_pool::RayList;
use std::collections::{HashMap, VecDeque};

/// One subshell of a CTU's walk.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Subshell {
    /// Traversal cycles (the FSM outside JOIN and DONE) from the subshell's start — the cycle
    /// after the join before it — to its end, where the FSM enters JOIN.
    pub cycles: u32,
    /// Per patch request, in order: the traversal cycle it went out on (from 0).
    pub requests: Vec<u32>,
    /// Per patch request: the jobs its patch was issued against (the rays remaining when it
    /// arrived; 0 when none remained).
    pub jobs: Vec<u32>,
}

/// The walk of one CTU.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CtuTrace {
    pub subshells: Vec<Subshell>,
    pub dda_steps: u64,
    pub ids_scanned: u64,
    pub patch_requests: u64,
    pub jobs: u64,
    /// Cycles the walk took against the ideal environment (its own critical path).
    pub cycles: u64,
}

/// The walk of a CTU could not finish (a model bug: the ideal environment answers everything).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Stuck {
    pub cluster: u16,
    pub ctu: u16,
    pub cycle: u64,
}

impl std::fmt::Display for Stuck {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the walk of CTU {}.{} did not finish by cycle {} against an ideal environment",
            self.cluster, self.ctu, self.cycle
        )
    }
}

/// What the walk of one CTU reads.
pub struct WalkInput<'a> {
    pub params: CtuParams,
    /// The sector's ray ids, ascending.
    pub rays: &'a [u32],
    pub records: &'a [RayRecord],
    pub cells: &'a CellTable,
    pub patches: usize,
    /// Patches marked loaded before the walk (the source's coplanar twins).
    pub twins: &'a [u32],
    /// Each ray's nearest hit from the untimed model, by global ray id.
    pub hits: &'a [Option<FixedHit>],
    /// Load requests the CTU may queue at the arbiter.
    pub request_capacity: usize,
}

/// Walks one CTU against the ideal environment and returns its trace.
pub fn walk(w: &WalkInput) -> Result<CtuTrace, Stuck> {
    let p = w.params;
    let me = UnitId::Ctu(p.cluster as usize, p.local as usize);
    let c = p.cluster as usize;
    let mut ctu = Ctu::new(p, w.rays, w.records, w.cells, w.patches).skipping(w.twins);
    let mut requests = Link::new(w.request_capacity).wired(me, UnitId::Memory);
    let mut arrivals = Link::new(2).wired(UnitId::PatchBuffer(c), me);
    let mut jobs = Link::new(2).wired(me, UnitId::RayBuffer(c));
    let mut results = Link::new(2).wired(UnitId::Icu(c), me);
    let mut remote = Link::new(2).wired(UnitId::Balancer, me);
    let mut descs = Link::new(2).wired(me, UnitId::RayBuffer(c));
    let mut pool = if p.bundle {
        RayList::new(w.rays)
    } else {
        RayList::default()
    };
    let oracle = |ray: u32, slot: u32, patch: u32| JobResult {
        slot,
        patch,
        t: w.hits[ray as usize]
            .filter(|h| h.patch == patch)
            .map(|h| h.t),
    };
    let mut trace = CtuTrace::default();
    let mut cur = Subshell::default();
    // Per requested patch: (subshell, request index) — a CTU requests a patch once.
    let mut which: HashMap<u32, (usize, usize)> = HashMap::new();
    let mut to_arrive: VecDeque<u32> = VecDeque::new();
    let mut answers: VecDeque<JobResult> = VecDeque::new();
    let mut requested = 0u64;
    // Per request in order: (subshell, index in it).
    let mut order: Vec<(usize, usize)> = Vec::new();
    // Generous: every cycle of the walk does something; the ideal environment never stalls
    // it for long.
    let limit = 64 * (w.rays.len() as u64 + 1) * (w.patches as u64 + 16) + 1_000_000;
    let mut now = 0u64;
    loop {
        let before = ctu.state;
        {
            let mut io = CtuPorts {
                requests: &mut requests,
                arrivals: &mut arrivals,
                jobs: &mut jobs,
                results: &mut results,
                remote_results: &mut remote,
                descs: &mut descs,
                pool: &mut pool,
            };
            ctu.tick(now, &mut io, w.cells);
        }
        let traversing = !matches!(before, CtuState::Join | CtuState::Done);
        if traversing {
            cur.cycles += 1;
        }
        if ctu.stats.patch_requests > requested {
            requested = ctu.stats.patch_requests;
            order.push((trace.subshells.len(), cur.requests.len()));
            cur.requests.push(cur.cycles.saturating_sub(1));
            cur.jobs.push(0);
        }
        if traversing && ctu.state == CtuState::Join {
            trace.subshells.push(std::mem::take(&mut cur));
        }
        // The ideal environment: memory answers a request in one cycle, the ICU every job.
        if requests.valid() {
            let r = requests.pop(UnitId::Memory);
            // Requests leave the link in the order they were recorded.
            which.insert(r.patch, order[which.len()]);
            to_arrive.push_back(r.patch);
        }
        if arrivals.can_push() {
            if let Some(patch) = to_arrive.pop_front() {
                arrivals.push(
                    UnitId::PatchBuffer(c),
                    PatchArrival {
                        patch,
                        ctu: p.local,
                    },
                );
            }
        }
        if jobs.valid() {
            let j: Job = jobs.pop(UnitId::RayBuffer(c));
            count(&mut trace, &mut cur, &which, j.patch, 1);
            answers.push_back(oracle(j.ray, j.slot, j.patch));
        }
        if descs.valid() {
            let d: Descriptor = descs.pop(UnitId::RayBuffer(c));
            count(&mut trace, &mut cur, &which, d.patch, d.hi - d.lo);
            for pos in d.lo..d.hi {
                let (slot, ray) = pool.get(d.list, pos);
                answers.push_back(oracle(ray, slot, d.patch));
            }
        }
        for (port, by) in [
            (&mut results, UnitId::Icu(c)),
            (&mut remote, UnitId::Balancer),
        ] {
            if port.can_push() {
                if let Some(a) = answers.pop_front() {
                    port.push(by, a);
                }
            }
        }
        requests.commit();
        arrivals.commit();
        jobs.commit();
        results.commit();
        remote.commit();
        descs.commit();
        now += 1;
        if ctu.done() && to_arrive.is_empty() && answers.is_empty() {
            break;
        }
        if now > limit {
            return Err(Stuck {
                cluster: p.cluster,
                ctu: p.local,
                cycle: now,
            });
        }
    }
    if !cur.requests.is_empty() || cur.cycles > 0 {
        trace.subshells.push(cur);
    }
    trace.dda_steps = ctu.stats.dda_steps;
    trace.ids_scanned = ctu.stats.ids_scanned;
    trace.patch_requests = ctu.stats.patch_requests;
    trace.jobs = ctu.stats.jobs_issued;
    trace.cycles = now;
    Ok(trace)
}

/// Adds `n` jobs to the request that loaded `patch`.
fn count(
    trace: &mut CtuTrace,
    cur: &mut Subshell,
    which: &HashMap<u32, (usize, usize)>,
    patch: u32,
    n: u32,
) {
    let &(s, i) = which.get(&patch).expect("a job's patch was requested");
    match trace.subshells.get_mut(s) {
        Some(sub) => sub.jobs[i] += n,
        None => cur.jobs[i] += n,
    }
}
