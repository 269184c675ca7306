//! The FST format (GTKWave's compressed format): the header and the value changes of a
//! `.fst` path, on the patched `fst-writer` crate (vendor/fst-writer).
//!
//! The crate writes bit vectors and reals only, so a string (an FSM state) is a bit vector of
//! [`FST_TEXT_CHARS`] ASCII characters, right-aligned and NUL-padded, which the .gtkw shows in
//! GTKWave's ASCII format: the same text as the VCD's string variable.
//!
//! The body runs on the waveform's own thread, fed the samples' value arrays in order by the
//! simulation thread (`super::stream`): each sample comes as its
//! changed values (the machine finds them as it fills its array), and each changed declared value goes to the crate
//! as an integer (a text, an FSM state, as the bits of its ASCII characters), which encodes
//! it into its signal's change chain; each section is compressed (zlib format through
//! libdeflate, or LZ4: [`FstPack`]) and written in turn by the crate's compressor thread
//! while the next one fills, so the file's bytes do not depend on the timing. Sections are
//! cut every [`FST_FLUSH_BYTES`] of changes (the crate's estimate) so memory stays bounded.

use super::options::{FstPack, WaveOptions, Window};
use super::signal::{ScopeNode, SignalKind, Slot};
use super::stream::{entries, Body, BodyEnd, Clock};
use fst_writer::{
    FstBodyWriter, FstCompression, FstFileType, FstHeaderWriter, FstInfo, FstScopeType,
    FstSignalId, FstSignalType, FstVarDirection, FstVarType,
};
use shellsim_hw::trace::{apply_changes, ChangeSink};
use std::fs::File;
use std::io::{self, BufWriter, Write};

/// Characters of an FST text signal (the longest FSM state, SHELL_START, has 11); a longer
/// text keeps its last 16 characters.
pub const FST_TEXT_CHARS: u32 = 16;

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

/// One probe signal as the FST body writes it.
#[derive(Clone, Copy)]
struct FstHandle {
    /// Its FST signal, when declared (inside the scope filter).
    id: Option<FstSignalId>,
    /// A text (FSM state): written as the bits of its ASCII characters.
    text: bool,
    /// Its width in the FST, in bits (a text's: 8 per character).
    width: u32,
}

/// The FST's value changes, after the header, on the waveform's thread (`super::stream`): the last sample's values, the window clock, and the crate's body writer.
pub(super) struct FstBody {
    w: FstBodyWriter<BufWriter<File>>,
    /// Per probe signal (the sample's positions): its FST signal and how it is written.
    sigs: Vec<Sig>,
    /// Per probe signal, a text's values as FST bits: one per name, then "-" (any other);
    /// each as '0'/'1' and packed eight bits a byte.
    text_bits: Vec<Vec<(Vec<u8>, Vec<u8>)>>,
    /// Declared signals in the header's order (probe positions).
    order: Vec<usize>,
    /// The last sample's values and the window.
    prev: Vec<u64>,
    clock: Clock,
    /// The sample being written, and whether its time change is out.
    now: u64,
    stamped: bool,
    /// One sample's integer changes, handed over together (room for every signal).
    batch: Vec<(FstSignalId, u64)>,
    /// One sample's text changes (probe position, value).
    text_batch: Vec<(usize, u64)>,
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
    /// A text (FSM state), else a bit vector written as an integer.
    text: bool,
    /// The bytes a change of it counts toward a section's size: one for the time delta and
    /// the value's bytes (the crate's own estimate of its chains).
    cost: u32,
}

