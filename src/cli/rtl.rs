//! `shellsim rtl` and `shellsim cosim`: the SystemVerilog for a configuration, and its
//! co-simulation against the model.

use super::args::DatapathArgs;
use crate::error::{Error, Result};
use crate::output::outln;
use crate::output::{check_outputs, Output};
use crate::rtl::cosim::{self, Pressure};
use crate::rtl::layout::Params;
use std::path::PathBuf;

/// Arguments of `shellsim rtl`.
#[derive(clap::Args, Debug)]
#[command(args_conflicts_with_subcommands = true)]
pub struct RtlArgs {
    #[command(subcommand)]
    pub cmd: Option<RtlCmd>,
    #[command(flatten)]
    pub datapath: DatapathArgs,
    /// Directory for the package `shellsim_cfg.sv`, the RTL and the co-simulation tops.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `shellsim rtl`'s subcommands.
#[derive(clap::Subcommand, Debug)]
pub enum RtlCmd {
    /// Synthesize the ICU and the DDA step with Yosys: cells, flip-flops, logic depth, and
    /// ECP5 LUT4s and multipliers, beside the bits proxy (cached by configuration).
    Cost(CostArgs),
}

/// Arguments of `shellsim rtl cost`.
#[derive(clap::Args, Debug)]
pub struct CostArgs {
    #[command(flatten)]
    pub datapath: DatapathArgs,
    /// Synthesize every fractional width A..=B instead of the configuration's.
    #[arg(long, value_name = "A..=B", value_parser = super::args::parse_bits_range)]
    pub sweep: Option<(u32, u32)>,
    /// Skip the ECP5 mapping (LUTs and multipliers): generic synthesis only.
    #[arg(long)]
    pub no_fpga: bool,
    /// Write the table (markdown) and the fit of cells to the bits proxy here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write the table as CSV (hw/rtl/cost.csv is the one `size` and `explore` read).
    #[arg(long)]
    pub csv: Option<PathBuf>,
}

/// Runs `shellsim rtl cost`.
fn run_cost(a: &CostArgs) -> Result<()> {
    use crate::rtl::cost::{fit, synth_cost};
    use crate::rtl::layout::Unit;
    let outs: Vec<Output> = [("--out", &a.out), ("--csv", &a.csv)]
        .into_iter()
        .filter_map(|(o, p)| p.as_deref().map(|p| Output::file(o, p)))
        .collect();
    check_outputs(&outs)?;
    let base = a.datapath.resolve_config()?;
    let widths: Vec<u32> = match a.sweep {
        Some((lo, hi)) => (lo..=hi).collect(),
        None => vec![base.datapath.frac_bits],
    };
    let mut rows = vec![];
    for f in widths {
        let mut cfg = base;
        cfg.datapath = crate::config::with_frac_bits(cfg.datapath, f)?;
        let p = Params::new(&cfg)?;
        for unit in [Unit::Icu, Unit::Dda] {
            eprintln!("synthesizing the {} at F = {f}", unit.name());
            rows.push(synth_cost(&p, unit, !a.no_fpga)?);
        }
    }
    let opt = |x: Option<u64>| x.map_or("-".to_string(), |v| v.to_string());
    let mut md = String::from(
        "| unit | F | cells | flip-flops | depth | ECP5 LUT4 | ECP5 MULT18 | bits proxy |\n|---|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in &rows {
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.unit,
            r.frac_bits,
            r.cells,
            r.flip_flops,
            r.depth,
            opt(r.luts),
            opt(r.multipliers),
            if r.unit == "icu" {
                r.bits_proxy.to_string()
            } else {
                "-".into()
            }
        ));
    }
    let icu: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.unit == "icu")
        .map(|r| (r.bits_proxy as f64, r.cells as f64))
        .collect();
    if icu.len() >= 3 {
        let (c0, c1, r) = fit(&icu);
        md.push_str(&format!(
            "\nICU cells ≈ {c0:.0} + {c1:.3} × bits proxy (r = {r:.4}, {} widths)\n",
            icu.len()
        ));
    }
    crate::output::out!("{md}");
    if let Some(o) = &a.out {
        crate::output::write_atomic(o, md.as_bytes())?;
    }
    if let Some(c) = &a.csv {
        crate::output::write_atomic(c, crate::rtl::cost::csv(&rows).as_bytes())?;
    }
    Ok(())
}

