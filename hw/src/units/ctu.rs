//! The cell traversal unit (CTU): for each shell of its sector it steps the sector's
//! remaining rays through the shell's cells with the fixed-point DDA, requests every patch of
//! those cells its sector has not loaded yet, issues one job per (remaining ray, arrived
//! patch), takes the results back and keeps each ray's nearest hit. A (sub)shell ends with a
//! join: traversal done AND every job back (the paper's C_Join and R_Join); then a ray
//! retires when no unprocessed cell can hold a nearer hit.
//!
//! Three parts act in the same cycle, as separate hardware would: the traversal FSM, the job
//! issuer (one job per cycle), the result port (one result per cycle). It reads only its own
//! state and the links' registered state (see `link`).
//!
//! Traversal FSM:
//! - `Idle` → `ShellStart` on the first cycle.
//! - `ShellStart`: the shell's outer radius; the first remaining ray → `Scan`.
//! - `Scan`: looks at `scan_ids_per_cycle` patch ids of the current cell per cycle (the
//!   paper's machine: one); the first id not yet loaded (and not the source) goes out as a
//!   request, at most one per cycle (`Request` when the request link is full). When the cell
//!   is done — in the cycle after its last id, or in that cycle if it had ids to spare: a
//!   subshell join if this subshell has loaded its quota, else `Step`.
//! - `Step`: one DDA step (dda_cycles_per_step cycles). The next cell is scanned if it is
//!   entered inside the shell; otherwise the next ray's turn comes; after the last ray,
//!   `Join` ends the shell.
//! - `Join`: waits until every requested patch has arrived and all its jobs are back, then
//!   retires rays, and goes on with the shell (subshell join) or to the next one.
//! - `Done`: no ray remains.
//!
//! Machine variants (`[machine] job_source`, `overlap_joins`; `ctu` and `false`, the paper's
//! machine, when absent):
//! - `job_source = "bundle"`: instead of issuing one job per cycle per arrived patch, the CTU
//!   hands its ray buffer one `Descriptor` per arrived patch (its `descs` link), naming the
//!   CTU's remaining rays by their positions in the ray pool (`super::ray_pool`); the ray
//!   buffer expands descriptors into jobs.
//! - `overlap_joins`: the CTU traverses the next subshell while the current one drains (one
//!   ahead). Requests, pending loads and outstanding jobs carry the subshell's parity as their
//!   phase (`phase_of` per patch); the draining subshell joins when its phase is empty, each
//!   ray retiring against its position at that subshell's end (a snapshot taken at its first
//!   step in the next one). With bundles, a patch of the next subshell waits in the patch
//!   buffer until the join, so its descriptor names the list the join leaves.
//!
//! Per-state counters (`state_cycles`, `join_wait_patches`, `join_wait_results`) are in every
//! run's statistics.

use crate::datapath::dda::FixedDda;
use crate::datapath::model::STOP_SLACK_T_LSB;
use crate::datapath::record::{CellTable, RayRecord};
use crate::datapath::{compare, FixedHit};
use crate::link::{Link, UnitCode, UnitId};
use crate::machine::sink::Sink;
use crate::msg::{Descriptor, Job, JobResult, MemRequest, PatchArrival};
use crate::units::ray_pool::RayList;
use crate::units::{Around, Unit};
use bitvec::prelude::*;

/// The traversal FSM's states.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CtuState {
    Idle,
    ShellStart,
    Scan,
    Request,
    Step,
    Join,
    Done,
}

impl CtuState {
    /// Every state's name (for waveforms), indexed by [`CtuState::index`].
    pub const NAMES: &'static [&'static str] = &[
        "IDLE",
        "SHELL_START",
        "SCAN",
        "REQUEST",
        "STEP",
        "JOIN",
        "DONE",
    ];

    /// The state's position in [`CtuState::NAMES`].
    pub fn index(self) -> u64 {
        match self {
            CtuState::Idle => 0,
            CtuState::ShellStart => 1,
            CtuState::Scan => 2,
            CtuState::Request => 3,
            CtuState::Step => 4,
            CtuState::Join => 5,
            CtuState::Done => 6,
        }
    }

    /// The state's name (for waveforms).
    pub fn name(self) -> &'static str {
        Self::NAMES[self.index() as usize]
    }
}

/// One ray of the sector.
#[derive(Clone, Copy, Debug)]
struct RaySlot {
    /// Its DDA position; `None` once it has left the grid.
    dda: Option<FixedDda>,
    retired: bool,
    /// Overlapped joins: the position before the first step taken while traversing
    /// subshell `snap_sub` (so the join of subshell `snap_sub − 1` sees where it ended).
    snap: Option<FixedDda>,
    snap_sub: u32,
}

/// Overlapped joins: a subshell whose traversal is over and whose jobs drain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Drain {
    sub: u32,
    phase: usize,
}

/// CTU counters (cycles partition into busy + stalled + idle).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct CtuStats {
    pub busy_cycles: u64,
    pub stalled_cycles: u64,
    pub idle_cycles: u64,
    pub dda_steps: u64,
    pub patch_requests: u64,
    pub jobs_issued: u64,
    pub results: u64,
    pub shells: u64,
    pub subshells: u64,
    /// Cycles spent in each traversal state (they sum to all cycles).
    pub state_cycles: StateCycles,
    /// Of the JOIN cycles that did not join: waiting for a requested patch to reach the CTU
    /// with nothing to issue, and issuing jobs or waiting for their results.
    pub join_wait_patches: u64,
    pub join_wait_results: u64,
    /// Descriptors handed to the ray buffer (bundle only; their jobs are in `jobs_issued`).
    pub descriptors: u64,
    /// Patch ids the scan looked at (loaded or not, the source's too): at most
    /// `scan_ids_per_cycle` per SCAN cycle.
    pub ids_scanned: u64,
}

