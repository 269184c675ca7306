//! The intersection computation unit (ICU): an S-stage pipeline over the datapath's stages —
//! translate, shear, edges, interpolate, D divider stages, result — one job in per cycle
//! unless stalled. The whole pipeline stalls while the result at its end cannot leave (its
//! CTU's result link is full): back-pressure, never a lost result.
//!
//! The datapath is a pure function of (ray, patch), so the model evaluates a job's stages
//! when it enters and carries the result down the pipeline with the job (the stage
//! registers hold the job, its result and the divider's exception flags): timing, order,
//! stalls and every counter are those of the staged pipeline, at the cost of one
//! `intersect` per job — the same work as the untimed model. The exceptions the divider
//! raises are counted when the job passes the divider, as the staged hardware counts them.
//! [`Icu::stage`] rebuilds any stage's intermediate values for inspection.

use crate::datapath::format::Formats;
use crate::datapath::record::{PatchRecord, RayRecord};
use crate::datapath::{self, Edges, Exceptions, Interpolated, RaySpace, Translated};
use crate::link::{Link, UnitCode, UnitId};
use crate::machine::sink::Sink;
use crate::msg::{Job, JobResult, RemoteResult};
use crate::units::{Around, Unit};

/// What a stage register holds besides the job.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StageValue {
    Translated(Translated),
    Sheared(RaySpace),
    Edged(RaySpace, Edges),
    Interpolated(Interpolated),
    /// In the divider: the fraction, carried until the last divider stage.
    Dividing(Interpolated),
    /// The quotient (t raw) or no hit.
    Result(Option<i64>),
}

impl StageValue {
    /// The stage's name.
    pub fn stage_name(&self) -> &'static str {
        match self {
            StageValue::Translated(_) => "translate",
            StageValue::Sheared(_) => "shear",
            StageValue::Edged(..) => "edges",
            StageValue::Interpolated(_) => "interpolate",
            StageValue::Dividing(_) => "divide",
            StageValue::Result(_) => "result",
        }
    }
}

/// The links an ICU reads and drives.
pub struct IcuPorts<'a> {
    /// This ICU's cluster (results of its own jobs stay local).
    pub cluster: u16,
    /// From the ray buffer.
    pub input: &'a mut Link<Job>,
    /// To each CTU of the cluster.
    pub results: &'a mut [Link<JobResult>],
    /// Results of other clusters' jobs, back over the inter-cluster link.
    pub remote: &'a mut Link<RemoteResult>,
}

/// One stage register.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StageReg {
    pub job: Job,
    pub value: StageValue,
}

/// ICU counters. Per cycle: busy (advanced with work inside), stalled (held by back-pressure)
/// or idle (empty); `busy_stage_cycles` sums valid stage registers over advancing cycles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct IcuStats {
    pub busy_cycles: u64,
    pub stalled_cycles: u64,
    pub idle_cycles: u64,
    pub busy_stage_cycles: u64,
    pub stage_cycles: u64,
    pub jobs_in: u64,
    pub results_out: u64,
    /// Of those, results of other clusters' jobs sent home.
    pub remote_results_out: u64,
    pub hits: u64,
}

/// One stage register as the model stores it: the job, its result (computed at entry, see
/// the module note) and the exceptions its divide raises, counted when it passes the divider.
#[derive(Clone, Copy, Debug, Default)]
struct Reg {
    valid: bool,
    job: Job,
    t: Option<i64>,
    divide_exceptions: Exceptions,
}

/// The ICU. The stage registers sit in a ring: logical stage k is slot (base + k) mod S, so a
/// pipeline advance moves `base` instead of copying every register.
#[derive(Clone, Debug)]
pub struct Icu {
    slots: Vec<Reg>,
    base: usize,
    /// Registers holding a job.
    count: usize,
    pub exceptions: Exceptions,
    pub stats: IcuStats,
}

impl Icu {
    /// The ICU's own waveform signals: [`Icu::signals`] reports exactly these.
    pub const SIGNALS: usize = 1;
    /// A stage's waveform signals (valid, ray, patch, t): [`Icu::stage_job_signals`] and
    /// [`Icu::stage_t_signal`] report them, the waveform's walk calling them for each stage
    /// with [`Icu::for_each_stage`]'s values (a new stage signal: a line in one of them,
    /// counted here).
    pub const STAGE_SIGNALS: usize = 4;
    /// The first of them that move on to the next stage as the pipeline advances (valid,
    /// ray, patch; t is shown in the result stage only, zero before it).
    pub const STAGE_MOVING: usize = 3;

