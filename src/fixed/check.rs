//! The float reference against the untimed fixed-point model on the same rays: mismatches,
//! each put into an explained class (overflow, a tie in t, near an edge or vertex, grazing)
//! or reported as unexplained; t error in LSBs; form-factor error.

use crate::error::{Error, Result};
use crate::fixed::origin::Placement;
use crate::fixed::records::HostFixed;
use crate::output::write_json;
use crate::reference::cast::form_factors;
use crate::reference::rays::{RaySet, RaySpec};
use crate::reference::tracer::{Hit, PatchGeom, PreparedRay, Ray, Tracer};
use crate::scene::Scene;
use rayon::prelude::*;
use serde::Serialize;
use shellsim_hw::DatapathConfig;
use shellsim_hw::{Exceptions, FixedHit};
use std::path::Path;

/// Tolerances of the classes.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Tolerances {
    /// "Near an edge or vertex": the hit point within `edge_lsb · (1 + 2t) / |n·d|`
    /// coordinate LSBs of the patch's boundary (the quantized ray strays about an LSB per
    /// unit of t; on the patch's plane the stray grows by 1/|cos| of the incidence angle).
    pub edge_lsb: f64,
    /// "Tie in t": the two patches' float t within `tie_lsb · (1 + 2t)` t LSBs.
    pub tie_lsb: f64,
    /// "Grazing": |n·d| under this for a patch involved.
    pub grazing_cos: f64,
}

impl Default for Tolerances {
    fn default() -> Self {
        Tolerances {
            edge_lsb: 4.0,
            tie_lsb: 4.0,
            grazing_cos: 0.01,
        }
    }
}

/// Mismatch counts per class (each mismatch in the first class that explains it, checked
/// in the order overflow, near the origin, grazing, near an edge, tie).
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq, Eq)]
pub struct Classes {
    pub overflow: u64,
    pub near_origin: u64,
    pub grazing: u64,
    pub near_edge: u64,
    pub tie: u64,
}

impl Classes {
    /// The count of class `c`.
    pub fn of(&self, c: Class) -> u64 {
        match c {
            Class::Overflow => self.overflow,
            Class::NearOrigin => self.near_origin,
            Class::Grazing => self.grazing,
            Class::NearEdge => self.near_edge,
            Class::Tie => self.tie,
        }
    }

    fn of_mut(&mut self, c: Class) -> &mut u64 {
        match c {
            Class::Overflow => &mut self.overflow,
            Class::NearOrigin => &mut self.near_origin,
            Class::Grazing => &mut self.grazing,
            Class::NearEdge => &mut self.near_edge,
            Class::Tie => &mut self.tie,
        }
    }
}

/// One unexplained mismatch, with what it takes to reproduce it.
#[derive(Clone, Debug, Serialize)]
pub struct Unexplained {
    pub ray: usize,
    pub origin: [f64; 3],
    pub direction: [f64; 3],
    pub float_hit: Option<(u32, f64)>,
    pub fixed_hit: Option<(u32, f64)>,
}

/// The report of `shellsim check`.
#[derive(Clone, Debug, Serialize)]
pub struct CheckReport {
    pub format: String,
    pub rays: usize,
    pub mismatches: u64,
    pub classes: Classes,
    /// Rays in each class's zone, whether the models differ on them or not (ties: only the
    /// mismatches): a class explains its mismatches only while they are not most of its
    /// zone ([`CLASS_SHARE_MAX`]).
    pub zones: Classes,
    pub unexplained_mismatches: u64,
    pub t_err_max_lsb: f64,
    pub t_err_rms_lsb: f64,
    pub ff_err_max: f64,
    /// max over patches of the binomial sampling error √(F(1−F)/N) of the float estimate.
    pub ff_sampling_err: f64,
    pub exceptions: Exceptions,
    pub tolerances: Tolerances,
    pub unexplained: Vec<Unexplained>,
    /// Rays that hit nothing, per model.
    pub escaped_float: u64,
    pub escaped_fixed: u64,
    /// Rays the fixed-point model lost where the float reference hit a patch.
    pub leaked: u64,
    /// Of those, rays whose origin could not be placed 2 LSB clear of every patch
    /// (`crate::fixed::origin::Placement::Crowded`: a source a few LSBs wide, or a patch
    /// within 2 LSB of it) — where watertightness is not promised at this width.
    pub leaked_crowded: u64,
    /// Rays the fixed-point model lost although the float reference found a patch for them
    /// (the first 20, with where the float ray met the scene). From a closed scene every
    /// one is a failure.
    pub leaks: Vec<Leak>,
    /// The patch with the largest form-factor error, and that error in units of the float
    /// estimate's sampling error (`ff_err_max / ff_sampling_err`).
    pub ff_err_patch: Option<u32>,
    pub ff_err_sigmas: f64,
    /// When the patch of the largest error lies parallel to the source within 8 LSB of its
    /// plane, in front of it (a panel set just off it, like cornell's light under the
    /// ceiling): its gap in LSBs. The host cannot start a ray between the two below ~5 LSB.
    pub panel_gap_lsb: Option<f64>,
}