/// Cycles per traversal state, one field per [`CtuState`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct StateCycles {
    pub idle: u64,
    pub shell_start: u64,
    pub scan: u64,
    pub request: u64,
    pub step: u64,
    pub join: u64,
    pub done: u64,
}

impl StateCycles {
    /// Adds `n` cycles to `state`.
    pub fn add(&mut self, state: CtuState, n: u64) {
        *match state {
            CtuState::Idle => &mut self.idle,
            CtuState::ShellStart => &mut self.shell_start,
            CtuState::Scan => &mut self.scan,
            CtuState::Request => &mut self.request,
            CtuState::Step => &mut self.step,
            CtuState::Join => &mut self.join,
            CtuState::Done => &mut self.done,
        } += n;
    }

    /// Adds every state's cycles of `o`.
    pub fn sum(&mut self, o: &StateCycles) {
        self.idle += o.idle;
        self.shell_start += o.shell_start;
        self.scan += o.scan;
        self.request += o.request;
        self.step += o.step;
        self.join += o.join;
        self.done += o.done;
    }

    /// The sum over states.
    pub fn total(&self) -> u64 {
        self.idle + self.shell_start + self.scan + self.request + self.step + self.join + self.done
    }
}

/// What a CTU needs that is fixed for the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CtuParams {
    pub cluster: u16,
    pub local: u16,
    pub source: u32,
    pub dda_cycles_per_step: u32,
    pub subshell_max_patches: u32,
    /// Shell radius, t format raw.
    pub shell_raw: i64,
    pub t_frac: u32,
    pub t_max: i64,
    /// `job_source = "bundle"`: one descriptor per arrived patch instead of one job per
    /// (ray, patch).
    pub bundle: bool,
    /// `overlap_joins`: traverse the next subshell while the current one drains.
    pub overlap: bool,
    /// Patch ids the scan compares against the loaded set per cycle (at most one request).
    pub scan_ids_per_cycle: u32,
}

/// The links a CTU drives or reads.
pub struct CtuPorts<'a> {
    pub requests: &'a mut Link<MemRequest>,
    pub arrivals: &'a mut Link<PatchArrival>,
    pub jobs: &'a mut Link<Job>,
    pub results: &'a mut Link<JobResult>,
    /// Results of this CTU's jobs computed by other clusters (dynamic balancing).
    pub remote_results: &'a mut Link<JobResult>,
    /// To the ray buffer: descriptors (bundle only).
    pub descs: &'a mut Link<Descriptor>,
    /// This CTU's ray pool (bundle only): written at joins, read by ray buffers.
    pub pool: &'a mut RayList,
}

/// A cell traversal unit.
#[derive(Clone, Debug)]
pub struct Ctu {
    p: CtuParams,
    /// Its end of its links (rule 7).
    me: UnitCode,
    /// The sector is finished ([`Ctu::done`]) with no load pending: no result and no patch
    /// can reach it any more, so every later cycle is an idle one in DONE.
    finished: bool,
    pub state: CtuState,
    /// Per ray (its slot): the traversal's state. The ray's id and its best hit so far, read
    /// per issued job and per result, are apart in dense arrays by slot: a slot is a few
    /// hundred bytes, and reaching into it per job cost a cache miss per job.
    slots: Vec<RaySlot>,
    /// Per slot: the ray's global id.
    ray_ids: Vec<u32>,
    /// Per slot: the nearest hit so far.
    best: Vec<Option<FixedHit>>,
    /// Slots of the rays not retired at the last join, ascending.
    remaining: Vec<u32>,
    loaded: BitVec,
    shell: u32,
    shell_limit: i64,
    /// Position in `remaining` of the ray being traversed.
    cursor: usize,
    /// Next patch id of the current cell to look at.
    cell_pos: usize,
    /// The cycle the current DDA step completes.
    timer: u64,
    /// True when the join ends the shell (not only a subshell).
    shell_end: bool,
    subshell_loads: u32,
    pending_loads: u32,
    /// The patch whose jobs are being issued and the next position in `remaining`.
    issuing: Option<(u32, usize)>,
    outstanding: u64,
    /// The ray-pool list descriptors name (bundle only).
    list: u8,
    /// Overlapped joins: the subshell being traversed (its parity is its phase), the one
    /// draining, pending loads and outstanding jobs per phase, each patch's phase, and the
    /// ray whose step was under way when the traversal reached a subshell's end.
    sub: u32,
    draining: Option<Drain>,
    pending_ph: [u32; 2],
    outstanding_ph: [u64; 2],
    phase_of: BitVec,
    boundary_ray: Option<u32>,
    pub stats: CtuStats,
    /// Cycles [`Ctu::tick_active`] ran ([`Ctu::active_cycles`]).
    active: u64,
}

impl Ctu {
    /// A CTU's waveform signals: [`Ctu::signals`] reports exactly these (the walk skips
    /// this many for a CTU that cannot have changed them).
    pub const SIGNALS: usize = 6;
    /// Its bundle signals, after its links: [`Ctu::bundle_signals`] reports these.
    pub const BUNDLE_SIGNALS: usize = 1;

