//! The VCD format: the header (through the `vcd` crate's writer, into memory) and the body,
//! on the waveform's thread, its value change lines formatted by hand (the same bytes as the
//! `vcd` crate's) into a block written out whole (`super::blockfile`).
//!
//! **Layout.** One `$scope module` per dot-separated level of a signal's scope (`machine`,
//! `cluster_0`, `icu`, `stage_3`, …), a `wire` of the reported width for bits (with an
//! explicit `[w-1:0]` range when wider than one bit, so the name GTKWave gives it can be read
//! off the declaration), a `string` variable for a text (FSM states), and for a fixed-point
//! value a `wire` of its width holding the raw two's-complement value — the .gtkw file
//! (gtkw.rs) shows it as a decimal through GTKWave's fixed-point shift.
//!
//! **Time.** `$timescale 1 ns`: one time unit is one clock cycle and `#t` is the cycle
//! number. The paper gives no clock rate, so the unit is nominal; 1 ns is chosen because
//! GTKWave then reads out times as plain integers equal to the cycle ("1234 ns" is cycle
//! 1234), whereas with 1 ps long runs would be shown scaled to ns or µs. A `#t` line is
//! written only when something declared changed at cycle t. The header holds no date, so
//! the same run gives a byte-identical file whatever the thread's timing.

use super::blockfile::BlockOut;
use super::options::{WaveOptions, Window};
use super::signal::{ScopeNode, Signal, SignalKind, Slot};
use super::stream::{entries, Body, BodyEnd, BodyError, Clock};
use shellsim_hw::trace::{apply_changes, ChangeSink, Pipeline};
use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use vcd::{ReferenceIndex, TimescaleUnit, VarType};

/// Hand the VCD body to the file past this many buffered bytes.
const VCD_BLOCK_BYTES: usize = 1 << 20;

/// The VCD body, on its thread: the last sample's values, the window, and the formatted
/// bytes on their way to the file.
pub(super) struct VcdBody {
    /// Per position: how its lines are written.
    formats: Vec<LineFormat>,
    /// Per position: a text signal's value lines, one per name (`s<name> <id>\n`), which
    /// only a text's change reads.
    texts: Vec<Vec<Vec<u8>>>,
    /// Signal order of the header (positions).
    declared: Vec<usize>,
    /// The last sample's values (those holding now).
    prev: Vec<u64>,
    /// The pipelines the probe declared, whose later stages this body moves itself.
    pipelines: Vec<Pipeline>,
    clock: Clock,
    /// The sample being written, and whether its `#t` is out.
    now: u64,
    stamped: bool,
    samples: u64,
    timestamps: u64,
    /// The header, written first.
    head: Vec<u8>,
    /// The bytes on their way to the file: a fixed array filled from the front, each line
    /// written in place (fixed-size copies, no growth check) and handed to the file (in
    /// whole blocks, past the page cache where it can) once past [`VCD_BLOCK_BYTES`];
    /// `margin` bytes past that take the longest line.
    out: BlockOut,
    margin: usize,
    /// The size limit in bytes (`WaveOptions::limit`).
    limit: u64,
    path: PathBuf,
    over: Arc<AtomicBool>,
}

