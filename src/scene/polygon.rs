//! The one polygon check, for patches and for OBJ faces before they are split into
//! triangle fans: finite vertices in range, then a planar, strictly convex polygon of
//! nonzero area that winds once around (no star polygons).
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
    let v = &local[..];
    let av = area_vector(v);
    let area = 0.5 * av.length();
    if area.is_nan() || area <= 1e-12 * diam * diam || area == 0.0 {
        return Err(format!(
            "has zero area ({area:e}): its vertices are collinear"
        ));
    }
    let normal = av / av.length();
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