    /// Reports the CTU's waveform signals to `s` under `scope` (a new signal: one line here,
    /// counted in [`Ctu::SIGNALS`]; it must change only in [`Ctu::tick_active`], which
    /// counts [`Ctu::active_cycles`]).
    #[inline(always)]
    pub(crate) fn signals(&self, s: &mut impl Sink, scope: &str) {
        s.text(scope, "state", CtuState::NAMES, self.state.index());
        s.bits(scope, "shell", 16, self.shell() as u64);
        s.bits(scope, "remaining_rays", 32, self.remaining() as u64);
        s.bits(scope, "outstanding_jobs", 32, self.outstanding());
        s.bits(scope, "pending_loads", 16, self.pending_loads() as u64);
        s.bits(scope, "jobs_issued", 32, self.stats.jobs_issued);
    }

    /// Reports the CTU's bundle signals to `s` under `scope` ([`Ctu::BUNDLE_SIGNALS`]).
    #[inline(always)]
    pub(crate) fn bundle_signals(&self, s: &mut impl Sink, scope: &str) {
        s.bits(scope, "descriptors", 32, self.stats.descriptors);
    }

    /// The CTU with `ids` marked loaded before it starts: patches its source's rays pass
    /// through (coplanar twins), never requested — like the source.
    pub fn skipping(mut self, ids: &[u32]) -> Self {
        for &id in ids {
            self.loaded.set(id as usize, true);
        }
        self
    }

    /// A CTU for the sector whose rays are `rays` (global ids, ascending).
    pub fn new(
        p: CtuParams,
        rays: &[u32],
        records: &[RayRecord],
        cells: &CellTable,
        patches: usize,
    ) -> Self {
        let slots: Vec<RaySlot> = rays
            .iter()
            .map(|&r| RaySlot {
                dda: FixedDda::new(cells, &records[r as usize]),
                retired: false,
                snap: None,
                snap_sub: u32::MAX,
            })
            .collect();
        Ctu {
            p,
            me: UnitId::Ctu(p.cluster as usize, p.local as usize).into(),
            finished: false,
            active: 0,
            state: CtuState::Idle,
            remaining: (0..slots.len() as u32).collect(),
            best: vec![None; slots.len()],
            slots,
            ray_ids: rays.to_vec(),
            loaded: bitvec![0; patches],
            shell: 0,
            shell_limit: 0,
            cursor: 0,
            cell_pos: 0,
            timer: 0,
            shell_end: false,
            subshell_loads: 0,
            pending_loads: 0,
            issuing: None,
            outstanding: 0,
            list: 0,
            sub: 0,
            draining: None,
            pending_ph: [0; 2],
            outstanding_ph: [0; 2],
            phase_of: if p.overlap {
                bitvec![0; patches]
            } else {
                BitVec::new()
            },
            boundary_ray: None,
            stats: CtuStats::default(),
        }
    }

    /// True when the sector is finished.
    pub fn done(&self) -> bool {
        self.state == CtuState::Done
            && self.issuing.is_none()
            && self.outstanding == 0
            && self.draining.is_none()
    }

