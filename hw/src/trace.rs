//! The trace interface: the machine declares its signals to a [`Probe`] once, then hands it
//! one flat array of values per sample (after each clock edge), with the positions that
//! changed since the last. The host's waveform writers implement it; hw/ knows nothing of
//! files or formats.

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
    /// The layout, called once before the first sample.
    fn declare(&mut self, signals: &[SignalDecl]);
    /// The values at cycle `t` (strictly increasing), one per declared signal, each masked
    /// to its width (a text signal's value is its name's index).
    fn sample(&mut self, t: u64, values: &[u64]);
    /// The values at cycle `t` as [`Probe::sample`] takes them, with `changed`: the
    /// positions, ascending, whose value differs from the previous sample's (at the first
    /// sample, those not zero). A probe that keeps the values of the samples it saw writes
    /// only these; the default hands `values` to [`Probe::sample`]. The machine calls this
    /// one, having found the changes while filling the array.
    fn sample_changes(&mut self, t: u64, values: &[u64], changed: &[u32]) {
        let _ = changed;
        self.sample(t, values);
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
    fn declare(&mut self, _: &[SignalDecl]) {}
    fn sample(&mut self, _: u64, _: &[u64]) {}
}
