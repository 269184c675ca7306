//! The declared signals, format-free: each signal of the layout ([`Signal`], with an FSM's
//! state names in a [`Slot`]), the scope tree both formats declare them in, and what a
//! finished waveform holds ([`WaveSummary`]).

use super::options::Window;
use std::path::PathBuf;

/// How a signal is reported and shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SignalKind {
    /// An unsigned value.
    Bits,
    /// A string: an FSM state name, one of `states` names (a VCD string; in an FST the
    /// state's index in [`state_bits`] bits, named by an enum table).
    Text { states: u32 },
    /// Raw signed fixed point with `frac` fractional bits.
    Fixed { frac: u32 },
}

/// A declared signal.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Signal {
    /// The dotted scope, e.g. `machine.cluster_0.icu.stage_3`.
    pub scope: String,
    pub name: String,
    /// Width in bits (1 for strings, as VCD declares them).
    pub width: u32,
    pub kind: SignalKind,
}

impl Signal {
    /// The full dotted name as in the VCD's hierarchy: `machine.cluster_0.icu.stage_3.valid`.
    pub fn full_name(&self) -> String {
        format!("{}.{}", self.scope, self.name)
    }

    /// A fixed-point signal's range with its binary point, `(msb, lsb)` = `(w-1-frac, -frac)`
    /// (`t[2:-12]` for 15 bits with 12 fractional): the FST declares it in the name, so a
    /// viewer reading the range (Surfer, through wellen) scales the value. None for others.
    pub fn fixed_range(&self) -> Option<(i64, i64)> {
        match self.kind {
            SignalKind::Fixed { frac } => {
                Some((self.width as i64 - 1 - frac as i64, -(frac as i64)))
            }
            _ => None,
        }
    }

    /// True when declared as a vector (`wire` wider than one bit, with a `[w-1:0]` range).
    pub fn is_vector(&self) -> bool {
        !matches!(self.kind, SignalKind::Text { .. }) && self.width > 1
    }
}

/// The bits an FSM state of `states` names takes in an FST: room for every index and one
/// more, the enum table's "-" (any other value); at least one.
pub fn state_bits(states: u32) -> u32 {
    (u32::BITS - states.leading_zeros()).max(1)
}

/// What a finished waveform (VCD or FST) holds.
#[derive(Clone, Debug)]
pub struct WaveSummary {
    /// Where it was written.
    pub path: PathBuf,
    /// The declared signals, in declaration order (scope tree, first seen first).
    pub signals: Vec<Signal>,
    pub window: Window,
    /// Samples seen (one per simulated cycle), including those outside the window.
    pub samples: u64,
    /// Time changes written (a VCD's `#t` lines).
    pub timestamps: u64,
    /// Size of the file in bytes.
    pub bytes: u64,
}

/// One signal of the probe's layout (position = its index), as the header declares it.
#[derive(Clone, Debug)]
pub(crate) struct Slot {
    pub(crate) sig: Signal,
    /// A text signal's names (whitespace as '_', empty as "-"), by value.
    pub(crate) names: Vec<String>,
}

/// A VCD string token: whitespace becomes '_', empty becomes "-".
pub(crate) fn token(s: &str) -> String {
    if s.is_empty() {
        "-".into()
    } else {
        s.chars()
            .map(|c| if c.is_whitespace() { '_' } else { c })
            .collect()
    }
}

/// A level of the scope tree: its variables (slot positions) and sub-scopes, each level's
/// children in first-seen order.
#[derive(Default)]
pub(crate) struct ScopeNode {
    pub(crate) name: String,
    pub(crate) vars: Vec<usize>,
    pub(crate) children: Vec<ScopeNode>,
}

impl ScopeNode {
    /// The tree of the slots at the positions `keep`.
    pub(crate) fn of(slots: &[Slot], keep: &[usize]) -> ScopeNode {
        let mut root = ScopeNode::default();
        for &i in keep {
            let mut node = &mut root;
            for part in slots[i].sig.scope.split('.') {
                node = node.child(part);
            }
            node.vars.push(i);
        }
        root
    }

    /// The child named `name`, added at the end if new.
    fn child(&mut self, name: &str) -> &mut ScopeNode {
        let i = match self.children.iter().position(|c| c.name == name) {
            Some(i) => i,
            None => {
                self.children.push(ScopeNode {
                    name: name.to_string(),
                    ..Default::default()
                });
                self.children.len() - 1
            }
        };
        &mut self.children[i]
    }
}