    /// Each ray's nearest hit: (global ray id, hit).
    pub fn hits(&self) -> impl Iterator<Item = (u32, Option<FixedHit>)> + '_ {
        self.ray_ids.iter().copied().zip(self.best.iter().copied())
    }

    /// The shell being processed.
    pub fn shell(&self) -> u32 {
        self.shell
    }

    /// Jobs issued whose results are not back.
    pub fn outstanding(&self) -> u64 {
        self.outstanding
    }

    /// Patches requested that have not arrived.
    pub fn pending_loads(&self) -> u32 {
        self.pending_loads
    }

    /// Rays not yet retired.
    pub fn remaining(&self) -> usize {
        self.remaining.len()
    }

    /// The cycle its DDA step completes, while it waits on it.
    pub fn timer(&self, now: u64) -> Option<u64> {
        (self.state == CtuState::Step && self.timer > now).then_some(self.timer)
    }

    /// Accounts `n` cycles skipped by the machine's cycle jump: busy while a DDA step runs,
    /// idle otherwise (waiting at a join, or done).
    pub fn skip(&mut self, n: u64) {
        self.stats.state_cycles.add(self.state, n);
        if self.state == CtuState::Join {
            self.count_join_wait(n);
        }
        if self.state == CtuState::Step {
            self.stats.busy_cycles += n;
        } else {
            self.stats.idle_cycles += n;
        }
    }

    /// Accounts `n` cycles at a join that cannot happen yet: waiting for patches while a
    /// requested one has not reached the CTU and it has no jobs to issue, else for jobs to be
    /// issued and their results.
    fn count_join_wait(&mut self, n: u64) {
        let pending = match self.draining {
            Some(d) if self.p.overlap => self.pending_ph[d.phase],
            _ => self.pending_loads,
        };
        if pending > 0 && self.issuing.is_none() {
            self.stats.join_wait_patches += n;
        } else {
            self.stats.join_wait_results += n;
        }
    }

    /// True when the CTU does nothing until its timer or an arrival: stepping on the timer,
    /// waiting at a join for patches still in memory, or done.
    pub fn quiet(&self, now: u64) -> bool {
        self.issuing.is_none()
            && !self.draining.is_some_and(|d| self.drain_due(d))
            && match self.state {
                CtuState::Step => self.timer > now,
                CtuState::Join => self.outstanding == 0 && self.pending_loads > 0,
                CtuState::Done => true,
                _ => false,
            }
    }

    /// The sector's ray count.
    pub fn rays(&self) -> usize {
        self.slots.len()
    }

    /// True when, with nothing at its inputs, this cycle would change nothing but the
    /// counters [`Ctu::skip`] advances: [`Ctu::quiet`], or at a join that waits for results
    /// (or, with overlapped joins, for the subshell draining before it).
    #[inline]
    fn idle_now(&self, now: u64) -> bool {
        self.quiet(now)
            || (self.state == CtuState::Join
                && self.issuing.is_none()
                && if self.p.overlap {
                    self.draining.is_some_and(|d| !self.drain_due(d))
                } else {
                    self.outstanding > 0 || self.pending_loads > 0
                })
    }

    /// One clock cycle.
    #[inline]
    pub fn tick(&mut self, now: u64, io: &mut CtuPorts, cells: &CellTable) {
        if !self.idle_tick(now, io.results, io.remote_results, io.arrivals) {
            self.tick_active(now, io, cells);
        }
    }

    /// The cycle when it is provably idle (`idle_now`) with nothing at its inputs: it would
    /// change nothing but the counters `skip` advances, so only they move, and it returns
    /// true; otherwise false, and the cycle is [`Ctu::tick_active`]'s. The machine calls it
    /// before building the ports.
    #[inline(always)]
    pub fn idle_tick(
        &mut self,
        now: u64,
        results: &Link<JobResult>,
        remote_results: &Link<JobResult>,
        arrivals: &Link<PatchArrival>,
    ) -> bool {
        if self.finished {
            self.finished_cycle();
            return true;
        }
        let idle = results.is_empty()
            && remote_results.is_empty()
            && arrivals.is_empty()
            && self.idle_now(now);
        if idle {
            self.skip(1);
            self.finished = self.done() && self.pending_loads == 0;
        }
        idle
    }

    /// True once the sector is finished with no load pending: nothing can reach the CTU any
    /// more, and every cycle is [`Ctu::finished_cycle`].
    #[inline(always)]
    pub fn is_finished(&self) -> bool {
        self.finished
    }

    /// Cycles [`Ctu::tick_active`] ran. Nothing else changes what the waveform shows of a
    /// CTU (its state, shell, remaining rays, outstanding jobs, pending loads, jobs issued):
    /// an idle cycle and a cycle jump only count cycles, so the waveform's sampler reads the
    /// CTU's signals only when this moved since its last sample.
    #[inline(always)]
    pub fn active_cycles(&self) -> u64 {
        self.active
    }

    /// A cycle of a finished CTU: `skip(1)` in DONE.
    #[inline(always)]
    pub fn finished_cycle(&mut self) {
        self.stats.state_cycles.done += 1;
        self.stats.idle_cycles += 1;
    }

    /// A cycle with something to do (or to check).
    #[inline(always)]
    pub fn tick_active(&mut self, now: u64, io: &mut CtuPorts, cells: &CellTable) {
        self.active += 1;
        self.stats.state_cycles.add(self.state, 1);
        let me = self.me;
        let mut busy = false;
        let mut stalled = false;
        // Result ports: one local and one remote result per cycle, each through a compare
        // stage of the datapath (two results for one ray apply in port order).
        for port in [&mut *io.results, &mut *io.remote_results] {
            if port.valid() {
                let r = port.pop(me);
                if let Some(t) = r.t {
                    compare(
                        &mut self.best[r.slot as usize],
                        FixedHit { patch: r.patch, t },
                    );
                }
                self.outstanding -= 1;
                if self.p.overlap {
                    self.outstanding_ph[self.phase_of[r.patch as usize] as usize] -= 1;
                }
                self.stats.results += 1;
                busy = true;
            }
        }
        // Job issuer: one job per cycle for the arrived patch, against every remaining ray.
        match self.issuing {
            Some((patch, i)) => {
                if io.jobs.can_push() {
                    let slot = self.remaining[i];
                    io.jobs.push(
                        me,
                        Job {
                            ray: self.ray_ids[slot as usize],
                            slot,
                            patch,
                            ctu: self.p.local,
                            owner: self.p.cluster,
                        },
                    );
                    self.outstanding += 1;
                    if self.p.overlap {
                        self.outstanding_ph[self.phase_of[patch as usize] as usize] += 1;
                    }
                    self.stats.jobs_issued += 1;
                    self.issuing = (i + 1 < self.remaining.len()).then_some((patch, i + 1));
                    busy = true;
                } else {
                    stalled = true;
                }
            }
            None if self.p.bundle && !self.remaining.is_empty() => {
                // One descriptor per arrived patch: the patch against every remaining ray.
                // With overlapped joins a patch of the next subshell waits in the patch
                // buffer until the draining subshell joins, so that its descriptor names
                // the rays that join leaves (none it retires).
                let held = |a: &PatchArrival| {
                    self.draining
                        .is_some_and(|d| self.phase_of[a.patch as usize] as usize != d.phase)
                };
                if io.arrivals.peek().is_some_and(held) {
                    stalled = true;
                } else if io.arrivals.valid() {
                    if io.descs.can_push() {
                        let a = io.arrivals.pop(me);
                        self.arrived(a.patch);
                        let n = self.remaining.len() as u32;
                        io.descs.push(
                            me,
                            Descriptor {
                                patch: a.patch,
                                ctu: self.p.local,
                                owner: self.p.cluster,
                                list: self.list,
                                lo: 0,
                                hi: n,
                            },
                        );
                        self.outstanding += n as u64;
                        if self.p.overlap {
                            self.outstanding_ph[self.phase_of[a.patch as usize] as usize] +=
                                n as u64;
                        }
                        self.stats.jobs_issued += n as u64;
                        self.stats.descriptors += 1;
                        busy = true;
                    } else {
                        stalled = true;
                    }
                }
            }
            None => {
                if io.arrivals.valid() {
                    let a = io.arrivals.pop(me);
                    self.arrived(a.patch);
                    if !self.remaining.is_empty() {
                        self.issuing = Some((a.patch, 0));
                    }
                    busy = true;
                }
            }
        }
        // Overlapped joins: the draining subshell joins once its patches and jobs are in.
        if let Some(d) = self.draining {
            if self.drain_due(d) {
                self.drain_join(d, io.pool);
                busy = true;
            }
        }
        // Traversal FSM.
        match self.state {
            CtuState::Idle => {
                self.state = CtuState::ShellStart;
                busy = true;
            }
            CtuState::ShellStart => {
                if self.remaining.is_empty() {
                    self.state = CtuState::Done;
                } else {
                    self.shell_limit =
                        ((self.shell as i64 + 1) * self.p.shell_raw).min(self.p.t_max);
                    self.cursor = 0;
                    self.cell_pos = 0;
                    self.stats.shells += 1;
                    self.stats.subshells += 1;
                    self.state = self.enter_ray();
                }
                busy = true;
            }
            CtuState::Scan | CtuState::Request => {
                let slot = self.remaining[self.cursor] as usize;
                let dda = self.slots[slot].dda.expect("a scanned ray is in the grid");
                let list = cells.patches_in(cells.index(dda.c));
                // Up to `scan_ids_per_cycle` ids against the loaded set, in cell order; the
                // first one not loaded goes out as this cycle's one request, a second one
                // waits for the next cycle.
                let k = self.p.scan_ids_per_cycle as usize;
                let mut looked = 0;
                let mut requested = false;
                while looked < k && self.cell_pos < list.len() {
                    let id = list[self.cell_pos];
                    if id != self.p.source && !self.loaded[id as usize] {
                        if requested || !io.requests.can_push() {
                            break;
                        }
                        io.requests.push(
                            me,
                            MemRequest {
                                patch: id,
                                cluster: self.p.cluster,
                                ctu: self.p.local,
                                issued: now,
                            },
                        );
                        requested = true;
                        self.loaded.set(id as usize, true);
                        self.pending_loads += 1;
                        if self.p.overlap {
                            let ph = (self.sub & 1) as usize;
                            self.phase_of.set(id as usize, ph == 1);
                            self.pending_ph[ph] += 1;
                        }
                        self.subshell_loads += 1;
                        self.stats.patch_requests += 1;
                    }
                    self.cell_pos += 1;
                    looked += 1;
                }
                self.stats.ids_scanned += looked as u64;
                if self.cell_pos < list.len() || looked == k {
                    // Ids left (or the cycle's ids used up): the cell ends in a later cycle.
                    if looked == 0 {
                        self.state = CtuState::Request;
                        stalled = true;
                    } else {
                        self.state = CtuState::Scan;
                        busy = true;
                    }
                } else if self.subshell_loads >= self.p.subshell_max_patches {
                    // Subshell full: join before stepping on (the cell is done).
                    self.shell_end = false;
                    self.start_step(now);
                    self.boundary_ray = self.remaining.get(self.cursor).copied();
                    self.state = CtuState::Join;
                    busy = true;
                } else {
                    self.start_step(now);
                    busy = true;
                }
            }
            CtuState::Step => {
                busy = true;
                if now >= self.timer {
                    self.after_step();
                }
            }
            CtuState::Join if self.p.overlap => {
                // The traversal reached a subshell's end: it goes on at once unless the
                // subshell before is still draining (at most one subshell ahead).
                if self.draining.is_none() {
                    self.start_drain();
                    busy = true;
                } else {
                    self.count_join_wait(1);
                }
            }
            CtuState::Join => {
                if self.pending_loads == 0 && self.issuing.is_none() && self.outstanding == 0 {
                    self.join(io.pool);
                    busy = true;
                } else {
                    self.count_join_wait(1);
                }
            }
            CtuState::Done => {}
        }
        if busy {
            self.stats.busy_cycles += 1;
        } else if stalled {
            self.stats.stalled_cycles += 1;
        } else {
            self.stats.idle_cycles += 1;
        }
    }

    /// The state for the ray at `cursor` (or the join after the last ray): scan its current
    /// cell if it is entered inside the shell, else move on.
    fn enter_ray(&mut self) -> CtuState {
        while self.cursor < self.remaining.len() {
            let s = self.remaining[self.cursor] as usize;
            if let Some(d) = &self.slots[s].dda {
                // Overlapped joins: a ray that its hit so far already retires (its next cell
                // starts beyond it, and later results can only bring the hit nearer) is not
                // walked again; it retires at the next join.
                let retires = self.p.overlap
                    && self.best[s]
                        .is_some_and(|b| d.entry_beyond(b.t + STOP_SLACK_T_LSB, self.p.t_frac));
                if !retires && !d.entry_at_or_beyond(self.shell_limit, self.p.t_frac) {
                    self.cell_pos = 0;
                    return CtuState::Scan;
                }
            }
            self.cursor += 1;
        }
        self.shell_end = true;
        CtuState::Join
    }

    /// Starts the DDA step of the current ray (the step completes after the timer).
    fn start_step(&mut self, now: u64) {
        let slot = self.remaining[self.cursor] as usize;
        let mut dda = self.slots[slot].dda.expect("stepping a ray in the grid");
        if self.p.overlap && self.slots[slot].snap_sub != self.sub {
            self.slots[slot].snap = Some(dda);
            self.slots[slot].snap_sub = self.sub;
        }
        self.slots[slot].dda = dda.step().then_some(dda);
        self.stats.dda_steps += 1;
        self.timer = now + self.p.dda_cycles_per_step as u64;
        self.state = CtuState::Step;
        self.cell_pos = 0;
    }

    /// After a step: scan the new cell if inside the shell, else the next ray.
    fn after_step(&mut self) {
        let slot = &self.slots[self.remaining[self.cursor] as usize];
        let inside = slot
            .dda
            .as_ref()
            .is_some_and(|d| !d.entry_at_or_beyond(self.shell_limit, self.p.t_frac));
        if inside {
            self.cell_pos = 0;
            self.state = CtuState::Scan;
        } else {
            self.cursor += 1;
            self.state = self.enter_ray();
        }
    }

    /// A patch record arrived: one load fewer pending (and of its subshell's phase).
    fn arrived(&mut self, patch: u32) {
        self.pending_loads -= 1;
        if self.p.overlap {
            self.pending_ph[self.phase_of[patch as usize] as usize] -= 1;
        }
    }

    /// True when draining subshell `d` may join: every patch it requested has arrived, its
    /// jobs are all issued and every result is back.
    fn drain_due(&self, d: Drain) -> bool {
        self.pending_ph[d.phase] == 0
            && self.outstanding_ph[d.phase] == 0
            && self
                .issuing
                .is_none_or(|(p, _)| self.phase_of[p as usize] as usize != d.phase)
    }

    /// Overlapped joins: the traversal of the current subshell is over; it drains, and the
    /// traversal goes on with the next subshell (or shell).
    fn start_drain(&mut self) {
        self.draining = Some(Drain {
            sub: self.sub,
            phase: (self.sub & 1) as usize,
        });
        self.sub += 1;
        self.subshell_loads = 0;
        if self.shell_end {
            self.shell += 1;
            self.state = CtuState::ShellStart;
        } else {
            self.stats.subshells += 1;
            // The step begun at the subshell's end goes on, unless its ray has retired.
            self.state = if self.boundary_ray.is_some()
                && self.remaining.get(self.cursor).copied() == self.boundary_ray
            {
                CtuState::Step
            } else {
                self.enter_ray()
            };
        }
    }

    /// The retirement rule of a join: drop every remaining ray that has left the grid, or
    /// whose position `at` (where its walk stood when the subshell ended) lies beyond its
    /// best hit, so no unprocessed cell can hold a nearer one. With bundles, every
    /// descriptor of the old ray-pool list is back: the survivors go into the other one.
    fn retire(&mut self, pool: &mut RayList, at: impl Fn(&RaySlot) -> Option<FixedDda>) {
        let tf = self.p.t_frac;
        for &s in &self.remaining {
            let slot = &mut self.slots[s as usize];
            slot.retired = match (at(slot), self.best[s as usize]) {
                (None, _) => true,
                (Some(p), Some(b)) => p.entry_beyond(b.t + STOP_SLACK_T_LSB, tf),
                (Some(_), None) => false,
            };
        }
        self.remaining.retain(|&s| !self.slots[s as usize].retired);
        if self.p.bundle {
            self.list ^= 1;
            let ids = &self.ray_ids;
            pool.write(self.list, &self.remaining, |s| ids[s as usize]);
        }
    }

    /// Overlapped joins: the join of draining subshell `d` — the exact rule against each
    /// ray's position at the end of `d` (before any step the traversal took since) — while
    /// the traversal and the issuer go on at the same rays in the shorter list.
    fn drain_join(&mut self, d: Drain, pool: &mut RayList) {
        let resume = self.remaining.get(self.cursor).copied();
        let issuing = self.issuing.map(|(p, i)| (p, self.remaining[i]));
        self.retire(pool, |slot| {
            if slot.snap_sub == d.sub + 1 {
                slot.snap
            } else {
                slot.dda
            }
        });
        self.cursor = match resume {
            Some(r) => self.remaining.partition_point(|&s| s < r),
            None => self.remaining.len(),
        };
        if let Some((p, r)) = issuing {
            let i = self.remaining.partition_point(|&s| s < r);
            self.issuing = (i < self.remaining.len()).then_some((p, i));
        }
        let moved = self.remaining.get(self.cursor).copied() != resume;
        if moved
            && matches!(
                self.state,
                CtuState::Scan | CtuState::Request | CtuState::Step
            )
        {
            // The ray being walked retired: the traversal goes on with the next one.
            self.state = self.enter_ray();
        }
        self.draining = None;
    }

    /// The join: retire every ray that no unprocessed cell can give a nearer hit, then go on
    /// with the shell (after a subshell) or start the next one.
    fn join(&mut self, pool: &mut RayList) {
        let resume_ray = self.remaining.get(self.cursor).copied();
        self.retire(pool, |slot| slot.dda);
        self.subshell_loads = 0;
        if self.shell_end {
            self.shell += 1;
            self.state = CtuState::ShellStart;
        } else {
            // Resume the shell at the ray that was being traversed (or the next one left).
            self.stats.subshells += 1;
            self.cursor = match resume_ray {
                Some(r) => self.remaining.partition_point(|&s| s < r),
                None => self.remaining.len(),
            };
            // The step begun before the join completes on its timer; then on as after a step.
            if self.cursor < self.remaining.len() && Some(self.remaining[self.cursor]) == resume_ray
            {
                self.state = CtuState::Step;
            } else {
                self.state = self.enter_ray();
            }
        }
    }
}

