//! The partition report: what `shellsim partition --json` writes and the terminal table.
//!
//! **Invariant:** the report holds no timing, so the same inputs give a byte-identical file.
//! Counts are the machine's (see [`super::shells`]): `intersections` = remaining rays ×
//! active patches summed over subshells, `traversals` = cell steps of remaining rays,
//! `patch_loads` = distinct patches per sector summed; `predicted_*` = the low-resolution
//! counts of the items inside the box, times the ratio.

use super::angles::AngleBox;
use super::lowres::Workload;
use super::{imbalance, Granularity, Partition};
use serde::Serialize;

/// The whole report.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    pub scene: String,
    pub patches: usize,
    pub source: u32,
    /// P: sections, one per cluster (ICU).
    pub clusters: usize,
    /// K: sectors per section, one per CTU.
    pub ctus: usize,
    /// Hi_Low_Ratio.
    pub ratio: usize,
    pub rays_low: usize,
    pub rays_high: usize,
    /// Subregion grid, θ × φ.
    pub subregions: [usize; 2],
    pub granularity: Granularity,
    pub shell_radius: f64,
    pub subshell_max: usize,
    pub cell_size: f64,
    pub seed: u64,
    /// Max over mean of actual intersections per section.
    pub imbalance: f64,
    /// Max over mean of predicted intersections per section.
    pub predicted_imbalance: f64,
    /// Worst section's max over mean of actual traversals per sector (CTU balance).
    pub sector_imbalance: f64,
    pub intersections: u64,
    pub traversals: u64,
    /// Patches loaded with shelling (each once per sector).
    pub patch_loads: u64,
    /// Ray-by-ray baseline: each ray loads the distinct patches of the cells it steps
    /// through up to its hit.
    pub patch_loads_baseline: u64,
    /// `patch_loads / patch_loads_baseline`.
    pub patch_load_ratio: f64,
    /// Cuts made where the granularity allowed none (see `split`).
    pub forced_splits: usize,
    /// High-resolution rays whose shelling nearest hit differs from the float tracer's.
    pub nearest_hit_mismatches: u64,
    pub sections: Vec<SectionReport>,
    /// The low-resolution pass, per subregion.
    pub low_resolution: Vec<BoxReport>,
}

/// What a section and a sector report alike: its box and actual work (as a low-resolution
/// box reports them) and the low-resolution prediction. Flattened into both, so their JSON
/// lists these fields first.
#[derive(Clone, Debug, Serialize)]
pub struct PartReport {
    /// Index among the partition's sections, or within its section for a sector; the box
    /// and the actual work of the high-resolution pass.
    #[serde(flatten)]
    pub actual: BoxReport,
    pub predicted_rays: u64,
    pub predicted_intersections: u64,
    pub predicted_traversals: u64,
}

impl PartReport {
    fn new(index: usize, bounds: &AngleBox, actual: &Workload, predicted: &Workload) -> Self {
        PartReport {
            actual: BoxReport::new(index, bounds, actual),
            predicted_rays: predicted.rays,
            predicted_intersections: predicted.intersections,
            predicted_traversals: predicted.traversals,
        }
    }
}

/// One section (cluster).
#[derive(Clone, Debug, Serialize)]
pub struct SectionReport {
    #[serde(flatten)]
    pub part: PartReport,
    pub sectors: Vec<SectorReport>,
}

/// One sector (CTU).
#[derive(Clone, Debug, Serialize)]
pub struct SectorReport {
    #[serde(flatten)]
    pub part: PartReport,
    /// Shells with work, and subshells in all.
    pub shells: usize,
    pub subshells: usize,
}

/// A box of the low-resolution pass (a subregion).
#[derive(Clone, Debug, Serialize)]
pub struct BoxReport {
    pub index: usize,
    pub theta_deg: [f64; 2],
    pub phi_deg: [f64; 2],
    pub rays: u64,
    pub intersections: u64,
    pub traversals: u64,
    pub patch_loads: u64,
}

impl BoxReport {
    fn new(index: usize, bounds: &AngleBox, w: &Workload) -> Self {
        BoxReport {
            index,
            theta_deg: bounds.theta_deg(),
            phi_deg: bounds.phi_deg(),
            rays: w.rays,
            intersections: w.intersections,
            traversals: w.traversals,
            patch_loads: w.patch_loads,
        }
    }
}

