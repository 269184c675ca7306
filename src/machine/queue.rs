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
use shellsim_hw::units::ctu::CtuParams;
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
    /// Each ray's result (the untimed model's; empty from [`retime`], whose walks hold them).
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

/// The CTUs' walks of one partition under one CTU configuration: what every machine that
/// differs only in timing knobs (memory, buffers, arbiter, balancing) re-times — the paper's
/// trace-driven method, one trace for many design points.
pub struct Walks {
    pub traces: Vec<CtuTrace>,
    /// Each CTU's parameters, rays and sector sizes, for [`retime`]'s check that a machine
    /// reads the same walks.
    params: Vec<CtuParams>,
    request_capacity: u32,
    rays: usize,
    sector_rays: Vec<usize>,
    /// Each ray's result (the untimed model's).
    pub hits: Vec<Option<FixedHit>>,
    pub untimed_s: f64,
    pub walks_s: f64,
}

/// `cfg` resolved into hardware units for `input`'s scene.
fn hardware(input: &MachineInput, cfg: &MachineConfig) -> Result<MachineConfig> {
    let host = input.host;
    config::in_hardware_units(
        cfg,
        config::SceneSize {
            scale: host.scale,
            patches: host.scene.patches.len(),
        },
    )
}

/// Each CTU's parameters under `hw` (hardware units), cluster-major.
fn params_of(input: &MachineInput, hw: &MachineConfig, spec: &RunSpec) -> Result<Vec<CtuParams>> {
    let f = &input.host.scene.formats;
    let shell_raw = hw
        .shell_raw()
        .map_err(|e| Error::Check(format!("the machine configuration: {e}")))?;
    let k = hw.machine.ctus_per_cluster as usize;
    let n: usize = input.sectors.iter().map(Vec::len).sum();
    if input.sectors.len() != hw.machine.clusters as usize || n != hw.machine.clusters as usize * k
    {
        return Err(Error::Check(format!(
            "{n} sectors for {} clusters of {k} CTUs",
            hw.machine.clusters
        )));
    }
    Ok((0..n)
        .map(|i| ctu_params(hw, f, shell_raw, spec.source, i / k, i % k))
        .collect())
}

/// Walks every CTU of `input` under `cfg`; `hits` are the untimed model's results when the
/// caller has them.
pub fn walks(
    input: &MachineInput,
    cfg: &MachineConfig,
    spec: &RunSpec,
    hits: Option<Vec<Option<FixedHit>>>,
) -> Result<Walks> {
    let host = input.host;
    let hw = hardware(input, cfg)?;
    let t0 = Instant::now();
    let hits = hits.unwrap_or_else(|| untimed_hits(input, spec.source));
    let t1 = Instant::now();
    let params = params_of(input, &hw, spec)?;
    let sectors: Vec<&[u32]> = input.sectors.iter().flatten().map(|r| &r[..]).collect();
    let traces: Vec<CtuTrace> = (params.par_iter())
        .zip(sectors.par_iter())
        .map(|(&p, rays)| {
            walk::walk(&WalkInput {
                params: p,
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
    Ok(Walks {
        traces,
        params,
        request_capacity: hw.machine.request_queue_capacity,
        rays: input.records.len(),
        sector_rays: sectors.iter().map(|s| s.len()).collect(),
        hits,
        untimed_s: (t1 - t0).as_secs_f64(),
        walks_s: t1.elapsed().as_secs_f64(),
    })
}

/// Re-times `walks` on the machine `cfg` with the queueing network; `cfg` must give every
/// CTU the parameters the walks were taken with (it may differ in any timing knob).
pub fn retime(
    walks: &Walks,
    input: &MachineInput,
    scene_name: &str,
    cfg: &MachineConfig,
    spec: &RunSpec,
) -> Result<QueueRun> {
    let hw = hardware(input, cfg)?;
    let sector_rays: Vec<usize> = input.sectors.iter().flatten().map(Vec::len).collect();
    if params_of(input, &hw, spec)? != walks.params
        || hw.machine.request_queue_capacity != walks.request_capacity
        || input.records.len() != walks.rays
        || sector_rays != walks.sector_rays
    {
        return Err(Error::Check(
            "the machine's CTUs or sectors differ from those the walks were taken with: walk again"
                .into(),
        ));
    }
    let t0 = Instant::now();
    let words = RecordSizes::of(&input.host.scene.formats).patch_words;
    let estimate = net::estimate(NetParams::of(&hw, words), &walks.traces).map_err(Error::Check)?;
    let network_s = t0.elapsed().as_secs_f64();
    let p = hw.machine.clusters.max(1) as f64;
    Ok(QueueRun {
        scene: scene_name.to_string(),
        source: spec.source,
        rays: input.records.len(),
        pipeline_efficiency: estimate.jobs as f64 / (p * estimate.cycles.max(1) as f64),
        estimate,
        hits: Vec::new(),
        wall: QueueWall {
            untimed_s: 0.0,
            walks_s: 0.0,
            network_s,
        },
    })
}

/// Estimates a run of the machine on `input` at the queue level: [`walks`] then [`retime`].
pub fn estimate(
    input: &MachineInput,
    scene_name: &str,
    cfg: &MachineConfig,
    spec: &RunSpec,
    hits: Option<Vec<Option<FixedHit>>>,
) -> Result<QueueRun> {
    let w = walks(input, cfg, spec, hits)?;
    let mut q = retime(&w, input, scene_name, cfg, spec)?;
    q.wall.untimed_s = w.untimed_s;
    q.wall.walks_s = w.walks_s;
    q.hits = w.hits;
    Ok(q)
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
