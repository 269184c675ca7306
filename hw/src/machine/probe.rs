//! The machine's waveform: every unit's signals and every link's handshake. One walk
//! ([`Machine::walk`]) visits them in the waveform's signal order: on the first sample it
//! declares the layout to the [`Probe`] (scope names built once), on every sample it fills a
//! flat value array, position = signal id, handed to the probe whole with the positions whose
//! value changed, ascending (each put stores its position at the end of the list and counts
//! it in only when it changed the value it replaces, without a branch; the walk visits the
//! positions in ascending order, so no second pass sorts or gathers them) — no string is
//! touched per cycle and nothing is allocated. The array keeps the last sample's values, so
//! what cannot have changed is not put again: an empty ICU's stages (all zero) and a finished
//! CTU's signals (final) when so at the last sample too, a CTU that did not tick, a link no
//! edge touched, a stage's t before the result stage (always zero). For a probe that
//! [`Probe::shifts_stages`], an advanced ICU's later stages are not moved in the array: one
//! entry naming the ICU's [`Pipeline`], declared once with the layout, stands for them in the
//! list, and the probe moves its own copy.
//!
//! The run owns a [`Sampler`] that keeps all of this — the scopes, the arrays and what each
//! unit showed at the last sample (quiet or not, an ICU's ring position, a CTU's active
//! cycles) — so looking at the machine changes nothing in it.

use super::links::{probe_link, LinkShown, Section};
use super::sink::{Shift, Sink, Stages};
use super::Machine;
use crate::trace::{Pipeline, Probe, SignalDecl, SignalKind};
use crate::units::ctu::Ctu;
use crate::units::icu::Icu;

/// The low `width` bits.
fn mask(width: u32) -> u64 {
    if width >= 64 {
        u64::MAX
    } else {
        (1u64 << width) - 1
    }
}

/// Collects the layout: the signals, and the pipelines a probe can shift with the cluster
/// each belongs to.
#[derive(Default)]
struct Declare {
    signals: Vec<SignalDecl>,
    pipelines: Vec<Pipeline>,
    /// Per cluster: its pipeline's number among `pipelines` ([`NO_PIPELINE`]: none).
    pipeline_of: Vec<u32>,
}

/// A cluster whose ICU has no declared pipeline (left out, or its stages do not fit one).
const NO_PIPELINE: u32 = u32::MAX;

impl Sink for Declare {
    /// An ICU's stages: declared as a pipeline when they fit one, stage 0 at the next
    /// position (the walk then reports every stage).
    fn shift_stages(&mut self, stages: Stages) -> Shift {
        let Stages {
            cluster: c,
            stride,
            width,
            signals: n,
            ..
        } = stages;
        let p = Pipeline {
            at: self.signals.len() + stride,
            stride,
            width,
            later: (n / stride.max(1)).saturating_sub(1),
        };
        if width <= CARRY && n >= 2 * stride && p.fits() {
            if self.pipeline_of.len() <= c {
                self.pipeline_of.resize(c + 1, NO_PIPELINE);
            }
            self.pipeline_of[c] = self.pipelines.len() as u32;
            self.pipelines.push(p);
        }
        Shift::Walk
    }
    fn bits(&mut self, scope: &str, name: &'static str, width: u32, _: u64) {
        self.signals.push(SignalDecl {
            scope: scope.to_string(),
            name,
            width,
            kind: SignalKind::Bits,
        });
    }
    fn text(&mut self, scope: &str, name: &'static str, names: &'static [&'static str], _: u64) {
        self.signals.push(SignalDecl {
            scope: scope.to_string(),
            name,
            width: 1,
            kind: SignalKind::Text(names),
        });
    }
    fn fixed(&mut self, scope: &str, name: &'static str, width: u32, frac: u32, _: i64) {
        self.signals.push(SignalDecl {
            scope: scope.to_string(),
            name,
            width,
            kind: SignalKind::Fixed { frac },
        });
    }
}

/// Values [`Fixed`] arrays hold: layouts up to this size (the paper's machine has 435
/// signals, 16 clusters about 1,700) are filled without a bound check per value; larger
/// ones through [`Checked`] slices.
const FILL_CAP: usize = 1 << 12;

/// A stage's signals that [`Sink::shift_stages`] can move on (an ICU moves 3): a filler
/// keeps this many of stage 0's values to hand to stage 1.
const CARRY: usize = 4;

/// Positions [`Fixed`] arrays' change list holds: every position of 16 bits, so the list's end,
/// taken as 16 bits, needs no bound check nor mask (one zero-extension where a wrap at
/// [`FILL_CAP`] takes a copy and a mask); it never passes `FILL_CAP`. Only the list's first
/// positions are ever written (a fresh allocation's pages are mapped when first touched).
const LIST_CAP: usize = 1 << 16;

/// Where a [`Fill`] keeps the value array and the change list: [`Fixed`] arrays, whose
/// puts need no bound check, or [`Checked`] slices of any size. The one filler is written
/// once over this and compiled for each.
trait Arrays {
    /// The arrays always hold a whole earlier sample ([`Fixed`] ones serve only after the
    /// first), so no skip tests for it.
    const FILLED: bool;
    /// Sets position `at` to `v`, lists it at `*listed` when that changed it, and returns
    /// the value it held.
    fn set(&mut self, listed: &mut usize, at: usize, v: u64) -> u64;
    /// The value at position `at`.
    fn get(&self, at: usize) -> u64;
    /// Lists the entry `code` (a [`Pipeline::entry`]) at `*listed`, whatever the values.
    fn list(&mut self, listed: &mut usize, code: u32);
}

/// Arrays of a fixed size: the position wraps at the array's size and the list's end at the
/// list's ([`LIST_CAP`]), so no put can panic (the compiler then keeps them in registers
/// over a run of puts and drops the bound checks); `Machine::probe` checks once per sample
/// that the walk filled exactly the layout, which is never larger than the array.
struct Fixed<'a> {
    values: &'a mut [u64; FILL_CAP],
    changes: &'a mut [u32; LIST_CAP],
}

