//! The signal buffer: values, per-signal change chains and time table of the open section.
// Copyright 2024 Cornell University
// released under BSD 3-Clause License
// author: Kevin Laeufer <laeufer@cornell.edu>
//
// shellsim: the value changes of a section are kept in one chain per signal (a `Vec<u8>`
// each, recycled from section to section) instead of back-linked lists through one buffer,
// so a flush hands the chains over as they are; `signal_change_u64` takes a bit vector of
// up to 64 bits as an integer and encodes it without an ASCII round trip; a flush hands
// its section over whole (to the compressor thread, see `writer.rs`). Reals are gone.

use crate::io::{
    FstCompression, Section, write_multi_bit_signal, write_one_bit_signal, write_time_chain_update,
};
use crate::{FstSignalId, FstSignalType, FstWriteError, Result};
use std::borrow::Cow;
use std::cmp::Ordering;

/// keeps track of signal values before writing them to disk
pub(crate) struct SignalBuffer {
    start_time: u64,
    end_time: u64,
    /// each signal's meta-data and state
    signals: Box<[SignalState]>,
    /// values for all signals in the first time step of this block
    frame: Box<[u8]>,
    /// copy of the frame with all value changes applied (but see `SignalState::int`)
    values: Box<[u8]>,
    /// the encoded value changes of each signal in this section
    chains: Vec<Vec<u8>>,
    /// contains the delta encoded timetable
    time_table: Vec<u8>,
    time_table_index: u32,
    /// keep a vec allocation around for encoding signals
    write_buf: Vec<u8>,
    /// is this the first buffer for the file that we are writing?
    first_buffer: bool,
    /// remove a consecutive value change that repeats the same value
    deduplicate: bool,
}

/// How a signal's `SignalState::int` relates to its ASCII in `values`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum IntState {
    /// `int` holds nothing: the ASCII is the value
    None,
    /// `int` holds the value and the ASCII is the same value
    Both,
    /// `int` holds the value; the ASCII is older (written when needed)
    Stale,
}

/// One signal's constant meta-data and changing state, kept together (one cache line).
#[derive(Debug, Clone)]
struct SignalState {
    /// length in bytes / number of characters
    len: u32,
    /// starting offset in the value buffer
    offset: u32,
    /// time table index of the previous change
    prev_time_table_index: u32,
    int_state: IntState,
    /// the current value when last changed through `signal_change_u64`
    int: u64,
}

impl SignalState {
    #[inline]
    fn range(&self) -> std::ops::Range<usize> {
        self.offset as usize..(self.offset + self.len) as usize
    }
}