impl VcdBody {
    /// Writes the header of the signals at `keep` (positions into `slots`) into memory and
    /// returns the body that writes it, then the changes, into `file` (in whole blocks, past
    /// the page cache where it can when `temporary`, a file of its own), with the declared
    /// positions in the header's order. `stop` is raised once the size limit passes.
    pub(super) fn new(
        slots: &[Slot],
        keep: &[usize],
        opts: &WaveOptions,
        file: File,
        temporary: bool,
        path: &Path,
        stop: Arc<AtomicBool>,
    ) -> io::Result<(Self, Vec<usize>)> {
        let mut w = vcd::Writer::new(Vec::new());
        w.version(concat!("shellsim ", env!("CARGO_PKG_VERSION")))?;
        w.comment("one time unit is one clock cycle of the machine; #t is the cycle number")?;
        if opts.window != Window::ALL {
            w.comment(&format!(
                "cycle window {}:{}",
                opts.window.from, opts.window.to
            ))?;
        }
        if let Some(f) = &opts.scope {
            w.comment(&format!("scope filter {:?}", f.pattern()))?;
        }
        w.timescale(1, TimescaleUnit::NS)?;
        let mut lines = Lines {
            formats: vec![LineFormat::default(); slots.len()],
            texts: vec![Vec::new(); slots.len()],
            order: Vec::new(),
        };
        declare(&mut w, &ScopeNode::of(slots, keep), slots, &mut lines)?;
        w.enddefinitions()?;
        // The header goes out ahead of the body, which the body's thread writes from now on.
        let head = std::mem::take(w.writer());
        let margin = lines
            .texts
            .iter()
            .flatten()
            .map(Vec::len)
            .fold(LINE, usize::max);
        let body = VcdBody {
            formats: lines.formats,
            texts: lines.texts,
            declared: lines.order.clone(),
            prev: vec![0; slots.len()],
            pipelines: Vec::new(),
            clock: Clock::default(),
            now: 0,
            stamped: false,
            samples: 0,
            timestamps: 0,
            head,
            out: BlockOut::new(
                file,
                VCD_BLOCK_BYTES + 1 + margin,
                VCD_BLOCK_BYTES,
                temporary,
            ),
            margin,
            limit: opts.limit,
            path: path.to_path_buf(),
            over: stop,
        };
        Ok((body, lines.order))
    }

    /// The body, moving the later stages of the declared `pipelines` itself.
    pub(super) fn with_pipelines(mut self, pipelines: &[Pipeline]) -> Self {
        self.pipelines = pipelines.to_vec();
        self
    }

    /// Room for the next line (`margin` bytes at `at`), the bytes written out first once
    /// they are many.
    #[inline(always)]
    fn room(&mut self) -> io::Result<&mut [u8]> {
        if self.out.is_full() {
            self.out.write_out()?;
        }
        Ok(self.out.window(self.margin))
    }

    /// Appends `bytes` (at most `margin` of them).
    fn put(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.room()?[..bytes.len()].copy_from_slice(bytes);
        self.out.advance(bytes.len());
        Ok(())
    }

    /// `#t\n`.
    fn put_time(&mut self, t: u64) -> io::Result<()> {
        let n = put_time(self.room()?, t);
        self.out.advance(n);
        Ok(())
    }

    /// Position `i`'s line for the value `v`, written as `f` (its format) says: a text's
    /// through its slot, any other in a window of [`LINE`] bytes.
    #[inline(always)]
    fn put_value(&mut self, i: usize, f: &LineFormat, v: u64) -> io::Result<()> {
        if self.out.is_full() {
            self.out.write_out()?;
        }
        let n = if f.class == LineClass::Text {
            put_text(self.out.window(self.margin), f, &self.texts[i], v)
        } else {
            let w = self.out.window(LINE);
            put_line(w.try_into().expect("LINE bytes"), f, v)
        };
        self.out.advance(n);
        Ok(())
    }
}

impl Body for VcdBody {
    fn values(&self) -> usize {
        self.prev.len()
    }

    fn begin(&mut self) -> io::Result<()> {
        // Through the buffer (the body's blocks start at the file's start).
        let head = std::mem::take(&mut self.head);
        self.out.put_all(&head)
    }

