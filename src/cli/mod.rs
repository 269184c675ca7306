//! Command-line interface: the argument types (clap) and the dispatch to one file per
//! subcommand. Each subcommand parses, calls the library and prints; nothing in the
//! library imports this module.

pub mod args;
pub mod check;
pub mod default;
pub mod experiment;
pub mod explore;
pub mod matrix;
pub mod paper;
pub mod partition;
pub mod radiosity;
pub mod reference;
pub mod rtl;
pub mod run;
pub mod scene;
pub mod size;
pub mod stability;
pub mod sweep;

use crate::error::Result;
use clap::{Parser, Subcommand};

/// Cycle-level model of the shelling ray-casting machine (Shen, Laarakker & Deprettere, 1992)
/// for radiosity form factors. With no subcommand: the default job on built-in inputs.
#[derive(Parser, Debug)]
#[command(name = "shellsim", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Generate, inspect or import scenes.
    #[command(subcommand)]
    Scene(scene::SceneCmd),
    /// Form factors from one source patch by the float reference tracer.
    Reference(reference::ReferenceArgs),
    /// The float reference against the untimed fixed-point model on the same rays.
    Check(check::CheckArgs),
    /// Partition, simulate the cycle-level machine, check against the fixed-point model.
    Run(run::RunArgs),
    /// Sweep a model parameter and chart accuracy against cost.
    #[command(subcommand)]
    Sweep(sweep::SweepCmd),
    /// The shelling partition: low-resolution pass, sections and sectors, shells and
    /// subshells, workloads predicted against actual, patch loads, schedule.
    Partition(partition::PartitionArgs),
    /// The paper's experiments on the machine: pipeline efficiency with and without
    /// balancing, efficiency against work-item size, speedup against ICUs (CSV + SVG).
    /// Clusters, balancing and the work-item size are set per run; the rest of the machine
    /// configuration is kept.
    Experiment(experiment::ExperimentArgs),
    /// Regenerate every figure of the paper and a report (report.md) in one command.
    Paper(paper::PaperArgs),
    /// The smallest machine that meets a form-factor accuracy target on a scene (bits,
    /// buffers, clusters), written as a configuration and a report.
    Size(size::SizeArgs),
    /// The whole form-factor matrix on one model (float, fixed or machine): Matrix Market
    /// plus a JSON summary (per row the escaped weight and row sum; the machine's cycles).
    Matrix(matrix::MatrixArgs),
    /// Solve B = E + ρ F B (Gauss-Seidel or shooting), write per-patch radiosity and a
    /// picture; compare two models' pictures and solutions.
    Radiosity(radiosity::RadiosityArgs),
    /// Where each method fails: adversarial cases on the float reference, the fixed-point
    /// model over bit widths and the machine — differences per class, leaks, overflow, DDA
    /// faults, machine mismatches and deadlocks (CSV, markdown, SVG).
    Stability(stability::StabilityArgs),
    /// A design-space sweep: accuracy, machine speed, hardware and simulator cost per
    /// point, the non-dominated fronts and a report; sharded runs, their merge, and Slurm
    /// job-array scripts.
    #[command(subcommand)]
    Explore(explore::ExploreCmd),
    /// Write the SystemVerilog of the ICU pipeline and the DDA step for a configuration
    /// (the parameter package, the RTL and the co-simulation tops).
    Rtl(rtl::RtlArgs),
    /// Co-simulate the RTL (Verilator) against the model: every stage register of every
    /// vector, and the handshake cycle by cycle under back-pressure.
    Cosim(rtl::CosimArgs),
}

/// Runs the job the command line asks for; errors name the flags the user typed.
pub fn run(cli: Cli) -> Result<()> {
    dispatch(cli).map_err(args::name_flags)
}

fn dispatch(cli: Cli) -> Result<()> {
    match cli.command {
        Some(Command::Scene(c)) => scene::run(c),
        Some(Command::Reference(a)) => reference::run(&a),
        Some(Command::Check(a)) => check::run(&a),
        Some(Command::Sweep(c)) => sweep::run(&c),
        Some(Command::Partition(a)) => partition::run(&a),
        Some(Command::Experiment(a)) => experiment::run(&a),
        Some(Command::Paper(a)) => paper::run(&a),
        Some(Command::Run(a)) => run::run(&a),
        Some(Command::Size(a)) => size::run(&a),
        Some(Command::Matrix(a)) => matrix::run(&a),
        Some(Command::Radiosity(a)) => radiosity::run(&a),
        Some(Command::Stability(a)) => stability::run(&a),
        Some(Command::Explore(c)) => explore::run(&c),
        Some(Command::Rtl(a)) => rtl::run_rtl(&a),
        Some(Command::Cosim(a)) => rtl::run_cosim(&a),
        None => default::run(),
    }
}
