//! The trace interface: the machine declares its signals and its pipelines to a [`Probe`]
//! once, then hands it one flat array of values per sample (after each clock edge), with the
//! positions that changed since the last — for a probe that asks, with one entry naming a
//! declared [`Pipeline`] per pipeline that advanced, in place of its later stages' changes,
//! which [`apply_changes`] expands. The host's waveform writers implement it; hw/ knows
//! nothing of files or formats.

/// How a signal's value is to be read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SignalKind {
    /// An unsigned value.
    Bits,
    /// An FSM state: the value is an index into these names.
    Text(&'static [&'static str]),
    /// A signed fixed-point value with `frac` fractional bits, as its raw two's-complement
    /// bits in `width` — shown as a decimal in the viewer through its fixed-point shift.
    Fixed { frac: u32 },
}

/// One signal of the layout. Its position in the layout is its id: the value at that index
/// of every sample.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SignalDecl {
    /// Dot-separated unit path ("machine.cluster_0.icu").
    pub scope: String,
    pub name: &'static str,
    /// Width in bits (1..=64; a text signal declares 1).
    pub width: u32,
    pub kind: SignalKind,
}

/// Receives the machine's signals: the layout once, then the values of every sample.
pub trait Probe {
    /// The layout, called once before the first sample: the signals, and the pipelines
    /// whose later stages a probe that [`Probe::shifts_stages`] moves itself (each
    /// [`Pipeline::fits`], inside the signals; the entry [`Pipeline::entry`]`(k)` in a change
    /// list says `pipelines[k]` advanced).
    fn declare(&mut self, signals: &[SignalDecl], pipelines: &[Pipeline]);
    /// The values at cycle `t` (strictly increasing), one per declared signal, each masked
    /// to its width (a text signal's value is its name's index).
    fn sample(&mut self, t: u64, values: &[u64]);
    /// The values at cycle `t` as [`Probe::sample`] takes them, with `changed`: the
    /// positions, ascending, whose value differs from the previous sample's (at the first
    /// sample, those not zero; with [`Probe::shifts_stages`], also [`Pipeline::entry`]s).
    /// A probe that keeps the values of the samples it saw writes
    /// only these; the default hands `values` to [`Probe::sample`]. The machine calls this
    /// one, having found the changes while filling the array.
    fn sample_changes(&mut self, t: u64, values: &[u64], changed: &[u32]) {
        let _ = changed;
        self.sample(t, values);
    }
    /// True when the probe moves an advanced pipeline's later stages itself (the same answer
    /// for the whole run): [`Probe::sample_changes`]'s lists then hold one entry naming the
    /// declared pipeline in place of their changes (apply a list with [`apply_changes`]), and
    /// `values` is not kept at their positions; an undeclared pipeline's changes are listed
    /// as any signal's. It saves the machine a put per moving signal of every later stage of
    /// every advanced pipeline, and the hand-off of their changes.
    fn shifts_stages(&self) -> bool {
        false
    }
    /// True when the probe keeps some signals of `scope` (a dotted unit path): the machine
    /// neither declares nor samples a unit none of whose scopes it keeps, so signals filtered
    /// out cost nothing per cycle. Asked once per scope, before the layout is declared; a
    /// probe still gets the whole of a unit one of whose scopes it keeps (an ICU's stages go
    /// together), and drops the rest itself.
    fn wants(&self, scope: &str) -> bool {
        let _ = scope;
        true
    }
    /// True when the probe cannot go on (a waveform past its size limit): the machine then
    /// ends the run early and the caller reports the probe's error.
    fn stop(&self) -> bool {
        false
    }
}

/// A probe that records nothing (for runs without a waveform).
pub struct NoProbe;

impl Probe for NoProbe {
    fn declare(&mut self, _: &[SignalDecl], _: &[Pipeline]) {}
    fn sample(&mut self, _: u64, _: &[u64]) {}
}

/// The flag of a change-list entry that names an advanced [`Pipeline`], not a position
/// (positions are below it).
pub const STAGE_SHIFT: u32 = 1 << 31;

/// A pipeline, declared once with the signals ([`Probe::declare`]): stage k (0..=`later`)
/// starts at `at + (k − 1)·stride`, and when the pipeline advances, the first `width`
/// signals of each later stage take the values the stage before had at the last sample. A
/// probe that shifts stages gets the entry [`Pipeline::entry`] for it, before stage 0's
/// changes (it needs stage 0's last values); the shift's changes go before the first
/// position at or past `at` (ascending order kept).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pipeline {
    /// Position of stage 1's first signal.
    pub at: usize,
    /// Signals per stage.
    pub stride: usize,
    /// Signals of a stage that move (1..=[`SHIFT_WIDTH`], at most `stride`).
    pub width: usize,
    /// Stages after stage 0 (at least 1, spanning at most [`SHIFT_SPAN`] positions).
    pub later: usize,
}

