//! The shelling partitioner (the paper's §12.2.2): a low-resolution pass estimates the work
//! in each subregion of the source's hemisphere; recursive median splits turn the estimates
//! into sections (one per cluster, balancing intersections) and sectors (one per CTU,
//! balancing traversals); a high-resolution pass then works each sector through its shells
//! and subshells and measures the actual work, the patch loads and the schedule the
//! hardware will run.
//!
//! ```text
//! low-res rays ─► subregion bundles ─► counts ─► median splits ─► sections ─► sectors
//!  (N_low)        (shells.rs)          (lowres.rs)  (split.rs)         │
//! high-res rays (ratio × N_low) ─► sector bundles ─► actual work, loads, Schedule
//! ```
//!
//! **Invariant:** every high-resolution ray belongs to exactly one sector, and the sectors'
//! angle boxes tile the hemisphere (disjoint, covering it) — see [`angles`] and [`split`].
//!
//! **Invariant:** the nearest hit each ray gets from its sector's schedule equals the float
//! tracer's ([`crate::reference::tracer::Tracer::trace`], source excluded); a run counts the
//! disagreements (`nearest_hit_mismatches`), and the CLI fails when there are any.
//!
//! **Invariant:** deterministic: the same scene, configuration and seed give the same
//! partition, counts and schedule, whatever the thread count; reports hold no timings.

pub mod angles;
pub mod figures;
pub mod lowres;
pub mod report;
pub mod schedule;
pub mod shells;
pub mod split;

use crate::error::{Error, Result};
use crate::paper::{PAPER_RAYS, SUBREGIONS};
use crate::reference::rays::{
    check_source_and_rays, hemisphere_rays, Directions, Frame, Origins, RaySet,
};
use crate::reference::tracer::{Hit, Tracer};
use crate::scene::Scene;
use angles::{AngleBox, Angles, Axis, SubregionGrid};
use lowres::{LowRes, Workload};
use rayon::prelude::*;
use serde::Serialize;
use shells::{BundleRun, Caster, ShellParams};
use split::{Item, Positions};
use std::path::Path;

/// Most sections (clusters) a partition may have.
pub const MAX_SECTIONS: usize = 1024;
/// Most CTUs per cluster.
pub const MAX_CTUS: usize = 256;
/// Most rays in either pass (each keeps its walk in memory: about 1 kB per ray).
pub const MAX_PASS_RAYS: usize = 2_000_000;
/// Most shells a ray may cross (the grid's diagonal over the shell radius).
pub const MAX_SHELLS: f64 = 100_000.0;

/// Where sections and sectors may be cut.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Granularity {
    /// Only at subregion boundaries (the paper's 25 low-resolution sectors).
    Subregion,
    /// Between any two low-resolution ray directions (finer).
    Ray,
}

impl From<shellsim_hw::config::PartitionGranularity> for Granularity {
    fn from(g: shellsim_hw::config::PartitionGranularity) -> Self {
        match g {
            shellsim_hw::config::PartitionGranularity::Subregion => Granularity::Subregion,
            shellsim_hw::config::PartitionGranularity::Ray => Granularity::Ray,
        }
    }
}

/// Everything a partition depends on besides the scene.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Config {
    /// The source patch.
    pub source: u32,
    /// Sections P: one per cluster (ICU).
    pub sections: usize,
    /// Sectors per section K: one per CTU.
    pub ctus: usize,
    /// Hi_Low_Ratio: N_high = ratio × N_low.
    pub ratio: usize,
    /// N_low, the low-resolution ray count (ring directions).
    pub rays_low: usize,
    /// Subregion grid: θ × φ.
    pub subregions: (usize, usize),
    pub granularity: Granularity,
    /// Shell radius step.
    pub shell_radius: f64,
    /// Subshell threshold on new active patches.
    pub subshell_max: usize,
    /// Seed of the low-resolution origins; the high-resolution pass uses `seed + 1`, so
    /// its origins are independent of the low-resolution ones.
    pub seed: u64,
    /// Grid cell size.
    pub cell_size: f64,
}