impl Arrays for Fixed<'_> {
    const FILLED: bool = true;

    /// No branch: the position is always stored at the list's end, the end moved on only
    /// for a change.
    #[inline(always)]
    fn set(&mut self, listed: &mut usize, at: usize, v: u64) -> u64 {
        let i = at % FILL_CAP;
        let old = std::mem::replace(&mut self.values[i], v);
        self.changes[*listed as u16 as usize] = i as u32;
        *listed += (old != v) as usize;
        old
    }

    #[inline(always)]
    fn get(&self, at: usize) -> u64 {
        self.values[at % FILL_CAP]
    }

    #[inline(always)]
    fn list(&mut self, listed: &mut usize, code: u32) {
        self.changes[*listed as u16 as usize] = code;
        *listed += 1;
    }
}

/// Slices of any size (a layout past [`FILL_CAP`], and every layout's first sample): a
/// bound check per value, nothing set (zero returned or read) past the array.
struct Checked<'a> {
    values: &'a mut [u64],
    /// At least as long as `values` (a shift stands for more positions than it takes).
    changes: &'a mut [u32],
}

impl Arrays for Checked<'_> {
    const FILLED: bool = false;

    #[inline(always)]
    fn set(&mut self, listed: &mut usize, at: usize, v: u64) -> u64 {
        let Some(x) = self.values.get_mut(at) else {
            return 0;
        };
        let old = std::mem::replace(x, v);
        if let Some(c) = self.changes.get_mut(*listed) {
            *c = at as u32;
            *listed += (old != v) as usize;
        }
        old
    }

    #[inline(always)]
    fn get(&self, at: usize) -> u64 {
        self.values.get(at).copied().unwrap_or(0)
    }

    #[inline(always)]
    fn list(&mut self, listed: &mut usize, code: u32) {
        if let Some(c) = self.changes.get_mut(*listed) {
            *c = code;
            *listed += 1;
        }
    }
}

/// Fills the value array in signal order, over the last sample's values, and lists the
/// positions it changes as it goes (the [`Sink`] of every sample: every kind of signal is
/// one value put in order).
struct Fill<'a, A> {
    arrays: A,
    pos: usize,
    /// Positions listed in the change list so far (this sample's changed positions,
    /// ascending; past them: scratch).
    listed: usize,
    /// What the units showed at the last sample, updated as the walk goes.
    last: Last<'a>,
    /// The arrays hold a whole earlier sample (unchanged units may be skipped); always,
    /// for [`Arrays::FILLED`] ones.
    filled_before: bool,
    /// Stage 0's moving values at the last sample, kept by [`Sink::shift_stages`] for
    /// [`Sink::move_stages`] (unless it listed a pipeline's entry: `shifted`).
    carry: [u64; CARRY],
    /// The probe moves the later stages itself ([`Probe::shifts_stages`]).
    shifts: bool,
    /// The last [`Sink::shift_stages`] listed a pipeline's entry (its stages not moved here).
    shifted: bool,
}

