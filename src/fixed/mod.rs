//! Host side of the fixed-point model: the scene and rays as hardware records
//! ([`records`]), the float reference against the untimed fixed-point model ([`check`]),
//! and that comparison over bit widths ([`sweep`]).

pub mod check;
pub mod origin;
pub mod records;
pub mod sweep;