impl Config {
    /// The paper's parameters (Table 12.1, [`crate::paper`]) for `sections` × `ctus` at
    /// `ratio`; the shell radius, cell size and subshell threshold of the built-in
    /// configuration (`machine.shell_radius`, `machine.cell_size`,
    /// `machine.subshell_max_patches`) for a scene of scale 1 (the unit cube; see
    /// [`Config::scaled_to`]).
    pub fn paper(source: u32, sections: usize, ctus: usize, ratio: usize) -> Config {
        Config {
            source,
            sections,
            ctus,
            ratio,
            rays_low: PAPER_RAYS,
            subregions: SUBREGIONS,
            granularity: Granularity::Subregion,
            shell_radius: ShellParams::default().radius,
            subshell_max: ShellParams::default().subshell_max,
            seed: 1,
            cell_size: crate::config::cell_size(
                crate::config::built_in().machine.cell_size,
                crate::config::SceneSize::of_scale(1.0),
            ),
        }
    }

    /// The built-in configuration's shell radius and cell size for a scene of `size`
    /// (`Scene::size`) instead of the unit cube's.
    pub fn scaled_to(mut self, size: crate::config::SceneSize) -> Config {
        let m = &crate::config::built_in().machine;
        self.shell_radius = crate::config::shell_radius(m.shell_radius, size.scale);
        self.cell_size = crate::config::cell_size(m.cell_size, size);
        self
    }

    /// The high-resolution ray count.
    pub fn rays_high(&self) -> usize {
        self.rays_low.saturating_mul(self.ratio)
    }

    fn shell_params(&self) -> ShellParams {
        ShellParams {
            radius: self.shell_radius,
            subshell_max: self.subshell_max,
        }
    }

    /// Checks the configuration against `scene` (read from `file`): bad values are
    /// `Error::Input` (a source that does not exist) or `Error::Param` naming the field
    /// (`sections`, `ratio`, `shell_radius`, ...; exit status 2).
    pub fn validate(&self, scene: &Scene, file: &Path) -> Result<()> {
        check_source_and_rays(scene, file, self.source, self.rays_low.max(1))?;
        let param = |key: &str, m: String| Err(Error::param(key, m));
        if !(1..=MAX_SECTIONS).contains(&self.sections) {
            return param(
                "sections",
                format!("{} is out of range (1..={MAX_SECTIONS})", self.sections),
            );
        }
        if !(1..=MAX_CTUS).contains(&self.ctus) {
            return param(
                "ctus",
                format!("{} is out of range (1..={MAX_CTUS})", self.ctus),
            );
        }
        if !(1..=MAX_PASS_RAYS).contains(&self.rays_low) {
            return param(
                "rays",
                format!("{} is out of range (1..={MAX_PASS_RAYS})", self.rays_low),
            );
        }
        if self.ratio == 0 || self.rays_high() > MAX_PASS_RAYS {
            return param(
                "ratio",
                format!(
                    "{} is out of range: at least 1, and ratio × {} rays at most {MAX_PASS_RAYS}",
                    self.ratio, self.rays_low
                ),
            );
        }
        let (a, b) = self.subregions;
        if !(1..=SubregionGrid::MAX_THETA).contains(&a)
            || !(1..=SubregionGrid::MAX_PHI).contains(&b)
        {
            return param(
                "subregions",
                format!(
                    "{a}x{b} is out of range (θ 1..={}, φ 1..={})",
                    SubregionGrid::MAX_THETA,
                    SubregionGrid::MAX_PHI
                ),
            );
        }
        let diag = scene.bounds.extent().length();
        if !(self.shell_radius.is_finite() && self.shell_radius > 0.0)
            || diag / self.shell_radius > MAX_SHELLS
        {
            return param(
                "shell_radius",
                format!(
                    "{} must be a finite number above 0 giving at most {MAX_SHELLS} shells across the scene (diagonal {diag})",
                    self.shell_radius
                ),
            );
        }
        if self.subshell_max == 0 {
            return param("subshell_max", "must be at least 1".into());
        }
        Ok(())
    }
}

/// The static partition: sections, each cut into sectors.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Plan {
    pub sections: Vec<SectionPlan>,
    /// Cuts made where no allowed position lay inside a box (see [`split`]).
    pub forced_splits: usize,
}

/// One section and its sectors.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SectionPlan {
    pub bounds: AngleBox,
    pub sectors: Vec<AngleBox>,
}