impl<'a, A: Arrays> Fill<'a, A> {
    /// A filler over `arrays`, at the start of a sample.
    fn new(arrays: A, last: Last<'a>, filled_before: bool, shifts: bool) -> Self {
        Fill {
            arrays,
            pos: 0,
            listed: 0,
            last,
            filled_before,
            carry: [0; CARRY],
            shifts,
            shifted: false,
        }
    }

    /// Sets position `at` to `v` (listing it when that changed it) and returns the value it
    /// held.
    #[inline(always)]
    fn set(&mut self, at: usize, v: u64) -> u64 {
        self.arrays.set(&mut self.listed, at, v)
    }

    /// The value at position `at`.
    #[inline(always)]
    fn get(&self, at: usize) -> u64 {
        self.arrays.get(at)
    }

    /// The arrays hold a whole earlier sample.
    #[inline(always)]
    fn filled_before(&self) -> bool {
        A::FILLED || self.filled_before
    }

    /// Puts `v` at the next position, listing it when it changed the value there.
    #[inline(always)]
    fn put(&mut self, v: u64) {
        self.set(self.pos, v);
        self.pos += 1;
    }
}

impl<A: Arrays> Sink for Fill<'_, A> {
    #[inline(always)]
    fn bits(&mut self, _: &str, _: &'static str, width: u32, value: u64) {
        self.put(value & mask(width));
    }
    #[inline(always)]
    fn text(&mut self, _: &str, _: &'static str, _: &'static [&'static str], index: u64) {
        self.put(index);
    }
    #[inline(always)]
    fn fixed(&mut self, _: &str, _: &'static str, width: u32, _: u32, raw: i64) {
        self.put(raw as u64 & mask(width));
    }
    #[inline(always)]
    fn fixed_zero(&mut self, _: &str, _: &'static str, _: u32, _: u32) {
        self.pos += 1;
    }
    #[inline(always)]
    fn skip_quiet(&mut self, u: usize, quiet: bool, n: usize) -> bool {
        let Some(was) = self.last.quiet.get_mut(u) else {
            return false;
        };
        let skip = std::mem::replace(was, quiet) && quiet;
        if skip {
            self.pos += n;
        }
        skip
    }
    #[inline(always)]
    fn shift_stages(&mut self, stages: Stages) -> Shift {
        let Stages {
            cluster: c,
            position,
            stride,
            width,
            signals: n,
        } = stages;
        let Some(at) = self.last.ring.get_mut(c) else {
            return Shift::Walk;
        };
        let moved = std::mem::replace(at, position) != position;
        let fits = stride > 0 && width <= CARRY.min(stride) && n >= 2 * stride;
        if !self.filled_before() || !fits {
            return Shift::Walk;
        }
        if !moved {
            self.pos += n;
            return Shift::Held;
        }
        // The probe moves them itself: one entry naming the declared pipeline, ahead of
        // stage 0's changes.
        self.shifted = false;
        let k = self.last.pipelines.get(c).copied().unwrap_or(NO_PIPELINE);
        if self.shifts && k != NO_PIPELINE {
            self.arrays.list(&mut self.listed, Pipeline::entry(k));
            self.shifted = true;
            return Shift::Moved;
        }
        for j in 0..width {
            self.carry[j] = self.get(self.pos + j);
        }
        Shift::Moved
    }
    #[inline(always)]
    fn move_stages(&mut self, stages: Stages) {
        let Stages {
            stride,
            width,
            signals: n,
            ..
        } = stages;
        // Stage k takes stage k − 1's value as it was, its own carried on to k + 1. Two
        // stages a round, the second taking the first's values where they were read
        // (carried from stage to stage, they would be copied between registers).
        let later = n / stride - 1;
        if self.shifted {
            self.pos += (later - 1) * stride + width;
            return;
        }
        let mut carry = self.carry;
        let mut at = self.pos;
        for _ in 0..later / 2 {
            let mut mid = [0; CARRY];
            for (j, (m, c)) in mid.iter_mut().zip(&carry).enumerate().take(width) {
                *m = self.set(at + j, *c);
            }
            for (j, (c, m)) in carry.iter_mut().zip(&mid).enumerate().take(width) {
                *c = self.set(at + stride + j, *m);
            }
            at += 2 * stride;
        }
        if later % 2 == 1 {
            for (j, c) in carry.iter_mut().enumerate().take(width) {
                *c = self.set(at + j, *c);
            }
            at += stride;
        }
        self.pos = at - stride + width;
    }
    #[inline(always)]
    fn moved(&mut self, u: usize, count: u64) -> bool {
        match self.last.counts.get_mut(u) {
            Some(was) => std::mem::replace(was, count) != count,
            None => true,
        }
    }
    #[inline(always)]
    fn link_moved(&mut self, stamp: u64) -> bool {
        stamp > self.last.since
    }
    #[inline(always)]
    fn skip_unchanged(&mut self, changed: bool, n: usize) -> bool {
        let skip = !changed && self.filled_before();
        if skip {
            self.pos += n;
        }
        skip
    }
}

