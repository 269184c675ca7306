//! The RTL side: the SystemVerilog in hw/rtl/ (the ICU pipeline and the CTU's DDA step), its
//! parameter package written from a machine configuration, the Verilator build of a
//! co-simulation top, and the replay of the untimed model's vectors through it (cosim.rs);
//! synthesized cost by Yosys (cost.rs).
//!
//! One source of truth for the formats: `Formats` (hw/src/config/datapath.rs) gives every
//! width; [`layout`] turns them into the package `shellsim_cfg` and into the field order of
//! the co-simulation's buses; the hand-written RTL reads only the package.

pub mod cosim;
pub mod cost;
pub mod layout;
pub mod vectors;

use crate::error::{Error, Result};
use layout::{Params, Unit};
use std::path::{Path, PathBuf};

/// The committed RTL sources, embedded so that an installed binary can write and build them.
pub const SOURCES: &[(&str, &str)] = &[
    (
        "shellsim_icu.sv",
        include_str!("../../hw/rtl/shellsim_icu.sv"),
    ),
    (
        "shellsim_dda.sv",
        include_str!("../../hw/rtl/shellsim_dda.sv"),
    ),
];

/// The harness the co-simulation builds with the Verilated top.
pub const HARNESS: &str = include_str!("../../hw/rtl/cosim/harness.cpp");

/// The package `shellsim_cfg` for `p`.
pub fn package_sv(p: &Params, config: &str) -> String {
    let mut s = format!(
        "// shellsim_cfg.sv — written by `shellsim rtl` from {config}; do not edit.\n\
         // Every width of the RTL, from the configuration's datapath formats \
         (hw/src/config/datapath.rs).\n\npackage shellsim_cfg;\n"
    );
    for (name, v, about) in p.package() {
        s.push_str(&format!(
            "  localparam int {name:<10} = {v:>4};  // {about}\n"
        ));
    }
    s.push_str("endpackage\n");
    s
}

/// The co-simulation top for `unit`: the unit with its inputs taken from one packed
/// `in_bus`, and every stage register's valid, tag and fields brought out as `st_*`, in the
/// order of [`layout`].
pub fn top_sv(p: &Params, unit: Unit, side_by_side: bool) -> String {
    let inputs = p.inputs(unit);
    let stages = p.stages(unit);
    let wi: u32 = inputs.iter().map(|f| f.bits()).sum();
    let ws: u32 = stages.iter().map(|s| s.bits()).sum();
    let n = stages.len();
    let model_ports = if side_by_side {
        format!(
            ",\n  input logic [{}:0] m_valid,\n  input logic [{}:0] m_ray, m_patch,\n  input logic [63:0] m_t",
            n - 1,
            32 * n - 1
        )
    } else {
        String::new()
    };
    let mut s = format!(
        "// cosim_top.sv — written by `shellsim cosim` from src/rtl/layout.rs; do not edit.\n\
         module cosim_top (\n  input logic clk, rst, in_valid, out_ready,\n  \
         input logic [31:0] in_tag,\n  input logic [{}:0] in_bus,\n  \
         output logic in_ready, out_valid,\n  output logic [31:0] out_tag,\n  \
         output logic [{}:0] st_valid,\n  output logic [{}:0] st_tag,\n  \
         output logic [{}:0] st_bus{model_ports}\n);\n",
        wi - 1,
        n - 1,
        32 * n - 1,
        ws - 1
    );
    s.push_str(&format!(
        "  {} u (\n    .clk(clk), .rst(rst), .in_valid(in_valid), .in_ready(in_ready),\n    \
         .in_tag(in_tag), .out_valid(out_valid), .out_ready(out_ready), .out_tag(out_tag)",
        unit.module()
    ));
    let mut at = 0;
    for f in &inputs {
        s.push_str(&format!(",\n    .{}(in_bus[{} +: {}])", f.sv, at, f.bits()));
        at += f.bits();
    }
    let unused: &[&str] = match unit {
        Unit::Icu => &["out_hit", "out_t", "out_near_zero", "out_saturated"],
        Unit::Dda => &[
            "out_moved",
            "out_c",
            "out_n",
            "out_entry_num",
            "out_entry_den",
            "out_pinned",
            "out_exit_beyond",
            "out_entry_beyond",
            "out_entry_at_or_beyond",
        ],
    };
    for o in unused {
        s.push_str(&format!(",\n    .{o}()"));
    }
    s.push_str("\n  );\n");
    let mut at = 0;
    for (k, st) in stages.iter().enumerate() {
        s.push_str(&format!(
            "  // stage {k}: {} (Rust: {})\n  assign st_valid[{k}] = {};\n  \
             assign st_tag[{} +: 32] = {};\n",
            st.name,
            st.rust,
            st.valid,
            32 * k,
            st.tag
        ));
        for f in &st.fields {
            s.push_str(&format!(
                "  assign st_bus[{at} +: {}] = {};\n",
                f.bits(),
                f.sv
            ));
            at += f.bits();
        }
    }
    if side_by_side {
        s.push_str(&side_by_side_scopes(p, &stages));
    }
    s.push_str("endmodule\n");
    s
}

