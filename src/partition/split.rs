//! The median splitter: a box of the hemisphere cut recursively into any number of parts
//! of about equal weight, along alternating angles (θ first), at weighted quantiles.
//!
//! To cut a box into `P` parts, the splitter cuts it into `⌈P/2⌉` and `⌊P/2⌋` parts at the
//! position whose weight on the left is closest to `W·⌈P/2⌉/P` (the matching weighted
//! quantile, so P need not be a power of two), then recurses into both halves along the
//! other angle (and a tree cut further — sectors inside a section — carries on with the
//! angle after its last cut, [`Splits::next_axis`]). Positions come from the granularity: only subregion boundaries
//! ([`Positions::Boundaries`]) or between any two consecutive distinct item angles
//! ([`Positions::BetweenItems`], the low-resolution rays).
//!
//! **Invariant:** the parts tile the box: their boxes are disjoint and cover it (every cut
//! is at an integer angle strictly inside the box being cut). There are exactly `P` parts,
//! numbered in depth-first order, left (lower angle) first.
//!
//! **Invariant:** deterministic and exact: weights are integers and quantiles compare
//! `|W_left·P − W·⌈P/2⌉|` in 128-bit integers. Ties go to the position nearest the box's
//! proportional point `lo + (hi − lo)·⌈P/2⌉/P`, then to the lower position — so regions of
//! zero weight are cut geometrically. A box with no allowed position on either angle
//! (one subregion, or one ray direction, asked for two parts) is cut at its proportional
//! point anyway; such cuts are counted in [`Splits::forced`].

use super::angles::{AngleBox, Angles, Axis};

/// Something with a position on the hemisphere and a weight (a subregion at its lower
/// corner, or a low-resolution ray at its direction).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Item {
    pub at: Angles,
    pub weight: u64,
}

/// Where cuts may go.
#[derive(Clone, Copy, Debug)]
pub enum Positions<'a> {
    /// Only at these positions per axis (the subregion grid's inner boundaries).
    Boundaries { theta: &'a [u64], phi: &'a [u64] },
    /// Between consecutive distinct item angles (midway, rounded up).
    BetweenItems,
}

/// The result of a split.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Splits {
    /// The parts, depth-first, lower angle first.
    pub boxes: Vec<AngleBox>,
    /// Per part: the angle its next cut would use (the alternation continued), so that
    /// sectors cut inside a section carry on the section tree's alternation.
    pub next_axis: Vec<Axis>,
    /// Cuts made at a box's proportional point because no allowed position lay inside it.
    pub forced: usize,
}

/// Cuts `root` into `parts` boxes balancing the weight of `items` (items outside `root`
/// are ignored), the first cut along `first` (θ at the root of the hemisphere). `parts`
/// must be at least 1.
pub fn split(
    root: AngleBox,
    items: &[Item],
    parts: usize,
    first: Axis,
    positions: Positions,
) -> Splits {
    assert!(parts >= 1, "at least one part");
    let inside: Vec<Item> = items
        .iter()
        .copied()
        .filter(|i| root.contains(i.at))
        .collect();
    let mut out = Splits {
        boxes: Vec::with_capacity(parts),
        next_axis: Vec::with_capacity(parts),
        forced: 0,
    };
    rec(root, inside, parts, first, positions, &mut out);
    debug_assert_eq!(out.boxes.len(), parts);
    out
}

fn rec(bx: AngleBox, items: Vec<Item>, parts: usize, axis: Axis, pos: Positions, out: &mut Splits) {
    if parts == 1 {
        out.boxes.push(bx);
        out.next_axis.push(axis);
        return;
    }
    let left_parts = parts.div_ceil(2);
    let mut cut = None;
    for a in [axis, axis.other()] {
        if let Some(at) = best_cut(&bx, &items, a, parts, left_parts, pos) {
            cut = Some((a, at));
            break;
        }
    }
    let (a, at) = cut.unwrap_or_else(|| {
        out.forced += 1;
        // The preferred angle if its range can be cut at all, else the other.
        let a = if span(&bx, axis) >= 2 {
            axis
        } else {
            axis.other()
        };
        let [lo, hi] = bx.range(a);
        assert!(
            hi - lo >= 2,
            "a box of one nanodegree square cannot be cut: {bx:?}"
        );
        (
            a,
            proportional(lo, hi, parts, left_parts).clamp(lo + 1, hi - 1),
        )
    });
    let (lb, rb) = bx.split(a, at);
    let (li, ri): (Vec<Item>, Vec<Item>) = items.into_iter().partition(|i| i.at.get(a) < at);
    rec(lb, li, left_parts, a.other(), pos, out);
    rec(rb, ri, parts - left_parts, a.other(), pos, out);
}

fn span(bx: &AngleBox, a: Axis) -> u64 {
    let [lo, hi] = bx.range(a);
    hi - lo
}

/// `lo + (hi − lo)·left/parts`.
fn proportional(lo: u64, hi: u64, parts: usize, left: usize) -> u64 {
    lo + ((hi - lo) as u128 * left as u128 / parts as u128) as u64
}

