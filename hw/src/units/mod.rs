//! The clocked units of the machine, one file per hardware block. Each is built from its
//! configuration, owns its state, and has a documented `tick` that reads only its own state
//! and its links' registered state (its ports). Each also implements [`Unit`], what the
//! machine's cold paths (the cycle jump, the end test, the watchdog's progress and report)
//! ask of it; the hot tick calls each unit by hand.
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

use crate::machine::links::Links;

/// What a unit's cold-path tests may read besides its own state (registered state only).
pub struct Around<'a> {
    /// Every link.
    pub links: &'a Links,
    /// Jobs waiting in cluster c's ray buffer (`RayBuffer::waiting`).
    pub waiting: &'a dyn Fn(usize) -> usize,
}

/// The cold paths' view of a clocked unit, visited through `Machine::each_unit` (the
/// cluster's units through `Cluster::each_unit`). None of these runs in the hot tick; each
/// is a pure read but `skip`.
pub trait Unit {
    /// True when the unit will not act at cycle `now` on its own or on what it holds (the
    /// cycle jump may pass over `now`); `around` is asked only when every link is empty.
    fn quiet(&self, now: u64, around: &Around) -> bool;
    /// The next cycle, from `now` on, at which it acts on its own or its signals change (a
    /// DDA step ends, the memory's port frees); `None` when it waits on nothing.
    fn timer(&self, _now: u64) -> Option<u64> {
        None
    }
    /// Accounts `n` cycles from `now` on that the cycle jump passed over, as the unit would
    /// have spent them (it was quiet all along).
    fn skip(&mut self, _now: u64, _n: u64) {}
    /// Its part of the watchdog's progress number: a count that grows whenever it moves
    /// something.
    fn activity(&self) -> u64 {
        0
    }
    /// True when it has finished and holds nothing.
    fn done(&self) -> bool;
    /// Its state at cycle `now`, one line of the watchdog's report.
    fn report(&self, now: u64) -> String;
}