/// A ray the fixed-point model lost where the float reference hit a patch.
#[derive(Clone, Debug, Serialize)]
pub struct Leak {
    pub ray: usize,
    pub origin: [f64; 3],
    pub direction: [f64; 3],
    /// The patch the float ray met and the point where it met it: where the fixed-point ray
    /// left the scene.
    pub float_patch: u32,
    pub float_point: [f64; 3],
}

/// The share of a class's zone that may differ before the class stops explaining it: a
/// rounding flips some of the rays near an edge, the origin or grazing, not most — when
/// most differ (and they are more than [`CLASS_MASS_MIN`] of all rays, so that a handful
/// of grazing rays does not count), a scene defect or too few bits is the cause.
pub const CLASS_SHARE_MAX: f64 = 0.5;
/// The least share of all rays a class must hold for [`CLASS_SHARE_MAX`] to apply.
pub const CLASS_MASS_MIN: f64 = 0.005;

/// The form-factor error at which `check` fails, in units of the float estimate's sampling
/// error: above it, the fixed point — not the ray count — limits the result.
pub const FF_ERR_SIGMAS_MAX: f64 = 2.0;

/// Distance from `p` to the boundary of a polygon.
fn boundary_distance(g: &PatchGeom, p: glam::DVec3) -> f64 {
    let n = g.n_verts as usize;
    (0..n)
        .map(|k| {
            let a = g.v[k];
            let b = g.v[(k + 1) % n];
            let ab = b - a;
            let s = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
            p.distance(a + ab * s)
        })
        .fold(f64::INFINITY, f64::min)
}

/// Per-ray outcome.
struct Outcome {
    float: Option<Hit>,
    fixed: Option<FixedHit>,
    exc: Exceptions,
    class: Option<Option<Class>>,
    t_err_lsb: Option<f64>,
    crowded: bool,
    zone: Option<Class>,
}

/// The explained class of a difference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    Overflow,
    NearOrigin,
    Tie,
    NearEdge,
    Grazing,
}

impl Class {
    /// The class's name, as in [`Classes`].
    pub fn name(self) -> &'static str {
        match self {
            Class::Overflow => "overflow",
            Class::NearOrigin => "near_origin",
            Class::Tie => "tie",
            Class::NearEdge => "near_edge",
            Class::Grazing => "grazing",
        }
    }
}

