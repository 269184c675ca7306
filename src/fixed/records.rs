//! Host side of the fixed-point model: converts a scene into patch records and a cell table,
//! and rays into ray records, for a datapath configuration. A value that does not fit its
//! format is an error naming it, never a silent wrap.
//!
//! The hardware's coordinates are the scene's relative to the grid origin (the bounds' low
//! corner) over the scene's scale (its largest extent, `Scene::scale`): every scene reaches
//! the datapath in [0, 1]³, so the formats of the unit cube fit any scene in any units, the
//! LSB is the scale × 2^-F, and a scene scaled and moved gives the hardware the same numbers
//! (up to the float rounding of the conversion). t is in the same units.

use crate::error::{Error, Result};
use crate::fixed::origin::{newell, place, rises, Placement};
use crate::reference::grid::polygon_touches_box;
use crate::reference::tracer::Ray;
use crate::scene::{Aabb, Scene};
use glam::DVec3;
use shellsim_hw::config::{DatapathConfig, Formats};
use shellsim_hw::datapath::record::{CellTable, PatchRecord, RayRecord, PATCH_ID_BITS};
use shellsim_hw::FixedScene;
use std::path::Path;

/// A scene converted for the hardware, with what the host needs to convert rays.
#[derive(Clone, Debug)]
pub struct HostFixed {
    pub scene: FixedScene,
    pub config: DatapathConfig,
    /// The grid origin: coordinates are stored relative to it.
    pub origin: DVec3,
    /// The scene's scale: hardware coordinates and t are scene lengths over it.
    pub scale: f64,
    /// Each patch's unit normal in the scene (float): the front side of a patch whose
    /// quantized vertices collapse (smaller than an LSB), for placing its rays' origins.
    pub normals: Vec<DVec3>,
}

impl HostFixed {
    /// Converts `scene` (named `file` in errors) with cells of `cell` (scene units) for
    /// `config`.
    pub fn new(scene: &Scene, file: &Path, config: DatapathConfig, cell: f64) -> Result<HostFixed> {
        let f = config
            .formats()
            .map_err(|e| Error::input(Path::new("<datapath config>"), e.key, e.what))?;
        if scene.patches.len() > 1 << PATCH_ID_BITS {
            return Err(Error::input(
                file,
                "patches",
                "more patches than 24-bit ids can name",
            ));
        }
        let origin = scene.bounds.lo;
        let scale = scene.bounds.scale();
        if !(scale.is_finite() && scale > 0.0) {
            return Err(Error::input(
                file,
                "bounds",
                format!("the largest extent {scale} is not a positive length"),
            ));
        }
        let q = |x: f64, what: &dyn Fn() -> String| -> Result<i64> {
            f.coord.quantize(x).ok_or_else(|| {
                Error::input(
                    file,
                    what(),
                    format!(
                        "{x} does not fit the coordinate format {} (range ±{}): widen coord_int_bits",
                        f.coord,
                        (f.coord.int_bits as f64 - 1.0).exp2()
                    ),
                )
            })
        };
        let mut patches = Vec::with_capacity(scene.patches.len());
        for (id, p) in scene.patches.iter().enumerate() {
            // Triangles repeat their last vertex: every record has four.
            let mut v = [[0i64; 3]; 4];
            for (k, vk) in v.iter_mut().enumerate() {
                let src = (p.vertices[k.min(p.vertices.len() - 1)] - origin) / scale;
                for a in 0..3 {
                    vk[a] = q(src[a], &|| format!("patch {id} vertex {k}"))?;
                }
            }
            patches.push(PatchRecord {
                id: id as u32,
                n_verts: p.vertices.len() as u8,
                v,
            });
        }
        let cells = cell_table(scene, file, &patches, &f, &config, cell / scale)?;
        Ok(HostFixed {
            scene: FixedScene {
                formats: f,
                patches,
                cells,
                twins: scene.twins(),
            },
            config,
            origin,
            scale,
            normals: scene.patches.iter().map(|p| p.normal()).collect(),
        })
    }

    /// The formats in use.
    pub fn formats(&self) -> &Formats {
        &self.scene.formats
    }