/// The most signals a stage moves in a [`Pipeline`].
pub const SHIFT_WIDTH: usize = 4;

/// The most positions a [`Pipeline`]'s shift spans, stage 1's first to the last stage's last
/// moving signal (a mask of its changes is one `u64`).
pub const SHIFT_SPAN: usize = 64;

/// A change-list entry that is not well formed: a position outside the layout, or a
/// pipeline not declared or not inside it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BadShift(pub u32);

impl std::fmt::Display for BadShift {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "a change-list entry {:#x} outside the layout", self.0)
    }
}

impl std::error::Error for BadShift {}

impl From<BadShift> for std::io::Error {
    fn from(e: BadShift) -> Self {
        std::io::Error::other(e)
    }
}

impl Pipeline {
    /// True when a probe can move its stages from one entry: at most [`SHIFT_WIDTH`] moving
    /// signals a stage, at least one later stage, at most [`SHIFT_SPAN`] positions moved,
    /// stage 0 inside the layout.
    pub fn fits(&self) -> bool {
        self.stride > 0
            && (1..=SHIFT_WIDTH.min(self.stride)).contains(&self.width)
            && self.later >= 1
            && self.span() <= SHIFT_SPAN
            && self.at >= self.stride
    }

    /// True when it [`Pipeline::fits`] and its shifted stages lie inside `n` values.
    pub fn fits_in(&self, n: usize) -> bool {
        self.fits() && self.at + self.span() <= n
    }

    /// The change-list entry that says declared pipeline number `k` advanced.
    #[inline(always)]
    pub fn entry(k: u32) -> u32 {
        STAGE_SHIFT | k
    }

    /// Positions from stage 1's first to the last stage's last moving signal.
    #[inline(always)]
    pub fn span(&self) -> usize {
        self.later.saturating_sub(1) * self.stride + self.width
    }

    /// Stage 0's moving values in `last` (to be taken before stage 0's changes).
    #[inline]
    fn carry(&self, last: &[u64]) -> [u64; SHIFT_WIDTH] {
        let mut c = [0; SHIFT_WIDTH];
        let at = self.at - self.stride;
        c[..self.width].copy_from_slice(&last[at..at + self.width]);
        c
    }
}

/// What takes a sample's changes from [`apply_changes`]: the last sample's values, kept
/// here, and each change in turn.
pub trait ChangeSink {
    type Error: From<BadShift>;
    /// The last sample's values (as the changes so far left them).
    fn last(&mut self) -> &mut [u64];
    /// Declared pipeline number `k` ([`Probe::declare`]).
    fn pipeline(&self, k: usize) -> Option<Pipeline>;
    /// Position `i` changed to `v` (already stored in [`ChangeSink::last`]).
    fn change(&mut self, i: usize, v: u64) -> Result<(), Self::Error>;
}

/// Applies a sample's change list to `sink`: each entry (a position and its new value, or a
/// [`Pipeline::entry`] and any value) in turn, every changed position handed to
/// [`ChangeSink::change`] with its new value, ascending. A shift is expanded in place: its
/// changes before the first position at or past its `at` (or at the end). An entry outside
/// the values is an error ([`BadShift`]). Past one compare a plain position costs what it
/// did before shifts: the shifts are taken out of line.
#[inline(always)]
pub fn apply_changes<S: ChangeSink>(
    sink: &mut S,
    entries: impl IntoIterator<Item = (u64, u64)>,
) -> Result<(), S::Error> {
    // The first position that needs more than a store: a pipeline's entry (flagged entries
    // are all past it) or, one pending, its `at`.
    let mut next = STAGE_SHIFT as u64;
    let mut pending = None;
    for (i, v) in entries {
        if i >= next {
            if let Some(p) = pending.take() {
                shift(sink, p)?;
                next = STAGE_SHIFT as u64;
            }
            if i >= next {
                let p = start_shift(sink, i)?;
                next = p.0.at as u64;
                pending = Some(p);
                continue;
            }
        }
        let Some(x) = sink.last().get_mut(i as usize) else {
            return Err(BadShift(i as u32).into());
        };
        *x = v;
        sink.change(i as usize, v)?;
    }
    match pending {
        Some(p) => shift(sink, p),
        None => Ok(()),
    }
}

/// The declared pipeline entry `code` names, inside `sink`'s values, with stage 0's last
/// values.
#[inline(never)]
fn start_shift<S: ChangeSink>(
    sink: &mut S,
    code: u64,
) -> Result<(Pipeline, [u64; SHIFT_WIDTH]), BadShift> {
    let code = u32::try_from(code).unwrap_or(u32::MAX);
    let last = sink.last().len();
    let p = sink
        .pipeline((code & !STAGE_SHIFT) as usize)
        .filter(|p| p.fits_in(last))
        .ok_or(BadShift(code))?;
    Ok((p, p.carry(sink.last())))
}