/// '0'/'1' bits packed eight a byte, MSB first, the last byte padded with zeros.
fn pack_bits(bits: &[u8]) -> Vec<u8> {
    bits.chunks(8)
        .map(|c| {
            c.iter()
                .enumerate()
                .fold(0u8, |b, (k, &x)| b | ((x == b'1') as u8) << (7 - k))
        })
        .collect()
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
            texts: vec![Vec::new(); slots.len()],
            order: Vec::new(),
        };
        declare(&mut h, &ScopeNode::of(slots, keep), slots, &mut decl).map_err(fst_err)?;
        let handles: Vec<FstHandle> = slots
            .iter()
            .zip(&decl.ids)
            .map(|(s, &id)| FstHandle {
                id,
                text: s.sig.kind == SignalKind::Text,
                width: fst_width(s),
            })
            .collect();
        let order = decl.order;
        let body = Self::on(
            h.finish().map_err(fst_err)?,
            handles,
            decl.texts,
            order.clone(),
            pack,
        )?;
        Ok((body, order))
    }

    /// The body writer `w` (the header written), the signals' handles and texts (by probe
    /// position) and the declared order.
    fn on(
        mut w: FstBodyWriter<BufWriter<File>>,
        handles: Vec<FstHandle>,
        text_bits: Vec<Vec<Vec<u8>>>,
        order: Vec<usize>,
        pack: FstPack,
    ) -> io::Result<Self> {
        w.set_compression(compression(pack));
        // The probe lists only values that changed: no change repeats the last value, so
        // the crate's test for one is never true.
        w.set_deduplicate(false);
        w.compress_in_background().map_err(fst_err)?;
        let sigs = handles.iter().map(|h| Sig {
            id: h.id,
            text: h.text,
            cost: 1 + h.width.div_ceil(8),
        });
        Ok(FstBody {
            w,
            sigs: sigs.collect(),
            text_bits: text_bits
                .into_iter()
                .map(|lines| {
                    let packed = lines.iter().map(|l| pack_bits(l)).collect::<Vec<_>>();
                    lines.into_iter().zip(packed).collect()
                })
                .collect(),
            order,
            prev: vec![0; handles.len()],
            clock: Clock::default(),
            now: 0,
            stamped: false,
            batch: Vec::with_capacity(handles.len()),
            text_batch: Vec::with_capacity(handles.len()),
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
            if s.text {
                self.text_batch.push((i, v));
            } else {
                self.batch.push((id, v));
            }
        }
    }

    /// Writes time `t` and the queued changes, when there are any.
    fn write_batch(&mut self, t: u64) -> io::Result<bool> {
        if self.batch.is_empty() && self.text_batch.is_empty() {
            return Ok(false);
        }
        self.w.time_change(t).map_err(fst_err)?;
        self.stamps += 1;
        self.w.signal_changes_u64(&self.batch).map_err(fst_err)?;
        self.batch.clear();
        self.write_texts()?;
        Ok(true)
    }

    /// Writes the queued text changes (at the time step already written).
    fn write_texts(&mut self) -> io::Result<()> {
        for &(i, v) in &self.text_batch {
            let id = self.sigs[i].id.expect("queued texts are declared");
            let lines = &self.text_bits[i];
            let (ascii, packed) = &lines[(v as usize).min(lines.len() - 1)];
            self.w
                .signal_change_packed(id, ascii, packed)
                .map_err(fst_err)?;
        }
        self.text_batch.clear();
        Ok(())
    }
}

impl Body for FstBody {
    fn values(&self) -> usize {
        self.prev.len()
    }

    fn state(&mut self) -> (&mut Clock, &mut [u64]) {
        (&mut self.clock, &mut self.prev)
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
        // Each integer change goes to the crate as it comes (time `t` first, once); the
        // texts after them (each signal's chain is its own, so the order between signals
        // within a time step does not show in the file).
        (self.now, self.stamped) = (t, false);
        apply_changes(self, entries(changes))?;
        let stamped = self.stamped;
        self.write_texts()?;
        if stamped && self.stamps.is_multiple_of(256) && self.size > FST_FLUSH_BYTES {
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

    /// A declared signal's change (after time `now`, once per sample): an integer to the
    /// crate now, a text queued for after the sample's integers.
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
        if s.text {
            self.text_batch.push((i, v));
        } else {
            self.w.signal_change_u64(id, v).map_err(fst_err)?;
        }
        Ok(())
    }
}

/// What [`declare`] builds: per position its FST id and a text's values as FST bits, and
/// the declared positions in the header's order.
struct Declared {
    ids: Vec<Option<FstSignalId>>,
    texts: Vec<Vec<Vec<u8>>>,
    order: Vec<usize>,
}

/// Declares `node`'s children in the FST, as the VCD's header does: a module scope each,
/// its variables, then its sub-scopes.
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
            let id = h.var(
                &s.sig.name,
                FstSignalType::bit_vec(fst_width(s)),
                FstVarType::Wire,
                FstVarDirection::Implicit,
                None,
            )?;
            decl.ids[i] = Some(id);
            let mut texts: Vec<Vec<u8>> = s.names.iter().map(|n| fst_text_bits(n)).collect();
            texts.push(fst_text_bits("-"));
            decl.texts[i] = texts;
            decl.order.push(i);
        }
        declare(h, c, slots, decl)?;
        h.up_scope()?;
    }
    Ok(())
}

/// A signal's width in the FST: a text's is [`FST_TEXT_CHARS`] ASCII characters.
fn fst_width(s: &Slot) -> u32 {
    match s.sig.kind {
        SignalKind::Text => 8 * FST_TEXT_CHARS,
        _ => s.sig.width,
    }
}

/// A text as FST writes it: [`FST_TEXT_CHARS`] ASCII characters, right-aligned and
/// NUL-padded (a longer text keeps its tail), as '0'/'1' bytes MSB first.
fn fst_text_bits(t: &str) -> Vec<u8> {
    let bytes = t.as_bytes();
    let n = FST_TEXT_CHARS as usize;
    let tail = &bytes[bytes.len().saturating_sub(n)..];
    let pad = std::iter::repeat_n(0u8, n - tail.len());
    pad.chain(tail.iter().copied())
        .flat_map(|c| format!("{c:08b}").into_bytes())
        .collect()
}
