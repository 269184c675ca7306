//! The fixed-point datapath: number formats (format.rs), memory records (record.rs), the
//! ICU's intersection stages (stages.rs, re-exported here: `datapath::intersect`), the CTU's
//! exact DDA (dda.rs), the divider's stages as the RTL builds them (divider.rs) and the untimed model built from the same stages (model.rs).

pub mod dda;
pub mod divider;
pub mod format;
pub mod model;
pub mod record;
pub mod stages;

pub use stages::*;
