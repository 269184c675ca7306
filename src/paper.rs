//! The paper's numbers in one place: Table 12.1 of Shen, Laarakker & Deprettere (1992) and
//! the constants of its experiments (§12.3.2). The machine's own parameters (cell size, shell
//! radius, subshell threshold, timing) live in the built-in configuration,
//! hw/configs/paper.toml (see the `config` module).

/// The paper's low-resolution ray count (Table 12.1): 20 rings of Δθ = 4.5° plus the zenith.
pub const PAPER_RAYS: usize = 969;

/// The subregion grid of the low-resolution pass, θ × φ (Table 12.1: 25 subregions).
pub const SUBREGIONS: (usize, usize) = (5, 5);

/// Section (cluster, ICU) counts of Table 12.1 and of the workload and efficiency figures.
pub const SECTIONS: [u32; 3] = [2, 4, 8];

/// The paper's Hi_Low_Ratios (Table 12.1).
pub const RATIOS: [usize; 3] = [1, 10, 30];

/// The ratio the paper favours ("it is favourable to choose 10"), used for work-item,
/// speedup and the imbalance table.
pub const PAPER_RATIO: usize = 10;

/// Work-item sizes of the work-item experiment (jobs; Fig 12.14).
pub const WORK_ITEMS: [u32; 8] = [1, 2, 4, 8, 16, 32, 64, 128];

/// Clusters of the work-item experiment and of the what-if table.
pub const WORK_ITEM_CLUSTERS: u32 = 8;

/// Cluster counts of the speedup experiment (Fig 12.15).
pub const SPEEDUP_CLUSTERS: [u32; 4] = [1, 2, 4, 8];

/// The paper's improvement from dynamic balancing, in efficiency and in speedup (§12.3.2).
pub const PAPER_GAIN: f64 = 0.15;

/// The aim for the speedup at 8 ICUs, as a fraction of ideal.
pub const AIM: f64 = 0.90;
