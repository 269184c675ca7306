//! The untimed fixed-point model: the hardware's right answer, bit for bit. Per ray, the
//! nearest hit by brute force over all patch records, or by the CTU's exact fixed-point DDA
//! over the cell table; the two agree exactly.

use crate::datapath::dda::FixedDda;
use crate::datapath::format::Formats;
use crate::datapath::record::{CellTable, PatchRecord, RayRecord};
use crate::datapath::{compare, intersect, Exceptions, FixedHit};

/// Slack of the grid variant's stopping rule, in t LSBs: it stops once the next cell starts
/// beyond best t + this. The interpolated hit point lies within ~2 LSBs of its polygon
/// (rounding points A and B), so a nearer hit can only sit in a cell entered before that.
pub const STOP_SLACK_T_LSB: i64 = 8;

/// A scene in hardware form.
#[derive(Clone, Debug)]
pub struct FixedScene {
    pub formats: Formats,
    pub patches: Vec<PatchRecord>,
    pub cells: CellTable,
    /// Per patch, the patches its rays pass through besides itself (its coplanar twins,
    /// found by the host): excluded with it as the source, never loaded for it.
    pub twins: Vec<Vec<u32>>,
}

/// Work counted by one grid walk.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WalkCounts {
    pub cells: u32,
    pub tests: u32,
}

impl FixedScene {
    /// The twins of `source`, which its rays pass through (empty for none).
    pub fn twins_of(&self, source: Option<u32>) -> &[u32] {
        source
            .and_then(|s| self.twins.get(s as usize))
            .map_or(&[], Vec::as_slice)
    }

    /// Nearest hit by testing every patch record except `exclude`.
    pub fn nearest_brute(
        &self,
        r: &RayRecord,
        exclude: Option<u32>,
        exc: &mut Exceptions,
    ) -> Option<FixedHit> {
        let mut best = None;
        let twins = self.twins_of(exclude);
        for p in &self.patches {
            if Some(p.id) == exclude || twins.contains(&p.id) {
                continue;
            }
            if let Some(h) = intersect(r, p, &self.formats, exc) {
                compare(&mut best, h);
            }
        }
        best
    }

    /// Nearest hit by the fixed-point DDA over the cell table; equal to `nearest_brute`.
    pub fn nearest_grid(
        &self,
        r: &RayRecord,
        exclude: Option<u32>,
        exc: &mut Exceptions,
    ) -> (Option<FixedHit>, WalkCounts) {
        let mut counts = WalkCounts::default();
        let Some(mut dda) = FixedDda::new(&self.cells, r) else {
            return (None, counts);
        };
        let tf = self.formats.t.frac_bits;
        let twins = self.twins_of(exclude);
        let mut best: Option<FixedHit> = None;
        loop {
            counts.cells += 1;
            for &id in self.cells.patches_in(self.cells.index(dda.c)) {
                if Some(id) == exclude || (!twins.is_empty() && twins.contains(&id)) {
                    continue;
                }
                counts.tests += 1;
                if let Some(h) = intersect(r, &self.patches[id as usize], &self.formats, exc) {
                    compare(&mut best, h);
                }
            }
            if let Some(b) = best {
                if dda.exit_beyond(b.t + STOP_SLACK_T_LSB, tf) {
                    break;
                }
            }
            if !dda.step() {
                break;
            }
        }
        (best, counts)
    }
}