impl Plan {
    /// The (section, sector) holding direction `a`.
    pub fn locate(&self, a: Angles) -> (usize, usize) {
        for (i, s) in self.sections.iter().enumerate() {
            if s.bounds.contains(a) {
                for (j, b) in s.sectors.iter().enumerate() {
                    if b.contains(a) {
                        return (i, j);
                    }
                }
            }
        }
        unreachable!("the sectors tile the hemisphere: {a:?}")
    }

    /// Every sector's box, section-major.
    pub fn sector_boxes(&self) -> Vec<AngleBox> {
        self.sections
            .iter()
            .flat_map(|s| s.sectors.iter().copied())
            .collect()
    }
}

/// The items the splitter balances: subregions (at their lower corner) or rays, weighted
/// by `weight` of their low-resolution work.
fn items(low: &LowRes, g: Granularity, weight: impl Fn(&Workload) -> u64) -> Vec<Item> {
    match g {
        Granularity::Subregion => (0..low.grid.len())
            .map(|k| {
                let b = low.grid.box_of(k);
                Item {
                    at: Angles {
                        theta: b.theta[0],
                        phi: b.phi[0],
                    },
                    weight: weight(&low.work[k]),
                }
            })
            .collect(),
        Granularity::Ray => low
            .angles
            .iter()
            .zip(&low.ray_work)
            .map(|(a, w)| Item {
                at: *a,
                weight: weight(w),
            })
            .collect(),
    }
}

/// Sections by intersections, then sectors by traversals inside each section.
pub fn plan(low: &LowRes, g: Granularity, sections: usize, ctus: usize) -> Plan {
    let pos = match g {
        Granularity::Subregion => Positions::Boundaries {
            theta: low.grid.inner_bounds(Axis::Theta),
            phi: low.grid.inner_bounds(Axis::Phi),
        },
        Granularity::Ray => Positions::BetweenItems,
    };
    let by_isect = items(low, g, |w| w.intersections);
    let by_trav = items(low, g, |w| w.traversals);
    let top = split::split(AngleBox::HEMISPHERE, &by_isect, sections, Axis::Theta, pos);
    let mut forced = top.forced;
    let sections = top
        .boxes
        .into_iter()
        .zip(top.next_axis)
        .map(|(bounds, next)| {
            // One BSP tree: sectors carry on the sections' alternation of angles.
            let s = split::split(bounds, &by_trav, ctus, next, pos);
            forced += s.forced;
            SectionPlan {
                bounds,
                sectors: s.boxes,
            }
        })
        .collect();
    Plan {
        sections,
        forced_splits: forced,
    }
}

/// Low-resolution work inside `bx` (the items whose position lies in it), unscaled.
pub fn predicted_in(low: &LowRes, g: Granularity, bx: &AngleBox) -> Workload {
    let mut w = Workload::default();
    match g {
        Granularity::Subregion => {
            for (k, work) in low.work.iter().enumerate() {
                let b = low.grid.box_of(k);
                let corner = Angles {
                    theta: b.theta[0],
                    phi: b.phi[0],
                };
                if bx.contains(corner) {
                    w.add(work);
                }
            }
        }
        Granularity::Ray => {
            for (a, work) in low.angles.iter().zip(&low.ray_work) {
                if bx.contains(*a) {
                    w.add(work);
                }
            }
        }
    }
    w
}

/// One sector of the high-resolution pass.
#[derive(Clone, Debug)]
pub struct SectorRun {
    pub section: usize,
    /// Index within its section.
    pub sector: usize,
    pub bounds: AngleBox,
    /// High-resolution ray ids, ascending.
    pub rays: Vec<u32>,
    pub run: BundleRun,
    /// Low-resolution prediction (scaled by the ratio).
    pub predicted: Workload,
}

impl SectorRun {
    /// Its actual work.
    pub fn actual(&self) -> Workload {
        Workload::of_run(self.rays.len(), &self.run)
    }
}

