//! Non-dominated fronts (Pareto, both coordinates minimized): a point is on the front when
//! no other point is at least as good in both and better in one. Points with a NaN are on
//! no front; equal points are all on it or all off it.

/// Whether `a` dominates `b`: no worse in both coordinates, better in at least one.
pub fn dominates(a: (f64, f64), b: (f64, f64)) -> bool {
    a.0 <= b.0 && a.1 <= b.1 && (a.0 < b.0 || a.1 < b.1)
}

/// The order of a front: by x, then y, then index.
fn by_x_y_index(pts: &[(f64, f64)], a: usize, b: usize) -> std::cmp::Ordering {
    pts[a]
        .0
        .total_cmp(&pts[b].0)
        .then(pts[a].1.total_cmp(&pts[b].1))
        .then(a.cmp(&b))
}

/// The indices of the non-dominated points of `pts`, ordered by x, then y, then index.
/// O(n log n): sorted by x, a point is on the front when its y is the least at its x and
/// below every y at a smaller x.
pub fn front(pts: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..pts.len())
        .filter(|&i| !pts[i].0.is_nan() && !pts[i].1.is_nan())
        .collect();
    order.sort_by(|&a, &b| by_x_y_index(pts, a, b));
    let mut out = Vec::new();
    // The least y at a smaller x (none yet).
    let mut best: Option<f64> = None;
    let mut i = 0;
    while i < order.len() {
        let x = pts[order[i]].0;
        let y0 = pts[order[i]].1;
        let mut j = i;
        while j < order.len() && pts[order[j]].0 == x {
            if pts[order[j]].1 == y0 && best.is_none_or(|b| y0 < b) {
                out.push(order[j]);
            }
            j += 1;
        }
        best = Some(best.map_or(y0, |b| b.min(y0)));
        i = j;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The definition, by brute force.
    fn brute(pts: &[(f64, f64)]) -> Vec<usize> {
        let mut v: Vec<usize> = (0..pts.len())
            .filter(|&i| {
                !pts[i].0.is_nan()
                    && !pts[i].1.is_nan()
                    && !pts.iter().enumerate().any(|(j, &q)| {
                        j != i && !q.0.is_nan() && !q.1.is_nan() && dominates(q, pts[i])
                    })
            })
            .collect();
        v.sort_by(|&a, &b| by_x_y_index(pts, a, b));
        v
    }

    /// Coordinates from a small grid (ties are common) or anywhere, sometimes NaN.
    fn coord() -> impl Strategy<Value = f64> {
        prop_oneof![
            8 => (0u8..6).prop_map(f64::from),
            4 => -1e6f64..1e6,
            1 => Just(f64::NAN),
            1 => Just(f64::INFINITY),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        #[test]
        fn the_front_is_the_set_of_non_dominated_points(pts in prop::collection::vec((coord(), coord()), 0..40)) {
            let f = front(&pts);
            prop_assert_eq!(&f, &brute(&pts));
            // And, said directly: nothing on the front is dominated, everything off it is.
            for (i, &p) in pts.iter().enumerate() {
                if p.0.is_nan() || p.1.is_nan() {
                    prop_assert!(!f.contains(&i));
                    continue;
                }
                let dominated = pts.iter().any(|&q| dominates(q, p));
                prop_assert_eq!(f.contains(&i), !dominated, "point {} {:?}", i, p);
            }
        }
    }

    #[test]
    fn equal_points_share_their_place() {
        let pts = [(1.0, 1.0), (1.0, 1.0), (0.0, 2.0), (2.0, 0.5), (2.0, 2.0)];
        assert_eq!(front(&pts), vec![2, 0, 1, 3]);
    }
}
