//! Uniform grid over the scene bounds: cell boundaries, binning by the inverse cell size, and
//! a sparse cell → patch table built with an exact polygon/box overlap test.
//!
//! **Invariant:** the cell of a coordinate `x` on an axis is the `i` with `b[i] <= x < b[i+1]`
//! (the last cell is closed), where `b[i] = lo + i / inv_cell` and `inv_cell = 1 / cell_size`.
//! Binning multiplies by `inv_cell` (20 exactly for the default 0.05) and then corrects by at
//! most one cell against those boundaries, so 0.15, 0.30, 0.35 land in cells 3, 6, 7 — not in
//! 2, 5, 6 as `x / 0.05` would put them.
//!
//! **Invariant:** a patch is listed in every cell whose closed box it touches (touching a face,
//! an edge or a corner counts). The overlap test is the separating-axis test for a convex
//! polygon against a box, conservative by [`OVERLAP_SLACK`] of a cell: it may list a patch that
//! misses a cell by less than that, never omits one that touches it.

use crate::error::short;
use crate::error::{Error, Result};
use crate::scene::{Aabb, Patch, Scene};
use glam::DVec3;
use std::path::Path;

/// Most cells a grid may have (512³): beyond this the cell table alone would be gigabytes.
pub const MAX_CELLS: usize = 1 << 27;

/// Conservative margin of the overlap test, as a fraction of the cell size.
pub const OVERLAP_SLACK: f64 = 1e-9;

/// A uniform grid with a sparse patch table (CSR: empty cells hold an empty range).
#[derive(Clone, Debug)]
pub struct Grid {
    /// Lower corner of cell (0,0,0).
    pub lo: DVec3,
    /// Cells per axis.
    pub dims: [usize; 3],
    /// The requested cell size.
    pub cell_size: f64,
    /// `1 / cell_size`: binning multiplies by this.
    pub inv_cell: f64,
    /// Cell boundaries per axis: `bounds[a][i] = lo[a] + i / inv_cell`, `i = 0..=dims[a]`.
    pub boundaries: [Vec<f64>; 3],
    /// The same boundaries in descending order, `boundaries_desc[a][k] =
    /// boundaries[a][dims[a] − k]`, so that a ray stepping down an axis reads its crossings
    /// front to back.
    boundaries_desc: [Vec<f64>; 3],
    /// `offsets[c]..offsets[c + 1]` indexes `ids` for cell `c` (x fastest, then y, then z).
    offsets: Vec<u32>,
    /// Patch ids of all cells, ascending within a cell.
    ids: Vec<u32>,
}

impl Grid {
    /// Builds the grid of `scene` with cells of `cell_size` (cubic cells).
    pub fn build(scene: &Scene, cell_size: f64) -> Result<Grid> {
        let mut g = Grid::empty(scene.bounds, cell_size)?;
        let n_cells = g.cell_count();
        // Two passes (count, then fill) so the table is exactly sized.
        let mut counts = vec![0u32; n_cells];
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        for (id, p) in scene.patches.iter().enumerate() {
            g.for_each_overlapping_cell(p, |c| {
                counts[c] += 1;
                pairs.push((c as u32, id as u32));
            });
        }
        let mut offsets = Vec::with_capacity(n_cells + 1);
        let mut acc = 0u32;
        offsets.push(0);
        for &c in &counts {
            acc += c;
            offsets.push(acc);
        }
        // Patches are visited in id order, so a stable sort by cell keeps ids ascending.
        pairs.sort_by_key(|&(c, _)| c);
        g.ids = pairs.into_iter().map(|(_, id)| id).collect();
        g.offsets = offsets;
        Ok(g)
    }

