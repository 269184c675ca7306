//! The header and body writers, and the body's optional writer thread.
// Copyright 2024 Cornell University
// released under BSD 3-Clause License
// author: Kevin Laeufer <laeufer@cornell.edu>
//
// shellsim: `FstBodyWriter` can compress with zlib (`set_compression`), take bit vectors as
// integers (`signal_change_u64`) and record its calls for a writer thread that encodes,
// compresses and writes them (`write_in_background`).

use crate::buffer::{SignalBuffer, full_length_value};
use crate::io::{
    ATTRIBUTE_TYPE_MISC, FstCompression, HeaderFinishInfo, MISC_TYPE_ENUM_TABLE, Section,
    SectionScratch, escape_enum_text, update_header, write_geometry, write_header_meta_data,
    write_hierarchy_attribute_begin, write_hierarchy_attribute_end, write_hierarchy_bytes,
    write_hierarchy_scope, write_hierarchy_up_scope, write_hierarchy_var,
    write_value_change_section,
};
use crate::{
    FstEnumHandle, FstInfo, FstScopeType, FstSignalId, FstSignalType, FstVarDirection, FstVarType,
    FstWriteError, Result,
};

pub fn open_fst<P: AsRef<std::path::Path>>(
    path: P,
    info: &FstInfo,
) -> Result<FstHeaderWriter<std::io::BufWriter<std::fs::File>>> {
    FstHeaderWriter::open(path, info)
}

pub struct FstHeaderWriter<W: std::io::Write + std::io::Seek> {
    out: W,
    /// collect hierarchy section before compressing it
    hierarchy_buf: std::io::Cursor<Vec<u8>>,
    signals: Vec<FstSignalType>,
    scope_depth: u64,
    var_count: u64,
    scope_count: u64,
    /// Enum tables declared (the last handle).
    enum_count: u32,
}

impl FstHeaderWriter<std::io::BufWriter<std::fs::File>> {
    pub fn open<P: AsRef<std::path::Path>>(path: P, info: &FstInfo) -> Result<Self> {
        let f = std::fs::File::create(path)?;
        let out = std::io::BufWriter::new(f);
        Self::new(out, info)
    }
}

impl FstHeaderWriter<std::io::Cursor<Vec<u8>>> {
    pub fn write_to_mem(info: &FstInfo) -> Result<Self> {
        Self::new(std::io::Cursor::new(Vec::new()), info)
    }
}

impl<W: std::io::Write + std::io::Seek> FstHeaderWriter<W> {
    pub fn new(mut out: W, info: &FstInfo) -> Result<Self> {
        write_header_meta_data(&mut out, info)?;
        Ok(Self {
            out,
            hierarchy_buf: std::io::Cursor::new(Vec::new()),
            signals: vec![],
            scope_depth: 0,
            var_count: 0,
            scope_count: 0,
            enum_count: 0,
        })
    }
    pub fn scope(
        &mut self,
        name: impl AsRef<str>,
        component: impl AsRef<str>,
        tpe: FstScopeType,
    ) -> Result<()> {
        self.scope_depth += 1;
        self.scope_count += 1;
        write_hierarchy_scope(&mut self.hierarchy_buf, name, component, tpe)
    }
    pub fn up_scope(&mut self) -> Result<()> {
        debug_assert!(self.scope_depth > 0, "no scope to pop");
        self.scope_depth -= 1;
        write_hierarchy_up_scope(&mut self.hierarchy_buf)
    }

    pub fn var(
        &mut self,
        name: impl AsRef<str>,
        signal_tpe: FstSignalType,
        tpe: FstVarType,
        dir: FstVarDirection,
        alias: Option<FstSignalId>,
    ) -> Result<FstSignalId> {
        self.var_count += 1;
        write_hierarchy_var(&mut self.hierarchy_buf, tpe, dir, name, signal_tpe, alias)?;
        if let Some(alias) = alias {
            debug_assert!(alias.to_index() <= self.signals.len() as u32);
            Ok(alias)
        } else {
            self.signals.push(signal_tpe);
            let id = FstSignalId::from_index(self.signals.len() as u32);
            Ok(id)
        }
    }