/// What the units showed at the last sample, as a filler reads and updates it.
struct Last<'a> {
    /// Per unit of [`quiet_units`]: it was quiet.
    quiet: &'a mut [bool],
    /// Per cluster: its ICU's ring position.
    ring: &'a mut [usize],
    /// Per CTU, cluster-major: its [`Ctu::active_cycles`] ([`Sink::moved`]).
    counts: &'a mut [u64],
    /// The cycle of the last sample (0 before the first, whose fill writes every signal): a
    /// link whose stamp is past it has changed since ([`Sink::link_moved`]).
    since: u64,
    /// Per cluster: its ICU's declared pipeline ([`NO_PIPELINE`]: none).
    pipelines: &'a [u32],
}

/// What a run keeps to sample the machine's waveform, none of it in the model: the scopes
/// (built on the first sample), the value array and change list (allocated with the layout,
/// reused), and what each unit showed at the last sample.
#[derive(Debug, Default)]
pub struct Sampler {
    scopes: Option<Scopes>,
    /// One value per signal (at least [`FILL_CAP`]).
    values: Vec<u64>,
    /// The last sample's changed positions, ascending (listed by the walk as it puts them;
    /// at least [`LIST_CAP`]).
    changes: Vec<u32>,
    /// Signals of the layout (the value array may be longer: see [`FILL_CAP`]).
    signals: usize,
    /// Per unit of [`quiet_units`]: it was quiet at the last sample.
    quiet: Vec<bool>,
    /// Per cluster: its ICU's ring position at the last sample.
    ring: Vec<usize>,
    /// Per CTU, cluster-major: its active cycles at the last sample.
    counts: Vec<u64>,
    /// The cycle of the last sample (0 before the first).
    since: u64,
    /// Per cluster: its ICU's declared pipeline ([`NO_PIPELINE`]: none).
    pipeline_of: Vec<u32>,
    /// The value array holds a whole sample (after the first fill).
    filled: bool,
}

impl Sampler {
    /// Reports every unit's signals of `m` at its current cycle to `p`: the layout first
    /// (on the first sample), then the sample's values.
    pub fn sample(&mut self, m: &Machine, p: &mut dyn Probe) {
        let sc = match &self.scopes {
            Some(sc) => sc,
            None => {
                // Units whose scopes the probe keeps none of are left out of the layout.
                let wants = |s: &str| p.wants(s);
                let sc = Scopes::new(m, &wants);
                let mut d = Declare::default();
                m.walk(&sc, &mut d);
                p.declare(&d.signals, &d.pipelines);
                let n = d.signals.len();
                self.pipeline_of = d.pipeline_of;
                self.values = vec![0; n.max(FILL_CAP)];
                self.changes = vec![0; n.max(LIST_CAP)];
                self.signals = n;
                self.quiet = vec![false; quiet_units(m)];
                self.ring = m.clusters.iter().map(|c| c.icu.ring_position()).collect();
                self.counts = vec![0; m.clusters.iter().map(|c| c.ctus.len()).sum()];
                self.scopes.insert(sc)
            }
        };
        let (n, filled_before) = (self.signals, self.filled);
        let shifts = p.shifts_stages();
        let last = Last {
            quiet: &mut self.quiet,
            ring: &mut self.ring,
            counts: &mut self.counts,
            since: self.since,
            pipelines: &self.pipeline_of,
        };
        let fixed = (
            <&mut [u64; FILL_CAP]>::try_from(&mut self.values[..]),
            <&mut [u32; LIST_CAP]>::try_from(&mut self.changes[..]),
        );
        let (filled, changed) = match fixed {
            (Ok(values), Ok(changes)) if n <= FILL_CAP && filled_before => {
                m.fill_fixed(sc, values, changes, last, shifts)
            }
            _ => m.fill_checked(
                sc,
                &mut self.values,
                &mut self.changes,
                last,
                filled_before,
                shifts,
            ),
        };
        assert_eq!(filled, n, "the walk's layout never changes");
        p.sample_changes(m.cycle, &self.values[..n], &self.changes[..changed]);
        self.filled = true;
        self.since = m.cycle;
    }
}

