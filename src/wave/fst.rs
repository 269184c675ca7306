//! The FST format (GTKWave's compressed format): the header and the value changes of a
//! `.fst` path, on the patched `fst-writer` crate (vendor/fst-writer).
//!
//! A fixed-point value is declared with its binary point in the name's range (`t[2:-12]`,
//! as GTKWave and wellen read an FST variable's range from its name), so Surfer scales it.
//! An FSM state (a text signal) is a small integer, its state's index — as wide as its
//! [`state_bits`] — declared with an FST enum table that names each value (the VCD's
//! strings, then "-" for any other value): GTKWave (through the .gtkw's `TR_ENUM`) and
//! Surfer show the names, and one table serves every signal with the same names.
//!
//! The body runs on the waveform's own thread, fed the samples' value arrays in order by the
//! simulation thread (`super::stream`): each sample comes as its
//! changed values (the machine finds them as it fills its array), and each changed declared value goes to the crate
//! as an integer, which encodes
//! it into its signal's change chain; each section is compressed (zlib format through
//! libdeflate, or LZ4: [`FstPack`]) and written in turn by the crate's compressor thread
//! while the next one fills, so the file's bytes do not depend on the timing. Sections are
//! cut every [`FST_FLUSH_BYTES`] of changes (the crate's estimate) so memory stays bounded.

use super::options::{FstPack, WaveOptions, Window};
use super::signal::{state_bits, ScopeNode, SignalKind, Slot};
use super::stream::{entries, Body, BodyEnd, Clock};
use fst_writer::{
    FstBodyWriter, FstCompression, FstEnumHandle, FstFileType, FstHeaderWriter, FstInfo,
    FstScopeType, FstSignalId, FstSignalType, FstVarDirection, FstVarType,
};
use shellsim_hw::trace::{apply_changes, ChangeSink, Pipeline};
use std::fs::File;
use std::io::{self, BufWriter, Write};

/// The FST's header writer, until the layout is declared.
pub(super) type FstHeader = FstHeaderWriter<BufWriter<File>>;

/// Starts the FST in `f`: its header block, the time starting at the window's start.
pub(super) fn header(f: File, opts: &WaveOptions) -> fst_writer::Result<FstHeader> {
    let buf = BufWriter::with_capacity(1 << 16, f);
    let info = FstInfo {
        start_time: if opts.window == Window::ALL {
            0
        } else {
            opts.window.from
        },
        timescale_exponent: -9,
        version: concat!("shellsim ", env!("CARGO_PKG_VERSION")).to_string(),
        // No date, so the same run gives a byte-identical file.
        date: String::new(),
        file_type: FstFileType::Verilog,
    };
    FstHeaderWriter::new(buf, &info)
}

/// Cut a section (compressed on its own, on the crate's compressor thread while the next
/// one fills) past this many bytes of encoded value changes: at Hi_Low_Ratio 10 nine sections,
/// so compressing overlaps filling for all but the last (32 MiB: 0.8 % smaller, 5 sections).
const FST_FLUSH_BYTES: usize = 16 << 20;

/// How the sections are compressed for each [`FstPack`]: zlib format through libdeflate at
/// level 1 — the fastest level, which makes the FST ~18× smaller than the VCD, cheaper than
/// miniz_oxide's zlib level 1 (~13×) — or LZ4 (~8.5×, short of issue 13's 10×, for about a
/// quarter of the compressor's work; BENCHMARKS.md).
fn compression(pack: FstPack) -> FstCompression {
    match pack {
        FstPack::Zlib => FstCompression::Deflate(1),
        FstPack::Lz4 => FstCompression::Lz4,
    }
}

/// The FST's value changes, after the header, on the waveform's thread (`super::stream`): the last sample's values, the window clock, and the crate's body writer.
pub(super) struct FstBody {
    w: FstBodyWriter<BufWriter<File>>,
    /// Per probe signal (the sample's positions): its FST signal and how it is written.
    sigs: Vec<Sig>,
    /// Declared signals in the header's order (probe positions).
    order: Vec<usize>,
    /// The last sample's values and the window.
    prev: Vec<u64>,
    clock: Clock,
    /// The sample being written, and whether its time change is out.
    now: u64,
    stamped: bool,
    /// One sample's changes, handed over together (room for every signal).
    batch: Vec<(FstSignalId, u64)>,
    /// Bytes of value changes counted since the last section was cut (see [`FST_FLUSH_BYTES`]).
    size: usize,
    /// Time changes written (a section may be cut every 256).
    stamps: u64,
}