impl Report {
    /// The report of a run.
    pub fn new(p: &Partition) -> Report {
        let c = &p.config;
        let work = p.section_work();
        let sections: Vec<SectionReport> = p
            .plan
            .sections
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let w = &work[i];
                let pr = &p.predicted_sections[i];
                let sectors = p
                    .sectors
                    .iter()
                    .filter(|x| x.section == i)
                    .map(|x| {
                        let a = x.actual();
                        SectorReport {
                            part: PartReport::new(x.sector, &x.bounds, &a, &x.predicted),
                            shells: x.run.shells(),
                            subshells: x.run.subshells.len(),
                        }
                    })
                    .collect();
                SectionReport {
                    part: PartReport::new(i, &s.bounds, w, pr),
                    sectors,
                }
            })
            .collect();
        let sector_imbalance = sections
            .iter()
            .map(|s| imbalance(s.sectors.iter().map(|x| x.part.actual.traversals)))
            .fold(1.0f64, f64::max);
        let total = work.iter().fold(Workload::default(), |mut a, w| {
            a.add(w);
            a
        });
        let loads = p.patch_loads();
        Report {
            scene: p.scene.clone(),
            patches: p.patches,
            source: c.source,
            clusters: c.sections,
            ctus: c.ctus,
            ratio: c.ratio,
            rays_low: c.rays_low,
            rays_high: c.rays_high(),
            subregions: [c.subregions.0, c.subregions.1],
            granularity: c.granularity,
            shell_radius: c.shell_radius,
            subshell_max: c.subshell_max,
            cell_size: c.cell_size,
            seed: c.seed,
            imbalance: p.imbalance(),
            predicted_imbalance: p.predicted_imbalance(),
            sector_imbalance,
            intersections: total.intersections,
            traversals: total.traversals,
            patch_loads: loads,
            patch_loads_baseline: p.patch_loads_baseline,
            patch_load_ratio: loads as f64 / (p.patch_loads_baseline.max(1)) as f64,
            forced_splits: p.plan.forced_splits,
            nearest_hit_mismatches: p.nearest_hit_mismatches,
            sections,
            low_resolution: p
                .low
                .work
                .iter()
                .enumerate()
                .map(|(k, w)| BoxReport::new(k, &p.low.grid.box_of(k), w))
                .collect(),
        }
    }

    /// Pretty JSON with a final newline.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a report serializes") + "\n"
    }

    /// The terminal summary.
    pub fn print(&self) {
        crate::output::outln!(
            "{} from patch {}: {} sections × {} CTUs, {} low-res rays ({}×{} subregions, {} granularity), ratio {} → {} high-res rays",
            self.scene,
            self.source,
            self.clusters,
            self.ctus,
            self.rays_low,
            self.subregions[0],
            self.subregions[1],
            match self.granularity {
                Granularity::Subregion => "subregion",
                Granularity::Ray => "ray",
            },
            self.ratio,
            self.rays_high
        );
        crate::output::outln!(
            "{:>7}  {:>15}  {:>15}  {:>8}  {:>7}  {:>12}  {:>8}  {:>7}",
            "section",
            "θ (deg)",
            "φ (deg)",
            "rays",
            "sectors",
            "intersect.",
            "pred.",
            "loads"
        );
        for s in &self.sections {
            crate::output::outln!(
                "{:>7}  {:>6.2}–{:<8.2}  {:>6.2}–{:<8.2}  {:>8}  {:>7}  {:>12}  {:>+7.1}%  {:>7}",
                s.part.actual.index,
                s.part.actual.theta_deg[0],
                s.part.actual.theta_deg[1],
                s.part.actual.phi_deg[0],
                s.part.actual.phi_deg[1],
                s.part.actual.rays,
                s.sectors.len(),
                s.part.actual.intersections,
                100.0
                    * (s.part.predicted_intersections as f64
                        / s.part.actual.intersections.max(1) as f64
                        - 1.0),
                s.part.actual.patch_loads
            );
        }
        crate::output::outln!(
            "imbalance (max/mean intersections per section): {:.3} actual, {:.3} predicted; worst CTU imbalance (traversals) {:.3}",
            self.imbalance, self.predicted_imbalance, self.sector_imbalance
        );
        crate::output::outln!(
            "patch loads: {} with shelling, {} ray by ray (ratio {:.3}); {} intersections, {} traversals",
            self.patch_loads,
            self.patch_loads_baseline,
            self.patch_load_ratio,
            self.intersections,
            self.traversals
        );
        if self.forced_splits > 0 {
            crate::output::outln!(
                "note: {} cut(s) fell where the {} granularity allows none (more parts than positions); those parts are cut geometrically",
                self.forced_splits,
                match self.granularity {
                    Granularity::Subregion => "subregion",
                    Granularity::Ray => "ray",
                }
            );
        }
        crate::output::outln!(
            "nearest hits vs float tracer: {} mismatches",
            self.nearest_hit_mismatches
        );
    }
}