/// A complete partition run.
#[derive(Clone, Debug)]
pub struct Partition {
    pub config: Config,
    pub scene: String,
    pub patches: usize,
    pub grid_dims: [usize; 3],
    pub low: LowRes,
    pub plan: Plan,
    pub high_rays: RaySet,
    /// Per high-resolution ray: its flat sector index (into `sectors`).
    pub sector_of: Vec<u32>,
    /// Sectors, section-major.
    pub sectors: Vec<SectorRun>,
    /// Per section: its low-resolution prediction (scaled by the ratio).
    pub predicted_sections: Vec<Workload>,
    /// Ray-by-ray baseline: Σ over rays of the distinct patches in the cells a ray steps
    /// through up to its hit (the source excluded).
    pub patch_loads_baseline: u64,
    /// Rays whose shelling nearest hit differs from the float tracer's (must be 0).
    pub nearest_hit_mismatches: u64,
    /// Per high-resolution ray: the float tracer's nearest hit (source excluded).
    pub reference: Vec<Option<Hit>>,
}

impl Partition {
    /// The float tracer's nearest hit of high-resolution ray `r`.
    pub fn reference_hit(&self, r: usize) -> Option<Hit> {
        self.reference[r]
    }

    /// Actual work per section.
    pub fn section_work(&self) -> Vec<Workload> {
        let mut v = vec![Workload::default(); self.plan.sections.len()];
        for s in &self.sectors {
            v[s.section].add(&s.actual());
        }
        v
    }

    /// Patches loaded with shelling: Σ over sectors of distinct patches.
    pub fn patch_loads(&self) -> u64 {
        self.sectors.iter().map(|s| s.run.patch_loads()).sum()
    }

    /// Max over mean of actual intersections per section (1 when there is no work).
    pub fn imbalance(&self) -> f64 {
        imbalance(self.section_work().iter().map(|w| w.intersections))
    }

    /// `Err(Error::Check)` when some ray's nearest hit from its sector's subshells differs
    /// from the float tracer's.
    pub fn verdict(&self) -> Result<()> {
        if self.nearest_hit_mismatches > 0 {
            return Err(Error::Check(format!(
                "{} rays got a different nearest hit from their sector's schedule than from the float tracer",
                self.nearest_hit_mismatches
            )));
        }
        Ok(())
    }

    /// Max over mean of predicted intersections per section.
    pub fn predicted_imbalance(&self) -> f64 {
        imbalance(self.predicted_sections.iter().map(|w| w.intersections))
    }
}

/// Max over mean (1 for no work or no parts).
pub fn imbalance(v: impl Iterator<Item = u64>) -> f64 {
    let v: Vec<u64> = v.collect();
    let total: u64 = v.iter().sum();
    if v.is_empty() || total == 0 {
        return 1.0;
    }
    *v.iter().max().unwrap() as f64 / (total as f64 / v.len() as f64)
}

/// The low-resolution pass and the static partition made from it.
fn low_res_plan(scene: &Scene, tracer: &Tracer, cfg: &Config) -> (LowRes, Plan) {
    let src = &scene.patches[cfg.source as usize];
    let frame = Frame::of_patch(src);
    let low_set = hemisphere_rays(
        src,
        cfg.rays_low,
        Directions::Rings,
        Origins::Patch,
        cfg.seed,
    );
    let low_caster = Caster::new(
        tracer,
        &low_set.rays,
        cfg.source,
        src.centroid(),
        cfg.shell_params(),
    );
    let grid = SubregionGrid::new(cfg.subregions.0, cfg.subregions.1);
    let low = lowres::low_res(&low_caster, &frame, grid);
    drop(low_caster);
    let plan = plan(&low, cfg.granularity, cfg.sections, cfg.ctus);
    (low, plan)
}

/// The machine's hand-off without the high-resolution pass: the low-resolution pass and
/// the static partition of [`partition`], then every ray of `rays` (any set over the
/// source's hemisphere) put into its sector. Returns `sectors[section][sector]`, each
/// sector's ray ids ascending. This is all the machine needs; it skips the float
/// shelling walk, the baseline and the self-check that [`partition`] adds for its report.
/// `cfg` must have passed [`Config::validate`].
pub fn sectors_for(
    scene: &Scene,
    tracer: &Tracer,
    cfg: &Config,
    rays: &RaySet,
) -> Vec<Vec<Vec<u32>>> {
    let frame = Frame::of_patch(&scene.patches[cfg.source as usize]);
    let (_, plan) = low_res_plan(scene, tracer, cfg);
    let mut out: Vec<Vec<Vec<u32>>> = plan
        .sections
        .iter()
        .map(|s| vec![Vec::new(); s.sectors.len()])
        .collect();
    for (r, ray) in rays.rays.iter().enumerate() {
        let (i, j) = plan.locate(Angles::of(&frame, ray.d));
        out[i][j].push(r as u32);
    }
    out
}

