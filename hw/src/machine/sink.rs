//! What the machine's waveform walk (probe.rs) reports each signal to: the [`Sink`] trait,
//! implemented by the layout's collector and the value fillers, and called by every unit
//! and link that draws its signals — each unit names its own in its file (`Ctu::signals`,
//! `Icu::stage_job_signals`, `Memory::signals`, …, each with the count it emits beside it; links
//! through links.rs' `probe_link`), without knowing the probe. [`Count`] counts what an
//! emitter reports (the units' tests check their counts with it).

/// What the walk reports a signal to: the layout (first sample) or the value array.
pub(crate) trait Sink {
    /// An unsigned value of `width` bits.
    fn bits(&mut self, scope: &str, name: &'static str, width: u32, value: u64);
    /// An FSM state: `index` into `names`.
    fn text(&mut self, scope: &str, name: &'static str, names: &'static [&'static str], index: u64);
    /// A signed fixed-point value (raw) with `frac` fractional bits in `width` bits.
    fn fixed(&mut self, scope: &str, name: &'static str, width: u32, frac: u32, raw: i64);
    /// The next `n` signals are unit `u`'s (its number among the units the walk asks this
    /// of: see probe.rs' `quiet_units`), unchanging while `quiet` (an empty ICU's stages, all zero; a
    /// finished CTU's, final): a filler skips them, leaving them as they are, when the unit
    /// was quiet at the last sample too. True when skipped (the walk then reports none).
    fn skip_quiet(&mut self, u: usize, quiet: bool, n: usize) -> bool {
        let _ = (u, quiet, n);
        false
    }
    /// A fixed-point signal that is zero at every sample (a stage's t before the result
    /// stage): a filler leaves its value, zero from the start, as it is.
    fn fixed_zero(&mut self, scope: &str, name: &'static str, width: u32, frac: u32) {
        self.fixed(scope, name, width, frac, 0);
    }
    /// An ICU's stages, next ([`Stages`]): the first `width` signals of each stage move on
    /// to the next stage when the pipeline advances — which it did since the last sample
    /// exactly when its ring's `position` moved (one cycle apart: a cycle jump
    /// needs every ICU empty). A filler holding the last sample's values does the shift
    /// itself ([`Shift::Moved`]: it keeps stage 0's moving signals as they were, the walk
    /// reports stage 0, [`Sink::move_stages`] moves the later stages, the walk reports the
    /// result stage's t) or, the ring unmoved, skips them all ([`Shift::Held`]: a stall
    /// changes nothing). For a probe that shifts stages itself, a filler lists the entry of
    /// the ICU's `Pipeline` (declared once with the layout, which the layout's collector
    /// records here) instead of keeping stage 0's values, and leaves the later stages as
    /// they are.
    fn shift_stages(&mut self, stages: Stages) -> Shift {
        let _ = stages;
        Shift::Walk
    }
    /// After [`Shift::Moved`] and stage 0, at stage 1: each later stage's first `width`
    /// signals take the stage before it as it was at the last sample, stage 1 first (so
    /// the positions stay ascending), up to the result stage's signal `width` (its t).
    /// Nothing reported.
    fn move_stages(&mut self, stages: Stages) {
        let _ = stages;
    }
    /// True when `count`, a counter of unit `u` (its number among the units the walk asks
    /// this of: every CTU, cluster-major) that moves whenever the unit's signals may change
    /// (`Ctu::active_cycles`), differs from its value at the last sample: a filler records
    /// it (the model keeps no flag for the waveform). True unless a filler knows better.
    fn moved(&mut self, u: usize, count: u64) -> bool {
        let _ = (u, count);
        true
    }
    /// True when `stamp`, a link's last touched edge (`Link::stamp`), is past
    /// the last sample: its signals may have changed. True unless a filler knows better.
    fn link_moved(&mut self, stamp: u64) -> bool {
        let _ = stamp;
        true
    }
    /// The next `n` signals are a unit's whose values can have changed since the last sample
    /// only when `changed` (a link whose stamp [`Sink::link_moved`]; a CTU whose
    /// counter [`Sink::moved`]): a filler skips them when not, leaving the last sample's
    /// values, once it has filled the array at least once. True when skipped.
    fn skip_unchanged(&mut self, changed: bool, n: usize) -> bool {
        let _ = (changed, n);
        false
    }
}

/// An ICU's stages as [`Sink::shift_stages`] is told of them: cluster `cluster`'s, its ring at
/// `position`, `signals` in all, `stride` a stage of which the first `width` move on.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Stages {
    pub cluster: usize,
    pub position: usize,
    pub stride: usize,
    pub width: usize,
    pub signals: usize,
}

/// What [`Sink::shift_stages`] did with an ICU's stages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Shift {
    /// Nothing: the walk reports every stage.
    Walk,
    /// The ring did not move: every stage as it was, all skipped.
    Held,
    /// The ring moved (stage 0's moving values kept): the walk reports stage 0, has the
    /// later stages take the stages before them ([`Sink::move_stages`]), and reports t.
    Moved,
}

/// Counts the signals reported to it (a unit's emitter checked against its count).
#[cfg(test)]
#[derive(Debug, Default)]
pub(crate) struct Count(pub usize);

#[cfg(test)]
impl Sink for Count {
    fn bits(&mut self, _: &str, _: &'static str, _: u32, _: u64) {
        self.0 += 1;
    }
    fn text(&mut self, _: &str, _: &'static str, _: &'static [&'static str], _: u64) {
        self.0 += 1;
    }
    fn fixed(&mut self, _: &str, _: &'static str, _: u32, _: u32, _: i64) {
        self.0 += 1;
    }
}