    /// Reports the ICU's own waveform signals to `s` under `scope` (a new signal: one line
    /// here, counted in [`Icu::SIGNALS`]).
    #[inline(always)]
    pub(crate) fn signals(&self, s: &mut impl Sink, scope: &str) {
        s.bits(scope, "jobs_in", 32, self.stats.jobs_in);
    }

    /// Stage 0's signals (an advanced pipeline whose later stages the sink moves itself).
    #[inline(always)]
    pub(crate) fn first_stage_signals(&self, s: &mut impl Sink, scope: &str, t: (u32, u32)) {
        let job = self.stage_job(0).map(|(j, _)| j);
        let (ray, patch) = job.map_or((0, 0), |j| (j.ray as u64, j.patch as u64));
        Self::stage_job_signals(s, scope, job.is_some() as u64, ray, patch);
        Self::stage_t_signal(s, scope, None, t);
    }

    /// The result stage's t.
    #[inline(always)]
    pub(crate) fn result_t_signal(&self, s: &mut impl Sink, scope: &str, t: (u32, u32)) {
        let v = self.stage_job(self.depth() - 1).and_then(|(_, t)| t);
        Self::stage_t_signal(s, scope, Some(v.unwrap_or(0)), t);
    }

    /// A stage's t in the format `t` = (bits, fractional bits): `v` in the result stage,
    /// `None` before it (always zero: a sink may leave it as it is).
    #[inline(always)]
    pub(crate) fn stage_t_signal(s: &mut impl Sink, scope: &str, v: Option<i64>, t: (u32, u32)) {
        match v {
            Some(v) => s.fixed(scope, "t", t.0, t.1, v),
            None => s.fixed_zero(scope, "t", t.0, t.1),
        }
    }

    /// A stage's moving signals ([`Icu::STAGE_MOVING`]): valid, ray, patch (its t follows).
    #[inline(always)]
    pub(crate) fn stage_job_signals(
        s: &mut impl Sink,
        scope: &str,
        valid: u64,
        ray: u64,
        patch: u64,
    ) {
        s.bits(scope, "valid", 1, valid);
        s.bits(scope, "ray", 32, ray);
        s.bits(scope, "patch", 24, patch);
    }

    /// A pipeline of 4 + `divider_stages` + 1 stages.
    pub fn new(divider_stages: u32) -> Self {
        Icu {
            slots: vec![Reg::default(); 4 + divider_stages as usize + 1],
            base: 0,
            count: 0,
            exceptions: Exceptions::default(),
            stats: IcuStats::default(),
        }
    }

    /// Pipeline depth.
    pub fn depth(&self) -> usize {
        self.slots.len()
    }

    /// Stage `k`'s register (0 = translate, depth − 1 = result), as the value that stage
    /// holds: its intermediate values rebuilt from the job's records (the datapath is a pure
    /// function of them; the model itself carries only the result).
    pub fn stage(
        &self,
        k: usize,
        rays: &[RayRecord],
        patches: &[PatchRecord],
        f: &Formats,
    ) -> Option<StageReg> {
        let n = self.slots.len();
        let r = self.reg(k)?;
        let ray = &rays[r.job.ray as usize];
        let mut exc = Exceptions::default();
        let translated = datapath::translate(ray, &patches[r.job.patch as usize], f, &mut exc);
        let sheared = datapath::shear(ray, &translated, f);
        let edges = datapath::edges(&sheared);
        let interpolated = datapath::interpolate(&sheared, &edges);
        let value = match k {
            0 => StageValue::Translated(translated),
            1 => StageValue::Sheared(sheared),
            2 => StageValue::Edged(sheared, edges),
            k if k + 1 == n => StageValue::Result(r.t),
            3 => StageValue::Interpolated(interpolated),
            _ => StageValue::Dividing(interpolated),
        };
        Some(StageReg { job: r.job, value })
    }

    /// Stage `k`'s job and, in the last stage, its result (t raw or no hit) — what the
    /// waveform shows, without building the stage's value.
    #[inline]
    pub fn stage_job(&self, k: usize) -> Option<(Job, Option<i64>)> {
        let last = k + 1 == self.slots.len();
        self.reg(k).map(|r| (r.job, if last { r.t } else { None }))
    }

