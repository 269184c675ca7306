//! The queue level of timing (`--level queue`): each ray's result from the untimed model,
//! each CTU's walk against an ideal environment, and the paper's queueing network
//! (`shellsim_hw::queue`) re-timing those walks under contention — cycles, each ICU's jobs
//! and the balancer's work-items without stepping the machine.

use crate::config;
use crate::error::{Error, Result};
use crate::machine::run::{MachineInput, RunSpec};
use rayon::prelude::*;
use serde::Serialize;
use shellsim_hw::config::MachineConfig;
use shellsim_hw::datapath::record::RecordSizes;
use shellsim_hw::machine::ctu_params;
use shellsim_hw::queue::net::{self, Estimate, NetParams};
use shellsim_hw::queue::walk::{self, CtuTrace, WalkInput};
use shellsim_hw::{Exceptions, FixedHit};
use std::time::Instant;

/// A queue-level estimate with where its time went.
#[derive(Clone, Debug, Serialize)]
pub struct QueueRun {
    pub scene: String,
    pub source: u32,
    pub rays: usize,
    pub estimate: Estimate,
    /// Σ jobs / (ICUs × cycles): the pipelines' time-space efficiency.
    pub pipeline_efficiency: f64,
    /// Each ray's result (the untimed model's).
    #[serde(skip)]
    pub hits: Vec<Option<FixedHit>>,
    /// Wall seconds: the untimed model's results, the walks, the network (not in the JSON).
    #[serde(skip)]
    pub wall: QueueWall,
}

/// Where a queue-level estimate's wall time went.
#[derive(Clone, Copy, Debug, Default)]
pub struct QueueWall {
    pub untimed_s: f64,
    pub walks_s: f64,
    pub network_s: f64,
}

impl QueueWall {
    /// Everything but the untimed model's results (which a checked run computes anyway).
    pub fn timing_s(&self) -> f64 {
        self.walks_s + self.network_s
    }
}

/// The untimed model's result for every ray of `input`.
pub fn untimed_hits(input: &MachineInput, source: u32) -> Vec<Option<FixedHit>> {
    input
        .records
        .par_iter()
        .map(|r| {
            let mut e = Exceptions::default();
            input.host.scene.nearest_grid(r, Some(source), &mut e).0
        })
        .collect()
}

/// Estimates a run of the machine on `input` at the queue level; `hits` are the untimed
/// model's results when the caller has them.
pub fn estimate(
    input: &MachineInput,
    scene_name: &str,
    cfg: &MachineConfig,
    spec: &RunSpec,
    hits: Option<Vec<Option<FixedHit>>>,
) -> Result<QueueRun> {
    let host = input.host;
    let hw = config::in_hardware_units(
        cfg,
        config::SceneSize {
            scale: host.scale,
            patches: host.scene.patches.len(),
        },
    )?;
    let t0 = Instant::now();
    let hits = hits.unwrap_or_else(|| untimed_hits(input, spec.source));
    let t1 = Instant::now();
    let f = &host.scene.formats;
    let shell_raw = hw
        .shell_raw()
        .map_err(|e| Error::Check(format!("the machine configuration: {e}")))?;
    let k = hw.machine.ctus_per_cluster as usize;
    let sectors: Vec<(usize, usize, &[u32])> = input
        .sectors
        .iter()
        .enumerate()
        .flat_map(|(c, secs)| secs.iter().enumerate().map(move |(j, r)| (c, j, &r[..])))
        .collect();
    if sectors.len() != hw.machine.clusters as usize * k {
        return Err(Error::Check(format!(
            "{} sectors for {} clusters of {k} CTUs",
            sectors.len(),
            hw.machine.clusters
        )));
    }
    let traces: Vec<CtuTrace> = sectors
        .par_iter()
        .map(|&(c, j, rays)| {
            walk::walk(&WalkInput {
                params: ctu_params(&hw, f, shell_raw, spec.source, c, j),
                rays,
                records: input.records,
                cells: &host.scene.cells,
                patches: host.scene.patches.len(),
                twins: host.scene.twins_of(Some(spec.source)),
                hits: &hits,
                request_capacity: hw.machine.request_queue_capacity as usize,
            })
        })
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| Error::Check(e.to_string()))?;
    let t2 = Instant::now();
    let words = RecordSizes::of(f).patch_words;
    let estimate = net::estimate(NetParams::of(&hw, words), &traces).map_err(Error::Check)?;
    let t3 = Instant::now();
    let p = hw.machine.clusters.max(1) as f64;
    Ok(QueueRun {
        scene: scene_name.to_string(),
        source: spec.source,
        rays: input.records.len(),
        pipeline_efficiency: estimate.jobs as f64 / (p * estimate.cycles.max(1) as f64),
        estimate,
        hits,
        wall: QueueWall {
            untimed_s: (t1 - t0).as_secs_f64(),
            walks_s: (t2 - t1).as_secs_f64(),
            network_s: (t3 - t2).as_secs_f64(),
        },
    })
}

/// `shellsim run --level queue`: partitions the scene as a cycle-level run does, estimates
/// its timing at the queue level and writes the JSON (configuration, estimate, wall seconds
/// apart from it) when asked.
pub fn execute(
    scene: &crate::scene::Scene,
    file: &std::path::Path,
    cfg: &MachineConfig,
    spec: &RunSpec,
    json: Option<&std::path::Path>,
) -> Result<QueueRun> {
    let prep = crate::machine::run::prepare(scene, file, cfg, spec)?;
    let q = estimate(&prep.input(), &scene.name, cfg, spec, None)?;
    if let Some(path) = json {
        #[derive(Serialize)]
        struct Wall {
            untimed_s: f64,
            walks_s: f64,
            network_s: f64,
        }
        #[derive(Serialize)]
        struct Out<'a> {
            level: &'static str,
            config: MachineConfig,
            run: &'a QueueRun,
            /// Host figures: not estimated statistics.
            host: Wall,
        }
        crate::output::write_json(
            path,
            &Out {
                level: "queue",
                config: config::resolve(cfg, scene.size())?,
                run: &q,
                host: Wall {
                    untimed_s: q.wall.untimed_s,
                    walks_s: q.wall.walks_s,
                    network_s: q.wall.network_s,
                },
            },
        )?;
    }
    Ok(q)
}
