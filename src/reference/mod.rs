//! The float model: the uniform grid, the watertight reference tracer, ray sets, casting a
//! ray set into form factors, the analytic form factors they converge to, and the faces
//! that face out of the enclosure ([`orient`]).

pub mod analytic;
pub mod cast;
pub mod grid;
pub mod orient;
pub mod rays;
pub mod tracer;