fn gen_signal_info(signals: &[FstSignalType]) -> (Box<[SignalState]>, usize) {
    let mut offset = 0;
    let mut out = Vec::with_capacity(signals.len());
    for signal in signals {
        out.push(SignalState {
            len: signal.len(),
            offset,
            prev_time_table_index: 0,
            int_state: IntState::None,
            int: 0,
        });
        offset += signal.len();
    }
    (out.into_boxed_slice(), offset as usize)
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

/// Writes the low `out.len()` (at most 64) bits of `v` as ASCII '0'/'1', MSB first.
#[inline]
fn ascii_bits(out: &mut [u8], v: u64) {
    let w = out.len();
    debug_assert!(w <= 64);
    let head = w % 8;
    for (i, c) in out[..head].iter_mut().enumerate() {
        *c = b'0' + ((v >> (w - 1 - i)) & 1) as u8;
    }
    for (j, c) in out[head..].chunks_exact_mut(8).enumerate() {
        let shift = w - head - 8 * (j + 1);
        c.copy_from_slice(&BIN8[((v >> shift) & 0xff) as usize]);
    }
}

impl SignalBuffer {
    pub(crate) fn new(signals: &[FstSignalType]) -> Result<Self> {
        let (states, values_len) = gen_signal_info(signals);
        let chains = vec![Vec::new(); states.len()];

        let values = vec![b'x'; values_len].into_boxed_slice();
        let frame = values.clone();
        let time_table = Vec::with_capacity(16);
        Ok(Self {
            start_time: 0,
            end_time: 0,
            signals: states,
            frame,
            values,
            chains,
            time_table,
            time_table_index: 0,
            write_buf: vec![],
            first_buffer: true,
            deduplicate: true,
        })
    }

    pub(crate) fn set_deduplicate(&mut self, deduplicate: bool) {
        self.deduplicate = deduplicate;
    }

    pub(crate) fn time_change(&mut self, new_time: u64) -> Result<()> {
        match new_time.cmp(&self.end_time) {
            Ordering::Less => Err(FstWriteError::TimeDecrease(self.end_time, new_time)),
            Ordering::Equal => Ok(()),
            Ordering::Greater => {
                let first_time_step = self.time_table.is_empty();
                if first_time_step {
                    // at the end of the first step, we copy values over into the frame
                    self.write_stale_values();
                    self.frame.copy_from_slice(&self.values);
                } else {
                    // the first step is not captured in the time table, but instead in the start_time
                    self.time_table_index += 1;
                }
                debug_assert!(self.start_time <= self.end_time);

                // in the first step, the time needs to be written relative to 0
                let delta_to = if first_time_step { 0 } else { self.end_time };
                // write timetable in compressed format
                write_time_chain_update(&mut self.time_table, delta_to, new_time)?;
                self.end_time = new_time;
                Ok(())
            }
        }
    }

    /// Writes the ASCII of every value kept only as an integer.
    fn write_stale_values(&mut self) {
        for index in 0..self.signals.len() {
            self.write_stale_value(index);
        }
    }

    #[inline]
    fn write_stale_value(&mut self, index: usize) {
        let s = &mut self.signals[index];
        if s.int_state == IntState::Stale {
            ascii_bits(&mut self.values[s.range()], s.int);
            s.int_state = IntState::Both;
        }
    }

    /// Takes `value` (ASCII, the signal's length) as the signal's value. Returns the time
    /// table delta to encode when it is a change to record, `None` when the value only sets
    /// the initial state or repeats the current one.
    #[inline]
    fn take_value(&mut self, index: usize, value: &[u8]) -> Option<u64> {
        self.write_stale_value(index);
        let s = &mut self.signals[index];
        s.int_state = IntState::None;
        let range = s.range();
        let first_time_step = self.time_table.is_empty();
        if first_time_step && self.first_buffer {
            self.values[range].copy_from_slice(value);
            return None;
        }
        if self.time_table.is_empty() {
            // write_time_chain_update(&mut self.time_table, 0, self.end_time)?;
            todo!("Currently we only support flushing right before a new time step.")
        }
        // check to see if there actually was a change
        if self.deduplicate && &self.values[range.clone()] == value {
            return None;
        }
        self.values[range].copy_from_slice(value);
        let delta = (self.time_table_index - s.prev_time_table_index) as u64;
        // remember previous time-table index
        s.prev_time_table_index = self.time_table_index;
        Some(delta)
    }

    pub(crate) fn signal_change(&mut self, signal_id: FstSignalId, value: &[u8]) -> Result<()> {
        let index = signal_id.to_array_index();
        let len = match self.signals.get(index) {
            Some(info) => info.len as usize,
            None => return Err(FstWriteError::InvalidSignalId(signal_id)),
        };
        let value_cow = full_length_value(value, len);
        let value = value_cow.as_ref();
        debug_assert_eq!(value.len(), len);
        if let Some(delta) = self.take_value(index, value) {
            // write down value change
            self.write_buf.clear();
            match value {
                [value] => write_one_bit_signal(&mut self.write_buf, delta, *value)?,
                values => write_multi_bit_signal(&mut self.write_buf, delta, values)?,
            }
            self.chains[index].extend_from_slice(&self.write_buf);
        }
        Ok(())
    }

    /// A change of a bit vector of at most 64 bits given as an integer (its low bits; higher
    /// bits are ignored): the same change as [`Self::signal_change`] with the bits as ASCII.
    #[inline(always)]
    pub(crate) fn signal_change_u64(&mut self, signal_id: FstSignalId, value: u64) -> Result<()> {
        let index = signal_id.to_array_index();
        let (len, s) = match self.signals.get_mut(index) {
            Some(s) if (1..=64).contains(&s.len) => (s.len as usize, s),
            _ => return Err(FstWriteError::NotU64(signal_id)),
        };
        // the value's bits at the top (MSB first), the rest zero
        let top = value << (64 - len);
        let value = top >> (64 - len);
        if self.time_table.is_empty() {
            if self.first_buffer {
                let mut ascii = [0u8; 64];
                ascii_bits(&mut ascii[..len], value);
                self.take_value(index, &ascii[..len]);
                return Ok(());
            }
            todo!("Currently we only support flushing right before a new time step.")
        }
        if self.deduplicate {
            let same = match s.int_state {
                IntState::None => {
                    let mut ascii = [0u8; 64];
                    ascii_bits(&mut ascii[..len], value);
                    self.values[s.range()] == ascii[..len]
                }
                _ => s.int == value,
            };
            if same {
                return Ok(());
            }
        }
        s.int = value;
        s.int_state = IntState::Stale;
        let delta = (self.time_table_index - s.prev_time_table_index) as u64;
        s.prev_time_table_index = self.time_table_index;

        // The change, as `write_one_bit_signal` / `write_multi_bit_signal` encode it: a
        // varint, then (a vector) its bits MSB first, the last byte padded with zeros. Built
        // in a fixed-size buffer, appended whole and cut to length (no variable-size copy).
        let mut buf = [0u8; 24];
        let (mut head, mut n) = if len == 1 {
            ((delta << 2) | (value << 1), 0)
        } else {
            (delta << 1, 0)
        };
        while head > 0x7f {
            buf[n] = (head & 0x7f) as u8 | 0x80;
            head >>= 7;
            n += 1;
        }
        buf[n] = head as u8;
        n += 1;
        if len > 1 {
            buf[n..n + 8].copy_from_slice(&top.to_be_bytes());
            n += len.div_ceil(8);
        }
        let chain = &mut self.chains[index];
        let end = chain.len() + n;
        chain.extend_from_slice(&buf);
        chain.truncate(end);
        Ok(())
    }

    fn num_time_table_entries(&self) -> u64 {
        if self.time_table.is_empty() {
            0
        } else {
            self.time_table_index as u64 + 1
        }
    }

    /// Takes this section's data out (handing it `spare`'s emptied buffers for the next
    /// section) and starts the next section.
    pub(crate) fn take_section(&mut self, compression: FstCompression, spare: Section) -> Section {
        let Section {
            mut frame,
            mut time_table,
            mut chains,
            ..
        } = spare;
        let time_table_entries = self.num_time_table_entries();
        frame.clear();
        frame.extend_from_slice(&self.frame);
        time_table.clear();
        std::mem::swap(&mut time_table, &mut self.time_table);
        chains.resize_with(self.chains.len(), Vec::new);
        for c in chains.iter_mut() {
            c.clear();
        }
        std::mem::swap(&mut chains, &mut self.chains);
        let section = Section {
            start_time: self.start_time,
            end_time: self.end_time,
            frame,
            time_table,
            time_table_entries,
            chains,
            compression,
        };

        // reset data
        self.time_table_index = 0;
        for s in self.signals.iter_mut() {
            s.prev_time_table_index = 0;
        }
        self.start_time = self.end_time;
        self.write_buf.clear();
        self.first_buffer = false;
        section
    }

    /// The time of the last time change.
    pub(crate) fn end_time(&self) -> u64 {
        self.end_time
    }
}

/// `value` at the signal's length `len`: as it is, or with a VCD shortening expanded.
fn full_length_value(value: &[u8], len: usize) -> Cow<'_, [u8]> {
    if value.len() == len {
        Cow::Borrowed(value)
    } else {
        let expanded = expand_special_vector_cases(value, len).unwrap_or_else(|| {
            panic!(
                "Failed to parse four state value: {} for signal of size {}",
                String::from_utf8_lossy(value),
                len
            )
        });
        assert_eq!(expanded.len(), len);
        Cow::Owned(expanded)
    }
}