/// Runs both models on `set` from `source` and classifies every difference.
pub fn check(
    tracer: &Tracer,
    host: &HostFixed,
    set: &RaySet,
    source: u32,
    tol: Tolerances,
) -> CheckReport {
    let f = *host.formats();
    // LSBs as scene lengths: the float reference works in scene units.
    let lsb_t = host.t_lsb();
    let outcomes: Vec<Outcome> = set
        .rays
        .par_iter()
        .enumerate()
        .map(|(i, ray)| {
            let float = tracer.trace(ray, Some(source));
            let mut exc = Exceptions::default();
            let placed = host.ray_placed(i as u32, ray, source);
            let crowded = placed.is_some_and(|(_, p)| p != Placement::Clear);
            let rec = placed.map(|(r, _)| r);
            let fixed = rec.and_then(|r| host.scene.nearest_grid(&r, Some(source), &mut exc).0);
            if rec.is_none() {
                exc.overflow += 1;
            }
            let same = match (float, fixed) {
                (None, None) => true,
                (Some(a), Some(b)) => a.patch == b.patch,
                _ => false,
            };
            let t_err_lsb = match (float, fixed) {
                (Some(a), Some(b)) if same => Some((host.t_f64(b.t) - a.t).abs() / lsb_t),
                _ => None,
            };
            let fixed_hit = fixed.map(|h| Hit {
                patch: h.patch,
                t: host.t_f64(h.t),
            });
            let overflow = exc.overflow > 0 || exc.t_saturated > 0;
            let shift = rec.map_or(0.0, |r| host.ray_back(&r).o.distance(ray.o));
            // The zone the ray lies in, whether or not the models differ on it: what each
            // class could explain, against what it is asked to.
            let zone = classify(
                tracer,
                host,
                ray,
                float,
                fixed_hit.or(float),
                overflow,
                shift,
                tol,
            );
            let class = (!same).then_some(zone);
            Outcome {
                float,
                fixed,
                exc,
                class,
                t_err_lsb,
                crowded,
                zone,
            }
        })
        .collect();
    let mut classes = Classes::default();
    let mut zones = Classes::default();
    let mut exceptions = Exceptions::default();
    let mut mismatches = 0;
    let mut unexplained = Vec::new();
    let mut unexplained_n = 0;
    let (mut escaped_float, mut escaped_fixed) = (0u64, 0u64);
    let mut leaks = Vec::new();
    let mut leaked = 0u64;
    let mut leaked_crowded = 0u64;
    let (mut t_max, mut t_sq, mut t_n) = (0.0f64, 0.0f64, 0usize);
    for (i, o) in outcomes.iter().enumerate() {
        exceptions.add(&o.exc);
        // (A tie needs the second patch, which a ray both models agree on does not name.)
        match (o.zone, o.class) {
            (Some(Class::Tie), None) | (None, _) => {}
            (Some(z), _) => *zones.of_mut(z) += 1,
        }
        escaped_float += o.float.is_none() as u64;
        escaped_fixed += o.fixed.is_none() as u64;
        let lost = o.float.is_some() && o.fixed.is_none();
        leaked += lost as u64;
        leaked_crowded += (lost && o.crowded) as u64;
        if let (Some(h), None, true) = (o.float, o.fixed, leaks.len() < 20) {
            let r = &set.rays[i];
            leaks.push(Leak {
                ray: i,
                origin: r.o.to_array(),
                direction: r.d.to_array(),
                float_patch: h.patch,
                float_point: (r.o + r.d * h.t).to_array(),
            });
        }
        if let Some(e) = o.t_err_lsb {
            t_max = t_max.max(e);
            t_sq += e * e;
            t_n += 1;
        }
        if let Some(c) = o.class {
            mismatches += 1;
            match c {
                Some(Class::Overflow) => classes.overflow += 1,
                Some(Class::NearOrigin) => classes.near_origin += 1,
                Some(Class::Tie) => classes.tie += 1,
                Some(Class::NearEdge) => classes.near_edge += 1,
                Some(Class::Grazing) => classes.grazing += 1,
                None => {
                    unexplained_n += 1;
                    if unexplained.len() < 20 {
                        let r = &set.rays[i];
                        unexplained.push(Unexplained {
                            ray: i,
                            origin: r.o.to_array(),
                            direction: r.d.to_array(),
                            float_hit: o.float.map(|h| (h.patch, h.t)),
                            fixed_hit: o.fixed.map(|h| (h.patch, host.t_f64(h.t))),
                        });
                    }
                }
            }
        }
    }
    let n = tracer.patches.len();
    let float_hits: Vec<Option<Hit>> = outcomes.iter().map(|o| o.float).collect();
    let fixed_hits: Vec<Option<Hit>> = outcomes
        .iter()
        .map(|o| {
            o.fixed.map(|h| Hit {
                patch: h.patch,
                t: host.t_f64(h.t),
            })
        })
        .collect();
    let (ff_a, _, _) = form_factors(&float_hits, &set.weights, n);
    let (ff_b, _, _) = form_factors(&fixed_hits, &set.weights, n);
    let mut dense = vec![0.0f64; n];
    for x in &ff_a {
        dense[x.patch as usize] += x.value;
    }
    let mut err = dense.clone();
    for x in &ff_b {
        err[x.patch as usize] -= x.value;
    }
    let (ff_err_patch, ff_err_max) =
        err.iter()
            .enumerate()
            .fold((None, 0.0f64), |(p, m), (j, e)| {
                if e.abs() > m {
                    (Some(j as u32), e.abs())
                } else {
                    (p, m)
                }
            });
    let nr = set.len() as f64;
    let ff_sampling_err = dense
        .iter()
        .fold(0.0f64, |m, &p| m.max((p * (1.0 - p) / nr).max(0.0).sqrt()));
    CheckReport {
        format: format!("coord {}, t {}", f.coord, f.t),
        rays: set.len(),
        mismatches,
        classes,
        zones,
        unexplained_mismatches: unexplained_n,
        t_err_max_lsb: t_max,
        t_err_rms_lsb: if t_n > 0 {
            (t_sq / t_n as f64).sqrt()
        } else {
            0.0
        },
        ff_err_max,
        ff_sampling_err,
        exceptions,
        tolerances: tol,
        unexplained,
        escaped_float,
        escaped_fixed,
        leaked,
        leaked_crowded,
        leaks,
        ff_err_patch,
        panel_gap_lsb: ff_err_patch.and_then(|j| panel_gap(tracer, host, source, j)),
        ff_err_sigmas: if ff_sampling_err > 0.0 {
            ff_err_max / ff_sampling_err
        } else if ff_err_max > 0.0 {
            f64::INFINITY
        } else {
            0.0
        },
    }
}

