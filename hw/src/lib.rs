//! shellsim-hw: the shelling machine's hardware — number formats, memory records, the
//! fixed-point intersection datapath, the CTU's DDA and the untimed fixed-point model.
//! Like RTL: no scene files, no floats in the datapath.

pub mod config;
pub mod datapath;
pub mod dda;
pub mod format;
pub mod model;
pub mod record;

pub use config::{DatapathConfig, Formats};
pub use datapath::{Exceptions, FixedHit};
pub use model::FixedScene;
pub use record::{CellTable, PatchRecord, RayRecord};