    /// Declares an enum table (fstapi.c's `fstWriterCreateEnumTable`, then
    /// `fstWriterSetAttrEnd`): `name` (no spaces) and its `(literal, value)` pairs, each
    /// value the bits of its code as '0'/'1' (MSB first), left-padded with '0' to
    /// `min_valbits`; literals and values are escaped as fstapi.c does. A variable declared
    /// with [`var_with_enum`](Self::var_with_enum) and the returned handle shows its values
    /// by these names (GTKWave, Surfer). shellsim: added.
    pub fn enum_table(
        &mut self,
        name: &str,
        min_valbits: u32,
        entries: &[(&str, &str)],
    ) -> Result<FstEnumHandle> {
        debug_assert!(!name.contains(' '), "an enum table's name holds no space");
        let mut text = format!("{name} {}", entries.len());
        for (literal, _) in entries {
            text.push(' ');
            escape_enum_text(literal, &mut text);
        }
        for (_, value) in entries {
            text.push(' ');
            for _ in value.len()..min_valbits as usize {
                text.push('0');
            }
            escape_enum_text(value, &mut text);
        }
        self.enum_count += 1;
        let handle = FstEnumHandle::from_index(self.enum_count);
        write_hierarchy_attribute_begin(
            &mut self.hierarchy_buf,
            ATTRIBUTE_TYPE_MISC,
            MISC_TYPE_ENUM_TABLE,
            &text,
            handle.to_index() as u64,
        )?;
        write_hierarchy_attribute_end(&mut self.hierarchy_buf)?;
        Ok(handle)
    }

    /// [`var`](Self::var) shown through the enum table `table`: the reference to it
    /// (fstapi.c's `fstWriterEmitEnumTableRef`), the variable, then an attribute end.
    /// shellsim: added.
    pub fn var_with_enum(
        &mut self,
        name: impl AsRef<str>,
        signal_tpe: FstSignalType,
        tpe: FstVarType,
        dir: FstVarDirection,
        table: FstEnumHandle,
    ) -> Result<FstSignalId> {
        debug_assert!(table.to_index() <= self.enum_count, "an undeclared table");
        write_hierarchy_attribute_begin(
            &mut self.hierarchy_buf,
            ATTRIBUTE_TYPE_MISC,
            MISC_TYPE_ENUM_TABLE,
            "",
            table.to_index() as u64,
        )?;
        let id = self.var(name, signal_tpe, tpe, dir, None)?;
        write_hierarchy_attribute_end(&mut self.hierarchy_buf)?;
        Ok(id)
    }

    pub fn finish(mut self) -> Result<FstBodyWriter<W>> {
        debug_assert_eq!(
            self.scope_depth, 0,
            "missing calls to up-scope to close all scopes!"
        );
        write_hierarchy_bytes(&mut self.out, &self.hierarchy_buf.into_inner())?;
        write_geometry(&mut self.out, &self.signals)?;
        let buffer = SignalBuffer::new(&self.signals)?;
        let signals = self.signals.clone();
        let finish_info = HeaderFinishInfo {
            end_time: 0, // currently unknown
            scope_count: self.scope_count,
            var_count: self.var_count,
            num_signals: self.signals.len() as u64,
            num_value_change_sections: 0, // currently unknown
        };
        let next = FstBodyWriter {
            sink: Sink::Direct(Box::new(Direct {
                buffer,
                out: Some(self.out),
                scratch: SectionScratch::new(),
                spare: Section::empty(),
                compressor: None,
            })),
            signals,
            finish_info,
            compression: FstCompression::Lz4,
        };
        Ok(next)
    }
}

pub struct FstBodyWriter<W: std::io::Write + std::io::Seek> {
    sink: Sink<W>,
    /// every signal's type (to check calls before they are recorded)
    signals: Vec<FstSignalType>,
    finish_info: HeaderFinishInfo,
    compression: FstCompression,
}

/// Where the calls go: into the signal buffer, whose sections are compressed and written on
/// the calling thread; or recorded into blocks that a writer thread replays in order into
/// its own signal buffer (so the file's bytes are the same either way).
enum Sink<W> {
    Direct(Box<Direct<W>>),
    Thread(Box<Recorder<W>>),
    /// between two states (only while switching to a thread)
    Gone,
}

/// The signal buffer and the file, on the calling thread.
struct Direct<W> {
    buffer: SignalBuffer,
    /// the file (None once the compressor thread owns it)
    out: Option<W>,
    scratch: SectionScratch,
    spare: Section,
    /// Once `compress_in_background` ran: the thread that compresses and writes the
    /// sections.
    compressor: Option<Compressor<W>>,
}

