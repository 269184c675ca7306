//! The low-resolution pass: N_low rays (default 969, the paper's ring set) sorted into the
//! subregion grid by direction; each subregion's rays form a bundle, worked through shells
//! and subshells as the machine would ([`super::shells`]), and its cell traversals and
//! intersection computations are recorded — the estimates the static partition balances.
//!
//! **Invariant:** a subregion's counts are those of its own bundle (its rays against the
//! active patches of its own shells), and the per-ray shares sum to them exactly: the
//! subregion-granular and ray-granular partitions see the same totals.

use super::angles::{Angles, SubregionGrid};
use super::shells::{BundleRun, Caster};
use crate::reference::rays::Frame;
use rayon::prelude::*;
use serde::Serialize;

/// Work of a bundle (or a part of one), as the machine counts it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Workload {
    /// Rays in the bundle.
    pub rays: u64,
    /// Ray/patch intersection computations (remaining rays × active patches, summed).
    pub intersections: u64,
    /// Cell steps of remaining rays.
    pub traversals: u64,
    /// Patches loaded (once per bundle).
    pub patch_loads: u64,
}

impl Workload {
    /// The workload of a whole bundle run.
    pub fn of_run(rays: usize, run: &BundleRun) -> Workload {
        Workload {
            rays: rays as u64,
            intersections: run.intersections(),
            traversals: run.traversals(),
            patch_loads: run.patch_loads(),
        }
    }

    /// Adds another workload.
    pub fn add(&mut self, o: &Workload) {
        self.rays += o.rays;
        self.intersections += o.intersections;
        self.traversals += o.traversals;
        self.patch_loads += o.patch_loads;
    }

    /// Every count multiplied by `k` (the low-to-high ratio).
    pub fn scaled(&self, k: u64) -> Workload {
        Workload {
            rays: self.rays * k,
            intersections: self.intersections * k,
            traversals: self.traversals * k,
            patch_loads: self.patch_loads * k,
        }
    }
}

/// What the low-resolution pass found.
#[derive(Clone, Debug)]
pub struct LowRes {
    pub grid: SubregionGrid,
    /// Per ray: its direction's angles.
    pub angles: Vec<Angles>,
    /// Per ray: its subregion.
    pub subregion: Vec<u32>,
    /// Per subregion: its bundle's work.
    pub work: Vec<Workload>,
    /// Per ray: its share of its subregion's work (`rays` = 1, `patch_loads` = 0).
    pub ray_work: Vec<Workload>,
}

/// Runs the low-resolution pass over the rays of `caster` (directions taken in `frame`).
pub fn low_res(caster: &Caster, frame: &Frame, grid: SubregionGrid) -> LowRes {
    let angles: Vec<Angles> = caster.rays.iter().map(|r| Angles::of(frame, r.d)).collect();
    let subregion: Vec<u32> = angles.iter().map(|a| grid.index(*a) as u32).collect();
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); grid.len()];
    for (i, &s) in subregion.iter().enumerate() {
        members[s as usize].push(i as u32);
    }
    let runs: Vec<BundleRun> = members
        .par_iter()
        .map(|ids| caster.run_bundle(ids))
        .collect();
    let mut ray_work = vec![Workload::default(); angles.len()];
    let mut work = Vec::with_capacity(grid.len());
    for (ids, run) in members.iter().zip(&runs) {
        work.push(Workload::of_run(ids.len(), run));
        for (j, &r) in ids.iter().enumerate() {
            ray_work[r as usize] = Workload {
                rays: 1,
                intersections: run.ray_intersections[j],
                traversals: run.ray_traversals[j],
                patch_loads: 0,
            };
        }
    }
    LowRes {
        grid,
        angles,
        subregion,
        work,
        ray_work,
    }
}
