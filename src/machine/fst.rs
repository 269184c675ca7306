//! FST output: the value-change half of the waveform writer ([`super::vcd::VcdWriter`]) for a
//! `.fst` path, on the patched `fst-writer` crate (vendor/fst-writer).
//!
//! Each sample's flat value array is compared with the previous one eight values at a time;
//! each changed declared value goes to the crate as an integer (a text, an FSM state, as the
//! bits of its ASCII characters). The crate records these calls in blocks for a writer thread
//! of its own, which encodes them into per-signal change chains, compresses each section with
//! zlib and writes it — in order, so the file's bytes depend neither on the timing nor on the
//! thread. Sections are cut every [`FST_FLUSH_BYTES`] of changes so memory stays bounded.

use fst_writer::{FstBodyWriter, FstCompression, FstSignalId};
use std::fs::File;
use std::io::{self, BufWriter, Write};

/// Cut a section (compressed on its own) past this many bytes of encoded value changes.
const FST_FLUSH_BYTES: usize = 32 << 20;

/// How the sections are compressed: zlib level 1 — the fastest level, which already makes
/// the FST ~13× smaller than the VCD (BENCHMARKS.md, issue 13).
const FST_COMPRESSION: FstCompression = FstCompression::Zlib(1);

/// One probe signal as the FST body writes it.
#[derive(Clone, Copy)]
pub(crate) struct FstHandle {
    /// Its FST signal, when declared (inside the scope filter).
    pub id: Option<FstSignalId>,
    /// A text (FSM state): written as the bits of its ASCII characters.
    pub text: bool,
}

/// The FST's value changes, after the header.
pub(crate) struct FstBody {
    w: FstBodyWriter<BufWriter<File>>,
    /// Per probe signal (the sample's positions), its FST signal when it is a declared
    /// bit vector (written as an integer).
    ints: Vec<Option<FstSignalId>>,
    /// Per probe signal, its FST signal when it is a declared text.
    texts: Vec<Option<FstSignalId>>,
    /// Per probe signal, a text's values as FST bits: one per name, then "-" (any other).
    text_bits: Vec<Vec<Vec<u8>>>,
    /// One sample's integer changes, handed over together (room for every signal).
    batch: Vec<(FstSignalId, u64)>,
    /// One sample's text changes (probe position, value).
    text_batch: Vec<(usize, u64)>,
    /// Time changes written (a section may be cut every 256).
    stamps: u64,
}

/// Bit `k` set when `prev[k] != values[k]`: eight values compared at once (fixed-size arrays,
/// no bounds checks, no branches).
#[inline(always)]
pub(crate) fn changed_mask8(prev: &[u64; 8], values: &[u64; 8]) -> u32 {
    let mut m = 0u32;
    for k in 0..8 {
        m |= ((prev[k] != values[k]) as u32) << k;
    }
    m
}

/// An FST error as an I/O error (the writer reports every failure as "writing: …").
pub(crate) fn fst_err(e: fst_writer::FstWriteError) -> io::Error {
    match e {
        fst_writer::FstWriteError::Io(e) => e,
        e => io::Error::other(e.to_string()),
    }
}

impl FstBody {
    /// The body writer `w` (the header written), the signals' handles and texts (by probe
    /// position); starts the writer thread.
    pub(crate) fn new(
        mut w: FstBodyWriter<BufWriter<File>>,
        handles: Vec<FstHandle>,
        text_bits: Vec<Vec<Vec<u8>>>,
    ) -> io::Result<Self> {
        w.set_compression(FST_COMPRESSION);
        w.write_in_background().map_err(fst_err)?;
        let n = handles.len();
        Ok(FstBody {
            w,
            ints: handles.iter().map(|h| h.id.filter(|_| !h.text)).collect(),
            texts: handles.iter().map(|h| h.id.filter(|_| h.text)).collect(),
            text_bits,
            batch: Vec::with_capacity(n),
            text_batch: Vec::with_capacity(n),
            stamps: 0,
        })
    }

    /// Time `t` and every declared value of `values` (in `order`): FST has no `$dumpvars`,
    /// the first time's values are the initial state.
    pub(crate) fn dump_all(&mut self, t: u64, order: &[usize], values: &[u64]) -> io::Result<()> {
        self.w.time_change(t).map_err(fst_err)?;
        self.stamps += 1;
        for &i in order {
            self.take(i, values[i]);
        }
        self.write_batch()
    }

    /// Queues probe signal `i`'s value `v` when declared.
    #[inline(always)]
    fn take(&mut self, i: usize, v: u64) {
        if let Some(id) = self.ints[i] {
            self.batch.push((id, v));
        } else if self.texts[i].is_some() {
            self.text_batch.push((i, v));
        }
    }

    /// Writes the queued changes (at the current time).
    fn write_batch(&mut self) -> io::Result<()> {
        self.w.signal_changes_u64(&self.batch).map_err(fst_err)?;
        self.batch.clear();
        for &(i, v) in &self.text_batch {
            let id = self.texts[i].expect("queued texts are declared");
            let lines = &self.text_bits[i];
            let line = &lines[(v as usize).min(lines.len() - 1)];
            self.w.signal_change(id, line).map_err(fst_err)?;
        }
        self.text_batch.clear();
        Ok(())
    }

    /// Compares `values` with `prev` (taking them), and writes time `t` and the changed
    /// declared values. Returns true when it wrote something (a time change).
    pub(crate) fn write_changes(
        &mut self,
        t: u64,
        prev: &mut [u64],
        values: &[u64],
    ) -> io::Result<bool> {
        let n = values.len().min(prev.len());
        let whole = n - n % 8;
        // Eight values at a time: a mask of the changed ones, then only those.
        for base in (0..whole).step_by(8) {
            let p: &mut [u64; 8] = (&mut prev[base..base + 8]).try_into().expect("8");
            let v: &[u64; 8] = values[base..base + 8].try_into().expect("8");
            let mut m = changed_mask8(p, v);
            if m == 0 {
                continue;
            }
            *p = *v;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                self.take(base + k, v[k]);
            }
        }
        for i in whole..n {
            if prev[i] != values[i] {
                prev[i] = values[i];
                self.take(i, values[i]);
            }
        }
        if self.batch.is_empty() && self.text_batch.is_empty() {
            return Ok(false);
        }
        self.w.time_change(t).map_err(fst_err)?;
        self.stamps += 1;
        self.write_batch()?;
        if self.stamps.is_multiple_of(256) && self.w.size() > FST_FLUSH_BYTES {
            self.w.flush().map_err(fst_err)?;
        }
        Ok(true)
    }

    /// Writes the last section and the header's totals; returns the file's size.
    pub(crate) fn finish(self) -> io::Result<u64> {
        let mut w = self.w.finish().map_err(fst_err)?;
        w.flush()?;
        let f = w.get_ref();
        crate::output::sync_file(f)?;
        f.metadata().map(|m| m.len())
    }
}