/// A thread that compresses and writes the sections handed to it, in order, and hands
/// each back emptied for reuse.
struct Compressor<W> {
    to: std::sync::mpsc::SyncSender<Section>,
    back: std::sync::mpsc::Receiver<Section>,
    handle: std::thread::JoinHandle<Result<W>>,
}

/// One recorded call (8 bytes): `tag` is [`TAG_TIME`] (value: the time), [`TAG_FLUSH`]
/// (value: the compression), a signal's index + 1 (value: the integer), or that with
/// [`TAG_ASCII`] (value: the offset of the signal's ASCII value in the block's `ascii`).
/// `lo` holds the value's low 32 bits; with [`TAG_WIDE`] in `tag`, the next record's `tag`
/// holds its high 32 bits (probe values mostly fit 32 bits: half the memory traffic).
#[derive(Debug, Clone, Copy)]
struct Rec {
    tag: u32,
    lo: u32,
}

const TAG_TIME: u32 = 0;
const TAG_FLUSH: u32 = TAG_WIDE - 1;
const TAG_ASCII: u32 = 1 << 31;
const TAG_WIDE: u32 = 1 << 30;

/// Recorded calls, handed to the writer thread when full.
struct Block {
    recs: Vec<Rec>,
    ascii: Vec<u8>,
}

/// Records per block (8 bytes each: 64 KiB, so the blocks in flight stay in cache).
const BLOCK_RECS: usize = 1 << 13;

impl Block {
    fn new() -> Self {
        Self {
            recs: Vec::with_capacity(BLOCK_RECS),
            ascii: vec![],
        }
    }
}

/// The calling side of a writer thread.
struct Recorder<W> {
    block: Block,
    /// the last time change
    end_time: u64,
    /// estimated bytes of the value changes since the last flush
    size: usize,
    /// per signal, the estimated bytes of an integer change (0: a real or wider than 64 bits)
    u64_cost: Vec<u8>,
    to: std::sync::mpsc::SyncSender<Block>,
    back: std::sync::mpsc::Receiver<Block>,
    handle: std::thread::JoinHandle<Result<(W, u64)>>,
}

impl<W> Recorder<W> {
    #[inline(always)]
    fn push(&mut self, tag: u32, value: u64) -> Result<()> {
        push_rec(&mut self.block.recs, tag, value);
        if self.block.recs.len() >= BLOCK_RECS {
            self.send()?;
        }
        Ok(())
    }

    /// Hands the block to the thread, taking an emptied one back when there is one.
    #[cold]
    #[inline(never)]
    fn send(&mut self) -> Result<()> {
        let next = match self.back.try_recv() {
            Ok(mut b) => {
                b.recs.clear();
                b.ascii.clear();
                b
            }
            Err(_) => Block::new(),
        };
        let full = std::mem::replace(&mut self.block, next);
        // the thread stopped on an error: `finish` reports it
        self.to.send(full).map_err(|_| FstWriteError::WriterThread)
    }
}

/// Appends the record(s) of `tag` with `value` (two when the value needs more than 32 bits).
#[inline(always)]
fn push_rec(recs: &mut Vec<Rec>, tag: u32, value: u64) {
    let hi = (value >> 32) as u32;
    if hi == 0 {
        recs.push(Rec {
            tag,
            lo: value as u32,
        });
    } else {
        recs.push(Rec {
            tag: tag | TAG_WIDE,
            lo: value as u32,
        });
        recs.push(Rec { tag: hi, lo: 0 });
    }
}

fn compression_code(c: FstCompression) -> u64 {
    match c {
        FstCompression::Lz4 => u32::MAX as u64,
        FstCompression::Zlib(level) => level as u64,
        FstCompression::Deflate(level) => 0x100 | level as u64,
    }
}

fn compression_of(code: u64) -> FstCompression {
    match code {
        0xffff_ffff => FstCompression::Lz4,
        code if code & 0x100 != 0 => FstCompression::Deflate(code as u8),
        level => FstCompression::Zlib(level as u8),
    }
}