    /// One sample, as [`Body::take_sample`] describes; then the size limit, looked at every
    /// 1024 samples (bytes written plus those buffered).
    fn sample(
        &mut self,
        win: Window,
        t: u64,
        changes: &[u64],
    ) -> std::result::Result<(), BodyError> {
        self.take_sample(win, t, changes).map_err(BodyError::Io)?;
        self.samples += 1;
        if self.samples.is_multiple_of(1024) {
            let bytes = self.out.written() + self.out.filled() as u64;
            if bytes > self.limit {
                self.over.store(true, Ordering::Relaxed);
                return Err(BodyError::Limit(format!(
                    "{}: the waveform passed --wave-limit ({} bytes) at cycle {t}, {:.0} bytes per cycle so far; the run was stopped and nothing written. Narrow it with --vcd-window FROM:TO or --vcd-scope PATTERN, or raise --wave-limit",
                    self.path.display(),
                    self.limit,
                    bytes as f64 / (t.max(1) as f64)
                )));
            }
        }
        Ok(())
    }

    fn end(self) -> io::Result<BodyEnd> {
        Ok(BodyEnd {
            file: self.out.finish()?,
            timestamps: self.timestamps,
        })
    }

    fn state(&mut self) -> (&mut Clock, &mut [u64], &[Pipeline]) {
        (&mut self.clock, &mut self.prev, &self.pipelines)
    }

    /// `#t` and the values in a `$dumpvars` block.
    fn dump_all(&mut self, t: u64) -> io::Result<()> {
        self.timestamps += 1;
        self.put_time(t)?;
        self.put(b"$dumpvars\n")?;
        for k in 0..self.declared.len() {
            let i = self.declared[k];
            let f = self.formats[i];
            self.put_value(i, &f, self.prev[i])?;
        }
        self.put(b"$end\n")
    }

    /// Each change taken, and the declared ones' lines after `#t`.
    fn write_changes(&mut self, t: u64, changes: &[u64]) -> io::Result<()> {
        (self.now, self.stamped) = (t, false);
        apply_changes(self, entries(changes))
    }
}

impl ChangeSink for VcdBody {
    type Error = io::Error;

    #[inline(always)]
    fn last(&mut self) -> &mut [u64] {
        &mut self.prev
    }

    fn pipeline(&self, k: usize) -> Option<Pipeline> {
        self.pipelines.get(k).copied()
    }

    /// The line of a declared signal, after `#t` (once per sample).
    #[inline(always)]
    fn change(&mut self, i: usize, v: u64) -> io::Result<()> {
        let f = self.formats[i];
        if f.class != LineClass::Hidden {
            if !self.stamped {
                self.stamped = true;
                self.timestamps += 1;
                self.put_time(self.now)?;
            }
            self.put_value(i, &f, v)?;
        }
        Ok(())
    }
}

/// Declares `node`'s children: a `$scope module` each, its variables, then its sub-scopes;
/// sets each declared position's line format and text lines, and lists it in `order`.
fn declare<W: Write>(
    w: &mut vcd::Writer<W>,
    node: &ScopeNode,
    slots: &[Slot],
    lines: &mut Lines,
) -> io::Result<()> {
    for c in &node.children {
        w.add_module(&c.name)?;
        for &i in &c.vars {
            let (s, names) = (&slots[i].sig, &slots[i].names);
            let id = match s.kind {
                SignalKind::Text { .. } => w.add_var(VarType::String, 1, &s.name, None)?,
                _ if s.width == 1 => w.add_wire(1, &s.name)?,
                _ => w.add_var(
                    VarType::Wire,
                    s.width,
                    &s.name,
                    Some(ReferenceIndex::Range(s.width as i32 - 1, 0)),
                )?,
            };
            let id_text = id.to_string();
            lines.formats[i] = LineFormat::new(s, id_text.as_bytes());
            lines.texts[i] = names
                .iter()
                .map(|n| format!("s{n} {id}\n").into_bytes())
                .collect();
            lines.order.push(i);
        }
        declare(w, c, slots, lines)?;
        w.upscope()?;
    }
    Ok(())
}

/// What [`declare`] builds, per position and in the header's order.
struct Lines {
    formats: Vec<LineFormat>,
    texts: Vec<Vec<Vec<u8>>>,
    order: Vec<usize>,
}