    /// Calls `f` with every stage's waveform values in stage order — valid, ray, patch and
    /// t (`Some` in the result stage only), all zero for an empty stage — as [`Icu::stage_job`]
    /// gives them, walking the ring as its two halves (no division per stage) and masking
    /// instead of branching on each stage's valid bit (the waveform's probe, every sample).
    #[inline]
    pub fn for_each_stage(&self, mut f: impl FnMut(u64, u64, u64, Option<i64>)) {
        let (wrapped, from_base) = self.slots.split_at(self.base);
        let last = self.slots.len() - 1;
        for (k, r) in from_base.iter().chain(wrapped).enumerate() {
            let m = (r.valid as u64).wrapping_neg();
            let t = (k == last).then(|| m as i64 & r.t.unwrap_or(0));
            f(m & 1, m & r.job.ray as u64, m & r.job.patch as u64, t);
        }
    }

    #[inline]
    fn reg(&self, k: usize) -> Option<&Reg> {
        let r = &self.slots[(self.base + k) % self.slots.len()];
        r.valid.then_some(r)
    }

    /// The ring's position: it moves (by one) exactly when the pipeline advances, so a
    /// waveform can tell an advance from a stall between two samples one cycle apart.
    pub fn ring_position(&self) -> usize {
        self.base
    }

    /// Stage registers holding a job.
    pub fn occupied(&self) -> usize {
        self.count
    }

    /// True when no stage holds a job.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Accounts `n` cycles skipped by the machine's cycle jump (the ICU is empty then).
    pub fn skip(&mut self, n: u64) {
        self.stats.idle_cycles += n;
        self.stats.stage_cycles += n * self.slots.len() as u64;
    }

    /// One clock cycle: the result at the end leaves (if its CTU's result link is ready),
    /// every stage advances, and a job enters from the ray buffer.
    #[inline]
    pub fn tick(
        &mut self,
        io: &mut IcuPorts,
        rays: &[RayRecord],
        patches: &[PatchRecord],
        f: &Formats,
    ) {
        if self.count == 0 && !io.input.valid() {
            self.idle_tick();
            return;
        }
        self.stats.stage_cycles += self.slots.len() as u64;
        self.tick_active(io, rays, patches, f);
    }

    /// The cycle of an empty ICU with nothing at its input: only the counters move.
    #[inline(always)]
    pub fn idle_tick(&mut self) {
        self.stats.stage_cycles += self.slots.len() as u64;
        self.stats.idle_cycles += 1;
    }

    /// A cycle with a job inside or waiting at the input.
    #[inline(always)]
    fn tick_active(
        &mut self,
        io: &mut IcuPorts,
        rays: &[RayRecord],
        patches: &[PatchRecord],
        f: &Formats,
    ) {
        let IcuPorts {
            cluster,
            input,
            results,
            remote,
        } = io;
        let cluster = *cluster;
        let me = UnitCode::from(UnitId::Icu(cluster as usize));
        let n = self.slots.len();
        let last = if self.base == 0 { n - 1 } else { self.base - 1 };
        if self.slots[last].valid {
            let reg = &self.slots[last];
            // A job from another cluster (dynamic balancing) sends its result home.
            let local = reg.job.owner == cluster;
            let ready = if local {
                results[reg.job.ctu as usize].can_push()
            } else {
                remote.can_push()
            };
            if !ready {
                self.stats.stalled_cycles += 1;
                return;
            }
            let t = reg.t;
            let r = JobResult {
                slot: reg.job.slot,
                patch: reg.job.patch,
                t,
            };
            if local {
                results[reg.job.ctu as usize].push(me, r);
            } else {
                remote.push(
                    me,
                    RemoteResult {
                        owner: reg.job.owner,
                        ctu: reg.job.ctu,
                        result: r,
                    },
                );
                self.stats.remote_results_out += 1;
            }
            self.stats.results_out += 1;
            self.stats.hits += t.is_some() as u64;
        }
        // Busy stage-cycles: the registers that held a job this cycle (the leaving one too).
        let valid = self.count as u64;
        if self.slots[last].valid {
            self.slots[last].valid = false;
            self.count -= 1;
        }
        // The ring turns: logical stage k becomes k + 1 and the emptied last slot becomes
        // stage 0. The job moving from the last divider stage into the result stage is the
        // one whose divide completes now: its exceptions count in this cycle.
        let into_result = if last == 0 { n - 1 } else { last - 1 };
        if self.slots[into_result].valid {
            self.exceptions
                .add(&self.slots[into_result].divide_exceptions);
        }
        self.base = last;
        if input.valid() {
            let job = input.pop(me);
            let mut divide_exceptions = Exceptions::default();
            let t = datapath::intersect_t(
                &rays[job.ray as usize],
                &patches[job.patch as usize],
                f,
                &mut self.exceptions,
                &mut divide_exceptions,
            );
            self.slots[self.base] = Reg {
                valid: true,
                job,
                t,
                divide_exceptions,
            };
            self.count += 1;
            self.stats.jobs_in += 1;
        }
        if valid > 0 || self.slots[self.base].valid {
            self.stats.busy_cycles += 1;
            self.stats.busy_stage_cycles += valid;
        } else {
            self.stats.idle_cycles += 1;
        }
    }
}

