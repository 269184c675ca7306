//! Surfer command files (.sucl) beside the GTKWave save files: the same overview for
//! [Surfer](https://surfer-project.org), which runs one with `surfer --command-file X.sucl`
//! (or `run_command_file X.sucl` at its prompt).
//!
//! Surfer's format (libsurfer's `batch_commands.rs` and `command_parser.rs`): one command per
//! line (`;` separates more), `#` starts a comment; each command runs once the one before it
//! has finished (a file's loading included). The file written here:
//!
//! - `load_file NAME` — the waveform by name, as the .gtkw names it: run Surfer from the
//!   directory holding both (`cd waves && surfer --command-file default.sucl`);
//! - `variable_add SCOPE.NAME` per overview signal (the .gtkw's overview, in its order), by
//!   its full dotted name (no range: Surfer names a variable without one);
//! - for a counter (a vector), `item_focus IDX`, `item_set_format Unsigned`, `item_unfocus`:
//!   IDX is the item's place in the list, 0, 1, … written as Surfer's letters (hex digits
//!   as `a`..=`p`); one-bit signals keep Surfer's waveform of a bit, FSM states its own
//!   choice (a VCD's string as text, an FST's enum table's names);
//! - `zoom_fit`.

use super::gtkw::overview;
use super::signal::{Signal, WaveSummary};
use crate::error::Result;
use crate::output::write_atomic;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The command file's path for a waveform: same directory and stem, extension `.sucl`.
pub fn path_for(wave: &Path) -> PathBuf {
    wave.with_extension("sucl")
}

/// Surfer's letters for the item index `i`: its hex digits as `a`..=`p` (libsurfer's
/// `uint_idx_to_alpha_idx` without the padding, which its reverse does not need).
fn alpha(i: usize) -> String {
    format!("{i:x}")
        .chars()
        .map(|c| (b'a' + c.to_digit(16).expect("a hex digit") as u8) as char)
        .collect()
}

/// The command file for the waveform `wave` (as the file should name it) holding `signals`.
pub fn render(wave: &Path, signals: &[Signal]) -> String {
    let mut out = String::new();
    out.push_str("# Surfer command file written by shellsim (`shellsim run --vcd` / `--wave`)\n");
    out.push_str(
        "# the .gtkw's overview; run it beside the waveform: surfer --command-file THIS\n",
    );
    let _ = writeln!(out, "load_file {}", wave.display());
    for (i, s) in overview(signals).into_iter().enumerate() {
        let _ = writeln!(out, "variable_add {}", s.full_name());
        if s.is_vector() {
            let _ = writeln!(out, "item_focus {}", alpha(i));
            out.push_str("item_set_format Unsigned\n");
            out.push_str("item_unfocus\n");
        }
    }
    out.push_str("zoom_fit\n");
    out
}

/// Writes the command file for a finished waveform to `path` (atomically), naming the
/// waveform by its file name (the pair lies in one directory).
pub fn write(path: &Path, wave: &WaveSummary) -> Result<()> {
    let name = PathBuf::from(wave.path.file_name().unwrap_or(wave.path.as_os_str()));
    write_atomic(path, render(&name, &wave.signals).as_bytes())
}

#[cfg(test)]
mod tests {
    use super::super::signal::SignalKind;
    use super::*;

    #[test]
    fn items_are_named_with_surfers_letters() {
        assert_eq!(alpha(0), "a");
        assert_eq!(alpha(1), "b");
        assert_eq!(alpha(15), "p");
        assert_eq!(alpha(16), "ba");
        assert_eq!(alpha(0x2f), "cp");
    }

    #[test]
    fn the_overview_is_added_and_counters_shown_unsigned() {
        let sig = |scope: &str, name: &str, width| Signal {
            scope: scope.into(),
            name: name.into(),
            width,
            kind: SignalKind::Bits,
        };
        let signals = [
            sig("machine.memory", "port_busy", 1),
            sig("machine.memory", "grants", 32),
            sig("machine.memory", "other", 8),
        ];
        let text = render(Path::new("x.fst"), &signals);
        let body: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
        assert_eq!(
            body,
            [
                "load_file x.fst",
                "variable_add machine.memory.port_busy",
                "variable_add machine.memory.grants",
                "item_focus b",
                "item_set_format Unsigned",
                "item_unfocus",
                "zoom_fit",
            ]
        );
        assert_eq!(path_for(Path::new("w/x.fst")), PathBuf::from("w/x.sucl"));
    }
}