/// Moves a shift's later stages in `sink`'s values, stage 0's last values into stage 1 and
/// so on (one tight pass noting the changed positions in a mask: a shift spans at most
/// [`SHIFT_SPAN`] positions), then hands each change to [`ChangeSink::change`], ascending.
#[inline(never)]
fn shift<S: ChangeSink>(
    sink: &mut S,
    (s, mut carry): (Pipeline, [u64; SHIFT_WIDTH]),
) -> Result<(), S::Error> {
    // Stages of at most four signals whose later stages lie whole inside the values: one
    // pass of whole stages, the carry in registers.
    if s.stride <= SHIFT_WIDTH {
        if let Some(w) = sink.last().get_mut(s.at..s.at + s.stride * s.later) {
            let mask = match (s.width, s.stride) {
                (1, 1) => move_whole::<1, 1>(w, &carry),
                (1, 2) => move_whole::<1, 2>(w, &carry),
                (2, 2) => move_whole::<2, 2>(w, &carry),
                (1, 3) => move_whole::<1, 3>(w, &carry),
                (2, 3) => move_whole::<2, 3>(w, &carry),
                (3, 3) => move_whole::<3, 3>(w, &carry),
                (1, 4) => move_whole::<1, 4>(w, &carry),
                (2, 4) => move_whole::<2, 4>(w, &carry),
                (3, 4) => move_whole::<3, 4>(w, &carry),
                _ => move_whole::<4, 4>(w, &carry),
            };
            return each_set(sink, s.at, mask);
        }
    }
    let Some(w) = sink.last().get_mut(s.at..s.at + s.span()) else {
        return Err(BadShift(s.at as u32).into());
    };
    let mask = match s.width {
        1 => move_stages::<1>(w, &mut carry, s.later, s.stride),
        2 => move_stages::<2>(w, &mut carry, s.later, s.stride),
        3 => move_stages::<3>(w, &mut carry, s.later, s.stride),
        _ => move_stages::<SHIFT_WIDTH>(w, &mut carry, s.later, s.stride),
    };
    each_set(sink, s.at, mask)
}

/// Hands each position `at + b` whose bit b is set in `mask`, ascending, to `sink` with its
/// value.
#[inline(always)]
fn each_set<S: ChangeSink>(sink: &mut S, at: usize, mut mask: u64) -> Result<(), S::Error> {
    while mask != 0 {
        let p = at + mask.trailing_zeros() as usize;
        mask &= mask - 1;
        let v = sink.last()[p];
        sink.change(p, v)?;
    }
    Ok(())
}

/// [`move_stages`] for `w` the later stages whole, `S` signals a stage of which the first
/// `W` move: the carry in registers, no bound check per signal (the positions a
/// [`Pipeline`] that fits moves are below [`SHIFT_SPAN`], so the mask holds them).
#[inline(always)]
fn move_whole<const W: usize, const S: usize>(w: &mut [u64], carry: &[u64; SHIFT_WIDTH]) -> u64 {
    let mut c = [0u64; W];
    c.copy_from_slice(&carry[..W]);
    let mut mask = 0u64;
    for (k, st) in w.as_chunks_mut::<S>().0.iter_mut().enumerate() {
        let mut m = 0u64;
        for j in 0..W {
            let old = std::mem::replace(&mut st[j], c[j]);
            m |= ((old != c[j]) as u64) << j;
            c[j] = old;
        }
        mask |= m << (S * k);
    }
    mask
}

/// Moves `later` stages of `stride` signals in `w` (stage 1 first), the first `W` of each
/// taking the stage before's (`carry`: stage 0's): the mask of the positions changed.
#[inline(always)]
fn move_stages<const W: usize>(
    w: &mut [u64],
    carry: &mut [u64; SHIFT_WIDTH],
    later: usize,
    stride: usize,
) -> u64 {
    let mut c = [0u64; W];
    c.copy_from_slice(&carry[..W]);
    let (mut mask, mut bit) = (0u64, 1u64);
    for stage in w.chunks_mut(stride).take(later) {
        let Some(stage) = stage.get_mut(..W) else {
            break;
        };
        for j in 0..W {
            let old = std::mem::replace(&mut stage[j], c[j]);
            mask |= bit << j & 0u64.wrapping_sub((old != c[j]) as u64);
            c[j] = old;
        }
        bit <<= stride % 64;
    }
    mask
}

/// A [`ChangeSink`] that only keeps the values (and knows the declared pipelines).
pub struct KeepValues<'a>(pub &'a mut [u64], pub &'a [Pipeline]);

impl ChangeSink for KeepValues<'_> {
    type Error = BadShift;
    #[inline(always)]
    fn last(&mut self) -> &mut [u64] {
        self.0
    }
    #[inline(always)]
    fn pipeline(&self, k: usize) -> Option<Pipeline> {
        self.1.get(k).copied()
    }
    #[inline(always)]
    fn change(&mut self, _: usize, _: u64) -> Result<(), BadShift> {
        Ok(())
    }
}
