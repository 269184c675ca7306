//! The header and body writers, and the body's optional compressor thread.
// Copyright 2024 Cornell University
// released under BSD 3-Clause License
// author: Kevin Laeufer <laeufer@cornell.edu>
//
// shellsim: `FstBodyWriter` can compress with libdeflate (`set_compression`), take bit
// vectors as integers (`signal_change_u64`) and hand each section to a thread that
// compresses and writes it (`compress_in_background`); `FstHeaderWriter` declares enum
// tables. `open_fst`, `FstHeaderWriter::open` and `write_to_mem` are gone (unused).

use crate::buffer::SignalBuffer;
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
        let finish_info = HeaderFinishInfo {
            end_time: 0, // currently unknown
            scope_count: self.scope_count,
            var_count: self.var_count,
            num_signals: self.signals.len() as u64,
            num_value_change_sections: 0, // currently unknown
        };
        let next = FstBodyWriter {
            buffer,
            out: Some(self.out),
            scratch: SectionScratch::new(),
            spare: Section::empty(),
            compressor: None,
            finish_info,
            compression: FstCompression::Lz4,
        };
        Ok(next)
    }
}

pub struct FstBodyWriter<W: std::io::Write + std::io::Seek> {
    buffer: SignalBuffer,
    /// the file (None once the compressor thread owns it)
    out: Option<W>,
    scratch: SectionScratch,
    spare: Section,
    /// Once `compress_in_background` ran: the thread that compresses and writes the
    /// sections.
    compressor: Option<Compressor<W>>,
    finish_info: HeaderFinishInfo,
    compression: FstCompression,
}

/// A thread that compresses and writes the sections handed to it, in order, and hands
/// each back emptied for reuse.
struct Compressor<W> {
    to: std::sync::mpsc::SyncSender<Section>,
    back: std::sync::mpsc::Receiver<Section>,
    handle: std::thread::JoinHandle<Result<W>>,
}

impl<W: std::io::Write + std::io::Seek> FstBodyWriter<W> {
    #[inline]
    pub fn time_change(&mut self, time: u64) -> Result<()> {
        self.buffer.time_change(time)
    }

    pub fn signal_change(&mut self, signal_id: FstSignalId, value: &[u8]) -> Result<()> {
        self.buffer.signal_change(signal_id, value)
    }

    /// A change of a bit vector signal of at most 64 bits, given as an integer (its low
    /// bits, MSB = bit `len - 1`): the same as [`signal_change`](Self::signal_change) with
    /// those bits as '0'/'1', without the ASCII round trip.
    #[inline(always)]
    pub fn signal_change_u64(&mut self, signal_id: FstSignalId, value: u64) -> Result<()> {
        self.buffer.signal_change_u64(signal_id, value)
    }

    /// [`signal_change_u64`](Self::signal_change_u64) for each of `changes` in turn (one
    /// call for a time step's changes).
    pub fn signal_changes_u64(&mut self, changes: &[(FstSignalId, u64)]) -> Result<()> {
        for &(id, value) in changes {
            self.buffer.signal_change_u64(id, value)?;
        }
        Ok(())
    }

    /// Enable or disable value change deduplication. By default, it is enabled.
    ///
    /// If `true`, a [`signal_change`](Self::signal_change) with the same value as the last recorded
    /// value for that signal will be dropped. If `false`, it will be recorded anyway.
    pub fn set_deduplicate(&mut self, deduplicate: bool) {
        self.buffer.set_deduplicate(deduplicate);
    }

    /// How the sections flushed from now on are compressed (default: LZ4).
    pub fn set_compression(&mut self, compression: FstCompression) {
        self.compression = compression;
    }

    /// flushes all value change data to disk (or to the compressor thread)
    pub fn flush(&mut self) -> Result<()> {
        self.flush_section()?;
        self.finish_info.num_value_change_sections += 1;
        Ok(())
    }

    fn flush_section(&mut self) -> Result<()> {
        match &self.compressor {
            None => {
                let empty = std::mem::replace(&mut self.spare, Section::empty());
                let section = self.buffer.take_section(self.compression, empty);
                let out = self
                    .out
                    .as_mut()
                    .expect("the file is here without a compressor");
                write_value_change_section(out, &section, &mut self.scratch)?;
                self.spare = section;
            }
            Some(c) => {
                // a section the thread is done with, else a new one
                let empty = c.back.try_recv().unwrap_or_else(|_| Section::empty());
                let section = self.buffer.take_section(self.compression, empty);
                // the thread stopped on an error: `finish` reports it
                c.to.send(section)
                    .map_err(|_| FstWriteError::CompressorThread)?;
            }
        }
        Ok(())
    }

    pub fn finish(mut self) -> Result<W> {
        // write value change section
        let flushed = self.flush_section();
        let end_time = self.buffer.end_time();
        let mut out = match self.compressor {
            None => self.out.expect("the file is here without a compressor"),
            Some(Compressor { to, handle, .. }) => {
                drop(to);
                handle
                    .join()
                    .map_err(|_| FstWriteError::CompressorThread)??
            }
        };
        flushed?;

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
    /// [`finish`](Self::finish).
    pub fn compress_in_background(&mut self) -> Result<()> {
        if self.compressor.is_some() {
            return Ok(());
        }
        let Some(mut out) = self.out.take() else {
            return Ok(());
        };
        let (to, from) = std::sync::mpsc::sync_channel::<Section>(1);
        let (give_back, back) = std::sync::mpsc::channel::<Section>();
        let mut scratch = std::mem::replace(&mut self.scratch, SectionScratch::new());
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
        self.compressor = Some(Compressor { to, back, handle });
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
        let mut h = FstHeaderWriter::new(std::io::Cursor::new(Vec::new()), &info).unwrap();
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
    /// `flush_every` changes; through the compressor thread when `background`.
    fn write(
        lens: &[u32],
        changes: &[(usize, u64, bool)],
        flush_every: usize,
        compression: FstCompression,
        background: bool,
    ) -> Vec<u8> {
        let info = FstInfo {
            start_time: 0,
            timescale_exponent: -9,
            version: "test".into(),
            date: String::new(),
            file_type: FstFileType::Verilog,
        };
        let mut h = FstHeaderWriter::new(std::io::Cursor::new(Vec::new()), &info).unwrap();
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
        if background {
            b.compress_in_background().unwrap();
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
        /// The compressor thread writes the same bytes as the calling thread, over many
        /// sections (LZ4 and libdeflate).
        #[test]
        fn test_background_writes_the_same_bytes(
            lens in prop::collection::vec(0u32..64, 1..10),
            changes in prop::collection::vec(
                (any::<usize>(), prop_oneof![0u64..64, any::<u64>()], any::<bool>()),
                0..3000,
            ),
            flush_every in 1usize..500,
            deflate in any::<bool>(),
        ) {
            let c = if deflate {
                FstCompression::Deflate(1)
            } else {
                FstCompression::Lz4
            };
            let direct = write(&lens, &changes, flush_every, c, false);
            let compressor = write(&lens, &changes, flush_every, c, true);
            prop_assert_eq!(&direct, &compressor);
        }
    }
}
