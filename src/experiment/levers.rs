//! The levers that keep eight ICUs busy (issue 36), each measured on its own on top of the
//! best machine variant (`job_source = "bundle"`, `overlap_joins`), then together as
//! hw/configs/balanced.toml: same-work speedup at 8 ICUs on scene2 (Fig 12.15's setting) and
//! balancing's gain there and on stress-skewed. Part of `shellsim paper`.

use super::{speedup, SpeedupRow, Workload};
use crate::error::Result;
use crate::paper::{AIM, PAPER_RATIO, SPEEDUP_CLUSTERS, WORK_ITEM_CLUSTERS};
use rayon::prelude::*;
use shellsim_hw::config::{
    DescriptorOrder, JobSource, MachineConfig, PartitionGranularity, VictimPolicy,
};
use std::fmt::Write as _;

/// `scan_ids_per_cycle` of the scan lever.
pub const WIDE_SCAN: u32 = 4;

/// One configuration of the ladder: its name and what it changes on `base`.
#[derive(Clone, Copy, Debug)]
pub struct Lever {
    pub name: &'static str,
    pub scan_ids_per_cycle: u32,
    pub largest_first: bool,
    pub ray_cuts: bool,
    pub round_robin_victim: bool,
}

/// The ladder: the best variant, each lever alone on it, the two that pay together (the
/// `balanced` configuration), and the scan lever on top of those.
pub const LADDER: [Lever; 7] = [
    Lever::new(
        "bundle + overlap_joins (the best variant)",
        1,
        false,
        false,
        false,
    ),
    Lever::new("+ scan_ids_per_cycle = 4", WIDE_SCAN, false, false, false),
    Lever::new("+ descriptor_order = largest-first", 1, true, false, false),
    Lever::new("+ partition_granularity = ray", 1, false, true, false),
    Lever::new("+ victim = round-robin", 1, false, false, true),
    Lever::new(BALANCED, 1, false, true, true),
    Lever::new(
        "balanced + scan_ids_per_cycle = 4",
        WIDE_SCAN,
        false,
        true,
        true,
    ),
];

/// The ladder's name for hw/configs/balanced.toml.
pub const BALANCED: &str = "balanced: + ray cuts + round-robin victim";

impl Lever {
    const fn new(
        name: &'static str,
        scan_ids_per_cycle: u32,
        largest_first: bool,
        ray_cuts: bool,
        round_robin_victim: bool,
    ) -> Lever {
        Lever {
            name,
            scan_ids_per_cycle,
            largest_first,
            ray_cuts,
            round_robin_victim,
        }
    }

    /// `base` with the best variant and this lever.
    pub fn config(&self, base: &MachineConfig) -> MachineConfig {
        let mut c = *base;
        let m = &mut c.machine;
        m.job_source = JobSource::Bundle;
        m.overlap_joins = true;
        m.scan_ids_per_cycle = self.scan_ids_per_cycle;
        if self.largest_first {
            m.descriptor_order = DescriptorOrder::LargestFirst;
        }
        if self.ray_cuts {
            m.partition_granularity = PartitionGranularity::Ray;
        }
        if self.round_robin_victim {
            c.balance.victim = VictimPolicy::RoundRobin;
        }
        c
    }
}

/// A lever measured, balancing off and on: Fig 12.15's P on scene2, P = 1 and 8 on
/// stress-skewed.
#[derive(Clone, Debug)]
pub struct LeverRow {
    pub lever: Lever,
    pub scene2: Vec<SpeedupRow>,
    pub skewed: Vec<SpeedupRow>,
}

impl LeverRow {
    /// Same-work speedup at 8 ICUs on scene2 (`on`: balancing).
    pub fn at8(rows: &[SpeedupRow], on: bool) -> Option<&SpeedupRow> {
        rows.iter()
            .find(|r| r.point.clusters == WORK_ITEM_CLUSTERS && r.point.balance == on)
    }
}

/// Every lever of [`LADDER`] on `base`, on scene2 (`w2`) and stress-skewed (`wk`).
pub fn measure(w2: &Workload, wk: &Workload, base: &MachineConfig) -> Result<Vec<LeverRow>> {
    LADDER
        .par_iter()
        .map(|l| {
            let c = l.config(base);
            Ok(LeverRow {
                lever: *l,
                scene2: speedup(
                    &Workload { base: &c, ..*w2 },
                    &SPEEDUP_CLUSTERS,
                    PAPER_RATIO,
                )?,
                skewed: speedup(
                    &Workload { base: &c, ..*wk },
                    &[1, WORK_ITEM_CLUSTERS],
                    PAPER_RATIO,
                )?,
            })
        })
        .collect()
}