impl Machine<'_> {
    /// Fills [`Fixed`] arrays over a whole earlier sample: the signals filled and the
    /// changes listed. The arrays are arguments of their own, so the compiler knows that
    /// no put changes what the walk reads (the machine holds cells), and the filler's
    /// position and list end stay in registers over the walk (inlined here).
    #[inline(never)]
    fn fill_fixed(
        &self,
        sc: &Scopes,
        values: &mut [u64; FILL_CAP],
        changes: &mut [u32; LIST_CAP],
        last: Last<'_>,
        shifts: bool,
    ) -> (usize, usize) {
        let a = Fixed { values, changes };
        self.fill(sc, Fill::new(a, last, true, shifts))
    }

    /// [`Machine::fill_fixed`] for [`Checked`] slices.
    #[inline(never)]
    fn fill_checked(
        &self,
        sc: &Scopes,
        values: &mut [u64],
        changes: &mut [u32],
        last: Last<'_>,
        filled_before: bool,
        shifts: bool,
    ) -> (usize, usize) {
        let a = Checked { values, changes };
        self.fill(sc, Fill::new(a, last, filled_before, shifts))
    }

    /// Walks `f` over every signal: the signals filled and the changes listed.
    #[inline(always)]
    fn fill<A: Arrays>(&self, sc: &Scopes, mut f: Fill<'_, A>) -> (usize, usize) {
        self.walk(sc, &mut f);
        (f.pos, f.listed)
    }

    /// Visits every signal in the waveform's order.
    #[inline(always)]
    fn walk<S: Sink>(&self, sc: &Scopes, p: &mut S) {
        // Two copies: with every unit shown (the tests of `Scopes::shown` compiled out, as
        // no scope filter costs anything) and with some left out.
        if sc.all_shown {
            self.walk_shown::<S, false>(sc, p)
        } else {
            self.walk_shown::<S, true>(sc, p)
        }
    }

    /// [`Machine::walk`], testing which units are shown when `FILTERED`. Each unit reports
    /// its own signals (`signals` and the like in its file); this walk orders them, skips
    /// what cannot have changed, and puts the links between them.
    #[inline(always)]
    fn walk_shown<S: Sink, const FILTERED: bool>(&self, sc: &Scopes, p: &mut S) {
        let now = self.cycle;
        let t = (self.scene.formats.t.bits(), self.scene.formats.t.frac_bits);
        let bundle = self.cfg.machine.job_source == crate::config::JobSource::Bundle;
        let balance = self.cfg.balance.enabled;
        if !FILTERED || sc.shown.memory {
            self.memory.signals(p, &sc.memory, now);
        }
        if !FILTERED || sc.shown.arbiter {
            self.memory.arbiter_signals(p, &sc.arbiter);
        }
        self.links
            .probe::<S, FILTERED>(p, Section::Arbiter, &sc.links);
        if balance && (!FILTERED || sc.shown.balancer) {
            self.balancer.signals(p, &sc.balancer);
        }
        // The scopes are looked up without an index (a filler uses none of them, and then
        // nothing is left of the lookups); `Scopes::new` made one per unit.
        for (c, (cl, cs)) in self.clusters.iter().zip(&sc.clusters).enumerate() {
            if balance && (!FILTERED || cs.shown.balance) {
                self.balancer.cluster_signals(p, &cs.balance, c);
            }
            if balance {
                self.links
                    .probe::<S, FILTERED>(p, Section::Balance(c), &sc.links);
            }
            if !FILTERED || cs.shown.patch_buffer {
                probe_link(p, &cs.patch_buffer, &cl.patch_buffer.store);
            }
            if !FILTERED || cs.shown.ray_buffer {
                probe_link(p, &cs.ray_buffer, &cl.ray_buffer.queue);
            }
            if bundle && (!FILTERED || cs.shown.ray_buffer) {
                cl.ray_buffer.bundle_signals(p, &cs.ray_buffer);
                if balance {
                    self.balancer.ray_buffer_signals(p, &cs.ray_buffer, c);
                }
            }
            if bundle {
                self.links
                    .probe::<S, FILTERED>(p, Section::BundleCluster(c), &sc.links);
            }
            for (j, (ctu, s)) in cl.ctus.iter().zip(&cs.ctus).enumerate() {
                // A finished CTU never ticks again: its signals are final; nor do they
                // change in a cycle it did not tick actively.
                let u = self.clusters.len() + c * cl.ctus.len() + j;
                let ticked = p.moved(c * cl.ctus.len() + j, ctu.active_cycles());
                let shown = !FILTERED || cs.shown.ctus.get(j).copied().unwrap_or(true);
                if shown
                    && !p.skip_quiet(u, ctu.is_finished(), Ctu::SIGNALS)
                    && !p.skip_unchanged(ticked, Ctu::SIGNALS)
                {
                    ctu.signals(p, s);
                }
                self.links
                    .probe::<S, FILTERED>(p, Section::Ctu(c, j), &sc.links);
                if bundle {
                    if shown {
                        ctu.bundle_signals(p, s);
                    }
                    self.links
                        .probe::<S, FILTERED>(p, Section::BundleCtu(c, j), &sc.links);
                }
            }
            if !FILTERED || cs.shown.icu {
                cl.icu.signals(p, &cs.icu);
            }
            if FILTERED && !cs.shown.stages {
                continue;
            }
            // Every stage's signals, all zero when empty; the first few move on a stage as
            // the pipeline advances.
            let depth = cl.icu.depth();
            let stages = Stages {
                cluster: c,
                position: cl.icu.ring_position(),
                stride: Icu::STAGE_SIGNALS,
                width: Icu::STAGE_MOVING,
                signals: Icu::STAGE_SIGNALS * depth,
            };
            if p.skip_quiet(c, cl.icu.is_empty(), stages.signals) {
                // Empty now and at the last sample: all zero still.
            } else if let shift @ (Shift::Held | Shift::Moved) = p.shift_stages(stages) {
                if shift == Shift::Moved {
                    // Stage 0's new job, the later stages moved, the result stage's t.
                    let stage = |k: usize| cs.stages.get(k).map_or("", String::as_str);
                    cl.icu.first_stage_signals(p, stage(0), t);
                    p.move_stages(stages);
                    cl.icu.result_t_signal(p, stage(depth - 1), t);
                }
            } else {
                // Every stage (t is shown in the result stage only: `for_each_stage` gives
                // it there alone). Walked here, not in a method of the ICU's walking the
                // stages itself: that cost the fill some 15 % more instructions (callgrind).
                let mut stages = cs.stages.iter();
                cl.icu.for_each_stage(|valid, ray, patch, v| {
                    let ss = stages.next().map_or("", String::as_str);
                    Icu::stage_job_signals(p, ss, valid, ray, patch);
                    Icu::stage_t_signal(p, ss, v, t);
                });
            }
        }
    }
}

