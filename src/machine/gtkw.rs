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
//!   `TR_GRP_END_B` = 24, `TR_FPDECSHIFT_B` = 30). Hence `@28` binary, `@22` hex, `@24`
//!   decimal, `@420` signed decimal; `@20` sets no number format, so the trace keeps the one
//!   GTKWave gives its type (a string variable shows its text whatever the format).
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

use crate::error::Result;
use crate::machine::vcd::{Signal, SignalKind, VcdSummary};
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
/// `TR_SIGNED`: signed decimal.
pub const TR_SIGNED: u64 = 1 << 10;
/// `TR_GRP_BEGIN`: opens a group.
pub const TR_GRP_BEGIN: u64 = 1 << 23;
/// `TR_GRP_END`: closes a group.
pub const TR_GRP_END: u64 = 1 << 24;
/// `TR_FPDECSHIFT`: fixed-point decimal with the trace's `[fpshift_count]` shift.
pub const TR_FPDECSHIFT: u64 = 1 << 30;

/// The save file's path for a VCD: same directory and stem, extension `.gtkw`.
pub fn path_for(vcd: &Path) -> PathBuf {
    vcd.with_extension("gtkw")
}

/// The name GTKWave gives `s` after loading the VCD (see the module doc).
pub fn trace_name(s: &Signal) -> String {
    if s.is_vector() {
        format!("{}[{}:0]", s.full_name(), s.width - 1)
    } else {
        s.full_name()
    }
}

/// The trace flags and fixed-point shift `s` is shown with.
pub fn format_of(s: &Signal) -> (u64, Option<u32>) {
    match s.kind {
        SignalKind::Text => (TR_RJUSTIFY, None),
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
        let (f, shift) = format_of(s);
        self.flags(f);
        if let Some(n) = shift {
            self.line(&format!("[fpshift_count] {n}"));
        }
        self.line(&trace_name(s));
    }

    /// A group per scope: its signals, then its sub-scopes' groups.
    fn group(&mut self, n: &Node) {
        self.flags(TR_GRP_BEGIN | TR_BLANK);
        self.line(&format!("-{}", n.name));
        self.body(n);
        self.flags(TR_GRP_END | TR_BLANK);
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
/// `signals`, the save file itself being written to `gtkw_path`.
pub fn render(vcd_path: &Path, gtkw_path: &Path, signals: &[Signal], timestart: u64) -> String {
    let mut root = Node::default();
    for s in signals {
        let mut n = &mut root;
        for part in s.scope.split('.') {
            n = n.child(part);
        }
        n.signals.push(s);
    }
    let mut out = Out {
        text: String::new(),
        flags: None,
    };
    out.line("[*] GTKWave save file written by shellsim (`shellsim run --vcd`)");
    out.line("[*] one group per unit; one time unit is one clock cycle");
    out.line(&format!("[dumpfile] \"{}\"", vcd_path.display()));
    out.line(&format!("[savefile] \"{}\"", gtkw_path.display()));
    out.line(&format!("[timestart] {timestart}"));
    // A single top scope (`machine`) is the whole file: its units are the top-level groups.
    if root.children.len() == 1 {
        out.body(&root.children[0]);
    } else {
        out.body(&root);
    }
    out.text
}

/// Writes the save file for a finished VCD to `gtkw_path` (atomically).
pub fn write(gtkw_path: &Path, vcd: &VcdSummary) -> Result<()> {
    let text = render(&vcd.path, gtkw_path, &vcd.signals, vcd.window.from);
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
            sig("machine.cluster_0.ctu_0", "state", 1, SignalKind::Text),
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
    fn the_save_file_sits_beside_the_vcd() {
        assert_eq!(
            path_for(Path::new("waves/x.vcd")),
            PathBuf::from("waves/x.gtkw")
        );
    }
}