/// The ladder as CSV: one line per lever, scene and balancing at 8 ICUs.
pub fn csv(rows: &[LeverRow]) -> String {
    let mut s = format!(
        "lever,scene,{},t1_same_work,speedup_same_work\n",
        super::POINT_HEADER
    );
    for r in rows {
        for (scene, rs) in [("scene2", &r.scene2), ("stress-skewed", &r.skewed)] {
            for on in [false, true] {
                if let Some(x) = LeverRow::at8(rs, on) {
                    let _ = writeln!(
                        s,
                        "\"{}\",{scene},{},{},{:.6}",
                        r.lever.name,
                        super::point_csv(&x.point),
                        x.t1_same_work,
                        x.speedup_same_work
                    );
                }
            }
        }
    }
    s
}

/// The report's section (markdown).
pub fn section(rows: &[LeverRow]) -> String {
    let mut s = format!(
        "## Levers that keep eight ICUs busy (issue 36)\n\n\
         Each lever on its own on top of the best variant, then the two that pay together — the\n\
         configuration `hw/configs/balanced.toml` (paper.toml's datapath, buffers and timing: the\n\
         same bits) — at 8 ICUs, ratio {PAPER_RATIO} ([CSV](levers-scene2.csv)). Same-work speedup as\n\
         above (ideal 8, aim {:.1}); balancing's gain is static cycles over balanced, minus 1.\n\
         `scan_ids_per_cycle`: the CTU compares that many patch ids of a cell against its\n\
         loaded set per cycle (one request per cycle); `descriptor_order = largest-first`: the\n\
         ray buffer expands the descriptor with the most jobs left first; `partition_granularity\n\
         = ray`: the partitioner cuts sections and sectors between any two low-resolution rays\n\
         rather than at the 25 subregions' boundaries; `victim = round-robin`: a starving cluster\n\
         takes work from the busy clusters in turn rather than always from the fullest.\n\n\
         | configuration | scene2: speedup (same work), balanced | static | balancing's gain | cycles | busiest CTU: jobs, traversal, joins | stress-skewed: speedup, balanced | static | gain |\n\
         | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
        AIM * WORK_ITEM_CLUSTERS as f64
    );
    for r in rows {
        let (Some(on), Some(off), Some(kon), Some(koff)) = (
            LeverRow::at8(&r.scene2, true),
            LeverRow::at8(&r.scene2, false),
            LeverRow::at8(&r.skewed, true),
            LeverRow::at8(&r.skewed, false),
        ) else {
            continue;
        };
        let gain = |off: &SpeedupRow, on: &SpeedupRow| {
            format!(
                "{:+.1}%",
                (off.point.cycles as f64 / on.point.cycles.max(1) as f64 - 1.0) * 100.0
            )
        };
        let p = &on.point;
        let _ = writeln!(
            s,
            "| {} | **{:.2}** ({:.1}% of ideal) | {:.2} | {} | {} | {}, {}, {} | {:.2} | {:.2} | {} |",
            r.lever.name,
            on.speedup_same_work,
            on.speedup_same_work / WORK_ITEM_CLUSTERS as f64 * 100.0,
            off.speedup_same_work,
            gain(off, on),
            p.cycles,
            p.busiest_ctu_jobs,
            p.busiest_ctu_traversal,
            p.busiest_ctu_join,
            kon.speedup_same_work,
            koff.speedup_same_work,
            gain(koff, kon)
        );
    }
    let _ = writeln!(
        s,
        "\nWhat binds is the busiest sector's serial chain: its traversal, then its joins, which\n\
         wait for its jobs (the busiest CTU's columns). A wider scan shortens the traversal, and\n\
         the joins then wait about as much longer for the same jobs; largest-first leaves the\n\
         chain as it was. Ray cuts shorten the chain itself — the busiest sector holds fewer jobs\n\
         — and a round-robin victim spreads the heavy clusters' work over more thieves (most on\n\
         stress-skewed, whose skew no partition of its sectors removes at 8 ICUs).\n"
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// hw/configs/balanced.toml is paper.toml with the ladder's `balanced` levers, nothing
    /// else: the report's row and the committed configuration are one machine.
    #[test]
    fn the_balanced_configuration_is_the_ladders() {
        let paper = crate::config::named("paper").unwrap();
        let balanced = crate::config::named("balanced").unwrap();
        let lever = LADDER.iter().find(|l| l.name == BALANCED).unwrap();
        assert_eq!(lever.config(&paper), balanced);
        assert_ne!(paper, balanced);
    }
}