    /// The ray record of `ray` (id `id`): origin relative to the grid origin over the scale,
    /// and unit direction, each rounded to nearest. `None` if a value does not fit or the
    /// direction rounds to 0.
    pub fn ray(&self, id: u32, ray: &Ray) -> Option<RayRecord> {
        self.ray_with(id, ray)
    }

    /// The ray record of a ray leaving patch `source`: its origin placed inside the scene,
    /// clear of every patch by more than the datapath's rounding can move one
    /// ([`crate::fixed::origin`]: a few LSBs inside the quantized source polygon and off its
    /// plane), and its direction turned an LSB towards the source's normal where the rounded
    /// shear would not rise away from the source. From a closed scene such a ray cannot
    /// escape in the fixed-point model. `None` if a value does not fit.
    pub fn ray_from(&self, id: u32, ray: &Ray, source: u32) -> Option<RayRecord> {
        self.ray_placed(id, ray, source).map(|(r, _)| r)
    }

    /// As [`HostFixed::ray_from`], with how the origin was placed.
    pub fn ray_placed(&self, id: u32, ray: &Ray, source: u32) -> Option<(RayRecord, Placement)> {
        let f = self.formats();
        let p = self.scene.patches.get(source as usize)?;
        let o = (ray.o - self.origin) / self.scale * (f.coord.frac_bits as f64).exp2();
        let fallback = self.normals[source as usize];
        let (oq, placement) = place(o, source, &self.scene, fallback)?;
        if !oq.iter().all(|&c| f.coord.fits(c as i128)) {
            return None;
        }
        let mut dq = self.direction(ray)?;
        let mut n = newell(&p.v[..p.n_verts as usize]);
        if n == [0; 3] {
            // Collapsed at this width: the scene's normal, to 2^-20.
            n = fallback
                .to_array()
                .map(|x| (x * (1u64 << 20) as f64).round() as i128);
        }
        let a = (0..3).max_by_key(|&a| n[a].unsigned_abs()).unwrap_or(2);
        let shear_one = 1i128 << f.shear.frac_bits;
        // A grazing direction whose rounding turned it along or behind the source: an LSB
        // at a time towards the normal (a handful of steps at most).
        for _ in 0..64 {
            let r = RayRecord::new(id, oq, dq, f);
            if rises(&r, n, shear_one) {
                return Some((r, placement));
            }
            dq[a] += n[a].signum() as i64;
            if !f.dir.fits(dq[a] as i128) {
                return None;
            }
        }
        None
    }

    /// The unit direction of `ray`, rounded to the direction format; `None` if it does not
    /// fit or rounds to 0.
    fn direction(&self, ray: &Ray) -> Option<[i64; 3]> {
        let f = self.formats();
        let d = ray.d / ray.d.length();
        let dq = [
            f.dir.quantize(d.x)?,
            f.dir.quantize(d.y)?,
            f.dir.quantize(d.z)?,
        ];
        (dq != [0, 0, 0]).then_some(dq)
    }

    fn ray_with(&self, id: u32, ray: &Ray) -> Option<RayRecord> {
        let f = self.formats();
        let o = (ray.o - self.origin) / self.scale;
        let oq = [
            f.coord.quantize(o.x)?,
            f.coord.quantize(o.y)?,
            f.coord.quantize(o.z)?,
        ];
        Some(RayRecord::new(id, oq, self.direction(ray)?, f))
    }

    /// The float ray the record stands for (quantized origin and direction, as f64).
    pub fn ray_back(&self, r: &RayRecord) -> Ray {
        let f = self.formats();
        let c = |x: i64| f.coord.to_f64(x as i128);
        let d = |x: i64| f.dir.to_f64(x as i128);
        Ray {
            o: self.origin + DVec3::new(c(r.o[0]), c(r.o[1]), c(r.o[2])) * self.scale,
            d: DVec3::new(d(r.d[0]), d(r.d[1]), d(r.d[2])),
        }
    }

    /// t of the t format as a scene length (f64).
    pub fn t_f64(&self, t: i64) -> f64 {
        self.formats().t.to_f64(t as i128) * self.scale
    }

    /// The coordinate LSB as a scene length.
    pub fn coord_lsb(&self) -> f64 {
        self.formats().coord.lsb() * self.scale
    }