/// The gap, in coordinate LSBs, between the source's plane and patch `j` when `j` is
/// parallel to it and lies in front of it within 8 LSB (`None` otherwise).
fn panel_gap(tracer: &Tracer, host: &HostFixed, source: u32, j: u32) -> Option<f64> {
    // A check of rays that leave no patch (`source` names none) has no source's plane.
    let (s, p) = (
        tracer.patches.get(source as usize)?,
        &tracer.patches[j as usize],
    );
    if s.normal.dot(p.normal).abs() < 1.0 - 1e-9 {
        return None;
    }
    let n = p.n_verts as usize;
    let gap = p.v[..n]
        .iter()
        .map(|v| s.normal.dot(*v) - s.offset)
        .fold(f64::INFINITY, f64::min)
        / host.coord_lsb();
    (gap > 0.0 && gap < 8.0).then_some(gap)
}

/// Why two answers for `ray` disagree — `float` (the float reference's, or an exact one)
/// and `fixed` (the other model's, t as a scene length) — if an explained class covers it,
/// with LSBs of `host`'s formats; `overflow`: the datapath overflowed or saturated on it;
/// `shift`: how far the fixed-point ray's origin lies from the float one (a scene length:
/// the host places a ray leaving a patch a few LSBs inside it, `crate::fixed::origin`), by
/// which every zone below widens.
#[allow(clippy::too_many_arguments)]
pub fn classify(
    tracer: &Tracer,
    host: &HostFixed,
    ray: &Ray,
    float: Option<Hit>,
    fixed: Option<Hit>,
    overflow: bool,
    shift: f64,
    tol: Tolerances,
) -> Option<Class> {
    if overflow {
        return Some(Class::Overflow);
    }
    let lsb_c = host.coord_lsb();
    let lsb_t = host.t_lsb();
    let pr = PreparedRay::new(ray);
    let dn = ray.d.normalize();
    // The patches involved, with the float t at which the ray meets each one's plane.
    let mut involved: Vec<(u32, f64)> = Vec::new();
    if let Some(a) = float {
        involved.push((a.patch, a.t));
    }
    if let Some(b) = fixed {
        let g = &tracer.patches[b.patch as usize];
        let t = g.plane_t(&pr);
        let t = if t.is_finite() && t > 0.0 { t } else { b.t };
        involved.push((b.patch, t));
    }
    // A hit within a few LSBs of the origin: the quantized origin may lie on the other
    // side of that surface (rays leaving a patch where it meets another).
    let len = ray.d.length();
    if involved
        .iter()
        .any(|&(_, t)| t * len <= tol.edge_lsb * lsb_c + shift)
    {
        return Some(Class::NearOrigin);
    }
    for &(id, _) in &involved {
        if tracer.patches[id as usize].normal.dot(dn).abs() < tol.grazing_cos {
            return Some(Class::Grazing);
        }
    }
    for &(id, t) in &involved {
        let g = &tracer.patches[id as usize];
        let p = ray.o + ray.d * t;
        // The quantized ray strays about an LSB per unit of t from the float one; on the
        // patch's plane that offset grows by 1/|cos| of the incidence angle.
        let cos = g.normal.dot(dn).abs();
        if boundary_distance(g, p)
            <= (tol.edge_lsb * lsb_c * (1.0 + 2.0 * t / host.scale) + shift) / cos
        {
            return Some(Class::NearEdge);
        }
    }
    if let [(_, ta), (_, tb)] = involved[..] {
        let t = ta.max(tb);
        if (ta - tb).abs() <= tol.tie_lsb * lsb_t * (1.0 + 2.0 * t / host.scale) {
            return Some(Class::Tie);
        }
    }
    // Near the origin along a patch's normal: the source and a patch nearly parallel to it
    // lie within a few LSBs of each other (a light set just below a ceiling), so their
    // quantized planes may swap; a shallow ray then meets the neighbour at t ≈ LSB / |n·d|,
    // beyond the plain distance test above.
    for &(id, t) in &involved {
        let cos = tracer.patches[id as usize].normal.dot(dn).abs();
        if t * len * cos <= tol.edge_lsb * lsb_c + shift {
            return Some(Class::NearOrigin);
        }
    }
    None
}

