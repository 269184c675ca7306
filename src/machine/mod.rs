//! Runs of the cycle-level machine (`shellsim_hw`) from the host: preparation, simulation
//! and statistics ([`run`]) with the waveform beside a run (`crate::wave`), and the default
//! job ([`default_job`]).

pub mod default_job;
pub mod queue;
pub mod run;
