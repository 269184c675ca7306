//! The intersection computation unit (ICU): an S-stage pipeline over the datapath's stages —
//! translate, shear, edges, interpolate, D divider stages, result — one job in per cycle
//! unless stalled. Each stage register holds the job and that stage's intermediate values
//! (visible in the waveform). The whole pipeline stalls while the result at its end cannot
//! leave (its CTU's result link is full): back-pressure, never a lost result.

use crate::config::Formats;
use crate::datapath::{self, Edges, Exceptions, Interpolated, RaySpace, Translated};
use crate::link::Link;
use crate::msg::{Job, JobResult};
use crate::record::{PatchRecord, RayRecord};

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
    pub hits: u64,
}

/// The ICU.
#[derive(Clone, Debug)]
pub struct Icu {
    pub stages: Vec<Option<StageReg>>,
    divider_stages: usize,
    pub exceptions: Exceptions,
    pub stats: IcuStats,
}

impl Icu {
    /// A pipeline of 4 + `divider_stages` + 1 stages.
    pub fn new(divider_stages: u32) -> Self {
        Icu {
            stages: vec![None; 4 + divider_stages as usize + 1],
            divider_stages: divider_stages as usize,
            exceptions: Exceptions::default(),
            stats: IcuStats::default(),
        }
    }

    /// Pipeline depth.
    pub fn depth(&self) -> usize {
        self.stages.len()
    }

    /// True when no stage holds a job.
    pub fn is_empty(&self) -> bool {
        self.stages.iter().all(Option::is_none)
    }

    /// Accounts `n` cycles skipped by the machine's cycle jump (the ICU is empty then).
    pub fn skip(&mut self, n: u64) {
        self.stats.idle_cycles += n;
        self.stats.stage_cycles += n * self.stages.len() as u64;
    }

    /// The value the next stage computes from a stage register's value (stage `k` → `k+1`).
    fn advance(
        &self,
        k: usize,
        v: StageValue,
        ray: &RayRecord,
        f: &Formats,
        exc: &mut Exceptions,
    ) -> StageValue {
        let last_div = 3 + self.divider_stages;
        match v {
            StageValue::Translated(t) => StageValue::Sheared(datapath::shear(ray, &t, f)),
            StageValue::Sheared(s) => StageValue::Edged(s, datapath::edges(&s)),
            StageValue::Edged(s, e) => StageValue::Interpolated(datapath::interpolate(&s, &e)),
            StageValue::Interpolated(q) | StageValue::Dividing(q) => {
                // Stages 4..=3+D are the divider; the quotient appears at the last.
                if k + 1 == last_div + 1 {
                    StageValue::Result(datapath::divide(&q, f, exc))
                } else {
                    StageValue::Dividing(q)
                }
            }
            StageValue::Result(r) => StageValue::Result(r),
        }
    }

    /// One clock cycle: the result at the end leaves (if its CTU's result link is ready),
    /// every stage advances, and a job enters from the ray buffer.
    pub fn tick(
        &mut self,
        input: &mut Link<Job>,
        results: &mut [Link<JobResult>],
        rays: &[RayRecord],
        patches: &[PatchRecord],
        f: &Formats,
    ) {
        let n = self.stages.len();
        self.stats.stage_cycles += n as u64;
        if let Some(last) = &self.stages[n - 1] {
            let out = &mut results[last.job.ctu as usize];
            if !out.can_push() {
                self.stats.stalled_cycles += 1;
                return;
            }
            let StageValue::Result(t) = last.value else {
                unreachable!("the last stage holds a result")
            };
            out.push(JobResult {
                slot: last.job.slot,
                patch: last.job.patch,
                t,
            });
            self.stats.results_out += 1;
            self.stats.hits += t.is_some() as u64;
        }
        let valid = self.stages.iter().filter(|s| s.is_some()).count() as u64;
        // Advance from the end so each register is read before it is overwritten.
        let mut exc = self.exceptions;
        for k in (0..n - 1).rev() {
            self.stages[k + 1] = self.stages[k].map(|r| StageReg {
                job: r.job,
                value: self.advance(k, r.value, &rays[r.job.ray as usize], f, &mut exc),
            });
        }
        self.stages[0] = None;
        if input.peek().is_some() {
            let job = input.pop();
            let t = datapath::translate(
                &rays[job.ray as usize],
                &patches[job.patch as usize],
                f,
                &mut exc,
            );
            self.stages[0] = Some(StageReg {
                job,
                value: StageValue::Translated(t),
            });
            self.stats.jobs_in += 1;
        }
        self.exceptions = exc;
        if valid > 0 || self.stages[0].is_some() {
            self.stats.busy_cycles += 1;
            self.stats.busy_stage_cycles += valid;
        } else {
            self.stats.idle_cycles += 1;
        }
    }
}