/// Refuses a ray count whose float and fixed-point rays and results cannot fit the memory
/// limit (`crate::limits`), before anything is allocated.
pub fn check_memory(spec: &RaySpec) -> Result<()> {
    let per_ray = crate::reference::rays::ray_bytes()
        + std::mem::size_of::<shellsim_hw::RayRecord>() as u64
        + 2 * std::mem::size_of::<Option<shellsim_hw::FixedHit>>() as u64
        + 64;
    crate::limits::check_memory(
        "rays",
        &spec.rays.to_string(),
        "the float and fixed-point rays and their results",
        spec.rays as u64 * per_ray,
    )
}

/// The `check` job: checks `spec` against `scene` (read from `file`), builds the float
/// tracer and the fixed-point scene on cells of `cell` with `datapath`, and compares them
/// on the rays with the default tolerances.
pub fn check_scene(
    scene: &Scene,
    file: &Path,
    datapath: DatapathConfig,
    spec: &RaySpec,
    cell: f64,
) -> Result<CheckReport> {
    spec.validate(scene, file)?;
    check_memory(spec)?;
    let tracer = Tracer::new(scene, cell).map_err(|e| e.for_scene(file))?;
    let host = HostFixed::new(scene, file, datapath, cell)?;
    let set = spec.rays(scene);
    Ok(check(&tracer, &host, &set, spec.source, Default::default()))
}

