//! The schedule: an output of the partitioner (`shellsim partition --schedule`) that says
//! which rays meet which patches in which order, per cluster and CTU, and nothing else.
//!
//! **The machine does not consume it.** `shellsim run` hands the cycle-level machine only
//! each sector's ray ids (see `machine::run::prepare`); the machine's CTUs redo the
//! shells and subshells themselves in fixed point. The schedule is the float partitioner's
//! account of the same work, for inspection and for tests (its jobs equal the partition's
//! intersections).
//!
//! **Invariant:** only ids and counts — ray ids (indices into the high-resolution ray
//! set), linear cell ids (x fastest, then y, then z, over `grid_dims`), patch ids (indices
//! into the scene), angle bounds in integer nanodegrees. No floats, nothing of the scene
//! file: the hardware takes the schedule together with the fixed-point ray, patch and cell
//! records of the fixed-point datapath issue, which the host builds from the same ids.
//!
//! **Invariant:** within a sector, every patch id appears in at most one subshell (each
//! patch is loaded once per sector); subshells are in processing order (shell, then part);
//! a subshell's `rays` are the sector's rays not yet retired at its start, ascending.

use super::shells::Subshell;
use super::Partition;
use serde::{Deserialize, Serialize};

/// The whole schedule: one entry per section (cluster).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Schedule {
    /// The source patch id.
    pub source: u32,
    /// Rays in the high-resolution set (ray ids are `0..rays`).
    pub rays: u32,
    /// Cells per axis of the grid the cell ids refer to.
    pub grid_dims: [u32; 3],
    /// Sections, one per cluster, in cluster order.
    pub sections: Vec<SectionSchedule>,
}

/// One cluster's work: its sectors, one per CTU.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SectionSchedule {
    /// θ range, half-open, in nanodegrees.
    pub theta_nanodeg: [u64; 2],
    /// φ range, half-open, in nanodegrees.
    pub phi_nanodeg: [u64; 2],
    pub sectors: Vec<SectorSchedule>,
}

/// One CTU's work: its bundle of rays and its subshells ([`Subshell`]) in order.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SectorSchedule {
    pub theta_nanodeg: [u64; 2],
    pub phi_nanodeg: [u64; 2],
    /// The sector's rays (ids), ascending.
    pub rays: Vec<u32>,
    pub subshells: Vec<Subshell>,
}

impl Schedule {
    /// The schedule of a partition run.
    pub fn new(p: &Partition) -> Schedule {
        let sections = p
            .plan
            .sections
            .iter()
            .enumerate()
            .map(|(i, s)| SectionSchedule {
                theta_nanodeg: s.bounds.theta,
                phi_nanodeg: s.bounds.phi,
                sectors: p
                    .sectors
                    .iter()
                    .filter(|x| x.section == i)
                    .map(|x| SectorSchedule {
                        theta_nanodeg: x.bounds.theta,
                        phi_nanodeg: x.bounds.phi,
                        rays: x.rays.clone(),
                        subshells: x.run.subshells.clone(),
                    })
                    .collect(),
            })
            .collect();
        Schedule {
            source: p.config.source,
            rays: p.high_rays.len() as u32,
            grid_dims: p.grid_dims.map(|d| d as u32),
            sections,
        }
    }

    /// Total ICU jobs (intersection computations).
    pub fn jobs(&self) -> u64 {
        self.sections
            .iter()
            .flat_map(|s| &s.sectors)
            .flat_map(|x| &x.subshells)
            .map(Subshell::intersections)
            .sum()
    }
}
