//! The CTU's fixed-point 3D-DDA: exact integer accumulators, no division, no rounding.
//!
//! Per axis it keeps N_a, the distance (coordinate LSBs) from the origin to the next cell
//! boundary along the ray's direction, and D_a = |d_a|. The ray crosses that boundary at
//! t_a = N_a / D_a, so the next axis to step is the one with the least N_a/D_a, found by
//! exact cross-multiplication N_a·D_b < N_b·D_a. A step adds the cell size to N_a: exact,
//! so no error accumulates however long the walk. A zero direction component is the
//! saturating infinity: its t_a never wins (a flag in hardware). Ties step the lowest axis.
//!
//! **Past the grid's faces.** Where the ray leaves the grid through a face, the walk goes on
//! [`OVERSHOOT_LSB`] beyond that face's plane, stepping only along the other axes through
//! the boundary layer of cells. Why: the datapath tests the ray against the patches' rounded
//! ray-space images (rounding point A), which lie up to 1.5 LSB off the quantized patches,
//! and the ray record's direction differs from the rounded shear's by up to ~1 LSB over the
//! grid — across a scene's boundary wall, ~2.5 LSB, which a grazing ray covers far beyond
//! the point where its exact line leaves the grid. The boundary cells list those walls
//! (the cell table's margin, at least [`OVERSHOOT_LSB`]), so a ray that meets a boundary
//! wall only past the grid's face still finds it. A ray that hits a wall before leaving
//! stops as before unless another axis's boundary lies within the overshoot.

use crate::datapath::record::{CellTable, RayRecord};

/// How far (coordinate LSBs) the walk goes on past the grid face the ray leaves through.
pub const OVERSHOOT_LSB: i64 = 3;

/// The DDA state of one ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FixedDda {
    pub c: [u32; 3],
    dims: [u32; 3],
    step: [i8; 3],
    /// Distance to the next boundary per axis (coordinate LSBs).
    n: [i64; 3],
    /// |d_a| (direction LSBs); 0 is "never crosses".
    den: [i64; 3],
    cell_raw: i64,
    /// The current cell's entry t as the fraction num/den (0/1 for the first cell).
    entry_num: i64,
    entry_den: i64,
    /// Bit a: the ray has left the grid along axis a and walks the overshoot.
    pinned: u8,
}

/// A DDA's registers, every field visible: what the RTL step (hw/rtl/shellsim_dda.sv) reads
/// and writes, for the co-simulation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DdaRegs {
    pub c: [u32; 3],
    pub dims: [u32; 3],
    pub step: [i8; 3],
    pub n: [i64; 3],
    pub den: [i64; 3],
    pub cell_raw: i64,
    pub entry_num: i64,
    pub entry_den: i64,
    pub pinned: u8,
}

impl From<&FixedDda> for DdaRegs {
    fn from(d: &FixedDda) -> Self {
        DdaRegs {
            c: d.c,
            dims: d.dims,
            step: d.step,
            n: d.n,
            den: d.den,
            cell_raw: d.cell_raw,
            entry_num: d.entry_num,
            entry_den: d.entry_den,
            pinned: d.pinned,
        }
    }
}

impl From<DdaRegs> for FixedDda {
    fn from(r: DdaRegs) -> Self {
        FixedDda {
            c: r.c,
            dims: r.dims,
            step: r.step,
            n: r.n,
            den: r.den,
            cell_raw: r.cell_raw,
            entry_num: r.entry_num,
            entry_den: r.entry_den,
            pinned: r.pinned,
        }
    }
}

impl FixedDda {
    /// Starts at the cell holding the ray's origin; `None` when the origin is outside the
    /// grid (the host places every origin inside).
    pub fn new(cells: &CellTable, r: &RayRecord) -> Option<Self> {
        let cr = cells.cell_raw;
        let mut s = FixedDda {
            c: [0; 3],
            dims: cells.dims,
            step: [0; 3],
            n: [0; 3],
            den: [0; 3],
            cell_raw: cr,
            entry_num: 0,
            entry_den: 1,
            pinned: 0,
        };
        for a in 0..3 {
            let o = r.o[a];
            let hi = cells.dims[a] as i64 * cr;
            if o < 0 || o > hi {
                return None;
            }
            let c = (o / cr).min(cells.dims[a] as i64 - 1);
            s.c[a] = c as u32;
            let d = r.d[a];
            s.den[a] = d.abs();
            if d > 0 {
                s.step[a] = 1;
                s.n[a] = (c + 1) * cr - o;
            } else if d < 0 {
                s.step[a] = -1;
                s.n[a] = o - c * cr;
            }
        }
        Some(s)
    }

