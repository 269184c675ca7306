//! The float model: the uniform grid, the watertight reference tracer, ray sets, casting a
//! ray set into form factors, and the analytic form factors they converge to.

pub mod analytic;
pub mod cast;
pub mod grid;
pub mod rays;
pub mod tracer;