    /// A grid with no patches, covering `bounds`.
    pub fn empty(bounds: Aabb, cell_size: f64) -> Result<Grid> {
        let here = Path::new(crate::error::GRID);
        if !(cell_size.is_finite() && cell_size > 0.0) {
            return Err(Error::input(
                here,
                "cell size",
                format!(
                    "cell size {} must be a finite number above 0",
                    short(cell_size)
                ),
            ));
        }
        let inv_cell = 1.0 / cell_size;
        let ext = bounds.extent();
        let mut dims = [0usize; 3];
        for a in 0..3 {
            let cells = ext[a] * inv_cell;
            // An extent that is a whole number of cells up to rounding gets exactly that many.
            let n = if (cells - cells.round()).abs() < 1e-9 * cells.max(1.0) {
                cells.round()
            } else {
                cells.ceil()
            };
            if !(n >= 1.0 && n <= MAX_CELLS as f64) {
                return Err(Error::input(
                    here,
                    "cell size",
                    format!(
                        "cell size {} gives {} cells along axis {a}",
                        short(cell_size),
                        short(n)
                    ),
                ));
            }
            dims[a] = n as usize;
        }
        let total = dims[0] as u128 * dims[1] as u128 * dims[2] as u128;
        if total > MAX_CELLS as u128 {
            return Err(Error::input(
                here,
                "cell size",
                format!(
                    "cell size {} gives {}×{}×{} = {total} cells, more than {MAX_CELLS}",
                    short(cell_size),
                    dims[0],
                    dims[1],
                    dims[2]
                ),
            ));
        }
        let boundaries = [0, 1, 2].map(|a| {
            (0..=dims[a])
                .map(|i| bounds.lo[a] + i as f64 / inv_cell)
                .collect::<Vec<f64>>()
        });
        let boundaries_desc = [0, 1, 2].map(|a| boundaries[a].iter().rev().copied().collect());
        Ok(Grid {
            lo: bounds.lo,
            dims,
            cell_size,
            inv_cell,
            boundaries,
            boundaries_desc,
            offsets: vec![0; total as usize + 1],
            ids: Vec::new(),
        })
    }

    /// Number of cells.
    pub fn cell_count(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// Number of cells that hold at least one patch.
    pub fn nonempty_cells(&self) -> usize {
        self.offsets.windows(2).filter(|w| w[1] > w[0]).count()
    }

    /// Total (cell, patch) entries.
    pub fn entries(&self) -> usize {
        self.ids.len()
    }

    /// The grid's box (its upper corner may lie beyond the scene bounds when the extent is
    /// not a whole number of cells).
    pub fn aabb(&self) -> Aabb {
        Aabb {
            lo: self.lo,
            hi: DVec3::new(
                self.boundaries[0][self.dims[0]],
                self.boundaries[1][self.dims[1]],
                self.boundaries[2][self.dims[2]],
            ),
        }
    }

    /// The linear index of cell `(i, j, k)`.
    #[inline]
    pub fn index(&self, c: [usize; 3]) -> usize {
        c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])
    }

    /// Axis `a`'s boundaries in the order a ray crosses them: ascending when `up`, else
    /// descending.
    #[inline]
    pub(crate) fn boundaries_along(&self, a: usize, up: bool) -> &[f64] {
        if up {
            &self.boundaries[a]
        } else {
            &self.boundaries_desc[a]
        }
    }

    /// The patch ids listed in cell `c` (linear index), ascending.
    #[inline]
    pub fn patches_in(&self, c: usize) -> &[u32] {
        &self.ids[self.offsets[c] as usize..self.offsets[c + 1] as usize]
    }

    /// The cell coordinate of `x` on `axis`, clamped into the grid: multiply by the inverse
    /// cell size, then correct against the boundaries (see the module invariant).
    #[inline]
    pub fn coord(&self, axis: usize, x: f64) -> usize {
        let b = &self.boundaries[axis];
        let n = self.dims[axis];
        // floor(s) without a libm call: for 0 <= s < n truncation is the floor, and
        // floor(s) < 0 iff s < 0, floor(s) >= n iff s >= n; NaN goes to cell 0. (n is at
        // most MAX_CELLS, so the conversions go through i64, one instruction each.)
        let s = (x - self.lo[axis]) * self.inv_cell;
        let mut i = if s.is_nan() || s < 0.0 {
            0
        } else if s >= n as i64 as f64 {
            n - 1
        } else {
            s as i64 as usize
        };
        if i > 0 && x < b[i] {
            i -= 1;
        } else if i + 1 < n && x >= b[i + 1] {
            i += 1;
        }
        i
    }

    /// The closed box of cell `c`.
    pub fn cell_box(&self, c: [usize; 3]) -> Aabb {
        let b = &self.boundaries;
        Aabb {
            lo: DVec3::new(b[0][c[0]], b[1][c[1]], b[2][c[2]]),
            hi: DVec3::new(b[0][c[0] + 1], b[1][c[1] + 1], b[2][c[2] + 1]),
        }
    }

    /// Calls `f(linear cell index)` for every cell the patch touches, in index order.
    pub fn for_each_overlapping_cell(&self, p: &Patch, mut f: impl FnMut(usize)) {
        let mut lo = p.vertices[0];
        let mut hi = p.vertices[0];
        for v in &p.vertices[1..] {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
        // One cell of margin each side: a patch lying on a boundary touches both neighbours.
        let mut r0 = [0usize; 3];
        let mut r1 = [0usize; 3];
        for a in 0..3 {
            r0[a] = self.coord(a, lo[a]).saturating_sub(1);
            r1[a] = (self.coord(a, hi[a]) + 1).min(self.dims[a] - 1);
        }
        let normal = p.area_vector();
        for k in r0[2]..=r1[2] {
            for j in r0[1]..=r1[1] {
                for i in r0[0]..=r1[0] {
                    let c = [i, j, k];
                    if polygon_touches_box(&p.vertices, normal, &self.cell_box(c), self.cell_size) {
                        f(self.index(c));
                    }
                }
            }
        }
    }
}

