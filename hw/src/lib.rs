//! shellsim-hw: the shelling machine's hardware — number formats, memory records, the
//! fixed-point intersection datapath, the CTU's DDA, the untimed fixed-point model, and the
//! clocked units of the machine (CTU, ICU, memory and arbiter, buffers, clusters).
//! Like RTL: no scene files, no floats in the datapath.

pub mod balancer;
pub mod cluster;
pub mod config;
pub mod ctu;
pub mod datapath;
pub mod dda;
pub mod format;
pub mod icu;
pub mod link;
pub mod machine;
pub mod machine_config;
pub mod memory;
pub mod model;
pub mod msg;
pub mod patch_buffer;
pub mod ray_buffer;
pub mod record;
pub mod trace;

pub use config::{DatapathConfig, Formats};
pub use datapath::{Exceptions, FixedHit};
pub use model::FixedScene;
pub use record::{CellTable, PatchRecord, RayRecord};
