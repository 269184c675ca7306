//! GTKWave save files (.gtkw) for the VCDs of `vcd_out`: the signals grouped per unit, each
//! in a format that reads well — bits as binary, counters and ids as decimals, FSM states as
//! their names, fixed-point values as decimals through GTKWave's fixed-point shift.
//!
//! The format is GTKWave's own (gtkwave/gtkwave, `src/savefile.c`: `write_save_helper` writes
//! it and `parsewavline` reads it back); a save file is line-oriented:
//!
//! - `[dumpfile] "PATH"` names the VCD, `[savefile] "PATH"` the save file itself: GTKWave uses
//!   the pair to find the dump relative to wherever the save file has moved
//!   (`get_relative_adjusted_name` → `find_dumpfile`), else opens PATH as given. `[*] TEXT`
//!   is a comment; `[timestart] T` the first time shown.
//! - `@HEX` sets the trace flags of the traces that follow (sticky): a bit set of GTKWave's
//!   `TR_*` flags (`src/analyzer.h`: `TR_HEX_B` = 1, `TR_DEC_B` = 2, `TR_BIN_B` = 3,
//!   `TR_RJUSTIFY_B` = 5, `TR_BLANK_B` = 9, `TR_SIGNED_B` = 10, `TR_GRP_BEGIN_B` = 23,
//!   `TR_GRP_END_B` = 24, `TR_FPDECSHIFT_B` = 30, `TR_ENUM_B` = 32). Hence `@28` binary,
//!   `@22` hex, `@24` decimal, `@420` signed decimal; `@20` sets no number format, so the
//!   trace keeps the one GTKWave gives its type (a string variable shows its text whatever
//!   the format); `@100000028` an FST's FSM state through its variable's enum table.
//! - `-LABEL` after `@800200` (group begin + blank) opens a group, after `@1000200` (group end
//!   + blank) closes it; groups nest.
//! - `[fpshift_count] N` sets the fixed-point shift of the traces that follow (sticky, 0..=255;
//!   written by `write_save_helper` for every trace with `TR_FPDECSHIFT`); a trace with
//!   `TR_FPDECSHIFT` and a shift N shows its value divided by 2^N (`cvt_fpsdec` in
//!   `src/baseconvert.c`, in the signed-decimal branch when `TR_SIGNED` is set). So a fixed
//!   value is `@40000420` + `[fpshift_count] frac`.
//! - Any other line is a signal's full hierarchical name, looked up exactly (`symfind`). The
//!   VCD loader (`src/vcd_recoder.c`, `vcd_build_symbols`) names a one-bit wire `scope.name`,
//!   a string `scope.name`, and a wider wire `scope.name[msb:lsb]` — so vectors carry their
//!   `[w-1:0]` range here, exactly as `vcd_out` declares it.

use super::options::WaveFormat;
use super::signal::{state_bits, Signal, SignalKind, WaveSummary};
use crate::error::Result;
use crate::output::write_atomic;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// `TR_HEX`: hexadecimal.
pub const TR_HEX: u64 = 1 << 1;
/// `TR_DEC`: unsigned decimal.
pub const TR_DEC: u64 = 1 << 2;
/// `TR_BIN`: binary.
pub const TR_BIN: u64 = 1 << 3;
/// `TR_RJUSTIFY`: right-justified values (GTKWave's default on every trace).
pub const TR_RJUSTIFY: u64 = 1 << 5;
/// `TR_BLANK`: a blank or comment line (groups are blanks with a group flag).
pub const TR_BLANK: u64 = 1 << 9;
/// `TR_COLLAPSED`: set on the end of a closed group.
pub const TR_COLLAPSED: u64 = 1 << 12;
/// `TR_CLOSED`: a group shown closed (its traces hidden until opened).
pub const TR_CLOSED: u64 = 1 << 22;
/// `TR_SIGNED`: signed decimal.
pub const TR_SIGNED: u64 = 1 << 10;
/// `TR_GRP_BEGIN`: opens a group.
pub const TR_GRP_BEGIN: u64 = 1 << 23;
/// `TR_GRP_END`: closes a group.
pub const TR_GRP_END: u64 = 1 << 24;
/// `TR_FPDECSHIFT`: fixed-point decimal with the trace's `[fpshift_count]` shift.
pub const TR_FPDECSHIFT: u64 = 1 << 30;
/// `TR_ENUM`: a value shown through the FST enum table its variable refers to (with
/// `TR_BIN`, the table's values being binary; GTKWave's `AddTrace` gives the trace the
/// variable's table when it loads the save file).
pub const TR_ENUM: u64 = 1 << 32;

