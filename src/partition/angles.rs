//! Hemisphere coordinates of the partitioner: the polar angle θ (from the source's normal)
//! and the azimuth φ (from the source's first edge) of [`crate::reference::rays::Frame::of_patch`],
//! held as integer nanodegrees, with the half-open angle boxes that sections, sectors and
//! subregions are made of.
//!
//! **Invariant:** every comparison of angles is an integer comparison. A direction's angles
//! are rounded once, to the nearest nanodegree, so a ring direction built at exactly 18° or
//! 72° lands exactly on a boundary of the default 5×5 subregion grid and always falls in
//! the box above it — never on either side at the whim of an ulp.
//!
//! **Invariant:** θ runs over `[0, THETA_END)` (θ = 90° exactly, a grazing direction, is
//! inside), φ over `[0, PHI_END)` (360° wraps to 0); a direction within 1e-12 of the normal
//! has φ = 0. Boxes are half-open on both axes, so boxes made by splitting a box at integer
//! positions are disjoint and cover it.

use crate::reference::rays::Frame;
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Angle units per degree.
pub const NANO_PER_DEG: u64 = 1_000_000_000;
/// θ's exclusive end: 90° plus one unit, so that θ = 90° belongs to the hemisphere.
pub const THETA_END: u64 = 90 * NANO_PER_DEG + 1;
/// φ's exclusive end: 360° (which wraps to 0).
pub const PHI_END: u64 = 360 * NANO_PER_DEG;

/// One of the two hemisphere angles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    Theta,
    Phi,
}

impl Axis {
    /// The other angle.
    pub fn other(self) -> Axis {
        match self {
            Axis::Theta => Axis::Phi,
            Axis::Phi => Axis::Theta,
        }
    }
}

/// A direction's hemisphere angles in nanodegrees.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Angles {
    pub theta: u64,
    pub phi: u64,
}

impl Angles {
    /// The angle on `axis`.
    #[inline]
    pub fn get(&self, axis: Axis) -> u64 {
        match axis {
            Axis::Theta => self.theta,
            Axis::Phi => self.phi,
        }
    }

    /// The angles of world direction `d` in `frame` (d need not be unit length). Directions
    /// behind the frame's plane clamp to θ = 90°.
    pub fn of(frame: &Frame, d: DVec3) -> Angles {
        let (x, y, z) = (d.dot(frame.t), d.dot(frame.b), d.dot(frame.n));
        let rho = x.hypot(y);
        // atan2 keeps θ accurate near the zenith, where acos(z) loses half its digits.
        let theta = rho.atan2(z.max(0.0)).to_degrees();
        let theta = ((theta * NANO_PER_DEG as f64).round() as u64).min(90 * NANO_PER_DEG);
        let phi = if rho <= 1e-12 * rho.hypot(z) {
            0
        } else {
            let p = y.atan2(x).to_degrees().rem_euclid(360.0);
            let p = (p * NANO_PER_DEG as f64).round() as u64;
            if p >= PHI_END {
                p - PHI_END
            } else {
                p
            }
        };
        Angles { theta, phi }
    }
}

/// A half-open box `[theta[0], theta[1]) × [phi[0], phi[1])` of hemisphere angles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct AngleBox {
    /// θ range in nanodegrees, half-open.
    pub theta: [u64; 2],
    /// φ range in nanodegrees, half-open.
    pub phi: [u64; 2],
}

impl AngleBox {
    /// The whole hemisphere.
    pub const HEMISPHERE: AngleBox = AngleBox {
        theta: [0, THETA_END],
        phi: [0, PHI_END],
    };

    /// True when `a` lies in the box.
    #[inline]
    pub fn contains(&self, a: Angles) -> bool {
        self.theta[0] <= a.theta
            && a.theta < self.theta[1]
            && self.phi[0] <= a.phi
            && a.phi < self.phi[1]
    }

    /// The range on `axis`.
    #[inline]
    pub fn range(&self, axis: Axis) -> [u64; 2] {
        match axis {
            Axis::Theta => self.theta,
            Axis::Phi => self.phi,
        }
    }