    /// The axis of the next step: least N_a/D_a, ties to the lowest axis; `None` if the
    /// direction is zero.
    #[inline]
    fn next_axis(&self) -> Option<usize> {
        let mut best: Option<usize> = None;
        for a in 0..3 {
            if self.den[a] == 0 {
                continue;
            }
            best = match best {
                None => Some(a),
                Some(b) => {
                    let lhs = self.n[a] as i128 * self.den[b] as i128;
                    let rhs = self.n[b] as i128 * self.den[a] as i128;
                    Some(if lhs < rhs { a } else { b })
                }
            };
        }
        best
    }

    /// True when the ray leaves the current cell beyond `t` (raw, `t_frac` fractional
    /// bits; direction and coordinates share `dir_frac` bits): exactly
    /// N_a / D_a > t, i.e. N_a·2^t_frac > t·D_a.
    #[inline]
    pub fn exit_beyond(&self, t: i64, t_frac: u32) -> bool {
        match self.next_axis() {
            None => true,
            Some(a) => ((self.n[a] as i128) << t_frac) > t as i128 * self.den[a] as i128,
        }
    }

    /// Steps to the next cell; false when the ray has left the grid (by the overshoot past
    /// the face it left through).
    #[inline]
    pub fn step(&mut self) -> bool {
        // At most one pass per axis pinned: the loop ends.
        loop {
            let Some(a) = self.next_axis() else {
                return false;
            };
            if self.pinned & (1 << a) != 0 {
                // The overshoot's depth past the face is reached.
                return false;
            }
            let c = self.c[a] as i64 + self.step[a] as i64;
            if c < 0 || c >= self.dims[a] as i64 {
                // Leaving through a face: axis a's next crossing is the overshoot's depth.
                self.pinned |= 1 << a;
                self.n[a] += OVERSHOOT_LSB;
                continue;
            }
            self.c[a] = c as u32;
            self.entry_num = self.n[a];
            self.entry_den = self.den[a];
            self.n[a] += self.cell_raw;
            return true;
        }
    }

    /// True when the current cell is entered at or beyond `t` (raw, `t_frac` fractional
    /// bits): exactly num/den ≥ t.
    #[inline]
    pub fn entry_at_or_beyond(&self, t: i64, t_frac: u32) -> bool {
        ((self.entry_num as i128) << t_frac) >= t as i128 * self.entry_den as i128
    }

    /// True when the current cell is entered beyond `t`: num/den > t.
    #[inline]
    pub fn entry_beyond(&self, t: i64, t_frac: u32) -> bool {
        ((self.entry_num as i128) << t_frac) > t as i128 * self.entry_den as i128
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(n: u32, cell: i64) -> CellTable {
        let cells = (n * n * n) as usize;
        CellTable {
            dims: [n; 3],
            cell_raw: cell,
            first: vec![0; cells],
            count: vec![0; cells],
            ids: vec![],
        }
    }

    #[test]
    fn a_diagonal_ray_visits_a_staircase_and_ends() {
        let f = crate::config::paper().datapath.formats().unwrap();
        let t = table(4, 16);
        // Direction (2, 1, 0): crosses x twice as often as y; z never.
        let r = RayRecord::new(0, [1, 1, 5], [2 << 10, 1 << 10, 0], &f);
        let mut d = FixedDda::new(&t, &r).unwrap();
        let mut path = vec![d.c];
        while d.step() {
            path.push(d.c);
            assert!(path.len() < 20, "endless walk");
        }
        // Every step moves one cell along one axis; z never changes.
        for w in path.windows(2) {
            let moved: u32 = (0..3).map(|a| w[0][a].abs_diff(w[1][a])).sum();
            assert_eq!(moved, 1);
            assert_eq!(w[1][2], 0);
        }
        assert_eq!(path.first(), Some(&[0, 0, 0]));
        assert_eq!(path.last().unwrap()[0], 3);
    }

    #[test]
    fn exact_ties_step_the_lowest_axis_first() {
        let f = crate::config::paper().datapath.formats().unwrap();
        let t = table(4, 16);
        let r = RayRecord::new(0, [0, 0, 0], [1 << 10, 1 << 10, 1 << 10], &f);
        let mut d = FixedDda::new(&t, &r).unwrap();
        d.step();
        assert_eq!(d.c, [1, 0, 0]);
        d.step();
        assert_eq!(d.c, [1, 1, 0]);
        d.step();
        assert_eq!(d.c, [1, 1, 1]);
    }

    #[test]
    fn zero_direction_components_never_step() {
        let f = crate::config::paper().datapath.formats().unwrap();
        let t = table(4, 16);
        let r = RayRecord::new(0, [8, 8, 8], [0, 0, -(1 << 10)], &f);
        let mut d = FixedDda::new(&t, &r).unwrap();
        let mut n = 0;
        while d.step() {
            n += 1;
            assert_eq!((d.c[0], d.c[1]), (0, 0));
        }
        assert_eq!(n, 0, "starts in the bottom cell, steps straight out");
    }
}
