//! The default job (`shellsim` with no arguments): runs
//! [`crate::machine::default_job::default_job`] and prints its table.

use super::run::print_waveform;
use crate::error::{Error, Result};
use crate::machine::default_job::{default_job, WAVES_JSON, WAVES_VCD};
use crate::output::{check_outputs, Output};
use crate::wave::gtkw::path_for;
use std::path::Path;

/// Runs the default job and prints the summary table.
pub fn run() -> Result<()> {
    check_outputs(&[
        Output::file("the default job's VCD", Path::new(WAVES_VCD)),
        Output::file("the default job's .gtkw", &path_for(Path::new(WAVES_VCD))),
        Output::file(
            "the default job's .sucl",
            &crate::wave::sucl::path_for(Path::new(WAVES_VCD)),
        ),
        Output::file("the default job's JSON", Path::new(WAVES_JSON)),
    ])?;
    let j = default_job()?;
    if let Some(w) = &j.waveform {
        print_waveform(w);
    }
    let m = &j.machine;
    let fixed = &j.fixed;
    let report = &j.reference;
    let mismatches = j.grid_mismatches;
    let (f, truth, sigma) = (j.analytic.estimate, j.analytic.truth, j.analytic.sigma);
    let source = j.source;
    crate::output::outln!(
        "shellsim: scene2 (808 patches) from patch {source}, machine hw/configs/paper.toml"
    );
    crate::output::outln!();
    crate::output::outln!("{:<46} {:>16} {:>8}", "check", "value", "verdict");
    let verdict = |ok: bool| if ok { "ok" } else { "FAILED" };
    let row = |name: &str, value: String, ok: Option<bool>| {
        crate::output::outln!("{:<46} {:>16} {:>8}", name, value, ok.map_or("", verdict));
    };
    row("machine: rays", m.rays.to_string(), None);
    row("machine: cycles", m.cycles.to_string(), None);
    row(
        "machine: pipeline efficiency",
        format!("{:.3}", m.pipeline_efficiency),
        None,
    );
    row(
        "machine: patch loads / jobs",
        format!("{} / {}", m.patch_loads, m.jobs),
        None,
    );
    row(
        "machine: memory utilization",
        format!("{:.3}", m.memory_utilization),
        None,
    );
    row(
        "machine: work-items moved (balancing)",
        m.balancer.work_items.to_string(),
        None,
    );
    row(
        "machine vs untimed fixed-point model",
        format!("{} differ", m.mismatches_vs_fixed),
        Some(m.mismatches_vs_fixed == 0),
    );
    row(
        "fixed point vs float: mismatches",
        fixed.mismatches.to_string(),
        None,
    );
    row(
        "fixed point vs float: unexplained",
        fixed.unexplained_mismatches.to_string(),
        Some(fixed.unexplained_mismatches == 0),
    );
    row(
        "fixed point: rays lost (leaks)",
        fixed.leaked.to_string(),
        Some(fixed.leaked == 0),
    );
    row(
        "fixed point vs float: F error / sampling error",
        format!("{:.2}", fixed.ff_err_sigmas),
        Some(fixed.verdict(None).is_ok()),
    );
    row(
        "float: rays escaped (enclosure)",
        report.escaped.to_string(),
        Some(report.escaped == 0),
    );
    row(
        "float: sum of form factors",
        format!("{:.12}", report.weight_sum),
        Some((report.weight_sum - 1.0).abs() < 1e-9),
    );
    row(
        "float: grid vs brute-force mismatches",
        mismatches.to_string(),
        Some(mismatches == 0),
    );
    row(
        &format!("float: F(floor centre->ceiling), ±{:.0e}", 3.0 * sigma),
        format!("{f:.10}"),
        Some((f - truth).abs() <= 3.0 * sigma),
    );
    row("  analytic (Lambert)", format!("{truth:.10}"), None);
    crate::output::outln!();
    crate::output::outln!(
        "waveform: gtkwave waves/default.vcd waves/default.gtkw; statistics: waves/default.json ({:.2} M simulated cycles/s)",
        m.sim_rate_hz / 1e6
    );
    if !j.ok() {
        return Err(Error::Check(
            "the default run disagrees with its references".into(),
        ));
    }
    Ok(())
}
