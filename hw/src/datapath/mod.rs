//! The fixed-point datapath: number formats (format.rs), memory records (record.rs), the
//! ICU's intersection stages (stages.rs, re-exported here: `datapath::intersect`), the CTU's
//! exact DDA (dda.rs) and the untimed model built from the same stages (model.rs).

pub mod dda;
pub mod format;
pub mod model;
pub mod record;
pub mod stages;

pub use stages::*;