impl<W: std::io::Write + std::io::Seek> FstBodyWriter<W> {
    #[inline]
    pub fn time_change(&mut self, time: u64) -> Result<()> {
        match &mut self.sink {
            Sink::Direct(d) => d.buffer.time_change(time),
            Sink::Thread(r) => {
                if time < r.end_time {
                    return Err(FstWriteError::TimeDecrease(r.end_time, time));
                }
                if time == r.end_time {
                    return Ok(());
                }
                r.end_time = time;
                r.push(TAG_TIME, time)
            }
            Sink::Gone => unreachable!("the sink is always set between calls"),
        }
    }

    pub fn signal_change(&mut self, signal_id: FstSignalId, value: &[u8]) -> Result<()> {
        match &mut self.sink {
            Sink::Direct(d) => d.buffer.signal_change(signal_id, value),
            Sink::Thread(r) => {
                let Some(tpe) = self.signals.get(signal_id.to_array_index()) else {
                    return Err(FstWriteError::InvalidSignalId(signal_id));
                };
                let len = tpe.len() as usize;
                let value = full_length_value(value, len);
                let offset = r.block.ascii.len() as u64;
                r.block.ascii.extend_from_slice(&value);
                r.size += 1 + len.div_ceil(8);
                r.push(signal_id.to_index() | TAG_ASCII, offset)
            }
            Sink::Gone => unreachable!("the sink is always set between calls"),
        }
    }

    /// A change of a '0'/'1' bit vector signal (wider than one bit) given both as ASCII
    /// (`ascii`, the signal's length) and packed (`packed`: the same bits eight a byte, MSB
    /// first, the last byte padded with zeros): the change [`signal_change`](Self::signal_change)
    /// writes for `ascii`, without packing it again (for values written many times).
    pub fn signal_change_packed(
        &mut self,
        signal_id: FstSignalId,
        ascii: &[u8],
        packed: &[u8],
    ) -> Result<()> {
        match &mut self.sink {
            Sink::Direct(d) => d.buffer.signal_change_packed(signal_id, ascii, packed),
            Sink::Thread(_) => self.signal_change(signal_id, ascii),
            Sink::Gone => unreachable!("the sink is always set between calls"),
        }
    }

    /// A change of a bit vector signal of at most 64 bits, given as an integer (its low
    /// bits, MSB = bit `len - 1`): the same as [`signal_change`](Self::signal_change) with
    /// those bits as '0'/'1', without the ASCII round trip.
    #[inline(always)]
    pub fn signal_change_u64(&mut self, signal_id: FstSignalId, value: u64) -> Result<()> {
        match &mut self.sink {
            Sink::Direct(d) => d.buffer.signal_change_u64(signal_id, value),
            Sink::Thread(r) => {
                let cost = match r.u64_cost.get(signal_id.to_array_index()) {
                    Some(&c) if c > 0 => c as usize,
                    _ => return Err(FstWriteError::NotU64(signal_id)),
                };
                r.size += cost;
                r.push(signal_id.to_index(), value)
            }
            Sink::Gone => unreachable!("the sink is always set between calls"),
        }
    }

    /// [`signal_change_u64`](Self::signal_change_u64) for each of `changes` in turn (one
    /// call for a time step's changes).
    pub fn signal_changes_u64(&mut self, changes: &[(FstSignalId, u64)]) -> Result<()> {
        match &mut self.sink {
            Sink::Direct(d) => {
                for &(id, value) in changes {
                    d.buffer.signal_change_u64(id, value)?;
                }
                Ok(())
            }
            Sink::Thread(r) => {
                // check them all, then copy them all (two tight loops)
                let mut size = 0;
                let mut high = 0;
                for &(id, value) in changes {
                    match r.u64_cost.get(id.to_array_index()) {
                        Some(&c) if c > 0 => size += c as usize,
                        _ => return Err(FstWriteError::NotU64(id)),
                    }
                    high |= value >> 32;
                }
                r.size += size;
                if high == 0 {
                    r.block.recs.extend(changes.iter().map(|&(id, value)| Rec {
                        tag: id.to_index(),
                        lo: value as u32,
                    }));
                } else {
                    for &(id, value) in changes {
                        push_rec(&mut r.block.recs, id.to_index(), value);
                    }
                }
                // a block may pass its size by one time step's changes
                if r.block.recs.len() >= BLOCK_RECS {
                    r.send()?;
                }
                Ok(())
            }
            Sink::Gone => unreachable!("the sink is always set between calls"),
        }
    }