    /// The t LSB as a scene length.
    pub fn t_lsb(&self) -> f64 {
        self.formats().t.lsb() * self.scale
    }
}

/// The cell table on the fixed-point grid: cubes of `round(cell · 2^F)` LSBs from the grid
/// origin (`cell` in hardware units: scene units over the scale). A patch is listed in every cell its quantized polygon comes within
/// `cell_margin_lsb` LSBs of (the separating-axis test on exact values of the raw integers).
fn cell_table(
    scene: &Scene,
    file: &Path,
    patches: &[PatchRecord],
    f: &Formats,
    cfg: &DatapathConfig,
    cell: f64,
) -> Result<CellTable> {
    let here = file;
    let cell_raw = f.coord.quantize(cell).filter(|&c| c > 0).ok_or_else(|| {
        Error::input(
            here,
            "cell size",
            format!(
                "{} is not a positive coordinate in {}",
                crate::error::short(cell),
                f.coord
            ),
        )
    })?;
    let ext = scene.bounds.extent() / scene.bounds.scale();
    let mut dims = [0u32; 3];
    for a in 0..3 {
        let e = f.coord.quantize(ext[a]).ok_or_else(|| {
            Error::input(
                file,
                "bounds",
                format!(
                    "extent {} does not fit {}",
                    crate::error::short(ext[a]),
                    f.coord
                ),
            )
        })?;
        let n = (e + cell_raw - 1) / cell_raw;
        if !(1..=4096).contains(&n) {
            return Err(Error::input(
                here,
                "cell size",
                format!("{n} cells along axis {a}"),
            ));
        }
        dims[a] = n as u32;
    }
    let total = (dims[0] * dims[1] * dims[2]) as usize;
    if total > crate::reference::grid::MAX_CELLS {
        return Err(Error::input(here, "cell size", format!("{total} cells")));
    }
    let lsb = f.coord.lsb();
    let cw = cell_raw as f64 * lsb;
    let margin = cfg.cell_margin_lsb as f64 * lsb;
    let mut lists: Vec<Vec<u32>> = vec![Vec::new(); total];
    for p in patches {
        let n = p.n_verts as usize;
        let verts: Vec<DVec3> = p.v[..n]
            .iter()
            .map(|v| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64) * lsb)
            .collect();
        let lo = verts.iter().copied().reduce(DVec3::min).unwrap();
        let hi = verts.iter().copied().reduce(DVec3::max).unwrap();
        let mut r0 = [0u32; 3];
        let mut r1 = [0u32; 3];
        for a in 0..3 {
            let c0 = ((lo[a] - margin) / cw).floor() - 1.0;
            let c1 = ((hi[a] + margin) / cw).floor() + 1.0;
            r0[a] = c0.clamp(0.0, dims[a] as f64 - 1.0) as u32;
            r1[a] = c1.clamp(0.0, dims[a] as f64 - 1.0) as u32;
        }
        let normal = crate::scene::Patch::new(verts.clone(), 0.0, 0.0).area_vector();
        for k in r0[2]..=r1[2] {
            for j in r0[1]..=r1[1] {
                for i in r0[0]..=r1[0] {
                    let b = Aabb {
                        lo: DVec3::new(i as f64, j as f64, k as f64) * cw - DVec3::splat(margin),
                        hi: DVec3::new(i as f64 + 1.0, j as f64 + 1.0, k as f64 + 1.0) * cw
                            + DVec3::splat(margin),
                    };
                    if polygon_touches_box(&verts, normal, &b, cw) {
                        lists[(i + dims[0] * (j + dims[1] * k)) as usize].push(p.id);
                    }
                }
            }
        }
    }
    let mut first = Vec::with_capacity(total);
    let mut count = Vec::with_capacity(total);
    let mut ids = Vec::new();
    for (c, l) in lists.into_iter().enumerate() {
        if l.len() > u16::MAX as usize {
            return Err(Error::input(
                here,
                format!("cell {c}"),
                format!("{} patches in one cell (at most 65535)", l.len()),
            ));
        }
        first.push(ids.len() as u32);
        count.push(l.len() as u16);
        ids.extend(l);
    }
    Ok(CellTable {
        dims,
        cell_raw,
        first,
        count,
        ids,
    })
}