/// Units whose signals the walk skips while they stay quiet ([`Sink::skip_quiet`]): each
/// cluster's ICU (numbers 0..clusters), then every CTU, cluster-major.
fn quiet_units(m: &Machine) -> usize {
    m.clusters.len() + m.clusters.iter().map(|c| c.ctus.len()).sum::<usize>()
}

/// The dotted scope names of every unit, built once per machine.
#[derive(Clone, Debug)]
pub(super) struct Scopes {
    memory: String,
    balancer: String,
    arbiter: String,
    clusters: Vec<ClusterScopes>,
    /// Which of these the probe keeps ([`crate::trace::Probe::wants`]), which links, and
    /// whether it keeps them all.
    shown: Shown,
    links: LinkShown,
    all_shown: bool,
}

/// Whether the probe keeps a unit's signals (any of its scopes), per unit.
#[derive(Clone, Copy, Debug)]
struct Shown {
    memory: bool,
    balancer: bool,
    arbiter: bool,
}

/// [`Shown`] for a cluster's units.
#[derive(Clone, Debug)]
struct ClusterShown {
    balance: bool,
    patch_buffer: bool,
    ray_buffer: bool,
    ctus: Vec<bool>,
    icu: bool,
    /// Any of the ICU's stages (they are walked together).
    stages: bool,
}

#[derive(Clone, Debug)]
struct ClusterScopes {
    balance: String,
    patch_buffer: String,
    ray_buffer: String,
    /// Per CTU (its links' scopes are the links' own, see links.rs).
    ctus: Vec<String>,
    icu: String,
    stages: Vec<String>,
    shown: ClusterShown,
}

