//! The schedule: the partitioner's hand-off to the hardware (`hw/`, the cycle-level
//! machine issue). It says which rays meet which patches in which order, per cluster and
//! CTU, and nothing else.
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

/// One CTU's work: its bundle of rays and its subshells in order.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SectorSchedule {
    pub theta_nanodeg: [u64; 2],
    pub phi_nanodeg: [u64; 2],
    /// The sector's rays (ids), ascending.
    pub rays: Vec<u32>,
    pub subshells: Vec<SubshellSchedule>,
}

/// One subshell: the primitive unit of work (the paper's s').
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SubshellSchedule {
    /// Shell index (concentric about the source's centroid).
    pub shell: u32,
    /// Subshell index within the shell.
    pub part: u32,
    /// Nonempty cells in traversal order (linear cell ids).
    pub cells: Vec<u32>,
    /// Patches to load and test: the ones the sector has not loaded before.
    pub patches: Vec<u32>,
    /// Remaining rays at the subshell's start (ids, ascending).
    pub rays: Vec<u32>,
    /// Cell steps the CTU makes for those rays in this subshell.
    pub traversals: u64,
}

impl SubshellSchedule {
    /// The ICU's jobs: every remaining ray against every active patch.
    pub fn jobs(&self) -> u64 {
        self.rays.len() as u64 * self.patches.len() as u64
    }
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
                        subshells: x
                            .run
                            .subshells
                            .iter()
                            .map(|sub| SubshellSchedule {
                                shell: sub.shell,
                                part: sub.part,
                                cells: sub.cells.clone(),
                                patches: sub.patches.clone(),
                                rays: sub.rays.clone(),
                                traversals: sub.traversals,
                            })
                            .collect(),
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
            .map(SubshellSchedule::jobs)
            .sum()
    }
}