    /// Enable or disable value change deduplication. By default, it is enabled.
    ///
    /// If `true`, a [`signal_change`](Self::signal_change) with the same value as the last recorded
    /// value for that signal will be dropped. If `false`, it will be recorded anyway.
    /// (Without effect once the writer thread runs.)
    pub fn set_deduplicate(&mut self, deduplicate: bool) {
        if let Sink::Direct(d) = &mut self.sink {
            d.buffer.set_deduplicate(deduplicate);
        }
    }

    /// How the sections flushed from now on are compressed (default: LZ4).
    pub fn set_compression(&mut self, compression: FstCompression) {
        self.compression = compression;
    }

    /// flushes all value change data to disk (or to the writer thread)
    pub fn flush(&mut self) -> Result<()> {
        self.flush_section()?;
        self.finish_info.num_value_change_sections += 1;
        Ok(())
    }

    fn flush_section(&mut self) -> Result<()> {
        match &mut self.sink {
            Sink::Direct(d) => match &d.compressor {
                None => {
                    let empty = std::mem::replace(&mut d.spare, Section::empty());
                    let section = d.buffer.take_section(self.compression, empty);
                    let out = d
                        .out
                        .as_mut()
                        .expect("the file is here without a compressor");
                    write_value_change_section(out, &section, &mut d.scratch)?;
                    d.spare = section;
                }
                Some(c) => {
                    // a section the thread is done with, else a new one
                    let empty = c.back.try_recv().unwrap_or_else(|_| Section::empty());
                    let section = d.buffer.take_section(self.compression, empty);
                    // the thread stopped on an error: `finish` reports it
                    c.to.send(section)
                        .map_err(|_| FstWriteError::WriterThread)?;
                }
            },
            Sink::Thread(r) => {
                r.size = 0;
                r.push(TAG_FLUSH, compression_code(self.compression))?;
                r.send()?;
            }
            Sink::Gone => unreachable!("the sink is always set between calls"),
        }
        Ok(())
    }

    /// Returns the estimated size of all data structures that grow over time.
    pub fn size(&self) -> usize {
        match &self.sink {
            Sink::Direct(d) => d.buffer.size(),
            Sink::Thread(r) => r.size,
            Sink::Gone => unreachable!("the sink is always set between calls"),
        }
    }

    pub fn finish(mut self) -> Result<W> {
        // write value change section
        let flushed = self.flush_section();
        let (mut out, end_time) = match std::mem::replace(&mut self.sink, Sink::Gone) {
            Sink::Direct(d) => {
                let end_time = d.buffer.end_time();
                let out = match d.compressor {
                    None => d.out.expect("the file is here without a compressor"),
                    Some(Compressor { to, handle, .. }) => {
                        drop(to);
                        handle.join().map_err(|_| FstWriteError::WriterThread)??
                    }
                };
                flushed?;
                (out, end_time)
            }
            Sink::Thread(r) => {
                let Recorder { to, handle, .. } = *r;
                drop(to);
                let done = handle.join().map_err(|_| FstWriteError::WriterThread)??;
                flushed?;
                done
            }
            Sink::Gone => unreachable!("the sink is always set between calls"),
        };

        // update info
        self.finish_info.num_value_change_sections += 1;
        self.finish_info.end_time = end_time;
        update_header(&mut out, &self.finish_info)?;

        Ok(out)
    }
}