/// Separating-axis test of a convex planar polygon against a closed box: the box axes, the
/// polygon's normal, and each polygon edge crossed with each box axis. Touching counts;
/// conservative by `OVERLAP_SLACK * cell` (see the module doc).
pub fn polygon_touches_box(poly: &[DVec3], normal: DVec3, b: &Aabb, cell: f64) -> bool {
    let c = 0.5 * (b.lo + b.hi);
    let h = 0.5 * (b.hi - b.lo);
    let slack = OVERLAP_SLACK * cell;
    let separated = |axis: DVec3| -> bool {
        let len = axis.length();
        if len == 0.0 {
            return false;
        }
        let r = h.x * axis.x.abs() + h.y * axis.y.abs() + h.z * axis.z.abs();
        let mid = axis.dot(c);
        let mut pmin = f64::INFINITY;
        let mut pmax = f64::NEG_INFINITY;
        for v in poly {
            let s = axis.dot(*v);
            pmin = pmin.min(s);
            pmax = pmax.max(s);
        }
        let tol = slack * len;
        pmin > mid + r + tol || pmax < mid - r - tol
    };
    for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
        if separated(axis) {
            return false;
        }
    }
    if separated(normal) {
        return false;
    }
    for i in 0..poly.len() {
        let e = poly[(i + 1) % poly.len()] - poly[i];
        for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
            if separated(e.cross(axis)) {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> Aabb {
        Aabb {
            lo: DVec3::ZERO,
            hi: DVec3::ONE,
        }
    }

    #[test]
    fn binning_multiplies_by_the_inverse() {
        let g = Grid::empty(unit(), 0.05).unwrap();
        assert_eq!(g.dims, [20, 20, 20]);
        assert_eq!(g.inv_cell, 20.0);
        // x / 0.05 would put these one cell low.
        assert_eq!((0.15f64 / 0.05).floor(), 2.0);
        assert_eq!(g.coord(0, 0.15), 3);
        assert_eq!(g.coord(0, 0.30), 6);
        assert_eq!(g.coord(0, 0.35), 7);
        assert_eq!(g.coord(0, 0.0), 0);
        assert_eq!(g.coord(0, 1.0), 19);
        assert_eq!(g.coord(0, 0.049999999), 0);
        // Every decimal boundary k/20 is the lower edge of cell k.
        for k in 0..20 {
            let x = k as f64 / 20.0;
            assert_eq!(g.coord(1, x), k, "x = {x}");
            assert_eq!(g.boundaries[1][k], x);
        }
    }

    #[test]
    fn a_patch_on_a_boundary_plane_lists_in_both_neighbours() {
        // A small square in the plane x = 0.5 (a cell boundary), inside one y/z cell.
        let p = Patch::new(
            vec![
                DVec3::new(0.5, 0.21, 0.21),
                DVec3::new(0.5, 0.24, 0.21),
                DVec3::new(0.5, 0.24, 0.24),
                DVec3::new(0.5, 0.21, 0.24),
            ],
            0.0,
            0.5,
        );
        let g = Grid::empty(unit(), 0.05).unwrap();
        let mut cells = Vec::new();
        g.for_each_overlapping_cell(&p, |c| cells.push(c));
        assert_eq!(cells, vec![g.index([9, 4, 4]), g.index([10, 4, 4])]);
    }

    #[test]
    fn diagonal_triangle_skips_cells_it_misses() {
        // A triangle in the plane x + y = 0.1 cuts cells (0,1) and (1,0) and (0,0),
        // touches (1,1) only at... nothing: x+y=0.1 meets cell (1,1) = [.05,.1]² only at (.05,.05).
        let p = Patch::new(
            vec![
                DVec3::new(0.1, 0.0, 0.01),
                DVec3::new(0.0, 0.1, 0.01),
                DVec3::new(0.0, 0.1, 0.04),
            ],
            0.0,
            0.5,
        );
        let g = Grid::empty(unit(), 0.05).unwrap();
        let mut cells = Vec::new();
        g.for_each_overlapping_cell(&p, |c| cells.push(c));
        for c in &cells {
            let (i, j) = (c % 20, (c / 20) % 20);
            assert!(i + j <= 2, "cell ({i},{j}) listed");
        }
        assert!(cells.contains(&g.index([0, 0, 0])));
        assert!(cells.contains(&g.index([1, 0, 0])));
        assert!(cells.contains(&g.index([0, 1, 0])));
        assert!(
            cells.contains(&g.index([1, 1, 0])),
            "touches the corner (0.05,0.05)"
        );
        // (0.1, 0) is a vertex: it touches cell (2,0) at its corner.
        assert!(cells.contains(&g.index([2, 0, 0])));
    }

    #[test]
    fn absurd_cell_sizes_are_errors() {
        for c in [0.0, -1.0, f64::NAN, 1e-9] {
            assert!(Grid::empty(unit(), c).is_err(), "cell {c}");
        }
    }

    /// Binning without `floor` agrees with the floor-based formula everywhere, NaN and the
    /// ends of the grid included.
    #[test]
    fn binning_matches_the_floor_formula() {
        let g = Grid::empty(unit(), 0.05).unwrap();
        let by_floor = |x: f64| {
            let b = &g.boundaries[0];
            let n = g.dims[0];
            let f = ((x - g.lo[0]) * g.inv_cell).floor();
            let mut i = if f.is_nan() || f < 0.0 {
                0
            } else if f >= n as f64 {
                n - 1
            } else {
                f as usize
            };
            if i > 0 && x < b[i] {
                i -= 1;
            } else if i + 1 < n && x >= b[i + 1] {
                i += 1;
            }
            i
        };
        let mut xs = vec![
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            -0.0,
            0.0,
            1.0,
            1e300,
        ];
        for k in 0..=20 {
            let x = k as f64 / 20.0;
            // The neighbouring doubles (below 0: the negative subnormal nearest to it).
            let down = if x > 0.0 {
                f64::from_bits(x.to_bits() - 1)
            } else {
                -f64::from_bits(1)
            };
            let up = f64::from_bits(x.to_bits() + 1);
            xs.extend([x, down, up, -x, 1.0 + x]);
        }
        xs.extend((0..10_000).map(|i| -0.1 + 1.2 * i as f64 / 10_000.0));
        for x in xs {
            assert_eq!(g.coord(0, x), by_floor(x), "x = {x}");
        }
    }
}