/// The ICU's stages under the model's waveform names (hw/src/machine/probe.rs: `stage_k`
/// with `valid`, `ray`, `patch` and, in the result stage, `t`) twice: scope `icu` from the
/// RTL's registers (in the co-simulation a job's ray and patch are its vector's index, the
/// tag) and scope `model_icu` from the model's ICU, which the harness drives each cycle.
fn side_by_side_scopes(p: &Params, stages: &[layout::Stage]) -> String {
    let last = stages.len() - 1;
    let pw = shellsim_hw::datapath::record::PATCH_ID_BITS;
    let tw = p.ttw;
    let mut s = String::from(
        "  // The waveform side by side: the RTL's ICU and the model's, by the model's names.\n",
    );
    for (scope, rtl) in [("icu", true), ("model_icu", false)] {
        s.push_str(&format!("  if (1) begin : {scope}\n"));
        for (k, st) in stages.iter().enumerate() {
            let (valid, ray, patch) = if rtl {
                (st.valid.clone(), st.tag.clone(), st.tag.clone())
            } else {
                (
                    format!("m_valid[{k}]"),
                    format!("m_ray[{} +: 32]", 32 * k),
                    format!("m_patch[{} +: 32]", 32 * k),
                )
            };
            s.push_str(&format!(
                "    if (1) begin : stage_{k}\n      logic valid;\n      logic [31:0] ray;\n      logic [{}:0] patch;\n      assign valid = {valid};\n      assign ray = {valid} ? {ray} : 32'd0;\n      assign patch = {valid} ? {pw}'({patch}) : {pw}'d0;\n",
                pw - 1
            ));
            if k == last {
                let t = if rtl {
                    "u.rr_t".to_string()
                } else {
                    "m_t".to_string()
                };
                s.push_str(&format!(
                    "      logic [{}:0] t;\n      assign t = {valid} ? {tw}'({t}) : {tw}'d0;\n",
                    tw - 1
                ));
            }
            s.push_str("    end\n");
        }
        s.push_str("  end\n");
    }
    s
}