impl<W: std::io::Write + std::io::Seek + Send + 'static> FstBodyWriter<W> {
    /// From now on, each section is compressed and written by a thread of its own while the
    /// caller goes on filling the next one (at most one more waits in between): the calls
    /// themselves stay on the calling thread. The file's bytes are the same as without the
    /// thread. An error found by the thread is reported by a later flush or by
    /// [`finish`](Self::finish). Without effect after [`write_in_background`](Self::write_in_background).
    pub fn compress_in_background(&mut self) -> Result<()> {
        let Sink::Direct(d) = &mut self.sink else {
            return Ok(());
        };
        if d.compressor.is_some() {
            return Ok(());
        }
        let Some(mut out) = d.out.take() else {
            return Ok(());
        };
        let (to, from) = std::sync::mpsc::sync_channel::<Section>(1);
        let (give_back, back) = std::sync::mpsc::channel::<Section>();
        let mut scratch = std::mem::replace(&mut d.scratch, SectionScratch::new());
        let handle = std::thread::Builder::new()
            .name("fst-compress".into())
            .spawn(move || -> Result<W> {
                for section in from {
                    write_value_change_section(&mut out, &section, &mut scratch)?;
                    // the caller takes it back for a later section (or makes a new one)
                    let _ = give_back.send(section);
                }
                Ok(out)
            })?;
        d.compressor = Some(Compressor { to, back, handle });
        Ok(())
    }

    /// From now on, records the calls (8 bytes each, in blocks) for a thread of its own
    /// that replays them in order into the signal buffer, compresses and writes the sections,
    /// while the caller goes on (at most two blocks wait in between); without effect after
    /// [`compress_in_background`](Self::compress_in_background). The file's bytes are
    /// the same as without the thread. An error found by the thread (I/O, an invalid
    /// character) is reported by a later call or by [`finish`](Self::finish).
    pub fn write_in_background(&mut self) -> Result<()> {
        let Sink::Direct(d) = std::mem::replace(&mut self.sink, Sink::Gone) else {
            return Ok(());
        };
        if d.compressor.is_some() {
            // sections already go to a compressor thread: nothing changes
            self.sink = Sink::Direct(d);
            return Ok(());
        }
        let Direct {
            mut buffer,
            out,
            mut scratch,
            mut spare,
            ..
        } = *d;
        let mut out = out.expect("the file is here without a compressor");
        let (to, from) = std::sync::mpsc::sync_channel::<Block>(2);
        let (give_back, back) = std::sync::mpsc::sync_channel::<Block>(4);
        let size = buffer.size();
        let end_time = buffer.end_time();
        let handle = std::thread::Builder::new()
            .name("fst-writer".into())
            .spawn(move || -> Result<(W, u64)> {
                for block in from {
                    let mut recs = block.recs.iter();
                    while let Some(rec) = recs.next() {
                        let mut value = rec.lo as u64;
                        if rec.tag & TAG_WIDE != 0 {
                            let hi = recs.next().ok_or(FstWriteError::WriterThread)?;
                            value |= (hi.tag as u64) << 32;
                        }
                        match rec.tag & !TAG_WIDE {
                            TAG_TIME => buffer.time_change(value)?,
                            TAG_FLUSH => {
                                let empty = std::mem::replace(&mut spare, Section::empty());
                                let c = compression_of(value);
                                let section = buffer.take_section(c, empty);
                                write_value_change_section(&mut out, &section, &mut scratch)?;
                                spare = section;
                            }
                            tag if tag & TAG_ASCII != 0 => {
                                let id = FstSignalId::from_index(tag & !TAG_ASCII);
                                let start = value as usize;
                                let len = buffer.signal_len(id);
                                buffer.signal_change(id, &block.ascii[start..start + len])?;
                            }
                            tag => buffer.signal_change_u64(FstSignalId::from_index(tag), value)?,
                        }
                    }
                    // the caller takes it back for the next calls (or makes a new one)
                    let _ = give_back.try_send(block);
                }
                Ok((out, buffer.end_time()))
            })?;
        self.sink = Sink::Thread(Box::new(Recorder {
            block: Block::new(),
            end_time,
            size,
            u64_cost: self
                .signals
                .iter()
                .map(|t| match t.len() {
                    len @ 1..=64 if !t.is_real() => 1 + len.div_ceil(8) as u8,
                    _ => 0,
                })
                .collect(),
            to,
            back,
            handle,
        }));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{FstFileType, FstInfo};
    use proptest::prelude::*;

    /// An enum table is fstapi.c's attribute (begin: type 252, FST_AT_MISC, FST_MT_ENUMTABLE,
    /// "name count literals values" with the values padded to `min_valbits`, the handle as a
    /// varint; then an end, 253), and a variable using it is wrapped in a reference (an
    /// attribute begin with an empty name and the handle) and an end.
    #[test]
    fn an_enum_table_is_fstapis_attribute() {
        let info = FstInfo {
            start_time: 0,
            timescale_exponent: -9,
            version: "test".into(),
            date: String::new(),
            file_type: FstFileType::Verilog,
        };
        let mut h = FstHeaderWriter::write_to_mem(&info).unwrap();
        let t = h
            .enum_table("fsm", 2, &[("IDLE", "0"), ("a b", "1"), ("\"x\"", "10")])
            .unwrap();
        assert_eq!(t.to_index(), 1);
        let start = h.hierarchy_buf.get_ref().len();
        let id = h
            .var_with_enum(
                "state",
                FstSignalType::bit_vec(2),
                FstVarType::Wire,
                FstVarDirection::Implicit,
                t,
            )
            .unwrap();
        assert_eq!(id.to_index(), 1);
        let bytes = h.hierarchy_buf.get_ref().clone();
        let mut want = vec![252u8, 0, 7];
        want.extend_from_slice(b"fsm 3 IDLE a\\040b \\\"x\\\" 00 01 10\0");
        want.extend_from_slice(&[1, 253]);
        assert_eq!(&bytes[..start], &want[..]);
        let mut var = vec![252u8, 0, 7, 0, 1];
        var.extend_from_slice(&[FstVarType::Wire as u8, FstVarDirection::Implicit as u8]);
        var.extend_from_slice(b"state\0");
        var.extend_from_slice(&[2, 0, 253]);
        assert_eq!(&bytes[start..], &var[..]);
    }

    /// An FST in memory of signals of widths `lens` (each below 64 bits, or a text of 128
    /// characters when 0), written from `changes` (signal, value, next time?), flushed every
    /// `flush_every` changes; through the writer thread when `background` is 1, the
    /// compressor thread when 2.
    fn write(
        lens: &[u32],
        changes: &[(usize, u64, bool)],
        flush_every: usize,
        compression: FstCompression,
        background: u8,
    ) -> Vec<u8> {
        let info = FstInfo {
            start_time: 0,
            timescale_exponent: -9,
            version: "test".into(),
            date: String::new(),
            file_type: FstFileType::Verilog,
        };
        let mut h = FstHeaderWriter::write_to_mem(&info).unwrap();
        h.scope("top", "", FstScopeType::Module).unwrap();
        let ids: Vec<FstSignalId> = lens
            .iter()
            .enumerate()
            .map(|(i, &len)| {
                let tpe = FstSignalType::bit_vec(if len == 0 { 128 } else { len });
                h.var(
                    format!("s{i}"),
                    tpe,
                    FstVarType::Wire,
                    FstVarDirection::Implicit,
                    None,
                )
                .unwrap()
            })
            .collect();
        h.up_scope().unwrap();
        let mut b = h.finish().unwrap();
        b.set_compression(compression);
        match background {
            1 => b.write_in_background().unwrap(),
            2 => b.compress_in_background().unwrap(),
            _ => {}
        }
        let mut t = 0;
        for (n, &(signal, value, next)) in changes.iter().enumerate() {
            if next {
                t += 1 + value % 3;
                b.time_change(t).unwrap();
                if n % flush_every == 0 && t > 0 {
                    b.flush().unwrap();
                    t += 1;
                    b.time_change(t).unwrap();
                }
            }
            let i = signal % lens.len();
            if lens[i] == 0 {
                let text: Vec<u8> = (0..128)
                    .map(|k| b'0' + ((value >> (k % 64)) & 1) as u8)
                    .collect();
                b.signal_change(ids[i], &text).unwrap();
            } else {
                b.signal_change_u64(ids[i], value).unwrap();
            }
        }
        b.finish().unwrap().into_inner()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// The writer thread and the compressor thread write the same bytes as the calling
        /// thread, over many sections (LZ4, zlib and libdeflate).
        #[test]
        fn test_background_writes_the_same_bytes(
            lens in prop::collection::vec(0u32..64, 1..10),
            changes in prop::collection::vec(
                (any::<usize>(), prop_oneof![0u64..64, any::<u64>()], any::<bool>()),
                0..3000,
            ),
            flush_every in 1usize..500,
            pack in 0u8..3,
        ) {
            let c = match pack {
                0 => FstCompression::Lz4,
                1 => FstCompression::Zlib(1),
                _ => FstCompression::Deflate(1),
            };
            let direct = write(&lens, &changes, flush_every, c, 0);
            let thread = write(&lens, &changes, flush_every, c, 1);
            prop_assert_eq!(&direct, &thread);
            let compressor = write(&lens, &changes, flush_every, c, 2);
            prop_assert_eq!(&direct, &compressor);
        }
    }
}