/// Every byte as eight ASCII '0'/'1', MSB first.
static BIN8: [[u8; 8]; 256] = {
    let mut t = [[0u8; 8]; 256];
    let mut i = 0;
    while i < 256 {
        let mut k = 0;
        while k < 8 {
            t[i][k] = b'0' + ((i >> (7 - k)) & 1) as u8;
            k += 1;
        }
        i += 1;
    }
    t
};

/// `#t\n` at the front of `w` (22 bytes or more); returns its length.
fn put_time(w: &mut [u8], mut t: u64) -> usize {
    let mut d = [0u8; 22];
    d[21] = b'\n';
    let mut at = 21;
    loop {
        at -= 1;
        d[at] = b'0' + (t % 10) as u8;
        t /= 10;
        if t == 0 {
            break;
        }
    }
    at -= 1;
    d[at] = b'#';
    let n = 22 - at;
    w[..n].copy_from_slice(&d[at..]);
    n
}

/// Every byte's digits without leading zeros ("0" for zero), left-aligned and zero-padded
/// to 8 bytes, and how many count.
static BIN8_TRIM: [([u8; 8], usize); 256] = {
    let mut t = [([0u8; 8], 0usize); 256];
    let mut i = 0;
    while i < 256 {
        let mut n = 8;
        while n > 1 && (i >> (n - 1)) & 1 == 0 {
            n -= 1;
        }
        let mut k = 0;
        while k < n {
            t[i].0[k] = b'0' + ((i >> (n - 1 - k)) & 1) as u8;
            k += 1;
        }
        t[i].1 = n;
        i += 1;
    }
    t
};

/// Bytes of the longest vector line (`b`, 64 digits, ' ', a 7-character id, '\n'), with
/// room for the last fixed-size copies.
const LINE: usize = 80;

/// How the body writes one signal's value lines, by position: built once when the header is
/// written. Ten bytes, so a whole layout's (435 signals on the paper's machine) stays in the
/// first-level cache.
#[derive(Clone, Copy, Debug, Default)]
struct LineFormat {
    class: LineClass,
    /// The id and a newline, zero-padded to 8 bytes (written as one fixed-size copy), and how
    /// many of its bytes count.
    id_nl: [u8; 8],
    id_nl_len: u8,
}

/// What kind of line a signal's change is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum LineClass {
    /// Outside the scope filter: no line.
    #[default]
    Hidden,
    /// A one-bit wire: `0!`, `1!`.
    Bit,
    /// A vector: `b<bits> !`.
    Vector,
    /// An FSM state: `s<text> !` (the slot's own lines).
    Text,
}

impl LineFormat {
    /// The format of signal `s` declared with the VCD id `id` (a signal outside the scope
    /// filter keeps the default, hidden).
    fn new(s: &Signal, id: &[u8]) -> Self {
        // Seven characters number 94^7 signals.
        assert!(id.len() < 8, "VCD id too long");
        let mut id_nl = [0; 8];
        id_nl[..id.len()].copy_from_slice(id);
        id_nl[id.len()] = b'\n';
        let class = match s.kind {
            SignalKind::Text { .. } => LineClass::Text,
            _ if s.width == 1 => LineClass::Bit,
            _ => LineClass::Vector,
        };
        LineFormat {
            class,
            id_nl,
            id_nl_len: id.len() as u8 + 1,
        }
    }
}

