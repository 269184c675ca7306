//! The clocked units of the machine, one file per hardware block. Each is built from its
//! configuration, owns its state, and has a documented `tick` that reads only its own state
//! and its links' registered state (its ports).

pub mod balancer;
pub mod cluster;
pub mod ctu;
pub mod icu;
pub mod memory;
pub mod patch_buffer;
pub mod ray_buffer;
pub mod ray_pool;