/// The save file's path for a VCD: same directory and stem, extension `.gtkw`.
pub fn path_for(vcd: &Path) -> PathBuf {
    vcd.with_extension("gtkw")
}

/// The name GTKWave gives `s` after loading the VCD (see the module doc).
pub fn trace_name(s: &Signal) -> String {
    trace_name_in(s, WaveFormat::Vcd)
}

/// The name GTKWave gives `s` in a waveform of `format`: as in the VCD, except that an FST
/// holds an FSM state as its index, a vector of [`state_bits`] (`name[2:0]`), and declares a
/// fixed-point value with its binary point (`t[2:-12]`, `Signal::fixed_range`).
pub fn trace_name_in(s: &Signal, format: WaveFormat) -> String {
    match (s.kind, format) {
        (SignalKind::Text { states }, WaveFormat::Fst) if state_bits(states) > 1 => {
            format!("{}[{}:0]", s.full_name(), state_bits(states) - 1)
        }
        (SignalKind::Fixed { .. }, WaveFormat::Fst) if s.width > 1 => {
            let (msb, lsb) = s.fixed_range().expect("a fixed-point signal");
            format!("{}[{msb}:{lsb}]", s.full_name())
        }
        _ if s.is_vector() => format!("{}[{}:0]", s.full_name(), s.width - 1),
        _ => s.full_name(),
    }
}

/// The trace flags and fixed-point shift `s` is shown with.
pub fn format_of(s: &Signal) -> (u64, Option<u32>) {
    format_in(s, WaveFormat::Vcd)
}

/// The trace flags and fixed-point shift `s` is shown with in a waveform of `format`.
pub fn format_in(s: &Signal, format: WaveFormat) -> (u64, Option<u32>) {
    match s.kind {
        SignalKind::Text { .. } if format == WaveFormat::Fst => {
            (TR_ENUM | TR_BIN | TR_RJUSTIFY, None)
        }
        SignalKind::Text { .. } => (TR_RJUSTIFY, None),
        SignalKind::Bits if s.width == 1 => (TR_BIN | TR_RJUSTIFY, None),
        SignalKind::Bits => (TR_DEC | TR_RJUSTIFY, None),
        SignalKind::Fixed { frac } => (TR_SIGNED | TR_RJUSTIFY | TR_FPDECSHIFT, Some(frac)),
    }
}

/// A level of the scope tree: its signals, then its sub-scopes, in first-seen order.
#[derive(Default)]
struct Node<'a> {
    name: &'a str,
    signals: Vec<&'a Signal>,
    children: Vec<Node<'a>>,
}

impl<'a> Node<'a> {
    fn child(&mut self, name: &'a str) -> &mut Node<'a> {
        let i = match self.children.iter().position(|c| c.name == name) {
            Some(i) => i,
            None => {
                self.children.push(Node {
                    name,
                    ..Default::default()
                });
                self.children.len() - 1
            }
        };
        &mut self.children[i]
    }
}

/// Writes lines, emitting a flags line only when the flags change (as GTKWave does).
struct Out {
    text: String,
    flags: Option<u64>,
    format: WaveFormat,
    /// Unit groups start closed (the overview is open above them).
    closed: bool,
}

impl Out {
    fn flags(&mut self, f: u64) {
        if self.flags != Some(f) {
            let _ = writeln!(self.text, "@{f:x}");
            self.flags = Some(f);
        }
    }

    fn line(&mut self, l: &str) {
        self.text.push_str(l);
        self.text.push('\n');
    }

    fn signal(&mut self, s: &Signal) {
        let (f, shift) = format_in(s, self.format);
        self.flags(f);
        if let Some(n) = shift {
            self.line(&format!("[fpshift_count] {n}"));
        }
        self.line(&trace_name_in(s, self.format));
    }

    /// A trace under a short label naming its unit (`c0 ctu1 state`): the overview shows
    /// many signals whose own names (`valid`, `state`) repeat.
    fn alias(&mut self, s: &Signal) {
        let (f, shift) = format_in(s, self.format);
        self.flags(f);
        if let Some(n) = shift {
            self.line(&format!("[fpshift_count] {n}"));
        }
        let unit = s
            .scope
            .strip_prefix("machine.")
            .unwrap_or(&s.scope)
            .replace("cluster_", "c")
            .replace("ray_buffer", "rb")
            .replace('_', "")
            .replace('.', " ");
        self.line(&format!(
            "+{{{unit} {}}} {}",
            s.name,
            trace_name_in(s, self.format)
        ));
    }

