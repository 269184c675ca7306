//! The trace interface: units describe their signals to a [`Probe`] after each clock edge.
//! The host's VCD writer implements it; hw/ knows nothing of files or formats.

/// Receives signal values. Scopes are dot-separated unit paths ("machine.cluster_0.icu");
/// the set of (scope, name, width) a unit reports never changes between calls.
pub trait Probe {
    /// The cycle the following values belong to (called first, once per sample).
    fn cycle(&mut self, t: u64);
    /// An unsigned value of `width` bits (at most 64).
    fn bits(&mut self, scope: &str, name: &str, width: u32, value: u64);
    /// A string (FSM state names).
    fn text(&mut self, scope: &str, name: &str, value: &str);
    /// A fixed-point value (raw bits, signed) with `frac` fractional bits — shown as a
    /// decimal in the viewer through its fixed-point shift.
    fn fixed(&mut self, scope: &str, name: &str, width: u32, frac: u32, raw: i64);
    /// True when the probe cannot go on (a waveform past its size limit): the machine then
    /// ends the run early and the caller reports the probe's error.
    fn stop(&self) -> bool {
        false
    }
}

/// A probe that records nothing (for runs without a waveform).
pub struct NoProbe;

impl Probe for NoProbe {
    fn cycle(&mut self, _: u64) {}
    fn bits(&mut self, _: &str, _: &str, _: u32, _: u64) {}
    fn text(&mut self, _: &str, _: &str, _: &str) {}
    fn fixed(&mut self, _: &str, _: &str, _: u32, _: u32, _: i64) {}
}
