//! shellsim: the host side and test bench of the shelling ray-casting machine — scenes,
//! grid, ray sets, the float reference tracer, analytic form factors, the partitioner, the
//! fixed-point host side, the machine's runs and experiments, design-space sweeps, and the
//! CLI.
//!
//! Dependencies point down the layers of ARCHITECTURE.md's rule (tests/layout.rs checks
//! it): `cli` → `explore`, `rtl` → `experiment`, `size`, `radiosity`, `stability` →
//! `machine` → `fixed`, `partition`, `wave` → `reference` → `scene`; nothing imports `cli`.
//! `error`, `output`, `limits`, `config`, `paper`, `progress` and `chart` are leaves anyone
//! may use.

pub mod chart;
pub mod cli;
pub mod config;
pub mod error;
pub mod experiment;
pub mod explore;
pub mod fixed;
pub mod limits;
pub mod machine;
pub mod output;
pub mod paper;
pub mod partition;
pub mod progress;
pub mod radiosity;
pub mod reference;
pub mod rtl;
pub mod scene;
pub mod size;
pub mod stability;
pub mod wave;

pub use error::{Error, Result};
pub use scene::{Aabb, Patch, Scene, Spectrum};