    /// The box with its range on `axis` replaced.
    pub fn with(&self, axis: Axis, range: [u64; 2]) -> AngleBox {
        let mut b = *self;
        match axis {
            Axis::Theta => b.theta = range,
            Axis::Phi => b.phi = range,
        }
        b
    }

    /// The two halves of a split at `at` on `axis` (`lo < at < hi`).
    pub fn split(&self, axis: Axis, at: u64) -> (AngleBox, AngleBox) {
        let [lo, hi] = self.range(axis);
        debug_assert!(lo < at && at < hi, "split {at} outside ({lo}, {hi})");
        (self.with(axis, [lo, at]), self.with(axis, [at, hi]))
    }

    /// Its measure in (nanodegree)² — boxes that tile the hemisphere sum to the hemisphere's.
    pub fn measure(&self) -> u128 {
        (self.theta[1] - self.theta[0]) as u128 * (self.phi[1] - self.phi[0]) as u128
    }

    /// True when the two boxes share a point.
    pub fn overlaps(&self, o: &AngleBox) -> bool {
        self.theta[0] < o.theta[1]
            && o.theta[0] < self.theta[1]
            && self.phi[0] < o.phi[1]
            && o.phi[0] < self.phi[1]
    }

    /// θ range in degrees (the exclusive end 90° + 1 unit reported as 90).
    pub fn theta_deg(&self) -> [f64; 2] {
        self.theta
            .map(|v| v.min(90 * NANO_PER_DEG) as f64 / NANO_PER_DEG as f64)
    }

    /// φ range in degrees.
    pub fn phi_deg(&self) -> [f64; 2] {
        self.phi.map(|v| v as f64 / NANO_PER_DEG as f64)
    }
}

/// The subregion grid: `n_theta × n_phi` boxes of equal Δθ and equal Δφ (the paper's
/// "equally distributed Δθ"). Subregion `i_theta * n_phi + i_phi`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SubregionGrid {
    pub n_theta: usize,
    pub n_phi: usize,
    /// θ boundaries, `n_theta + 1` of them, the last `THETA_END`.
    pub theta_bounds: Vec<u64>,
    /// φ boundaries, `n_phi + 1` of them, the last `PHI_END`.
    pub phi_bounds: Vec<u64>,
}

impl SubregionGrid {
    /// Most subregions along θ (one per degree).
    pub const MAX_THETA: usize = 90;
    /// Most subregions along φ (one per degree).
    pub const MAX_PHI: usize = 360;

    /// The grid of `n_theta × n_phi` subregions; both at least 1 and at most one per degree.
    pub fn new(n_theta: usize, n_phi: usize) -> SubregionGrid {
        assert!(
            (1..=Self::MAX_THETA).contains(&n_theta),
            "n_theta {n_theta}"
        );
        assert!((1..=Self::MAX_PHI).contains(&n_phi), "n_phi {n_phi}");
        let bounds = |n: usize, span: u64, end: u64| -> Vec<u64> {
            (0..=n)
                .map(|i| {
                    if i == n {
                        end
                    } else {
                        (i as u128 * span as u128 / n as u128) as u64
                    }
                })
                .collect()
        };
        SubregionGrid {
            n_theta,
            n_phi,
            theta_bounds: bounds(n_theta, 90 * NANO_PER_DEG, THETA_END),
            phi_bounds: bounds(n_phi, PHI_END, PHI_END),
        }
    }

    /// Number of subregions.
    pub fn len(&self) -> usize {
        self.n_theta * self.n_phi
    }

    /// Always false: a grid has at least one subregion.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The subregion holding `a`.
    pub fn index(&self, a: Angles) -> usize {
        // The number of boundaries at or below the angle, less one.
        let it = self.theta_bounds[1..].partition_point(|&b| b <= a.theta);
        let ip = self.phi_bounds[1..].partition_point(|&b| b <= a.phi);
        it.min(self.n_theta - 1) * self.n_phi + ip.min(self.n_phi - 1)
    }

    /// The box of subregion `k`.
    pub fn box_of(&self, k: usize) -> AngleBox {
        let (it, ip) = (k / self.n_phi, k % self.n_phi);
        AngleBox {
            theta: [self.theta_bounds[it], self.theta_bounds[it + 1]],
            phi: [self.phi_bounds[ip], self.phi_bounds[ip + 1]],
        }
    }