/// The CTU's cold paths: quiet while a DDA step runs or it waits at a join for loads only
/// (or is done); its timer is the step's end.
impl Unit for Ctu {
    fn quiet(&self, now: u64, _: &Around) -> bool {
        Ctu::quiet(self, now)
    }

    fn timer(&self, now: u64) -> Option<u64> {
        Ctu::timer(self, now)
    }

    fn skip(&mut self, _now: u64, n: u64) {
        Ctu::skip(self, n);
    }

    fn activity(&self) -> u64 {
        self.stats.dda_steps + self.stats.patch_requests + self.stats.shells + self.stats.subshells
    }

    fn done(&self) -> bool {
        Ctu::done(self)
    }

    fn report(&self, _now: u64) -> String {
        format!(
            "{} shell {} remaining {} outstanding {} pending loads {}",
            self.state.name(),
            self.shell(),
            self.remaining(),
            self.outstanding(),
            self.pending_loads()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::UnitId;

    /// A row of 4 cells along x (256 LSB each): cell 0 holds patch 1, cell 1 patch 2, cell 2
    /// the source (0) and patch 1 again, cell 3 nothing.
    fn scene() -> (CellTable, Vec<RayRecord>) {
        let cells = CellTable {
            dims: [4, 1, 1],
            cell_raw: 256,
            first: vec![0, 1, 2, 4],
            count: vec![1, 1, 2, 0],
            ids: vec![1, 2, 0, 1],
        };
        let f = crate::config::paper().datapath.formats().unwrap();
        let rays = vec![
            RayRecord::new(0, [32, 128, 128], [4096, 0, 0], &f),
            RayRecord::new(1, [64, 100, 100], [4096, 0, 0], &f),
        ];
        (cells, rays)
    }

    fn params(subshell_max_patches: u32) -> CtuParams {
        let f = crate::config::paper().datapath.formats().unwrap();
        CtuParams {
            cluster: 0,
            local: 0,
            source: 0,
            dda_cycles_per_step: 2,
            subshell_max_patches,
            shell_raw: f.t.max_raw() as i64,
            t_frac: f.t.frac_bits,
            t_max: f.t.max_raw() as i64,
            bundle: false,
            overlap: false,
            scan_ids_per_cycle: 1,
        }
    }

    /// A finished CTU, the states it walked, the patches it requested, its (ray, patch) jobs.
    type Walk = (Ctu, Vec<&'static str>, Vec<u32>, Vec<(u32, u32)>);

    /// Runs a CTU against a memory that answers each request after 5 cycles (and leaves
    /// the request link full for the first 12 cycles) and an ICU that answers every job
    /// with no hit. Returns the states walked (consecutive repeats merged), the requested
    /// patches and the (ray, patch) jobs.
    fn run(p: CtuParams) -> Walk {
        let (cells, rays) = scene();
        let mut ctu = Ctu::new(p, &[0, 1], &rays, &cells, 3);
        let mut w = Wires::new();
        let (mut states, mut asked, mut issued) = (vec![], vec![], vec![]);
        let mut in_memory: Vec<(u64, u32)> = vec![];
        for now in 0..500u64 {
            ctu.tick(now, &mut w.ports(), &cells);
            if states.last() != Some(&ctu.state.name()) {
                states.push(ctu.state.name());
            }
            if now >= 12 && w.requests.peek().is_some() {
                let r = w.requests.pop(UnitId::Memory);
                asked.push(r.patch);
                in_memory.push((now + 5, r.patch));
            }
            if let Some(&(at, patch)) = in_memory.first() {
                if at <= now && w.arrivals.can_push() {
                    w.arrivals
                        .push(UnitId::PatchBuffer(0), PatchArrival { patch, ctu: 0 });
                    in_memory.remove(0);
                }
            }
            if w.jobs.peek().is_some() && w.results.can_push() {
                let j = w.jobs.pop(UnitId::RayBuffer(0));
                issued.push((j.ray, j.patch));
                w.results.push(
                    UnitId::Icu(0),
                    JobResult {
                        slot: j.slot,
                        patch: j.patch,
                        t: None,
                    },
                );
            }
            for l in [
                &mut w.requests as &mut dyn Commit,
                &mut w.arrivals,
                &mut w.jobs,
                &mut w.results,
                &mut w.remote,
            ] {
                l.commit();
            }
            if ctu.done() {
                break;
            }
        }
        (ctu, states, asked, issued)
    }

    /// A CTU's links, wired to CTU (0, 0), and its ray pool: what the machine hands it.
    struct Wires {
        requests: Link<MemRequest>,
        arrivals: Link<PatchArrival>,
        jobs: Link<Job>,
        results: Link<JobResult>,
        remote: Link<JobResult>,
        descs: Link<Descriptor>,
        pool: RayList,
    }

    impl Wires {
        fn new() -> Self {
            let me = UnitId::Ctu(0, 0);
            Wires {
                requests: Link::new(1).wired(me, UnitId::Memory),
                arrivals: Link::new(2).wired(UnitId::PatchBuffer(0), me),
                jobs: Link::new(2).wired(me, UnitId::RayBuffer(0)),
                results: Link::new(2).wired(UnitId::Icu(0), me),
                remote: Link::new(2).wired(UnitId::Balancer, me),
                descs: Link::new(2).wired(me, UnitId::RayBuffer(0)),
                pool: RayList::new(&[0, 1]),
            }
        }

        fn ports(&mut self) -> CtuPorts<'_> {
            CtuPorts {
                requests: &mut self.requests,
                arrivals: &mut self.arrivals,
                jobs: &mut self.jobs,
                results: &mut self.results,
                remote_results: &mut self.remote,
                descs: &mut self.descs,
                pool: &mut self.pool,
            }
        }
    }

    trait Commit {
        fn commit(&mut self);
    }

    impl<T: Clone> Commit for Link<T> {
        fn commit(&mut self) {
            Link::commit(self);
        }
    }

    #[test]
    fn a_finished_ctu_counts_only_idle_cycles_in_done() {
        let (mut ctu, ..) = run(params(64));
        assert!(ctu.done());
        assert!(!ctu.is_finished(), "finished is noticed on its next cycle");
        let (cells, _) = scene();
        let mut w = Wires::new();
        let before = ctu.stats;
        for now in 500..510 {
            ctu.tick(now, &mut w.ports(), &cells);
        }
        assert!(ctu.is_finished());
        let mut want = before;
        want.state_cycles.done += 10;
        want.idle_cycles += 10;
        assert_eq!(ctu.stats, want);
        assert_eq!(ctu.state, CtuState::Done);
    }

    #[test]
    fn the_fsm_walks_its_states_and_issues_one_job_per_ray_and_patch() {
        let (ctu, states, asked, issued) = run(params(64));
        assert!(ctu.done(), "{states:?}");
        // Each patch is requested once; the source never; patch 1 seen again is not reloaded.
        assert_eq!(asked, vec![1, 2]);
        let mut jobs = issued.clone();
        jobs.sort();
        assert_eq!(jobs, vec![(0, 1), (0, 2), (1, 1), (1, 2)]);
        assert_eq!(ctu.stats.jobs_issued, 4);
        // The per-state counters partition the cycles; a join that waited split its wait.
        let st = &ctu.stats;
        assert_eq!(
            st.state_cycles.total(),
            st.busy_cycles + st.stalled_cycles + st.idle_cycles
        );
        assert!(st.state_cycles.join > st.join_wait_patches + st.join_wait_results);
        assert!(st.state_cycles.step >= 2 * st.dda_steps - 1, "{st:?}");
        assert_eq!(ctu.stats.results, 4);
        // Patch 1 goes out at once; patch 2 finds the request link still full (REQUEST).
        assert_eq!(
            &states[..5],
            &["SHELL_START", "SCAN", "STEP", "SCAN", "REQUEST"][..],
            "{states:?}"
        );
        for s in ["STEP", "JOIN"] {
            assert!(states.contains(&s), "{s}: {states:?}");
        }
        assert_eq!(states.last(), Some(&"DONE"));
        // No hit anywhere: both rays walk out of the grid and retire at the shell's join.
        assert_eq!(ctu.remaining(), 0);
        assert!(ctu.hits().all(|(_, h)| h.is_none()));
    }

    #[test]
    fn a_full_subshell_joins_before_stepping_on() {
        // One patch per subshell: the join after patch 1 waits for its jobs, then the shell
        // goes on and loads patch 2 in a second subshell.
        let (ctu, states, asked, _) = run(params(1));
        assert!(ctu.done());
        assert_eq!(asked, vec![1, 2]);
        assert!(ctu.stats.subshells >= 2, "{:?}", ctu.stats);
        let joins = states.iter().filter(|&&s| s == "JOIN").count();
        assert!(joins >= 2, "{states:?}");
    }

    #[test]
    fn a_wider_scan_looks_at_the_same_ids_in_fewer_cycles() {
        // Cell 2 holds the source and patch 1 (already loaded): one cycle for both at 2 ids
        // per cycle, and a cell whose ids fit the cycle ends in that cycle.
        let (one, _, asked1, issued1) = run(params(64));
        let (two, _, asked2, issued2) = run(CtuParams {
            scan_ids_per_cycle: 2,
            ..params(64)
        });
        assert!(two.done());
        assert_eq!(asked2, asked1);
        let sorted = |mut v: Vec<(u32, u32)>| {
            v.sort();
            v
        };
        assert_eq!(sorted(issued2), sorted(issued1));
        let (s1, s2) = (&one.stats, &two.stats);
        assert_eq!(s2.ids_scanned, s1.ids_scanned);
        assert_eq!(s2.dda_steps, s1.dda_steps);
        // At 1 id per cycle, a cycle per id and one to end each cell (stalls on top) …
        let scanning = |s: &CtuStats| s.state_cycles.scan + s.state_cycles.request;
        assert!(scanning(s1) >= s1.ids_scanned + s1.dda_steps, "{s1:?}");
        // … at 2, ⌊ids of the cell / 2⌋ + 1 per cell: fewer, never below ids / 2.
        assert!(scanning(s2) < scanning(s1), "{s1:?}\n{s2:?}");
        assert!(2 * scanning(s2) >= s2.ids_scanned, "{s2:?}");
    }

    #[test]
    fn a_ctu_reports_its_signal_counts() {
        use crate::machine::sink::Count;
        let (cells, rays) = scene();
        let ctu = Ctu::new(params(8), &[0, 1], &rays, &cells, 3);
        let (mut a, mut b) = (Count::default(), Count::default());
        ctu.signals(&mut a, "");
        ctu.bundle_signals(&mut b, "");
        assert_eq!((a.0, b.0), (Ctu::SIGNALS, Ctu::BUNDLE_SIGNALS));
    }
}