/// tries to expand common shortenings used in VCD encodings
#[inline]
fn expand_special_vector_cases(value: &[u8], len: usize) -> Option<Vec<u8>> {
    // if the value is actually longer than expected, there is nothing we can do
    if value.len() >= len {
        return None;
    }

    // zero, x or z extend
    match value[0] {
        b'1' | b'0' => {
            let mut extended = Vec::with_capacity(len);
            extended.resize(len - value.len(), b'0');
            extended.extend_from_slice(value);
            Some(extended)
        }
        b'x' | b'X' | b'z' | b'Z' => {
            let mut extended = Vec::with_capacity(len);
            extended.resize(len - value.len(), value[0]);
            extended.extend_from_slice(value);
            Some(extended)
        }
        _ => None, // failed
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn buffer_with_signals(lens: &[u32]) -> SignalBuffer {
        let signals = lens
            .iter()
            .map(|len| FstSignalType::bit_vec(*len))
            .collect::<Vec<_>>();
        SignalBuffer::new(&signals).unwrap()
    }

    /// An invalid signal id returns an error.
    #[test]
    fn test_signal_change_with_invalid_signal_id() {
        let mut buffer = buffer_with_signals(&[1, 1]);
        // ids are one based, so 2 is the last valid one
        buffer
            .signal_change(FstSignalId::from_index(2), b"1")
            .unwrap();
        let err = buffer
            .signal_change(FstSignalId::from_index(3), b"1")
            .unwrap_err();
        match err {
            FstWriteError::InvalidSignalId(id) => assert_eq!(id, FstSignalId::from_index(3)),
            other => panic!("unexpected error: {other:?}"),
        }
    }

    /// A value shorter than its signal that starts with none of the extendable characters fails to
    /// parse.
    #[test]
    #[should_panic(expected = "Failed to parse four state value: hh for signal of size 4")]
    fn test_signal_change_with_unexpandable_value() {
        let mut buffer = buffer_with_signals(&[4]);
        buffer
            .signal_change(FstSignalId::from_index(1), b"hh")
            .unwrap();
    }

    #[test]
    fn test_expand_special_vector_cases() {
        // zero extension, whatever the leading bit is
        assert_eq!(expand_special_vector_cases(b"1", 4), Some(b"0001".to_vec()));
        assert_eq!(
            expand_special_vector_cases(b"01", 4),
            Some(b"0001".to_vec())
        );
        // x and z extension repeat the leading character, in either case
        assert_eq!(
            expand_special_vector_cases(b"x1", 4),
            Some(b"xxx1".to_vec())
        );
        assert_eq!(
            expand_special_vector_cases(b"X1", 4),
            Some(b"XXX1".to_vec())
        );
        assert_eq!(
            expand_special_vector_cases(b"z0", 4),
            Some(b"zzz0".to_vec())
        );
        assert_eq!(
            expand_special_vector_cases(b"Z0", 4),
            Some(b"ZZZ0".to_vec())
        );
        // no rule covers the other characters
        assert_eq!(expand_special_vector_cases(b"h", 4), None);
        assert_eq!(expand_special_vector_cases(b"-", 4), None);
        // a value that is not actually short is left alone
        assert_eq!(expand_special_vector_cases(b"0011", 4), None);
        assert_eq!(expand_special_vector_cases(b"00111", 4), None);
    }

    /// A change given as an integer is encoded exactly as the same change in ASCII, also when
    /// both kinds of calls change one signal.
    fn do_test_u64_as_ascii(widths: &[u8], changes: &[(usize, u64, bool)]) {
        let lens: Vec<u32> = widths.iter().map(|w| (*w % 64) as u32 + 1).collect();
        let mut ascii = buffer_with_signals(&lens);
        let mut int = buffer_with_signals(&lens);
        let mut mixed = buffer_with_signals(&lens);
        for (step, (signal, value, next_time)) in changes.iter().enumerate() {
            if *next_time || step == 1 {
                ascii.time_change(step as u64 + 1).unwrap();
                int.time_change(step as u64 + 1).unwrap();
                mixed.time_change(step as u64 + 1).unwrap();
            }
            let index = signal % lens.len();
            let len = lens[index] as usize;
            let id = FstSignalId::from_index(index as u32 + 1);
            let text: String = (0..len)
                .rev()
                .map(|k| if (value >> k) & 1 == 1 { '1' } else { '0' })
                .collect();
            ascii.signal_change(id, text.as_bytes()).unwrap();
            int.signal_change_u64(id, *value).unwrap();
            if value.count_ones() % 2 == 0 {
                mixed.signal_change_u64(id, *value).unwrap();
            } else {
                mixed.signal_change(id, text.as_bytes()).unwrap();
            }
        }
        mixed.write_stale_values();
        assert_eq!(ascii.values, mixed.values);
        assert_eq!(ascii.chains, mixed.chains);
        int.write_stale_values();
        assert_eq!(ascii.values, int.values);
        assert_eq!(ascii.chains, int.chains);
        assert_eq!(ascii.time_table, int.time_table);
    }

    /// Integer changes need a bit vector of at most 64 bits.
    #[test]
    fn test_signal_change_u64_needs_a_narrow_bit_vector() {
        let mut buffer = buffer_with_signals(&[64, 65]);
        buffer
            .signal_change_u64(FstSignalId::from_index(1), u64::MAX)
            .unwrap();
        assert!(matches!(
            buffer.signal_change_u64(FstSignalId::from_index(2), 1),
            Err(FstWriteError::NotU64(_))
        ));
        assert!(matches!(
            buffer.signal_change_u64(FstSignalId::from_index(3), 1),
            Err(FstWriteError::NotU64(_))
        ));
    }

    proptest! {
        #[test]
        fn test_u64_as_ascii(
            widths in prop::collection::vec(any::<u8>(), 1..12),
            changes in prop::collection::vec((any::<usize>(), any::<u64>(), any::<bool>()), 0..200),
        ) {
            do_test_u64_as_ascii(&widths, &changes);
        }
    }
}
