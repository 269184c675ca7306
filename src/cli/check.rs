//! `shellsim check`: the float reference against the untimed fixed-point model on the same
//! rays.

use super::args::DatapathArgs;
use super::reference::ReferenceArgs;
use crate::error::Result;
use crate::fixed::check::{check_scene, CheckReport};
use crate::output::check_outputs;

/// Arguments of `shellsim check`.
#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    #[command(flatten)]
    pub rays: ReferenceArgs,
    #[command(flatten)]
    pub datapath: DatapathArgs,
}

/// Runs `shellsim check`.
pub fn run(a: &CheckArgs) -> Result<()> {
    let r = &a.rays;
    check_outputs(&r.outputs())?;
    let (scene, spec) = r.load()?;
    for p in scene.lying_on(spec.source) {
        eprintln!(
            "warning: {}: patch {} (the source) lies on patch {p}: coplanar and overlapping, rays leaving it start an LSB above its plane, so patch {p} lies behind them; at few bits the answer can still turn on rounding (classed near the origin)",
            r.input.scene.display(),
            spec.source
        );
    }
    let cfg = a.datapath.resolve()?;
    let report = check_scene(&scene, &r.input.scene, cfg, &spec, r.grid.for_scene(&scene))?;
    print_check(&report);
    if let Some(out) = &r.json {
        report.write_json(out, cfg)?;
    }
    report.verdict(r.json.as_deref())
}

fn print_check(r: &CheckReport) {
    crate::output::outln!("{}: {} rays, {} mismatches", r.format, r.rays, r.mismatches);
    crate::output::outln!(
        "  explained: {} overflow, {} near the origin, {} grazing, {} near an edge or vertex, {} tie in t; unexplained: {}",
        r.classes.overflow, r.classes.near_origin, r.classes.grazing, r.classes.near_edge, r.classes.tie, r.unexplained_mismatches
    );
    crate::output::outln!(
        "  t error: max {:.2} LSB, rms {:.2} LSB; form factors: max error {:.2e} (sampling error {:.2e})",
        r.t_err_max_lsb, r.t_err_rms_lsb, r.ff_err_max, r.ff_sampling_err
    );
    let z = &r.zones;
    crate::output::outln!(
        "  rays in each class's zone: {} near the origin, {} grazing, {} near an edge or vertex",
        z.near_origin,
        z.grazing,
        z.near_edge
    );
    crate::output::outln!(
        "  escaped: float {}, fixed {} ({} where the float reference hit a patch); form-factor error {:.2} sampling errors",
        r.escaped_float,
        r.escaped_fixed,
        r.leaked,
        r.ff_err_sigmas
    );
    let e = &r.exceptions;
    crate::output::outln!(
        "  exceptions: {} overflow, {} near-zero denominators, {} t saturated",
        e.overflow,
        e.near_zero_denominator,
        e.t_saturated
    );
}