    fn group(&mut self, n: &Node) {
        let (open, close) = if self.closed {
            (TR_CLOSED, TR_CLOSED | TR_COLLAPSED)
        } else {
            (0, 0)
        };
        self.flags(TR_GRP_BEGIN | TR_BLANK | open);
        self.line(&format!("-{}", n.name));
        self.body(n);
        self.flags(TR_GRP_END | TR_BLANK | close);
        self.line(&format!("-{}", n.name));
    }

    fn body(&mut self, n: &Node) {
        for s in &n.signals {
            self.signal(s);
        }
        for c in &n.children {
            self.group(c);
        }
    }
}

/// The save file's text for the VCD at `vcd_path` (as the save file should name it) holding
/// `signals`, the save file itself being written to `gtkw_path`: every unit's group, open.
pub fn render(vcd_path: &Path, gtkw_path: &Path, signals: &[Signal], timestart: u64) -> String {
    let mut out = Out {
        text: String::new(),
        flags: None,
        format: WaveFormat::Vcd,
        closed: false,
    };
    preamble(&mut out, vcd_path, gtkw_path, timestart, None);
    units(&mut out, signals);
    out.text
}

/// The first screen's zoom: GTKWave shows 2^-ZOOM time units (cycles) per pixel, so at −6
/// the ~1100-pixel wave pane of a 1400-pixel window shows ~500 cycles.
pub const FIRST_SCREEN_ZOOM: f64 = -6.0;

/// The overview's signals of one cluster, in order: ICU input and output stage valid, ray
/// buffer occupancy, each CTU's state (`name` within the scope after `machine.cluster_C.`).
fn overview_of_cluster(rest: &str, name: &str) -> Option<u32> {
    match (rest, name) {
        ("icu.stage_0", "valid") => Some(0),
        (r, "valid") if r.starts_with("icu.stage_") => Some(1),
        ("ray_buffer", "occupancy") => Some(2),
        (r, "state") if r.starts_with("ctu_") && !r.contains('.') => Some(3),
        _ => None,
    }
}

/// The overview: memory port busy and grants, then per cluster its ICU's first and last
/// stage valid, its ray buffer's occupancy and each CTU's state.
pub(super) fn overview(signals: &[Signal]) -> Vec<&Signal> {
    let mut v: Vec<&Signal> = signals
        .iter()
        .filter(|s| s.scope == "machine.memory" && (s.name == "port_busy" || s.name == "grants"))
        .collect();
    let depth_last = signals
        .iter()
        .filter_map(|s| {
            s.scope
                .rsplit_once(".icu.stage_")
                .and_then(|(_, n)| n.parse::<u32>().ok())
        })
        .max();
    let mut per: Vec<(u32, u32, usize, &Signal)> = Vec::new();
    for (i, s) in signals.iter().enumerate() {
        let Some(rest) = s.scope.strip_prefix("machine.cluster_") else {
            continue;
        };
        let Some((c, rest)) = rest.split_once('.') else {
            continue;
        };
        let Ok(c) = c.parse::<u32>() else { continue };
        let Some(rank) = overview_of_cluster(rest, &s.name) else {
            continue;
        };
        if rank == 1 && Some(rest) != depth_last.map(|d| format!("icu.stage_{d}")).as_deref() {
            continue;
        }
        per.push((c, rank, i, s));
    }
    per.sort_by_key(|&(c, r, i, _)| (c, r, i));
    v.extend(per.into_iter().map(|(.., s)| s));
    v
}

/// The save file for a waveform of `format`: the first screen shows ~450 cycles from
/// `timestart` with an open overview group on top; every unit's group follows, closed.
pub fn render_wave(
    wave_path: &Path,
    gtkw_path: &Path,
    signals: &[Signal],
    timestart: u64,
    format: WaveFormat,
) -> String {
    let mut out = Out {
        text: String::new(),
        flags: None,
        format,
        closed: false,
    };
    preamble(
        &mut out,
        wave_path,
        gtkw_path,
        timestart,
        Some(FIRST_SCREEN_ZOOM),
    );
    let ov = overview(signals);
    if !ov.is_empty() {
        out.flags(TR_GRP_BEGIN | TR_BLANK);
        out.line("-overview");
        for s in ov {
            out.alias(s);
        }
        out.flags(TR_GRP_END | TR_BLANK);
        out.line("-overview");
    }
    out.closed = true;
    units(&mut out, signals);
    out.text
}

fn preamble(out: &mut Out, wave: &Path, gtkw: &Path, timestart: u64, zoom: Option<f64>) {
    out.line("[*] GTKWave save file written by shellsim (`shellsim run --vcd` / `--wave`)");
    out.line("[*] one group per unit; one time unit is one clock cycle");
    out.line(&format!("[dumpfile] \"{}\"", wave.display()));
    out.line(&format!("[savefile] \"{}\"", gtkw.display()));
    out.line(&format!("[timestart] {timestart}"));
    if let Some(z) = zoom {
        // Window and pane sizes, then the zoom and the primary marker (none).
        out.line("[size] 1400 860");
        out.line("[sst_width] 160");
        out.line("[signals_width] 230");
        out.line("[sst_expanded] 1");
        out.line(&format!("*{z:.6} -1"));
    }
}

fn units(out: &mut Out, signals: &[Signal]) {
    let mut root = Node::default();
    for s in signals {
        let mut n = &mut root;
        for part in s.scope.split('.') {
            n = n.child(part);
        }
        n.signals.push(s);
    }
    // A single top scope (`machine`) is the whole file: its units are the top-level groups.
    if root.children.len() == 1 {
        out.body(&root.children[0]);
    } else {
        out.body(&root);
    }
}

/// Writes the save file for a finished waveform to `gtkw_path` (atomically).
pub fn write(gtkw_path: &Path, wave: &WaveSummary) -> Result<()> {
    // Both by name only: the pair lies in one directory, so a moved pair still opens and
    // the file does not depend on where it was written.
    let name = |p: &Path| PathBuf::from(p.file_name().unwrap_or(p.as_os_str()));
    let text = render_wave(
        &name(&wave.path),
        &name(gtkw_path),
        &wave.signals,
        wave.window.from,
        WaveFormat::of(&wave.path),
    );
    write_atomic(gtkw_path, text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sig(scope: &str, name: &str, width: u32, kind: SignalKind) -> Signal {
        Signal {
            scope: scope.into(),
            name: name.into(),
            width,
            kind,
        }
    }

    #[test]
    fn groups_nest_per_scope_and_formats_follow_the_kind() {
        let signals = [
            sig("machine.memory", "port_busy", 1, SignalKind::Bits),
            sig("machine.memory", "grants", 32, SignalKind::Bits),
            sig(
                "machine.cluster_0.ctu_0",
                "state",
                1,
                SignalKind::Text { states: 7 },
            ),
            sig(
                "machine.cluster_0.icu.stage_3",
                "t",
                15,
                SignalKind::Fixed { frac: 12 },
            ),
        ];
        let text = render(
            Path::new("waves/x.vcd"),
            Path::new("waves/x.gtkw"),
            &signals,
            0,
        );
        let want = "\
[dumpfile] \"waves/x.vcd\"
[savefile] \"waves/x.gtkw\"
[timestart] 0
@800200
-memory
@28
machine.memory.port_busy
@24
machine.memory.grants[31:0]
@1000200
-memory
@800200
-cluster_0
-ctu_0
@20
machine.cluster_0.ctu_0.state
@1000200
-ctu_0
@800200
-icu
-stage_3
@40000420
[fpshift_count] 12
machine.cluster_0.icu.stage_3.t[14:0]
@1000200
-stage_3
-icu
-cluster_0
";
        let body: String = text
            .lines()
            .filter(|l| !l.starts_with("[*]"))
            .map(|l| format!("{l}\n"))
            .collect();
        assert_eq!(body, want);
    }

    #[test]
    fn an_fst_names_states_and_fixed_point_values_by_their_fst_ranges() {
        let state = sig("m.ctu_0", "state", 1, SignalKind::Text { states: 7 });
        let t = sig("m.icu", "t", 15, SignalKind::Fixed { frac: 12 });
        assert_eq!(trace_name_in(&state, WaveFormat::Fst), "m.ctu_0.state[2:0]");
        assert_eq!(trace_name_in(&state, WaveFormat::Vcd), "m.ctu_0.state");
        assert_eq!(trace_name_in(&t, WaveFormat::Fst), "m.icu.t[2:-12]");
        assert_eq!(trace_name_in(&t, WaveFormat::Vcd), "m.icu.t[14:0]");
        assert_eq!(
            format_in(&state, WaveFormat::Fst),
            (TR_ENUM | TR_BIN | TR_RJUSTIFY, None)
        );
        assert_eq!(format_in(&state, WaveFormat::Vcd), (TR_RJUSTIFY, None));
    }

    #[test]
    fn the_save_file_sits_beside_the_vcd() {
        assert_eq!(
            path_for(Path::new("waves/x.vcd")),
            PathBuf::from("waves/x.gtkw")
        );
    }
}