/// One VCD value change line, as the `vcd` crate writes it, at the front of `w`; returns
/// its length: `0!`/`1!` for a one-bit wire, `b<bits> !` for a vector (leading zeros
/// dropped, which VCD zero-extends); none for a text ([`put_text`]) or a hidden signal. A
/// vector of up to 32 bits — every one of the machine's — is shifted so its first 1 leads,
/// and its four bytes' digits come from a table as four 8-byte copies, with no branch on
/// its length; the id is one 8-byte copy; bytes past the line's end are left as they fall.
#[inline(always)]
fn put_line(w: &mut [u8; LINE], f: &LineFormat, v: u64) -> usize {
    let id_len = f.id_nl_len as usize;
    match f.class {
        LineClass::Bit => {
            w[0] = b'0' + (v & 1) as u8;
            w[1..9].copy_from_slice(&f.id_nl);
            1 + id_len
        }
        LineClass::Vector if v >> 32 == 0 => {
            // Shifted up so its first 1 is bit 31, its n digits lead the word's 32; the
            // (zero) digits after them fall where the id goes.
            let n = (32 - (v as u32).leading_zeros()).max(1) as usize;
            let u = (v as u32) << (32 - n);
            w[0] = b'b';
            for k in 0..4 {
                let byte = (u >> (24 - 8 * k)) & 0xFF;
                w[1 + 8 * k..9 + 8 * k].copy_from_slice(&BIN8[byte as usize]);
            }
            w[1 + n] = b' ';
            w[2 + n..10 + n].copy_from_slice(&f.id_nl);
            2 + n + id_len
        }
        LineClass::Vector => {
            w[0] = b'b';
            let n = (64 - v.leading_zeros()).max(1) as usize;
            let top = (n - 1) / 8;
            let (first, len) = &BIN8_TRIM[((v >> (8 * top)) & 0xFF) as usize];
            w[1..9].copy_from_slice(first);
            let mut at = 1 + len;
            for k in (0..top).rev() {
                w[at..at + 8].copy_from_slice(&BIN8[((v >> (8 * k)) & 0xFF) as usize]);
                at += 8;
            }
            w[at] = b' ';
            w[at + 1..at + 9].copy_from_slice(&f.id_nl);
            at + 1 + id_len
        }
        LineClass::Text | LineClass::Hidden => 0,
    }
}

/// A text's value change line (`s<text> !`, the slot's own for the state `v`) at the front
/// of `w` (the longest of them fits); returns its length.
fn put_text(w: &mut [u8], f: &LineFormat, lines: &[Vec<u8>], v: u64) -> usize {
    if let Some(l) = lines.get(v as usize) {
        w[..l.len()].copy_from_slice(l);
        return l.len();
    }
    // Not a state of the declared list: shown as "-".
    w[..3].copy_from_slice(b"s- ");
    w[3..11].copy_from_slice(&f.id_nl);
    3 + f.id_nl_len as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hand-formatted lines are the `vcd` crate's.
    #[test]
    fn value_lines_are_the_vcd_crates() {
        let mut sig = Signal {
            scope: "m".into(),
            name: "x".into(),
            width: 40,
            kind: SignalKind::Bits,
        };
        let mut w = [0u8; LINE];
        for v in [
            0u64,
            1,
            2,
            0xFF,
            0x100,
            0x7F,
            0x80,
            0x1234_5678,
            0x8000_0000,
            0xFFFF_FFFF,
            0x1_0000_0000,
            0xFF_FFFF_FFFF,
            u64::MAX,
        ] {
            let n = put_line(&mut w, &LineFormat::new(&sig, b"%+"), v);
            let buf = w[..n].to_vec();
            let mut w = vcd::Writer::new(Vec::new());
            let n = (64 - v.leading_zeros()).max(1);
            let bits = (0..n).rev().map(|k| {
                if (v >> k) & 1 == 1 {
                    vcd::Value::V1
                } else {
                    vcd::Value::V0
                }
            });
            w.change_vector("%+".parse().unwrap(), bits).unwrap();
            assert_eq!(buf, w.writer().clone(), "{v:#x}");
        }
        sig.width = 1;
        let n = put_line(&mut w, &LineFormat::new(&sig, b"%+"), 1);
        assert_eq!(&w[..n], b"1%+\n");
        let n = put_time(&mut w, 1234567);
        assert_eq!(&w[..n], b"#1234567\n");
        let n = put_time(&mut w, 0);
        assert_eq!(&w[..n], b"#0\n");
        let n = put_time(&mut w, u64::MAX);
        assert_eq!(&w[..n], format!("#{}\n", u64::MAX).as_bytes());
    }
}
