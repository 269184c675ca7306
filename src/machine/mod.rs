//! Runs of the cycle-level machine (`shellsim_hw`) from the host: preparation, simulation
//! and statistics ([`run`]), the default job ([`default_job`]), and the waveform beside a
//! run — the VCD writer ([`vcd`]) and its GTKWave save file ([`gtkw`]).

pub mod default_job;
mod direct;
pub mod fst;
pub mod gtkw;
pub mod run;
pub mod vcd;
