//! shellsim: the host side and test bench of the shelling ray-casting machine — scenes,
//! grid, ray sets, the float reference tracer, analytic form factors, and the CLI's jobs.

pub mod analytic;
pub mod check;
pub mod cli;
pub mod error;
pub mod experiment;
pub mod fixed;
pub mod gen;
pub mod grid;
pub mod gtkw;
pub mod obj;
pub mod partition;
pub mod progress;
pub mod rays;
pub mod reference;
pub mod run;
pub mod scene;
pub mod sweep;
pub mod trace;
pub mod vcd_out;

pub use error::{Error, Result};
pub use scene::{Aabb, Patch, Scene, Spectrum};
