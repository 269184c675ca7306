//! The one polygon check, for patches and for OBJ faces before they are split into
//! triangle fans: finite vertices in range, then a planar, strictly convex polygon of
//! nonzero area that winds once around (no star polygons); and [`split`], the fan that
//! turns a face that is not planar and convex (a non-planar quad, a concave face) into
//! triangles that each pass the check.
//!
//! Works on bare vertex lists so that it depends on nothing of the scene model.

use crate::error::short;
use glam::DVec3;

/// Relative tolerance of the planarity check: a vertex may lie off the polygon's plane by
/// this fraction of the polygon's [`size`] (rounding in generated scenes is ~1e-16).
pub const PLANARITY_TOL: f64 = 1e-9;

/// Largest coordinate magnitude a scene may use: beyond it, areas and plane equations
/// overflow or lose all precision.
pub const MAX_COORD: f64 = 1e12;

/// Newell's normal: twice the vector area; its length is twice the polygon's area and it
/// points to the side from which the vertices are seen counter-clockwise.
pub fn area_vector(v: &[DVec3]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for i in 0..v.len() {
        let a = v[i];
        let b = v[(i + 1) % v.len()];
        n += a.cross(b);
    }
    n
}

/// The longest distance between two vertices.
pub fn diameter(v: &[DVec3]) -> f64 {
    let mut d: f64 = 0.0;
    for i in 0..v.len() {
        for j in i + 1..v.len() {
            d = d.max(v[i].distance(v[j]));
        }
    }
    d
}

/// Polygons of more vertices than this are measured by [`size`]'s bounding box.
pub const EXACT_DIAMETER_MAX: usize = 64;

/// The polygon's size for the tolerances: its [`diameter`] up to [`EXACT_DIAMETER_MAX`]
/// vertices (every patch), else the diagonal of its bounding box (at least the diameter, at
/// most √3 times it). Linear in the vertices, so a face of 200,000 vertices is checked in
/// milliseconds (the pairwise diameter took a minute).
pub fn size(v: &[DVec3]) -> f64 {
    if v.len() <= EXACT_DIAMETER_MAX {
        return diameter(v);
    }
    let (lo, hi) = v.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    if v.is_empty() {
        0.0
    } else {
        lo.distance(hi)
    }
}

/// The whole check: [`check_points`], then [`check_shape`].
pub fn check(v: &[DVec3]) -> Result<(), String> {
    check_points(v)?;
    check_shape(v)
}

/// Every vertex a finite point with coordinates at most [`MAX_COORD`] in magnitude.
pub fn check_points(v: &[DVec3]) -> Result<(), String> {
    for (k, p) in v.iter().enumerate() {
        if !p.is_finite() {
            return Err(format!(
                "vertex {k} is not a finite point: [{}, {}, {}]",
                short(p.x),
                short(p.y),
                short(p.z)
            ));
        }
        if p.abs().max_element() > MAX_COORD {
            return Err(format!(
                "vertex {k} [{}, {}, {}] is out of range (coordinates at most {MAX_COORD:e} in magnitude)",
                short(p.x),
                short(p.y),
                short(p.z)
            ));
        }
    }
    Ok(())
}

/// The shape of a polygon of finite vertices (at least 3): no two consecutive vertices
/// coincide, nonzero area, planar within [`PLANARITY_TOL`], every turn strictly to the
/// left, and the edges wind once around (a polygon whose turns are all left but that winds
/// more than once is a star; it cannot have fewer than 5 vertices).
pub fn check_shape(v: &[DVec3]) -> Result<(), String> {
    let (local, normal, diam) = check_area(v)?;
    check_planar_convex(&local, normal, diam)
}

/// The part of [`check_shape`] that no split can mend: no two consecutive vertices
/// coincide and the area is not zero. Returns the vertices relative to the first, the unit
/// Newell normal and the [`size`].
fn check_area(v: &[DVec3]) -> Result<(Vec<DVec3>, DVec3, f64), String> {
    let n = v.len();
    for i in 0..n {
        if v[i] == v[(i + 1) % n] {
            return Err(format!(
                "has zero area: vertices {i} and {} coincide",
                (i + 1) % n
            ));
        }
    }
    let diam = size(v);
    // Relative to the first vertex: Newell's sum over absolute positions cancels badly for
    // a small polygon far from the origin (a scene in millimetres, or moved away).
    let local: Vec<DVec3> = v.iter().map(|p| *p - v[0]).collect();
    let av = area_vector(&local);
    let area = 0.5 * av.length();
    if area.is_nan() || area <= 1e-12 * diam * diam || area == 0.0 {
        return Err(format!(
            "has zero area ({area:e}): its vertices are collinear"
        ));
    }
    Ok((local, av / av.length(), diam))
}