/// A GTKWave save file for a side-by-side FST `fst`: each stage's RTL and model signals
/// next to each other.
pub fn side_by_side_gtkw(p: &Params, fst: &Path) -> String {
    let stages = p.stages(Unit::Icu);
    let name = fst
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    let mut s = format!(
        "[*] GTKWave save file written by shellsim cosim: the RTL ICU (icu) beside the model's (model_icu)\n\
         [*] one time unit step of 10 is one clock cycle, sampled before its edge\n\
         [dumpfile] \"{name}\"\n[timestart] 0\n[size] 1400 860\n[signals_width] 260\n[sst_expanded] 1\n*-5.000000 -1\n"
    );
    let top = "TOP.cosim_top";
    for (k, st) in stages.iter().enumerate() {
        s.push_str(&format!("@800200\n-stage {k} {}\n", st.name));
        let mut sigs = vec![("valid", "", "28"), ("ray", "[31:0]", "22")];
        if k + 1 == stages.len() {
            sigs.push(("t", "", "22"));
        }
        for (sig, range, fmt) in sigs {
            for (scope, who) in [("icu", "rtl"), ("model_icu", "model")] {
                let r = if sig == "t" {
                    format!("[{}:0]", p.ttw - 1)
                } else {
                    range.to_string()
                };
                s.push_str(&format!(
                    "@{fmt}\n+{{{who} {sig}}} {top}.{scope}.stage_{k}.{sig}{r}\n"
                ));
            }
        }
        s.push_str(
            "@1000200\n-stage {k}\n"
                .replace("{k}", &k.to_string())
                .as_str(),
        );
    }
    s
}

/// The harness's shape header for `unit`.
fn shape_h(p: &Params, unit: Unit, side_by_side: bool) -> String {
    let wi: u32 = p.inputs(unit).iter().map(|f| f.bits()).sum();
    let stages = p.stages(unit);
    let ws: u32 = stages.iter().map(|s| s.bits()).sum();
    let mut off = vec![];
    let mut at = 0;
    for s in &stages {
        off.push(at.to_string());
        at += s.bits();
    }
    let widths: Vec<String> = stages.iter().map(|s| s.bits().to_string()).collect();
    format!(
        "// cosim_shape.h — written by `shellsim cosim`; do not edit.\n#pragma once\n\
         #include <cstdint>\nstatic const uint32_t IN_WORDS = {};\nstatic const uint32_t ST_WORDS = {};\n\
         static const uint32_t S = {};\nstatic const uint32_t STAGE_OFF[] = {{{}}};\n\
         static const uint32_t STAGE_W[] = {{{}}};\n#define COSIM_MODEL {}\n",
        wi.div_ceil(32),
        ws.div_ceil(32),
        stages.len(),
        off.join(", "),
        widths.join(", "),
        side_by_side as u8
    )
}

/// Writes the RTL for a configuration into `dir`: the package, the committed sources and the
/// co-simulation tops. Returns the files written.
pub fn write_rtl(dir: &Path, p: &Params, config: &str) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut files = vec![("shellsim_cfg.sv".to_string(), package_sv(p, config))];
    for (name, text) in SOURCES {
        files.push((name.to_string(), text.to_string()));
    }
    for unit in [Unit::Icu, Unit::Dda] {
        files.push((
            format!("cosim_top_{}.sv", unit.name()),
            top_sv(p, unit, false),
        ));
    }
    let mut out = vec![];
    for (name, text) in files {
        let path = dir.join(name);
        crate::output::write_atomic(&path, text.as_bytes())?;
        out.push(path);
    }
    Ok(out)
}

/// The error for a tool that is not installed: exit 2, naming the Debian package.
pub fn missing_tool(tool: &str, package: &str) -> Error {
    Error::Usage(format!(
        "`{tool}` was not found on PATH: install it (Debian/Ubuntu: apt-get install {package})"
    ))
}

/// True when `tool` runs.
pub fn have(tool: &str) -> bool {
    std::process::Command::new(tool)
        .arg("--version")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok()
}

/// Where built models and synthesis results are cached: $SHELLSIM_RTL_CACHE, else
/// target/rtl-cache under the current directory.
pub fn cache_dir() -> PathBuf {
    std::env::var_os("SHELLSIM_RTL_CACHE")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("target/rtl-cache"))
}

/// A hash of texts: the cache key of a build or a synthesis (std's SipHash with fixed keys:
/// stable for a toolchain; a new one only rebuilds the cache).
pub fn hash_of(parts: &[&str]) -> String {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    parts.hash(&mut h);
    format!("{:016x}", h.finish())
}