impl Scopes {
    /// The scopes of `m`'s units, each shown when `wants` it.
    fn new(m: &Machine, wants: &dyn Fn(&str) -> bool) -> Self {
        let links = m.links.shown(wants);
        let k = m.cfg.machine.ctus_per_cluster as usize;
        let memory = "machine.memory";
        let balancer = "machine.balancer";
        let arbiter = "machine.memory.arbiter";
        let mut sc = Scopes {
            shown: Shown {
                memory: wants(memory),
                balancer: wants(balancer),
                arbiter: wants(arbiter),
            },
            memory: memory.into(),
            balancer: balancer.into(),
            arbiter: arbiter.into(),
            clusters: (0..m.clusters.len())
                .map(|c| {
                    let base = format!("machine.cluster_{c}");
                    let balance = format!("{base}.balance");
                    let patch_buffer = format!("{base}.patch_buffer");
                    let ray_buffer = format!("{base}.ray_buffer");
                    let ctus: Vec<String> = (0..k).map(|j| format!("{base}.ctu_{j}")).collect();
                    let icu = format!("{base}.icu");
                    let stages: Vec<String> = (0..m.clusters[c].icu.depth())
                        .map(|n| format!("{base}.icu.stage_{n}"))
                        .collect();
                    ClusterScopes {
                        shown: ClusterShown {
                            balance: wants(&balance),
                            patch_buffer: wants(&patch_buffer),
                            ray_buffer: wants(&ray_buffer),
                            ctus: ctus.iter().map(|s| wants(s)).collect(),
                            icu: wants(&icu),
                            stages: stages.iter().any(|s| wants(s)),
                        },
                        balance,
                        patch_buffer,
                        ray_buffer,
                        ctus,
                        icu,
                        stages,
                    }
                })
                .collect(),
            links,
            all_shown: false,
        };
        let Shown {
            memory,
            balancer,
            arbiter,
        } = sc.shown;
        sc.all_shown = memory
            && balancer
            && arbiter
            && sc.clusters.iter().all(|c| {
                let s = &c.shown;
                s.balance
                    && s.patch_buffer
                    && s.ray_buffer
                    && s.icu
                    && s.stages
                    && s.ctus.iter().all(|&x| x)
            })
            && sc.links.all();
        sc
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::KeepValues;

    /// Three stages of four signals (valid, ray, patch, t) at the last sample, and the ICU
    /// advanced since: its ring moved on, stage 0 now empty, the result stage's t 4.
    const LAST: [u64; 12] = [1, 7, 8, 0, 1, 5, 6, 0, 1, 5, 9, 3];
    const STAGES: Stages = Stages {
        cluster: 0,
        position: 1,
        stride: 4,
        width: 3,
        signals: 12,
    };

    /// Reports the advanced ICU to `f` as the walk does.
    fn advance<S: Sink>(f: &mut S) {
        assert_eq!(f.shift_stages(STAGES), Shift::Moved);
        Icu::stage_job_signals(f, "", 0, 0, 0);
        f.fixed_zero("", "t", 8, 0);
        f.move_stages(STAGES);
        f.fixed("", "t", 8, 0, 4);
    }

    /// A [`Fill`]'s arrays, the values [`LAST`]'s.
    fn arrays() -> (Vec<u64>, Vec<u32>) {
        let mut values = vec![0u64; FILL_CAP];
        values[..12].copy_from_slice(&LAST);
        (values, vec![0u32; LIST_CAP])
    }

    /// What one ICU (its ring at `ring`) showed at the last sample, no quiet unit nor CTU.
    fn last(ring: &mut [usize]) -> Last<'_> {
        Last {
            quiet: &mut [],
            ring,
            counts: &mut [],
            since: 0,
            pipelines: &[0],
        }
    }

