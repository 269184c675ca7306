//! `timing = "auto"`: which machine points must run at the cycle level. Every machine point
//! is first timed by the queueing network; a point whose true cycles lie in an interval
//! around that estimate (the network's measured error) runs the cycle model only when no
//! other point certainly dominates it — better or equal in error and surely fewer cycles
//! whatever the true cycles in the intervals.
//!
//! **Soundness.** If every point's true cycles lie in its interval, (1) every point of the
//! true front of error against cycles is a candidate, and (2) the front computed from the
//! candidates' true cycles and any in-interval value for the others is the true front.
//! Certain domination is transitive and holds for any values in the intervals, so a screened
//! point is dominated by a candidate under every choice of values; the rest follows from the
//! front's definition. `candidates_are_a_superset_of_the_true_front` checks (1) and (2) on
//! random intervals.

/// One point: its error (exact at every timing level: the results are the untimed model's)
/// and the interval its true cycles lie in (`lo == hi` once measured at the cycle level).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Screened {
    pub err: f64,
    pub lo: f64,
    pub hi: f64,
}

/// The interval of true cycles `c` with |q − c| ≤ `margin`·c around a queue estimate `q`:
/// [q / (1 + margin), q / (1 − margin)] (unbounded above from a margin of 1).
pub fn interval(q: f64, margin: f64) -> (f64, f64) {
    let hi = if margin < 1.0 {
        q / (1.0 - margin)
    } else {
        f64::INFINITY
    };
    (q / (1.0 + margin), hi)
}

/// Whether `j` dominates `i` for every choice of cycles in their intervals.
pub fn certainly_dominates(j: Screened, i: Screened) -> bool {
    j.err <= i.err && j.hi <= i.lo && (j.err < i.err || j.hi < i.lo)
}

/// For each point, whether it may be on the front (no other point certainly dominates it).
/// Points with a NaN are never candidates. O(n log n): sorted by error, `i` is certainly
/// dominated when some point of smaller error has `hi ≤ lo_i`, or one of equal error has
/// `hi < lo_i`.
pub fn candidates(pts: &[Screened]) -> Vec<bool> {
    let ok = |p: &Screened| !(p.err.is_nan() || p.lo.is_nan() || p.hi.is_nan());
    let mut order: Vec<usize> = (0..pts.len()).filter(|&i| ok(&pts[i])).collect();
    order.sort_by(|&a, &b| pts[a].err.total_cmp(&pts[b].err));
    let mut out = vec![false; pts.len()];
    // The least `hi` among points of smaller error.
    let mut below = f64::INFINITY;
    let mut k = 0;
    while k < order.len() {
        let e = pts[order[k]].err;
        let mut end = k;
        while end < order.len() && pts[order[end]].err == e {
            end += 1;
        }
        let tie = order[k..end]
            .iter()
            .map(|&i| pts[i].hi)
            .fold(f64::INFINITY, f64::min);
        for &i in &order[k..end] {
            out[i] = !(below <= pts[i].lo || tie < pts[i].lo);
        }
        below = below.min(tie);
        k = end;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::explore::front::front;
    use proptest::prelude::*;

    /// By the definition, in O(n²).
    fn brute(pts: &[Screened]) -> Vec<bool> {
        (0..pts.len())
            .map(|i| {
                let p = pts[i];
                !p.err.is_nan()
                    && !p.lo.is_nan()
                    && !p.hi.is_nan()
                    && !pts
                        .iter()
                        .enumerate()
                        .any(|(j, &q)| j != i && certainly_dominates(q, p))
            })
            .collect()
    }

    /// A point with its true cycles: an interval from a small grid (ties are common), the
    /// true value somewhere inside it, and a value the screen may use instead.
    fn point() -> impl Strategy<Value = (Screened, f64, f64)> {
        (0u8..5, 0u8..8, 0u8..4, 0u8..=4, 0u8..=4).prop_map(|(e, lo, w, t, u)| {
            let (lo, hi) = (f64::from(lo), f64::from(lo) + f64::from(w));
            let at = |k: u8| lo + (hi - lo) * f64::from(k) / 4.0;
            (
                Screened {
                    err: f64::from(e),
                    lo,
                    hi,
                },
                at(t),
                at(u),
            )
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(3000))]
        #[test]
        fn candidates_are_a_superset_of_the_true_front(v in prop::collection::vec(point(), 0..30)) {
            let pts: Vec<Screened> = v.iter().map(|p| p.0).collect();
            let c = candidates(&pts);
            prop_assert_eq!(&c, &brute(&pts));
            // (1) The true front is among the candidates.
            let truth: Vec<(f64, f64)> = v.iter().map(|p| (p.1, p.0.err)).collect();
            let true_front = front(&truth);
            for &i in &true_front {
                prop_assert!(c[i], "point {} is on the true front but screened out", i);
            }
            // (2) True cycles for the candidates, any in-interval value for the rest: the
            // same front.
            let mixed: Vec<(f64, f64)> = v
                .iter()
                .zip(&c)
                .map(|(p, &cand)| (if cand { p.1 } else { p.2 }, p.0.err))
                .collect();
            prop_assert_eq!(front(&mixed), true_front);
        }
    }

    #[test]
    fn a_surely_slower_point_of_no_better_error_is_screened_out() {
        let a = Screened {
            err: 1.0,
            lo: 90.0,
            hi: 110.0,
        };
        // Slower for sure and no more accurate: out.
        let b = Screened {
            err: 1.0,
            lo: 120.0,
            hi: 140.0,
        };
        // Overlapping cycles: it may be faster, so it stays.
        let c = Screened {
            err: 2.0,
            lo: 100.0,
            hi: 130.0,
        };
        // More accurate: it stays whatever its cycles.
        let d = Screened {
            err: 0.5,
            lo: 500.0,
            hi: 600.0,
        };
        assert_eq!(candidates(&[a, b, c, d]), vec![true, false, true, true]);
        let (lo, hi) = interval(100.0, 0.25);
        assert_eq!((lo, hi), (80.0, 100.0 / 0.75));
        assert_eq!(interval(100.0, 1.0).1, f64::INFINITY);
    }
}