/// Runs `shellsim rtl`.
pub fn run_rtl(a: &RtlArgs) -> Result<()> {
    if let Some(RtlCmd::Cost(c)) = &a.cmd {
        return run_cost(c);
    }
    let Some(out) = &a.out else {
        return Err(Error::Usage(
            "shellsim rtl needs --out DIR (or the subcommand `cost`)".into(),
        ));
    };
    check_outputs(&[Output::dir("--out", out)])?;
    let cfg = a.datapath.resolve_config()?;
    let p = Params::new(&cfg)?;
    let what = a
        .datapath
        .hw
        .as_ref()
        .map_or("the built-in paper.toml".to_string(), |h| {
            h.display().to_string()
        });
    let files = crate::rtl::write_rtl(out, &p, &what)?;
    for f in files {
        outln!("wrote {}", f.display());
    }
    outln!(
        "ICU pipeline: {} stages (translate, shear, edges, interpolate, {} divider stages of {} bits, result); F = {}, t {}",
        4 + p.div.stages + 1,
        p.div.stages,
        p.div.bits_per_stage,
        p.f.coord.frac_bits,
        p.f.t
    );
    Ok(())
}

/// Arguments of `shellsim cosim`.
#[derive(clap::Args, Debug)]
pub struct CosimArgs {
    #[command(flatten)]
    pub datapath: DatapathArgs,
    /// ICU vectors in all (the DDA gets a quarter as many states).
    #[arg(long, default_value_t = 1_000_000)]
    pub vectors: u64,
    /// A scene whose walks give vectors (default: the built-in scene2 and cornell).
    #[arg(long)]
    pub scene: Vec<PathBuf>,
    /// Seed of the directed and random vectors and of the back-pressure pattern.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The cycle-by-cycle run's chance that a job is offered in a cycle, and that the
    /// result side is ready.
    #[arg(long, default_value_t = 0.7)]
    pub offer: f64,
    #[arg(long, default_value_t = 0.6)]
    pub take: f64,
    /// Write the RTL ICU's waveform of the first vectors (FST, the model's stage names).
    #[arg(long)]
    pub fst: Option<PathBuf>,
    /// Write the report (vectors per source, cycles, stalls per run) as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Runs `shellsim cosim`.
pub fn run_cosim(a: &CosimArgs) -> Result<()> {
    let mut outs = Vec::new();
    if let Some(f) = &a.fst {
        outs.push(Output::file("--fst", f));
        outs.push(Output::file("--fst (its .gtkw)", &f.with_extension("gtkw")));
    }
    if let Some(j) = &a.json {
        outs.push(Output::file("--json", j));
    }
    check_outputs(&outs)?;
    for (flag, v) in [("--offer", a.offer), ("--take", a.take)] {
        if !(v > 0.0 && v <= 1.0) {
            return Err(Error::Usage(format!("{flag} {v} is not in (0, 1]")));
        }
    }
    if a.vectors == 0 {
        return Err(Error::Usage("--vectors 0: nothing to compare".into()));
    }
    let cfg = a.datapath.resolve_config()?;
    let mut scenes = vec![];
    if a.scene.is_empty() {
        use crate::scene::gen::{generate, Kind};
        scenes.push(("scene2".to_string(), generate(Kind::Scene2, 1)));
        scenes.push(("cornell".to_string(), generate(Kind::Cornell, 1)));
    }
    for s in &a.scene {
        scenes.push((s.display().to_string(), crate::scene::Scene::load(s)?));
    }
    let o = cosim::Options {
        cfg,
        vectors: a.vectors,
        scenes,
        seed: a.seed,
        pressure: Pressure {
            offer: a.offer,
            take: a.take,
            seed: a.seed,
        },
        fst: a.fst.clone(),
    };
    let tty = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let (report, timings) = cosim::run(&o, &mut |m| {
        if tty {
            eprintln!("{m}")
        }
    })?;
    let s = &report.sources;
    outln!(
        "co-simulation at F = {}: bit-exact in every stage register and every handshake",
        report.frac_bits
    );
    outln!(
        "  ICU vectors: {} from scenes, {} from stability cases, {} directed, {} random",
        s.scenes,
        s.stability,
        s.directed,
        s.random
    );
    for r in &report.runs {
        outln!(
            "  {} at offer {} / take {}: {} vectors, {} cycles, {} stalled, {} hits",
            r.unit,
            r.pressure.offer,
            r.pressure.take,
            r.vectors,
            r.cycles,
            r.stalled_cycles,
            r.hits
        );
    }
    for (what, build, t) in &timings {
        if *build > 0.0 {
            outln!("  {what}: {build:.1} s");
        } else if t.seconds > 0.0 {
            outln!(
                "  {what}: {:.2} M vectors/s ({:.1} s)",
                t.vectors_per_second / 1e6,
                t.seconds
            );
        }
    }
    if let Some(f) = &a.fst {
        let p = Params::new(&o.cfg)?;
        let gtkw = f.with_extension("gtkw");
        crate::output::write_atomic(&gtkw, crate::rtl::side_by_side_gtkw(&p, f).as_bytes())?;
        outln!(
            "  waveform: {} (the RTL's ICU beside the model's: gtkwave {} {})",
            f.display(),
            f.display(),
            gtkw.display()
        );
    }
    if let Some(j) = &a.json {
        let text = serde_json::to_string_pretty(&report).expect("serializable");
        crate::output::write_atomic(j, text.as_bytes())?;
    }
    Ok(())
}