/// One probe signal as the body writes it.
#[derive(Clone, Copy)]
struct Sig {
    /// Its FST signal, when declared.
    id: Option<FstSignalId>,
    /// The largest value written as is: an FSM state's index past its names is written as
    /// the table's "-" (the names' count); any other signal's values are written unchanged.
    max: u64,
    /// The bytes a change of it counts toward a section's size: one for the time delta and
    /// the value's bytes (the crate's own estimate of its chains).
    cost: u32,
}

/// An FST error as an I/O error (the writer reports every failure as "writing: …").
pub(super) fn fst_err(e: fst_writer::FstWriteError) -> io::Error {
    match e {
        fst_writer::FstWriteError::Io(e) => e,
        e => io::Error::other(e.to_string()),
    }
}

impl FstBody {
    /// Declares the signals at `keep` (positions into `slots`) in the header `h` and returns
    /// the body that writes the changes after it, with the declared positions in the
    /// header's order; starts the thread that compresses the sections (as `pack` says).
    pub(super) fn new(
        mut h: FstHeader,
        slots: &[Slot],
        keep: &[usize],
        pack: FstPack,
    ) -> io::Result<(Self, Vec<usize>)> {
        let mut decl = Declared {
            ids: vec![None; slots.len()],
            tables: Vec::new(),
            order: Vec::new(),
        };
        declare(&mut h, &ScopeNode::of(slots, keep), slots, &mut decl).map_err(fst_err)?;
        let sigs = slots
            .iter()
            .zip(&decl.ids)
            .map(|(s, &id)| Sig {
                id,
                max: match s.sig.kind {
                    SignalKind::Text { states } => states as u64,
                    _ => u64::MAX,
                },
                cost: 1 + fst_width(s).div_ceil(8),
            })
            .collect();
        let order = decl.order;
        let body = Self::on(h.finish().map_err(fst_err)?, sigs, order.clone(), pack)?;
        Ok((body, order))
    }

    /// The body writer `w` (the header written), the signals (by probe position) and the
    /// declared order.
    fn on(
        mut w: FstBodyWriter<BufWriter<File>>,
        sigs: Vec<Sig>,
        order: Vec<usize>,
        pack: FstPack,
    ) -> io::Result<Self> {
        w.set_compression(compression(pack));
        // The probe lists only values that changed: no change repeats the last value, so
        // the crate's test for one is never true.
        w.set_deduplicate(false);
        w.compress_in_background().map_err(fst_err)?;
        let n = sigs.len();
        Ok(FstBody {
            w,
            sigs,
            order,
            prev: vec![0; n],
            clock: Clock::default(),
            now: 0,
            stamped: false,
            batch: Vec::with_capacity(n),
            size: 0,
            stamps: 0,
        })
    }

    /// Queues probe signal `i`'s value `v` when declared.
    #[inline(always)]
    fn take(&mut self, i: usize, v: u64) {
        let s = self.sigs[i];
        if let Some(id) = s.id {
            self.size += s.cost as usize;
            self.batch.push((id, v.min(s.max)));
        }
    }

    /// Writes time `t` and the queued changes, when there are any.
    fn write_batch(&mut self, t: u64) -> io::Result<bool> {
        if self.batch.is_empty() {
            return Ok(false);
        }
        self.w.time_change(t).map_err(fst_err)?;
        self.stamps += 1;
        self.w.signal_changes_u64(&self.batch).map_err(fst_err)?;
        self.batch.clear();
        Ok(true)
    }
}

impl Body for FstBody {
    fn values(&self) -> usize {
        self.prev.len()
    }

    /// No pipeline: an FST's probe does not shift stages (`Probe::shifts_stages`).
    fn state(&mut self) -> (&mut Clock, &mut [u64], &[Pipeline]) {
        (&mut self.clock, &mut self.prev, &[])
    }

    /// Time `t` and every declared value (the last sample's): FST has no `$dumpvars`, the
    /// first time's values are the initial state.
    fn dump_all(&mut self, t: u64) -> io::Result<()> {
        for k in 0..self.order.len() {
            let i = self.order[k];
            self.take(i, self.prev[i]);
        }
        self.write_batch(t).map(|_| ())
    }

    /// Takes the sample's changes and writes time `t` and the changed declared values
    /// (nothing when none is declared); cuts a section past [`FST_FLUSH_BYTES`].
    fn write_changes(&mut self, t: u64, changes: &[u64]) -> io::Result<()> {
        // Each change goes to the crate as it comes (time `t` first, once).
        (self.now, self.stamped) = (t, false);
        apply_changes(self, entries(changes))?;
        if self.stamped && self.stamps.is_multiple_of(256) && self.size > FST_FLUSH_BYTES {
            self.size = 0;
            self.w.flush().map_err(fst_err)?;
        }
        Ok(())
    }