/// The rest of [`check_shape`] on [`check_area`]'s result: planar, every turn strictly to
/// the left, winding once.
fn check_planar_convex(v: &[DVec3], normal: DVec3, diam: f64) -> Result<(), String> {
    let n = v.len();
    let d0 = normal.dot(v[0]);
    for (k, p) in v.iter().enumerate() {
        let off = (normal.dot(*p) - d0).abs();
        if off > PLANARITY_TOL * diam {
            return Err(format!(
                "is not planar: vertex {k} lies {off:e} off the plane of the others (tolerance {:e})",
                PLANARITY_TOL * diam
            ));
        }
    }
    let mut winding = 0.0;
    for i in 0..n {
        let a = v[i];
        let b = v[(i + 1) % n];
        let c = v[(i + 2) % n];
        let (e1, e2) = (b - a, c - b);
        let turn = e1.cross(e2).dot(normal);
        if turn <= 1e-12 * diam * diam {
            return Err(format!(
                "is not convex: the turn at vertex {} goes the wrong way or is straight",
                (i + 1) % n
            ));
        }
        winding += turn.atan2(e1.dot(e2));
    }
    let turns = winding / std::f64::consts::TAU;
    if (turns - 1.0).abs() > 1e-6 {
        return Err(format!(
            "is not convex: its edges wind {turns:.0} times around (a star polygon)"
        ));
    }
    Ok(())
}

/// Most vertices of a face [`split`] mends: a larger face must be planar and convex as it
/// is (it is then fanned from its first vertex, as before). Trying every apex is quadratic
/// in the vertices, and a huge face that fails the check (a 200,000-gon whose turns are too
/// small to tell from straight) would become 200,000 slivers.
pub const FAN_MAX_VERTICES: usize = 64;

/// How [`split`] cuts a face: the fan of triangles `(apex, apex + j, apex + j + 1)`
/// (indices modulo the vertex count), `j = 1 ..= n - 2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fan {
    /// The vertex all triangles share.
    pub apex: usize,
    /// The largest angle between the normals of two neighbouring triangles, in radians:
    /// how far from planar the face is (0 for a planar face).
    pub fold: f64,
}

impl Fan {
    /// The fan's triangles as vertex indices.
    pub fn triangles(&self, n: usize) -> impl Iterator<Item = [usize; 3]> + '_ {
        (1..n - 1).map(move |j| [self.apex, (self.apex + j) % n, (self.apex + j + 1) % n])
    }
}

/// Faces of more vertices than this, planar and convex, are split by [`balanced`] rather
/// than into a fan: a fan's slivers all meet at one vertex, so the grid cells around it hold
/// thousands of them.
pub const BALANCED_FROM: usize = 64;

/// The triangles of a planar convex face of `n` vertices by recursive halving: the
/// triangle (0, n/3, 2n/3), then each remaining arc (a, b) of the outline cut at its middle
/// vertex m into the triangle (a, m, b) and the arcs (a, m) and (m, b). Every cut is a
/// diagonal of the convex face, so the triangles tile it without overlap and keep its
/// winding; they are well shaped (a circle's are nearly equilateral near the middle and
/// small along the rim).
pub fn balanced(n: usize) -> Vec<[usize; 3]> {
    let mut out = Vec::with_capacity(n.saturating_sub(2));
    if n < 3 {
        return out;
    }
    let (p, q) = (n / 3, 2 * n / 3);
    out.push([0, p, q]);
    let mut arcs = vec![(0, p), (p, q), (q, n)];
    while let Some((a, b)) = arcs.pop() {
        if b - a < 2 {
            continue;
        }
        let m = (a + b) / 2;
        out.push([a, m, b % n]);
        arcs.push((m, b));
        arcs.push((a, m));
    }
    out
}