impl CheckReport {
    /// `Err(Error::Check)` with what is wrong and what to try when (1) the fixed-point
    /// model lost a ray the float reference found a patch for while the float reference
    /// lost none (a leak from a scene closed as seen from the source); (2) the form-factor
    /// error exceeds [`FF_ERR_SIGMAS_MAX`] times the float estimate's own sampling error —
    /// then the classes, however they file the differences, do not account for their size
    /// (a panel set within 8 LSB in front of the source is named, with the bits it needs);
    /// (3) a class holds most of the rays in its zone ([`CLASS_SHARE_MAX`]); or (4) some
    /// mismatch has no explanation. The message points to the JSON report `written` when
    /// one was written.
    pub fn verdict(&self, written: Option<&Path>) -> Result<()> {
        let listed = written.map_or(String::new(), |p| format!(" (listed in {})", p.display()));
        let mut wrong = Vec::new();
        // A leak is a failure where the float reference lost none of these rays (the scene
        // is closed as seen from the source); elsewhere it is a mismatch, classified.
        if let (Some(l), 0) = (self.leaks.first(), self.escaped_float) {
            wrong.push(format!(
                "{} rays escaped the fixed-point model where the float reference hit a patch{listed}; \
                 the first, ray {} from ({:.6}, {:.6}, {:.6}) along ({:.6}, {:.6}, {:.6}), left \
                 through patch {} at ({:.6}, {:.6}, {:.6}){}",
                self.leaked,
                l.ray,
                l.origin[0], l.origin[1], l.origin[2],
                l.direction[0], l.direction[1], l.direction[2],
                l.float_patch,
                l.float_point[0], l.float_point[1], l.float_point[2],
                if self.leaked_crowded > 0 {
                    format!(
                        "; {} of them start where no origin lies 2 LSB clear of every patch (a source \
                         only a few LSBs wide, or a patch within 2 LSB of it): give the datapath more \
                         fractional bits",
                        self.leaked_crowded
                    )
                } else {
                    ": the scene is not closed in fixed point there (a crack between patches that \
                     do not share vertices)"
                        .to_string()
                },
            ));
        }
        if self.ff_err_sigmas > FF_ERR_SIGMAS_MAX {
            let patch = self
                .ff_err_patch
                .map_or(String::new(), |p| format!(" (patch {p})"));
            if let (Some(gap), Some(p)) = (self.panel_gap_lsb, self.ff_err_patch) {
                let more = (5.0 / gap).log2().ceil().max(1.0) as u32;
                wrong.push(format!(
                    "patch {p} lies {gap:.2} LSB in front of the source's plane, parallel to it: \
                     a ray cannot start between the two, so rays from the part it covers miss \
                     its back — give the datapath at least {more} more fractional bits"
                ));
            }
            wrong.push(format!(
                "the form-factor error {:.3e}{patch} is {:.1}× the float estimate's sampling error \
                 {:.3e} (at most {FF_ERR_SIGMAS_MAX}× passes): the fixed point, not the ray count, \
                 limits the result — {} of {} rays differ ({} near the origin, {} near an edge); \
                 try more fractional bits (--frac-bits), a finer cell, or look for patches \
                 within an LSB of each other",
                self.ff_err_max,
                self.ff_err_sigmas,
                self.ff_sampling_err,
                self.mismatches,
                self.rays,
                self.classes.near_origin,
                self.classes.near_edge,
            ));
        }
        for c in [Class::NearOrigin, Class::Grazing, Class::NearEdge] {
            let (m, z) = (self.classes.of(c), self.zones.of(c));
            if m as f64 > CLASS_SHARE_MAX * z as f64 && m as f64 > CLASS_MASS_MIN * self.rays as f64
            {
                wrong.push(format!(
                    "class {}: {m} of the {z} rays in its zone differ ({:.0} %, {:.1} % of all rays) — \
                     rounding flips some of the rays it covers, not most, so it does not account \
                     for them; look for a scene defect (a patch within an LSB of the source, \
                     duplicated faces) or give the datapath more fractional bits",
                    c.name(),
                    100.0 * m as f64 / z.max(1) as f64,
                    100.0 * m as f64 / self.rays.max(1) as f64
                ));
            }
        }
        if self.unexplained_mismatches > 0 {
            wrong.push(format!(
                "{} unexplained mismatches{listed}",
                self.unexplained_mismatches
            ));
        }
        if wrong.is_empty() {
            Ok(())
        } else {
            Err(Error::Check(wrong.join("; ")))
        }
    }

    /// Writes the report with the datapath it ran on as JSON to `path`.
    pub fn write_json(&self, path: &Path, datapath: DatapathConfig) -> Result<()> {
        #[derive(Serialize)]
        struct Out<'a> {
            datapath: DatapathConfig,
            #[serde(flatten)]
            report: &'a CheckReport,
        }
        write_json(
            path,
            &Out {
                datapath,
                report: self,
            },
        )
    }
}