    /// Writes the last section and the header's totals.
    fn end(self) -> io::Result<BodyEnd> {
        let w = self.w.finish().map_err(fst_err)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        Ok(BodyEnd {
            file,
            timestamps: self.stamps,
        })
    }
}

impl ChangeSink for FstBody {
    type Error = io::Error;

    #[inline(always)]
    fn last(&mut self) -> &mut [u64] {
        &mut self.prev
    }

    /// None: an FST's probe does not shift stages (`Probe::shifts_stages`), so no entry
    /// names a pipeline.
    fn pipeline(&self, _: usize) -> Option<Pipeline> {
        None
    }

    /// A declared signal's change (after time `now`, once per sample), to the crate now.
    #[inline(always)]
    fn change(&mut self, i: usize, v: u64) -> io::Result<()> {
        let s = self.sigs[i];
        let Some(id) = s.id else {
            return Ok(());
        };
        if !self.stamped {
            self.stamped = true;
            self.w.time_change(self.now).map_err(fst_err)?;
            self.stamps += 1;
        }
        self.size += s.cost as usize;
        self.w.signal_change_u64(id, v.min(s.max)).map_err(fst_err)
    }
}

/// What [`declare`] builds: per position its FST id, the enum tables declared (their
/// names' lists, tables' names and handles), and the declared positions in the header's
/// order.
struct Declared {
    ids: Vec<Option<FstSignalId>>,
    tables: Vec<(Vec<String>, String, FstEnumHandle)>,
    order: Vec<usize>,
}

/// Declares `node`'s children in the FST, as the VCD's header does: a module scope each,
/// its variables, then its sub-scopes; an FSM state with its enum table (declared before
/// its first user, shared by every state with the same names).
fn declare<W: Write + io::Seek>(
    h: &mut FstHeaderWriter<W>,
    node: &ScopeNode,
    slots: &[Slot],
    decl: &mut Declared,
) -> fst_writer::Result<()> {
    for c in &node.children {
        h.scope(&c.name, "", FstScopeType::Module)?;
        for &i in &c.vars {
            let s = &slots[i];
            let tpe = FstSignalType::bit_vec(fst_width(s));
            let (wire, dir) = (FstVarType::Wire, FstVarDirection::Implicit);
            let id = match s.sig.kind {
                SignalKind::Text { .. } => {
                    let table = enum_table(h, s, &mut decl.tables)?;
                    h.var_with_enum(&s.sig.name, tpe, wire, dir, table)?
                }
                _ => match s.sig.fixed_range() {
                    Some((msb, lsb)) if s.sig.width > 1 => {
                        let name = format!("{}[{msb}:{lsb}]", s.sig.name);
                        h.var(name, tpe, wire, dir, None)?
                    }
                    _ => h.var(&s.sig.name, tpe, wire, dir, None)?,
                },
            };
            decl.ids[i] = Some(id);
            decl.order.push(i);
        }
        declare(h, c, slots, decl)?;
        h.up_scope()?;
    }
    Ok(())
}

/// The enum table of the FSM state `s`: its names, then "-" (any other value), valued
/// 0, 1, … in [`state_bits`] bits; declared when no earlier state has the same names, and
/// named after the signal (`state`, then `state_1`, … for other lists of names).
fn enum_table<W: Write + io::Seek>(
    h: &mut FstHeaderWriter<W>,
    s: &Slot,
    tables: &mut Vec<(Vec<String>, String, FstEnumHandle)>,
) -> fst_writer::Result<FstEnumHandle> {
    if let Some((.., t)) = tables.iter().find(|(n, ..)| *n == s.names) {
        return Ok(*t);
    }
    let base: String = s
        .sig
        .name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    let same = tables
        .iter()
        .filter(|(_, n, _)| n.starts_with(&base))
        .count();
    let name = match same {
        0 => base,
        k => format!("{base}_{k}"),
    };
    let w = fst_width(s) as usize;
    let values: Vec<String> = (0..=s.names.len()).map(|k| format!("{k:0w$b}")).collect();
    let entries: Vec<(&str, &str)> = s
        .names
        .iter()
        .map(String::as_str)
        .chain(["-"])
        .zip(values.iter().map(String::as_str))
        .collect();
    let t = h.enum_table(&name, w as u32, &entries)?;
    tables.push((s.names.clone(), name, t));
    Ok(t)
}

/// A signal's width in the FST: an FSM state's is its [`state_bits`].
fn fst_width(s: &Slot) -> u32 {
    match s.sig.kind {
        SignalKind::Text { states } => state_bits(states),
        _ => s.sig.width,
    }
}