/// The ICU's cold paths: quiet and done when empty (a job inside moves every cycle); a jump
/// counts its stages idle.
impl Unit for Icu {
    fn quiet(&self, _now: u64, _: &Around) -> bool {
        self.is_empty()
    }

    fn skip(&mut self, _now: u64, n: u64) {
        Icu::skip(self, n);
    }

    fn activity(&self) -> u64 {
        self.stats.jobs_in + self.stats.results_out
    }

    fn done(&self) -> bool {
        self.is_empty()
    }

    fn report(&self, _now: u64) -> String {
        format!("{} of {} stages full", self.occupied(), self.depth())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn records() -> (Vec<RayRecord>, Vec<PatchRecord>, Formats) {
        let f = crate::config::paper().datapath.formats().unwrap();
        let rays = (0..4)
            .map(|i| RayRecord::new(i, [32 + 16 * i as i64, 128, 128], [4096, 0, 0], &f))
            .collect();
        // A quad in the plane x = 512 that the rays cross (y, z in 0..256).
        let v = [[512, 0, 0], [512, 256, 0], [512, 256, 256], [512, 0, 256]];
        let patches = vec![PatchRecord {
            id: 0,
            n_verts: 4,
            v,
        }];
        (rays, patches, f)
    }

    /// An ICU's links in a test: its job input, its one result link and the remote link.
    struct Wires {
        input: Link<Job>,
        results: Vec<Link<JobResult>>,
        remote: Link<RemoteResult>,
    }

    impl Wires {
        /// Unwired links, two entries deep.
        fn new() -> Self {
            Wires {
                input: Link::new(2),
                results: vec![Link::new(2)],
                remote: Link::new(2),
            }
        }

        /// One cycle of `icu` on these links (cluster 0), without the edge.
        fn tick(
            &mut self,
            icu: &mut Icu,
            rays: &[RayRecord],
            patches: &[PatchRecord],
            f: &Formats,
        ) {
            let mut io = IcuPorts {
                cluster: 0,
                input: &mut self.input,
                results: &mut self.results,
                remote: &mut self.remote,
            };
            icu.tick(&mut io, rays, patches, f);
        }

        /// The clock edge of every link.
        fn commit(&mut self) {
            self.input.commit();
            self.results[0].commit();
            self.remote.commit();
        }
    }

    #[test]
    fn back_pressure_never_loses_a_result_and_keeps_order() {
        let (rays, patches, f) = records();
        let mut icu = Icu::new(4);
        let mut w = Wires {
            input: Link::new(2).wired(UnitId::RayBuffer(0), UnitId::Icu(0)),
            results: vec![Link::new(2).wired(UnitId::Icu(0), UnitId::Ctu(0, 0))],
            remote: Link::new(2),
        };
        let n = 24u32;
        let (mut sent, mut got) = (0u32, vec![]);
        for cycle in 0..400 {
            if sent < n && w.input.can_push() {
                let job = Job {
                    ray: sent % 4,
                    slot: sent,
                    patch: 0,
                    ctu: 0,
                    owner: 0,
                };
                w.input.push(UnitId::RayBuffer(0), job);
                sent += 1;
            }
            w.tick(&mut icu, &rays, &patches, &f);
            // The CTU holds its result link not-ready for 150 cycles, then takes one result
            // every third cycle.
            if cycle >= 150 && cycle % 3 == 0 && w.results[0].peek().is_some() {
                got.push(w.results[0].pop(UnitId::Ctu(0, 0)));
            }
            w.commit();
        }
        assert_eq!(
            got.iter().map(|r| r.slot).collect::<Vec<_>>(),
            (0..n).collect::<Vec<_>>()
        );
        assert!(icu.is_empty());
        assert!(icu.stats.stalled_cycles > 100, "{:?}", icu.stats);
        assert_eq!(icu.stats.results_out, n as u64);
    }

    #[test]
    fn the_stage_walk_gives_every_stage_as_stage_job_does_through_the_rings_wraps() {
        let (mut valid_seen, mut empty_seen) = (0, 0);
        let icu = drive(300, |cycle, icu| {
            let walked = walk(icu);
            let by_stage: Vec<_> = (0..icu.depth())
                .map(|k| match icu.stage_job(k) {
                    Some((j, t)) => (1, j.ray as u64, j.patch as u64, t.unwrap_or(0)),
                    None => (0, 0, 0, 0),
                })
                .enumerate()
                .map(|(k, (v, r, p, t))| (v, r, p, (k + 1 == icu.depth()).then_some(t)))
                .collect();
            assert_eq!(walked, by_stage, "cycle {cycle}");
            valid_seen += walked.iter().filter(|w| w.0 == 1).count();
            empty_seen += walked.iter().filter(|w| w.0 == 0).count();
        });
        assert!(
            valid_seen > 100 && empty_seen > 100,
            "{valid_seen} {empty_seen}"
        );
        assert!(icu.stats.results_out > 50, "{:?}", icu.stats);
    }

    /// What the waveform's walk relies on (`Sink::shift_stages` in machine/probe.rs): between two edges the
    /// ring's position moves exactly when every stage takes what the stage before it held,
    /// and stays when nothing moves (a stall, or an empty ICU).
    #[test]
    fn the_ring_moves_exactly_when_the_stages_shift_into_the_next() {
        let (mut shifts, mut holds) = (0, 0);
        // The ring's position and the stages' (valid, ray, patch) after the last edge.
        type Seen = (usize, Vec<(u64, u64, u64)>);
        let mut last: Option<Seen> = None;
        let icu = drive(300, |cycle, icu| {
            let now: Vec<_> = walk(icu).iter().map(|&(v, r, p, _)| (v, r, p)).collect();
            if let Some((at, before)) = &last {
                if icu.ring_position() != *at {
                    assert_eq!(
                        now[1..],
                        before[..before.len() - 1],
                        "cycle {cycle}: shifted"
                    );
                    shifts += 1;
                } else {
                    assert_eq!(&now, before, "cycle {cycle}: held");
                    holds += (now.iter().any(|s| s.0 == 1)) as u32;
                }
            }
            last = Some((icu.ring_position(), now));
        });
        assert!(shifts > 100 && holds > 20, "{shifts} {holds}");
        assert!(icu.stats.stalled_cycles > 20, "{:?}", icu.stats);
    }

    /// The waveform's stage values (`Icu::for_each_stage`).
    fn walk(icu: &Icu) -> Vec<(u64, u64, u64, Option<i64>)> {
        let mut walked = Vec::new();
        icu.for_each_stage(|v, r, p, t| walked.push((v, r, p, t)));
        walked
    }

    /// Drives an ICU for `cycles` cycles — jobs in bursts, results taken every other cycle,
    /// so its stages fill, stall and empty — calling `each` after every clock edge; returns
    /// it.
    fn drive(cycles: u32, mut each: impl FnMut(u32, &Icu)) -> Icu {
        let (rays, patches, f) = records();
        let mut icu = Icu::new(4);
        let mut w = Wires::new();
        for cycle in 0..cycles {
            if cycle % 40 < 25 && w.input.can_push() {
                let job = Job {
                    ray: cycle % 4,
                    slot: cycle,
                    patch: 0,
                    ctu: 0,
                    owner: 0,
                };
                w.input.push(UnitId::RayBuffer(0), job);
            }
            w.tick(&mut icu, &rays, &patches, &f);
            if cycle % 2 == 0 && w.results[0].peek().is_some() {
                w.results[0].pop(UnitId::Ctu(0, 0));
            }
            w.commit();
            each(cycle, &icu);
        }
        icu
    }

    #[test]
    fn another_clusters_job_goes_home_over_the_remote_link() {
        let (rays, patches, f) = records();
        let mut icu = Icu::new(4);
        let mut w = Wires::new();
        w.input.push(
            UnitId::RayBuffer(0),
            Job {
                ray: 1,
                slot: 5,
                patch: 0,
                ctu: 1,
                owner: 3,
            },
        );
        w.input.commit();
        let mut out = None;
        for _ in 0..20 {
            w.tick(&mut icu, &rays, &patches, &f);
            w.commit();
            if w.remote.peek().is_some() {
                out = Some(w.remote.pop(UnitId::Balancer));
            }
        }
        let r = out.expect("the result left");
        assert_eq!((r.owner, r.ctu, r.result.slot), (3, 1, 5));
        assert!(w.results[0].is_empty() && w.results[0].transfers == 0);
        assert_eq!(icu.stats.remote_results_out, 1);
    }

    /// Ticks `icu` with one job at the input on cycle 0 and its result link always ready;
    /// returns the exceptions after each of `cycles` cycles and the result.
    fn one_job(
        icu: &mut Icu,
        rays: &[RayRecord],
        patches: &[PatchRecord],
        f: &Formats,
        cycles: usize,
        mut at: impl FnMut(&Icu, usize),
    ) -> (Vec<Exceptions>, Option<JobResult>) {
        let mut w = Wires::new();
        let job = Job {
            ray: 0,
            slot: 0,
            patch: 0,
            ctu: 0,
            owner: 0,
        };
        w.input.push(UnitId::RayBuffer(0), job);
        w.input.commit();
        let (mut seen, mut out) = (vec![], None);
        for cycle in 0..cycles {
            w.tick(icu, rays, patches, f);
            w.commit();
            at(icu, cycle);
            seen.push(icu.exceptions);
            if w.results[0].peek().is_some() {
                out = Some(w.results[0].pop(UnitId::Ctu(0, 0)));
                w.results[0].commit();
            }
        }
        (seen, out)
    }

    #[test]
    fn a_divide_exception_counts_when_the_job_passes_the_divider_not_on_entry() {
        let (mut rays, patches, f) = records();
        // A direction of 1/128: the plane x = 512 lies at t ≈ 15, beyond t's format.
        rays[0] = RayRecord::new(0, [32, 128, 128], [32, 0, 0], &f);
        let mut icu = Icu::new(4);
        let n = icu.depth();
        let (seen, out) = one_job(&mut icu, &rays, &patches, &f, n + 2, |_, _| {});
        let first = seen.iter().position(|e| e.t_saturated == 1);
        // On cycle k the job sits in stage k; it enters the result stage on cycle n − 1.
        assert_eq!(first, Some(n - 1), "{seen:?}");
        assert_eq!(seen.last().unwrap().t_saturated, 1, "counted once");
        assert_eq!(out.expect("the result left").t, None);
    }

    #[test]
    fn every_stage_shows_the_datapath_values_of_its_job() {
        let (rays, patches, f) = records();
        let mut icu = Icu::new(4);
        let n = icu.depth();
        let mut exc = Exceptions::default();
        let tr = datapath::translate(&rays[0], &patches[0], &f, &mut exc);
        let sh = datapath::shear(&rays[0], &tr, &f);
        let ed = datapath::edges(&sh);
        let ip = datapath::interpolate(&sh, &ed);
        let hit = datapath::intersect(&rays[0], &patches[0], &f, &mut exc).map(|h| h.t);
        assert!(hit.is_some(), "the ray crosses the quad");
        let mut shown = vec![];
        let (_, out) = one_job(&mut icu, &rays, &patches, &f, n + 1, |icu, k| {
            if k < n {
                let st = icu
                    .stage(k, &rays, &patches, &f)
                    .expect("the job is in stage k");
                assert!((0..n).all(|j| j == k || icu.stage(j, &rays, &patches, &f).is_none()));
                shown.push(st.value);
            }
        });
        let mut want = vec![
            StageValue::Translated(tr),
            StageValue::Sheared(sh),
            StageValue::Edged(sh, ed),
            StageValue::Interpolated(ip),
        ];
        want.extend((4..n - 1).map(|_| StageValue::Dividing(ip)));
        want.push(StageValue::Result(hit));
        assert_eq!(shown, want);
        assert_eq!(out.expect("the result left").t, hit);
    }

    #[test]
    fn the_icu_reports_its_signal_counts() {
        use crate::machine::sink::Count;
        let icu = Icu::new(3);
        let [mut a, mut b, mut c, mut d] = <[Count; 4]>::default();
        icu.signals(&mut a, "");
        icu.for_each_stage(|valid, ray, patch, v| {
            Icu::stage_job_signals(&mut b, "", valid, ray, patch);
            Icu::stage_t_signal(&mut b, "", v, (16, 8));
        });
        Icu::stage_job_signals(&mut c, "", 0, 0, 0);
        icu.first_stage_signals(&mut d, "", (16, 8));
        assert_eq!(a.0, Icu::SIGNALS);
        assert_eq!(b.0, Icu::STAGE_SIGNALS * icu.depth());
        assert_eq!((c.0, d.0), (Icu::STAGE_MOVING, Icu::STAGE_SIGNALS));
    }
}