/// Splits a face of 3 or more vertices if it must be: `Ok(None)` when it passes [`check`]
/// as it is; `Ok(Some(fan))` when it is not planar or not convex but a fan of triangles
/// mends it; `Err` (what is wrong) for bad points, coincident vertices, zero area, a face of
/// more than [`FAN_MAX_VERTICES`] vertices, or a face that no fan mends (a bow tie, a star).
///
/// The rule: among the fans from each vertex, those whose
/// triangles each pass the check, all face the side of the face's Newell normal, and sweep
/// less than a full turn about the apex (so they do not overlap); of those, the one whose
/// largest fold between neighbouring triangles is smallest — the split closest to planar
/// (for a quad: the diagonal whose two triangles are nearer to coplanar); a tie goes to the
/// lower apex.
pub fn split(v: &[DVec3]) -> Result<Option<Fan>, String> {
    check_points(v)?;
    let (local, normal, diam) = check_area(v)?;
    let why = match check_planar_convex(&local, normal, diam) {
        Ok(()) => return Ok(None),
        Err(why) => why,
    };
    let n = local.len();
    if n > FAN_MAX_VERTICES {
        return Err(format!(
            "{why} (a face of more than {FAN_MAX_VERTICES} vertices is split only when it is planar and convex)"
        ));
    }
    let mut best: Option<Fan> = None;
    for apex in 0..n {
        let fan = Fan { apex, fold: 0.0 };
        if let Some(fold) = fan_fold(&local, &fan, normal) {
            if best.is_none_or(|b| fold < b.fold) {
                best = Some(Fan { apex, fold });
            }
        }
    }
    best.map(Some).ok_or_else(|| {
        format!(
            "{why}, and no fan of triangles splits it (it crosses itself or winds more than once)"
        )
    })
}