    /// A [`Fill`] over `arrays()`, its probe shifting stages itself when `shifts`.
    fn fill<'a>(
        values: &'a mut [u64],
        changes: &'a mut [u32],
        ring: &'a mut [usize],
        shifts: bool,
    ) -> Fill<'a, Fixed<'a>> {
        let a = Fixed {
            values: values.try_into().expect("FILL_CAP values"),
            changes: changes.try_into().expect("LIST_CAP positions"),
        };
        Fill::new(a, last(ring), true, shifts)
    }

    /// The values after the move, and the positions that changed, ascending.
    const NEXT: [u64; 12] = [0, 0, 0, 0, 1, 7, 8, 0, 1, 5, 6, 4];
    const CHANGED: [u32; 7] = [0, 1, 2, 5, 6, 10, 11];

    #[test]
    fn fill_moves_an_advanced_icus_stages_listing_the_changes_ascending() {
        let mut ring = [0];
        let (mut values, mut changes) = arrays();
        let mut f = fill(&mut values, &mut changes, &mut ring, false);
        advance(&mut f);
        assert_eq!((f.pos, f.listed), (12, CHANGED.len()));
        assert_eq!(values[..12], NEXT);
        assert_eq!(changes[..CHANGED.len()], CHANGED);
    }

    #[test]
    fn a_checked_fill_moves_an_advanced_icus_stages_listing_the_changes_ascending() {
        let mut ring = [0];
        let mut values = LAST.to_vec();
        let mut changes = vec![0u32; 12];
        let a = Checked {
            values: &mut values,
            changes: &mut changes,
        };
        let mut f = Fill::new(a, last(&mut ring), true, false);
        advance(&mut f);
        assert_eq!((f.pos, f.listed), (12, CHANGED.len()));
        assert_eq!(values, NEXT);
        assert_eq!(changes[..CHANGED.len()], CHANGED);
    }

    /// With a probe that shifts stages itself, the fill lists its pipeline's entry ahead of
    /// stage 0's changes and leaves the later stages as they were;
    /// [`crate::trace::apply_changes`] on the last sample then gives the same values and the
    /// same changes, ascending.
    #[test]
    fn a_shifting_probe_gets_one_entry_that_expands_to_the_same_changes() {
        let mut ring = [0];
        let (mut values, mut changes) = arrays();
        let mut f = fill(&mut values, &mut changes, &mut ring, true);
        advance(&mut f);
        let listed = f.listed;
        assert_eq!(f.pos, 12);
        let pipe = Pipeline {
            at: 4,
            stride: 4,
            width: 3,
            later: 2,
        };
        // The pipeline's entry, stage 0's three changes (1, 7, 8 → 0), the result stage's t
        // (3 → 4).
        let want = [Pipeline::entry(0), 0, 1, 2, 11];
        assert_eq!(changes[..listed], want);
        // Stages 1 and 2 (but t) untouched here.
        assert_eq!(values[4..11], LAST[4..11]);
        let mut last = LAST.to_vec();
        let entries = changes[..listed]
            .iter()
            .map(|&c| (c as u64, values.get(c as usize).copied().unwrap_or(0)));
        let mut got = Listed(&mut last, Vec::new(), vec![pipe]);
        crate::trace::apply_changes(&mut got, entries).expect("well formed");
        let got = got.1;
        assert_eq!(last, NEXT);
        assert_eq!(got, CHANGED);
    }

    /// The values, and the positions changed, in the order given; the declared pipelines.
    struct Listed<'a>(&'a mut [u64], Vec<u32>, Vec<Pipeline>);

    impl crate::trace::ChangeSink for Listed<'_> {
        type Error = crate::trace::BadShift;
        fn last(&mut self) -> &mut [u64] {
            self.0
        }
        fn pipeline(&self, k: usize) -> Option<Pipeline> {
            self.2.get(k).copied()
        }
        fn change(&mut self, i: usize, _: u64) -> Result<(), Self::Error> {
            self.1.push(i as u32);
            Ok(())
        }
    }

    /// A pipeline's entry whose pipeline is not declared, or does not lie inside the values,
    /// is an error, not a panic; so is a position outside them.
    #[test]
    fn a_shift_outside_the_values_is_an_error() {
        let pipes = [Pipeline {
            at: 4,
            stride: 4,
            width: 3,
            later: 8,
        }];
        let mut last = vec![0u64; 12];
        let (inside, undeclared) = (Pipeline::entry(0), Pipeline::entry(1));
        for (entry, bad) in [
            ((inside as u64, 0), inside),
            ((undeclared as u64, 0), undeclared),
            ((12, 1), 12),
        ] {
            let r = crate::trace::apply_changes(&mut KeepValues(&mut last, &pipes), [entry]);
            assert_eq!(r, Err(crate::trace::BadShift(bad)));
        }
        let mut longer = vec![0u64; 40];
        let r =
            crate::trace::apply_changes(&mut KeepValues(&mut longer, &pipes), [(inside as u64, 0)]);
        assert_eq!(r, Ok(()));
    }
}
