//! The clocked units of the machine, one file per hardware block. Each is built from its
//! configuration, owns its state, and has a documented `tick` that reads only its own state
//! and its links' registered state (its ports).
//!
//! **Each unit names its waveform signals in its own file**: a method that reports them, in
//! order, to the machine's `Sink` (`Ctu::signals` and `Ctu::bundle_signals`, `Icu::signals`,
//! `Icu::first_stage_signals`, `Icu::stage_job_signals` and the t signals, `Memory::signals`
//! and `Memory::arbiter_signals`, `RayBuffer::bundle_signals`, `Balancer::signals`,
//! `Balancer::cluster_signals` and `Balancer::ray_buffer_signals`; a link's in `Link::signals`),
//! with the count it reports as a const beside it (`Ctu::SIGNALS`, `Icu::STAGE_SIGNALS`, …:
//! the waveform walk skips that many for a unit that cannot have changed) and a unit test that
//! the method reports exactly that many (`machine::sink::Count`). Adding a signal is one edit
//! in the unit's file — a line in its signals method and the count beside it; the machine's
//! probe.rs is not touched, and the waveform's order is the method's.

pub mod balancer;
pub mod cluster;
pub mod ctu;
pub mod icu;
pub mod memory;
pub mod patch_buffer;
pub mod ray_buffer;
pub mod ray_pool;