/// The largest fold of `fan` over `v`, or `None` when one of its triangles fails the check,
/// faces away from `normal`, or the fan sweeps a full turn about its apex.
fn fan_fold(v: &[DVec3], fan: &Fan, normal: DVec3) -> Option<f64> {
    let (mut fold, mut sweep, mut last): (f64, f64, Option<DVec3>) = (0.0, 0.0, None);
    for [a, b, c] in fan.triangles(v.len()) {
        let t = [v[a], v[b], v[c]];
        check_shape(&t).ok()?;
        let tn = area_vector(&t).normalize();
        if tn.dot(normal) <= 0.0 {
            return None;
        }
        if let Some(prev) = last {
            fold = fold.max(prev.angle_between(tn));
        }
        last = Some(tn);
        sweep += (t[1] - t[0]).angle_between(t[2] - t[0]);
    }
    (sweep < std::f64::consts::TAU - 1e-9).then_some(fold)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_balanced_split_tiles_a_convex_face() {
        for n in [3, 4, 5, 64, 65, 1000, 20_000] {
            let t = balanced(n);
            assert_eq!(t.len(), n - 2, "n = {n}");
            // Each triangle keeps the outline's order (a < b < c, the last may wrap to 0),
            // and the areas add up to the polygon's: a tiling of a regular n-gon.
            let v: Vec<DVec3> = (0..n)
                .map(|i| {
                    let a = std::f64::consts::TAU * i as f64 / n as f64;
                    DVec3::new(a.cos(), a.sin(), 0.0)
                })
                .collect();
            let area: f64 = t
                .iter()
                .map(|&[a, b, c]| {
                    let z = (v[b] - v[a]).cross(v[c] - v[a]).z;
                    assert!(z > 0.0, "n = {n}: triangle {a} {b} {c} turned over");
                    0.5 * z
                })
                .sum();
            let want = 0.5 * n as f64 * (std::f64::consts::TAU / n as f64).sin();
            assert!(
                (area - want).abs() < 1e-9 * want,
                "n = {n}: {area} vs {want}"
            );
        }
    }

    #[test]
    fn a_200000_gon_is_checked_in_linear_work() {
        // Regression: the pairwise diameter made this face take 45–60 s. Its vertices
        // lie on a circle; its turns (~3e-14) are below the straightness tolerance, so it
        // is refused — the point is that the answer comes after linear work.
        let n = 200_000;
        let v: Vec<DVec3> = (0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        // The size is the bounding box's diagonal (2√2 for the unit circle), not the
        // pairwise maximum (2).
        assert!((size(&v) - 2.0 * 2f64.sqrt()).abs() < 1e-9);
        let e = check(&v).unwrap_err();
        assert!(e.contains("not convex"), "{e}");
        // Nor is it split into 199,998 slivers: too large a face to mend.
        let e = split(&v).unwrap_err();
        assert!(e.contains("more than 64 vertices"), "{e}");
        // A coarser circle is valid.
        let v: Vec<DVec3> = (0..1000)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / 1000.0;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        assert_eq!(check(&v), Ok(()));
    }

    #[test]
    fn a_pentagram_is_a_star() {
        // The five points of a regular pentagon, visited two apart (rational coordinates
        // close to it are enough: every turn is a left turn).
        let pts = [
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.951, 0.309, 0.0),
            DVec3::new(0.588, -0.809, 0.0),
            DVec3::new(-0.588, -0.809, 0.0),
            DVec3::new(-0.951, 0.309, 0.0),
        ];
        let star: Vec<DVec3> = (0..5).map(|k| pts[(2 * k) % 5]).collect();
        let e = check(&star).unwrap_err();
        assert!(e.contains("star"), "{e}");
        assert!(check(&pts).is_ok());
    }

    fn v(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    #[test]
    fn a_planar_convex_face_is_not_split() {
        let sq = [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)];
        assert_eq!(split(&sq), Ok(None));
    }

    #[test]
    fn a_non_planar_quad_is_cut_along_the_flatter_diagonal() {
        // The unit square with vertex 2 lifted by h. Cut along 0-2, the triangles' normals
        // are (0, -h, 1) and (-h, 0, 1): cos fold = 1 / (1 + h²). Cut along 1-3, they are
        // (-h, -h, 1) and (0, 0, 1): cos fold = 1 / √(1 + 2h²), the smaller fold, so the
        // crease runs through the two vertices that were not lifted.
        let h = 0.2f64;
        let quad = [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., h), v(0., 1., 0.)];
        let fan = split(&quad).unwrap().expect("a non-planar quad is split");
        assert_eq!(fan.apex, 1);
        let want = (1.0 / (1.0 + 2.0 * h * h).sqrt()).acos();
        assert!((fan.fold - want).abs() < 1e-12, "{} {want}", fan.fold);
        let other = fan_fold(&quad, &Fan { apex: 0, fold: 0.0 }, DVec3::Z).unwrap();
        assert!((other - (1.0 / (1.0 + h * h)).acos()).abs() < 1e-12);
        assert_eq!(
            fan.triangles(4).collect::<Vec<_>>(),
            vec![[1, 2, 3], [1, 3, 0]]
        );
        // Lifting vertex 1 instead moves the crease to 0-2.
        let quad = [v(0., 0., 0.), v(1., 0., h), v(1., 1., 0.), v(0., 1., 0.)];
        assert_eq!(split(&quad).unwrap().unwrap().apex, 0);
    }

    #[test]
    fn a_concave_quad_is_cut_through_its_reflex_vertex() {
        // A dart: vertex 2 is reflex; only the diagonal 0-2 (the fan from 2, or from 0)
        // keeps both triangles inside.
        let dart = [v(0., 0., 0.), v(1., 0., 0.), v(0.3, 0.3, 0.), v(0., 1., 0.)];
        let fan = split(&dart).unwrap().unwrap();
        assert_eq!(fan.apex, 0);
        assert_eq!(fan.fold, 0.0);
        let tris: Vec<_> = fan.triangles(4).collect();
        assert_eq!(tris, vec![[0, 1, 2], [0, 2, 3]]);
        // The other diagonal would give a triangle facing the other way.
        assert_eq!(fan_fold(&dart, &Fan { apex: 1, fold: 0.0 }, DVec3::Z), None);
    }

    #[test]
    fn a_bow_tie_and_a_star_are_not_split() {
        // Lobes of unequal area (a symmetric bow tie has zero area and is refused as such).
        let bow = [v(0., 0., 0.), v(2., 0., 0.), v(0., 1., 0.), v(1., 1., 0.)];
        let e = split(&bow).unwrap_err();
        assert!(e.contains("no fan"), "{e}");
        let pts = [
            v(0.0, 1.0, 0.0),
            v(0.951, 0.309, 0.0),
            v(0.588, -0.809, 0.0),
            v(-0.588, -0.809, 0.0),
            v(-0.951, 0.309, 0.0),
        ];
        let star: Vec<DVec3> = (0..5).map(|k| pts[(2 * k) % 5]).collect();
        assert!(split(&star).unwrap_err().contains("no fan"));
        // Degenerate faces are refused before any split is tried.
        let line = [v(0., 0., 0.), v(1., 0., 0.), v(2., 0., 0.), v(3., 0., 0.)];
        assert!(split(&line).unwrap_err().contains("zero area"));
    }
}
