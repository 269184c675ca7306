//! shellsim-hw: the shelling machine's hardware — number formats, memory records, the
//! fixed-point intersection datapath, the CTU's DDA, the untimed fixed-point model, and the
//! clocked units of the machine (CTU, ICU, memory and arbiter, buffers, clusters).
//! Like RTL: no scene files, no floats in the datapath.
//!
//! Invariants:
//! - **No floats in the datapath.** Host floats become integers once, in `config` (the shell
//!   radius) and `datapath::format` (`Format::quantize`); every stage after that is integer.
//! - **No file I/O, no scene knowledge.** hw/ reads no files (paper.toml is built in as
//!   text) and never imports the host.
//! - **Every link has one producer and one consumer** (enforced: see `link`), and every link
//!   is registered in one place, `machine::links`.
//! - **Tick order changes nothing.** Units read only their own state and registered link
//!   state; writes are staged and commit at the edge.
//!
//! Module map: `config/` (the one TOML parse), `datapath/` (formats, records, stages, DDA,
//! untimed model), `link`, `msg`, `trace` (the `Probe` interface), `units/` (one file per
//! clocked block), `machine/` (netlist, scheduling, observation).

pub mod config;
pub mod datapath;
pub mod link;
pub mod machine;
pub mod msg;
pub mod queue;
pub mod trace;
pub mod units;

pub use config::DatapathConfig;
pub use datapath::format::Formats;
pub use datapath::model::FixedScene;
pub use datapath::record::{CellTable, PatchRecord, RayRecord};
pub use datapath::{Exceptions, FixedHit};