/// Runs the low-resolution pass, the static partition and the high-resolution pass.
/// `cfg` must have passed [`Config::validate`]; `tracer` must be built on `scene` with
/// `cfg.cell_size`.
pub fn partition(scene: &Scene, tracer: &Tracer, cfg: &Config) -> Partition {
    let src = &scene.patches[cfg.source as usize];
    let frame = Frame::of_patch(src);
    let centre = src.centroid();
    let params = cfg.shell_params();
    let (low, plan) = low_res_plan(scene, tracer, cfg);
    let ratio = cfg.ratio as u64;
    let predicted_sections = plan
        .sections
        .iter()
        .map(|s| predicted_in(&low, cfg.granularity, &s.bounds).scaled(ratio))
        .collect();
    // High resolution.
    let high_rays = hemisphere_rays(
        src,
        cfg.rays_high(),
        Directions::Rings,
        Origins::Patch,
        cfg.seed.wrapping_add(1),
    );
    let caster = Caster::new(tracer, &high_rays.rays, cfg.source, centre, params);
    let mut flat: Vec<(usize, usize, AngleBox)> = Vec::new();
    for (i, s) in plan.sections.iter().enumerate() {
        for (j, b) in s.sectors.iter().enumerate() {
            flat.push((i, j, *b));
        }
    }
    let mut sector_of = Vec::with_capacity(high_rays.len());
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); flat.len()];
    let base: Vec<usize> = plan
        .sections
        .iter()
        .scan(0, |acc, s| {
            let b = *acc;
            *acc += s.sectors.len();
            Some(b)
        })
        .collect();
    for (r, ray) in high_rays.rays.iter().enumerate() {
        let (i, j) = plan.locate(Angles::of(&frame, ray.d));
        let k = base[i] + j;
        sector_of.push(k as u32);
        members[k].push(r as u32);
    }
    let runs: Vec<BundleRun> = members
        .par_iter()
        .map(|ids| caster.run_bundle(ids))
        .collect();
    let sectors: Vec<SectorRun> = flat
        .into_iter()
        .zip(members)
        .zip(runs)
        .map(|(((section, sector, bounds), rays), run)| SectorRun {
            section,
            sector,
            bounds,
            predicted: predicted_in(&low, cfg.granularity, &bounds).scaled(ratio),
            rays,
            run,
        })
        .collect();
    // The float reference: the baseline's loads and the schedule's self-check.
    let mut shelled = vec![None; high_rays.len()];
    for s in &sectors {
        for (j, &r) in s.rays.iter().enumerate() {
            shelled[r as usize] = s.run.hits[j];
        }
    }
    let per_ray: Vec<(Option<Hit>, u64)> = high_rays
        .rays
        .par_iter()
        .with_min_len(256)
        .map(|ray| {
            let hit = tracer.trace(ray, Some(cfg.source));
            let mut seen: Vec<u32> = Vec::new();
            tracer.cells_along(ray, hit.map_or(f64::INFINITY, |h| h.t), |c, _, _| {
                seen.extend(
                    tracer
                        .grid()
                        .patches_in(c)
                        .iter()
                        .filter(|&&p| p != cfg.source),
                );
            });
            seen.sort_unstable();
            seen.dedup();
            (hit, seen.len() as u64)
        })
        .collect();
    let baseline = per_ray.iter().map(|x| x.1).sum();
    let reference: Vec<Option<Hit>> = per_ray.into_iter().map(|x| x.0).collect();
    let mismatches = reference
        .iter()
        .zip(&shelled)
        .filter(|(a, b)| a != b)
        .count() as u64;
    Partition {
        config: cfg.clone(),
        scene: scene.name.clone(),
        patches: scene.patches.len(),
        grid_dims: tracer.grid().dims,
        low,
        plan,
        high_rays,
        sector_of,
        sectors,
        predicted_sections,
        patch_loads_baseline: baseline,
        nearest_hit_mismatches: mismatches,
        reference,
    }
}