/// The best allowed cut of `bx` on `axis`, or `None` when no allowed position lies inside.
fn best_cut(
    bx: &AngleBox,
    items: &[Item],
    axis: Axis,
    parts: usize,
    left_parts: usize,
    pos: Positions,
) -> Option<u64> {
    let [lo, hi] = bx.range(axis);
    let mut coords: Vec<(u64, u64)> = items.iter().map(|i| (i.at.get(axis), i.weight)).collect();
    coords.sort_unstable();
    let candidates: Vec<u64> = match pos {
        Positions::Boundaries { theta, phi } => {
            let b = match axis {
                Axis::Theta => theta,
                Axis::Phi => phi,
            };
            b.iter().copied().filter(|&s| lo < s && s < hi).collect()
        }
        Positions::BetweenItems => coords
            .windows(2)
            .filter(|w| w[0].0 < w[1].0)
            .map(|w| w[0].0 + (w[1].0 - w[0].0).div_ceil(2))
            .collect(),
    };
    if candidates.is_empty() {
        return None;
    }
    // Prefix sums of weight by coordinate.
    let mut prefix = Vec::with_capacity(coords.len() + 1);
    prefix.push(0u128);
    for &(_, w) in &coords {
        prefix.push(prefix.last().unwrap() + w as u128);
    }
    let total = *prefix.last().unwrap();
    let prop = proportional(lo, hi, parts, left_parts);
    candidates
        .into_iter()
        .map(|s| {
            let left = prefix[coords.partition_point(|&(c, _)| c < s)];
            let miss = (left * parts as u128).abs_diff(total * left_parts as u128);
            ((miss, s.abs_diff(prop), s), s)
        })
        .min_by_key(|&(key, _)| key)
        .map(|(_, s)| s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::partition::angles::{SubregionGrid, NANO_PER_DEG, PHI_END, THETA_END};

    const DEG: u64 = NANO_PER_DEG;

    fn item(theta_deg: u64, phi_deg: u64, weight: u64) -> Item {
        Item {
            at: Angles {
                theta: theta_deg * DEG,
                phi: phi_deg * DEG,
            },
            weight,
        }
    }

    fn weights(s: &Splits, items: &[Item]) -> Vec<u64> {
        s.boxes
            .iter()
            .map(|b| {
                items
                    .iter()
                    .filter(|i| b.contains(i.at))
                    .map(|i| i.weight)
                    .sum()
            })
            .collect()
    }

    fn assert_tiles(s: &Splits, root: AngleBox) {
        let m: u128 = s.boxes.iter().map(|b| b.measure()).sum();
        assert_eq!(m, root.measure());
        for (i, a) in s.boxes.iter().enumerate() {
            for b in &s.boxes[i + 1..] {
                assert!(!a.overlaps(b), "{a:?} overlaps {b:?}");
            }
        }
    }

    #[test]
    fn any_part_count_balances_uniform_weights() {
        // 60 unit items on a 6×10 lattice of directions; P not a power of two.
        let items: Vec<Item> = (0..6)
            .flat_map(|t| (0..10).map(move |p| item(5 + 15 * t, 18 + 36 * p, 1)))
            .collect();
        for parts in [1, 2, 3, 5, 6, 7, 12] {
            let s = split(
                AngleBox::HEMISPHERE,
                &items,
                parts,
                Axis::Theta,
                Positions::BetweenItems,
            );
            assert_eq!(s.boxes.len(), parts);
            assert_eq!(s.forced, 0);
            assert_tiles(&s, AngleBox::HEMISPHERE);
            let w = weights(&s, &items);
            assert_eq!(w.iter().sum::<u64>(), 60);
            // The lattice is coarse: no part carries more than twice its share.
            let hi = *w.iter().max().unwrap();
            assert!(hi <= 2 * 60u64.div_ceil(parts as u64), "P={parts}: {w:?}");
        }
    }

    #[test]
    fn three_parts_split_two_to_one() {
        let items = [item(10, 0, 1), item(30, 0, 1), item(50, 0, 1)];
        let s = split(
            AngleBox::HEMISPHERE,
            &items,
            3,
            Axis::Theta,
            Positions::BetweenItems,
        );
        assert_eq!(weights(&s, &items), vec![1, 1, 1]);
        // θ first: the first cut is between 30° and 50°, the left half then cut on φ fails
        // (one φ value) and falls back to θ.
        assert_eq!(s.boxes[2].theta, [40 * DEG, THETA_END]);
        assert_eq!(s.forced, 0);
        // The alternation carries on: the right part was made by a θ cut, the left two by
        // a θ cut (the φ fallback) too.
        assert_eq!(s.next_axis, vec![Axis::Phi, Axis::Phi, Axis::Phi]);
        let two = split(
            AngleBox::HEMISPHERE,
            &items,
            2,
            Axis::Phi,
            Positions::BetweenItems,
        );
        assert_eq!(two.next_axis, vec![Axis::Phi; 2], "no φ position: cut on θ");
    }

    #[test]
    fn zero_weight_and_empty_regions_are_cut_geometrically() {
        let g = SubregionGrid::new(5, 5);
        let pos = Positions::Boundaries {
            theta: g.inner_bounds(Axis::Theta),
            phi: g.inner_bounds(Axis::Phi),
        };
        // No items at all, and zero-weight items: the same geometric cuts.
        let zeros: Vec<Item> = (0..25)
            .map(|k| Item {
                at: Angles {
                    theta: g.box_of(k).theta[0],
                    phi: g.box_of(k).phi[0],
                },
                weight: 0,
            })
            .collect();
        let a = split(AngleBox::HEMISPHERE, &[], 4, Axis::Theta, pos);
        let b = split(AngleBox::HEMISPHERE, &zeros, 4, Axis::Theta, pos);
        assert_eq!(a, b);
        assert_eq!(a.forced, 0);
        assert_tiles(&a, AngleBox::HEMISPHERE);
        // Proportional point of θ is 45°: the nearest boundary is 36°; φ: 180° → 144°/216°
        // tie, the lower wins.
        assert_eq!(a.boxes[0].theta, [0, 36 * DEG]);
        assert_eq!(a.boxes[0].phi, [0, 144 * DEG]);
        // Between-items with no items: every cut forced, still a tiling.
        let c = split(
            AngleBox::HEMISPHERE,
            &[],
            5,
            Axis::Theta,
            Positions::BetweenItems,
        );
        assert_eq!(c.forced, 4);
        assert_tiles(&c, AngleBox::HEMISPHERE);
        // θ at 3/5 of 90°, φ at 2/3 of 360°, θ at half of 54°.
        assert_eq!(c.boxes[0].theta, [0, 27 * DEG]);
        assert_eq!(c.boxes[0].phi, [0, 240 * DEG]);
    }

    #[test]
    fn more_parts_than_positions_forces_cuts() {
        let g = SubregionGrid::new(1, 2);
        let pos = Positions::Boundaries {
            theta: g.inner_bounds(Axis::Theta),
            phi: g.inner_bounds(Axis::Phi),
        };
        let items = [item(0, 0, 5), item(0, 180, 5)];
        let s = split(AngleBox::HEMISPHERE, &items, 4, Axis::Theta, pos);
        assert_eq!(s.boxes.len(), 4);
        assert_eq!(s.forced, 2);
        assert_tiles(&s, AngleBox::HEMISPHERE);
        assert_eq!(weights(&s, &items).iter().sum::<u64>(), 10);
    }

    #[test]
    fn ties_go_to_the_proportional_point_then_lower() {
        // Weight only at the ends: every cut between them balances equally well.
        let items = [
            item(10, 0, 1),
            item(20, 0, 0),
            item(30, 0, 0),
            item(40, 0, 0),
            item(80, 0, 1),
        ];
        let s = split(
            AngleBox::HEMISPHERE,
            &items,
            2,
            Axis::Theta,
            Positions::BetweenItems,
        );
        // Candidates 15, 25, 35, 60: all leave weight 1 on the left; 45° is nearest to 35.
        assert_eq!(s.boxes[0].theta, [0, 35 * DEG]);
        // Exactly tied distances: 40° and 50° around the proportional 45°: the lower wins.
        let items = [item(35, 0, 1), item(45, 0, 0), item(55, 0, 1)];
        let s = split(
            AngleBox::HEMISPHERE,
            &items,
            2,
            Axis::Theta,
            Positions::BetweenItems,
        );
        assert_eq!(s.boxes[0].theta, [0, 40 * DEG]);
    }

    #[test]
    fn a_heavy_item_is_never_divided() {
        let items = [item(10, 0, 100), item(50, 0, 1), item(60, 0, 1)];
        let s = split(
            AngleBox::HEMISPHERE,
            &items,
            2,
            Axis::Theta,
            Positions::BetweenItems,
        );
        assert_eq!(weights(&s, &items), vec![100, 2]);
        // Three parts: the heavy item is closest to 2/3 of the weight, so its side gets two
        // parts; one direction cannot be cut, so one of them is a forced, empty part.
        let s = split(
            AngleBox::HEMISPHERE,
            &items,
            3,
            Axis::Theta,
            Positions::BetweenItems,
        );
        assert_eq!(weights(&s, &items), vec![100, 0, 2]);
        assert_eq!(s.forced, 1);
    }

    #[test]
    fn items_outside_the_root_are_ignored() {
        let root = AngleBox {
            theta: [0, 45 * DEG],
            phi: [0, PHI_END],
        };
        let items = [item(10, 0, 1), item(20, 0, 1), item(60, 0, 1000)];
        let s = split(root, &items, 2, Axis::Theta, Positions::BetweenItems);
        assert_eq!(weights(&s, &items), vec![1, 1]);
        assert_tiles(&s, root);
    }
}