    /// The inner boundaries on `axis` (the positions a subregion-granular split may use).
    pub fn inner_bounds(&self, axis: Axis) -> &[u64] {
        let b = match axis {
            Axis::Theta => &self.theta_bounds,
            Axis::Phi => &self.phi_bounds,
        };
        &b[1..b.len() - 1]
    }
}

/// Parses `AxB` (θ subregions × φ subregions), e.g. `5x5`.
pub fn parse_subregions(s: &str) -> Result<(usize, usize), String> {
    let (a, b) = s
        .split_once(['x', 'X', '×'])
        .ok_or_else(|| format!("{s:?}: expected N_THETAxN_PHI, e.g. 5x5"))?;
    let a: usize = a.trim().parse().map_err(|e| format!("{a:?}: {e}"))?;
    let b: usize = b.trim().parse().map_err(|e| format!("{b:?}: {e}"))?;
    if !(1..=SubregionGrid::MAX_THETA).contains(&a) || !(1..=SubregionGrid::MAX_PHI).contains(&b) {
        return Err(format!(
            "{s:?}: θ subregions must be 1..={} and φ subregions 1..={}",
            SubregionGrid::MAX_THETA,
            SubregionGrid::MAX_PHI
        ));
    }
    Ok((a, b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::rays::rings_local;
    use crate::scene::Patch;

    fn floor_frame() -> Frame {
        Frame::of_patch(&Patch::new(
            vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y],
            0.0,
            0.5,
        ))
    }

    #[test]
    fn zenith_and_wrap() {
        let f = floor_frame();
        assert_eq!(Angles::of(&f, DVec3::Z), Angles { theta: 0, phi: 0 });
        let a = Angles::of(&f, DVec3::new(1.0, -1e-18, 1.0));
        assert_eq!(a.theta, 45 * NANO_PER_DEG);
        assert!(a.phi < PHI_END);
        let g = Angles::of(&f, DVec3::new(0.0, -1.0, 0.0));
        assert_eq!(
            g,
            Angles {
                theta: 90 * NANO_PER_DEG,
                phi: 270 * NANO_PER_DEG
            }
        );
        assert!(AngleBox::HEMISPHERE.contains(g));
    }

    #[test]
    fn ring_directions_on_subregion_boundaries_go_up() {
        // Ring k of the 969-ray set sits at θ = 4.5°·k: rings 4, 8, 12, 16 lie exactly on the
        // 5×5 grid's θ boundaries, and every one of their rays lands in the box above.
        let f = floor_frame();
        let grid = SubregionGrid::new(5, 5);
        let l = rings_local(969);
        let mut k_of_theta = std::collections::BTreeMap::new();
        for (d, _) in &l {
            let a = Angles::of(&f, f.to_world(*d));
            let it = grid.index(a) / 5;
            k_of_theta.entry(a.theta).or_insert_with(Vec::new).push(it);
        }
        assert_eq!(k_of_theta.len(), 20, "20 distinct θ values");
        for (theta, its) in k_of_theta {
            let expect = (theta / (18 * NANO_PER_DEG)) as usize;
            assert!(
                its.iter().all(|&i| i == expect.min(4)),
                "θ {theta}: {its:?}"
            );
        }
    }

    #[test]
    fn grid_boxes_tile_the_hemisphere() {
        for (a, b) in [(5, 5), (1, 1), (7, 3), (90, 360)] {
            let g = SubregionGrid::new(a, b);
            let total: u128 = (0..g.len()).map(|k| g.box_of(k).measure()).sum();
            assert_eq!(total, AngleBox::HEMISPHERE.measure());
            for k in 0..g.len() {
                let bx = g.box_of(k);
                let corner = Angles {
                    theta: bx.theta[0],
                    phi: bx.phi[0],
                };
                assert_eq!(g.index(corner), k);
            }
        }
    }

    #[test]
    fn parse() {
        assert_eq!(parse_subregions("5x5"), Ok((5, 5)));
        assert_eq!(parse_subregions("3×12"), Ok((3, 12)));
        assert!(parse_subregions("0x5").is_err());
        assert!(parse_subregions("5").is_err());
        assert!(parse_subregions("91x1").is_err());
    }
}
