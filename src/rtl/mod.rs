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
pub fn top_sv(p: &Params, unit: Unit) -> String {
    let inputs = p.inputs(unit);
    let stages = p.stages(unit);
    let wi: u32 = inputs.iter().map(|f| f.bits()).sum();
    let ws: u32 = stages.iter().map(|s| s.bits()).sum();
    let n = stages.len();
    let mut s = format!(
        "// cosim_top.sv — written by `shellsim cosim` from src/rtl/layout.rs; do not edit.\n\
         module cosim_top (\n  input logic clk, rst, in_valid, out_ready,\n  \
         input logic [31:0] in_tag,\n  input logic [{}:0] in_bus,\n  \
         output logic in_ready, out_valid,\n  output logic [31:0] out_tag,\n  \
         output logic [{}:0] st_valid,\n  output logic [{}:0] st_tag,\n  \
         output logic [{}:0] st_bus\n);\n",
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
    s.push_str("endmodule\n");
    s
}

/// The harness's shape header for `unit`.
fn shape_h(p: &Params, unit: Unit) -> String {
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
         static const uint32_t STAGE_W[] = {{{}}};\n",
        wi.div_ceil(32),
        ws.div_ceil(32),
        stages.len(),
        off.join(", "),
        widths.join(", ")
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
        files.push((format!("cosim_top_{}.sv", unit.name()), top_sv(p, unit)));
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

/// A stable hash of texts (the cache key of a build).
pub fn hash_of(parts: &[&str]) -> String {
    let mut h = crate::explore::spec::FNV_START;
    for p in parts {
        h = crate::explore::spec::fnv1a(p.as_bytes(), h);
        h = crate::explore::spec::fnv1a(&[0], h);
    }
    format!("{h:016x}")
}
