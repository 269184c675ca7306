//! VCD output: a [`Probe`] that streams the machine's signals into a Value Change Dump, on
//! top of the `vcd` crate's writer.
//!
//! **Layout.** The first sample (the first `cycle()` and the calls after it) declares every
//! signal: one `$scope module` per dot-separated level of its scope (`machine`, `cluster_0`,
//! `icu`, `stage_3`, …), a `wire` of the reported width for `bits` (with an explicit
//! `[w-1:0]` range when wider than one bit, so the name GTKWave gives it can be read off the
//! declaration), a `string` variable for `text` (FSM states), and for `fixed` a `wire` of
//! `width` bits holding the raw two's-complement value — the .gtkw file (`crate::machine::gtkw`) shows
//! it as a decimal through GTKWave's fixed-point shift.
//!
//! **Time.** `$timescale 1 ns`: one time unit is one clock cycle and `#t` is the cycle
//! number. The paper gives no clock rate, so the unit is nominal; 1 ns is chosen because
//! GTKWave then reads out times as plain integers equal to the cycle ("1234 ns" is cycle
//! 1234), whereas with 1 ps long runs would be shown scaled to ns or µs.
//!
//! **Changes only.** The probe declares its signals once (position = id); each sample is one
//! flat value array with the positions whose value changed since the last (the machine finds
//! them while filling the array; a caller of [`Probe::sample`] hands whole arrays, which the
//! writer compares with the last). The writer writes a `#t` line only
//! when something declared changed at cycle t, and formats the change lines by hand (the
//! same bytes as the `vcd` crate's writer, which still writes the header). The machine probes after every clock edge
//! it simulates; cycles skipped by its cycle jump change nothing, so the waveform is the same.
//!
//! **Options.** A cycle window `[from, to]`: nothing outside it is written, but the values
//! holding at `from` are dumped in full (`$dumpvars`) so the window opens on a complete state.
//! A scope filter (a glob with `*`/`?`, or else a substring, on the full dotted scope):
//! signals outside it are not declared at all.
//!
//! **Output.** The samples' changes go to the waveform's own thread, which writes them in
//! the order sent (`SampleStream`; the simulation thread only copies the changed positions
//! and values): a VCD's lines (`VcdBody`), an FST's chains (`super::fst::FstBody`). Either streams
//! into a temporary file beside the target, renamed into place by [`VcdWriter::finish`]
//! (dropping an unfinished writer deletes it), so memory stays bounded on long runs and a
//! failed run leaves no half-written file. The header holds no date, so the same run gives a
//! byte-identical file whatever the thread's timing.

use super::direct::BlockOut;
use super::fst::{fst_err, FstBody, FstHandle};
use crate::error::{Error, Result};
use crate::output::TempFile;
use fst_writer::{
    FstFileType, FstHeaderWriter, FstInfo, FstScopeType, FstSignalId, FstSignalType,
    FstVarDirection, FstVarType,
};
use shellsim_hw::trace::{
    apply_changes, ChangeSink, KeepValues, Probe, SignalDecl, SignalKind as HwKind, STAGE_SHIFT,
};
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use vcd::{ReferenceIndex, TimescaleUnit, VarType};

/// The waveform's file format, from the path's extension: `.fst` is FST, anything else VCD.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WaveFormat {
    Vcd,
    /// FST (GTKWave's compressed format) through the `fst-writer` crate. The crate writes
    /// bit vectors and reals only, so a string (an FSM state) is a bit vector of
    /// [`FST_TEXT_CHARS`] ASCII characters, right-aligned and NUL-padded, which the .gtkw
    /// shows in GTKWave's ASCII format: the same text as the VCD's string variable.
    Fst,
}

impl WaveFormat {
    /// The format a waveform written to `path` takes.
    pub fn of(path: &Path) -> Self {
        match path.extension().and_then(|e| e.to_str()) {
            Some(e) if e.eq_ignore_ascii_case("fst") => WaveFormat::Fst,
            _ => WaveFormat::Vcd,
        }
    }
}

/// Characters of an FST text signal (the longest FSM state, SHELL_START, has 11); a longer
/// text keeps its last 16 characters.
pub const FST_TEXT_CHARS: u32 = 16;

/// A cycle window `[from, to]`, both ends inclusive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    pub from: u64,
    pub to: u64,
}

impl Window {
    /// Every cycle.
    pub const ALL: Window = Window {
        from: 0,
        to: u64::MAX,
    };

    /// Parses `FROM:TO`; either side may be empty (`1000:` = from cycle 1000 to the end).
    pub fn parse(s: &str) -> std::result::Result<Window, String> {
        let (a, b) = s
            .split_once(':')
            .ok_or_else(|| format!("{s:?}: expected FROM:TO (cycles)"))?;
        let num = |x: &str, default: u64| -> std::result::Result<u64, String> {
            let x = x.trim();
            if x.is_empty() {
                Ok(default)
            } else {
                x.parse::<u64>()
                    .map_err(|e| format!("{x:?}: not a cycle number ({e})"))
            }
        };
        let w = Window {
            from: num(a, 0)?,
            to: num(b, u64::MAX)?,
        };
        if w.from > w.to {
            return Err(format!("{s:?}: FROM is after TO"));
        }
        Ok(w)
    }

    /// True when cycle `t` lies in the window.
    pub fn contains(&self, t: u64) -> bool {
        self.from <= t && t <= self.to
    }
}

/// Which scopes to declare: a glob (`*` any run of characters, `?` one character) matched
/// against the whole dotted scope when the pattern holds `*` or `?`, else a substring.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ScopeFilter {
    pattern: String,
}

impl ScopeFilter {
    /// A filter from its pattern.
    pub fn new(pattern: &str) -> Self {
        ScopeFilter {
            pattern: pattern.to_string(),
        }
    }

    /// True when signals of `scope` are to be declared.
    pub fn matches(&self, scope: &str) -> bool {
        if self.pattern.contains(['*', '?']) {
            glob(self.pattern.as_bytes(), scope.as_bytes())
        } else {
            scope.contains(&self.pattern)
        }
    }
}

/// Glob match with `*` and `?` (iterative, backtracking to the last `*`).
fn glob(p: &[u8], s: &[u8]) -> bool {
    let (mut pi, mut si) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while si < s.len() {
        if pi < p.len() && (p[pi] == b'?' || p[pi] == s[si]) {
            pi += 1;
            si += 1;
        } else if pi < p.len() && p[pi] == b'*' {
            star = Some((pi, si));
            pi += 1;
        } else if let Some((sp, ss)) = star {
            pi = sp + 1;
            si = ss + 1;
            star = Some((sp, ss + 1));
        } else {
            return false;
        }
    }
    p[pi..].iter().all(|&c| c == b'*')
}

/// What the writer is asked to keep.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VcdOptions {
    pub window: Window,
    pub scope: Option<ScopeFilter>,
    /// How an FST's value changes are compressed (a VCD's are not).
    pub fst_pack: FstPack,
}

impl Default for VcdOptions {
    fn default() -> Self {
        VcdOptions {
            window: Window::ALL,
            scope: None,
            fst_pack: FstPack::Zlib,
        }
    }
}

/// How an FST's value-change sections are compressed (`--fst-pack`): a smaller file or a
/// faster run, the choice GTKWave's own writer offers (`vcd2fst --fastpack`). Both are
/// standard FST that GTKWave and any FST reader open.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum FstPack {
    /// zlib format through libdeflate at its fastest level: about 18× smaller than the VCD
    /// at the paper's scale.
    #[default]
    Zlib,
    /// LZ4: about 8.5× smaller than the VCD, compressed several times faster (the
    /// compressor thread's work falls to about a quarter).
    Lz4,
}

/// How a signal is reported and shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SignalKind {
    /// An unsigned value.
    Bits,
    /// A string: an FSM state name.
    Text,
    /// Raw signed fixed point with `frac` fractional bits.
    Fixed { frac: u32 },
}

/// A declared signal.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Signal {
    /// The dotted scope, e.g. `machine.cluster_0.icu.stage_3`.
    pub scope: String,
    pub name: String,
    /// Width in bits (1 for strings, as VCD declares them).
    pub width: u32,
    pub kind: SignalKind,
}

impl Signal {
    /// The full dotted name as in the VCD's hierarchy: `machine.cluster_0.icu.stage_3.valid`.
    pub fn full_name(&self) -> String {
        format!("{}.{}", self.scope, self.name)
    }

    /// True when declared as a vector (`wire` wider than one bit, with a `[w-1:0]` range).
    pub fn is_vector(&self) -> bool {
        self.kind != SignalKind::Text && self.width > 1
    }
}

/// What a finished VCD holds.
#[derive(Clone, Debug)]
pub struct VcdSummary {
    /// Where it was written.
    pub path: PathBuf,
    /// The declared signals, in declaration order (scope tree, first seen first).
    pub signals: Vec<Signal>,
    pub window: Window,
    /// Samples seen (one per simulated cycle), including those outside the window.
    pub samples: u64,
    /// `#t` lines written.
    pub timestamps: u64,
    /// Size of the file in bytes.
    pub bytes: u64,
}

/// The waveform body's thread, fed by the simulation thread: each sample goes over as its
/// cycle, its number of changes and each change's position and value, one record after
/// another in large chunks; the thread applies them to the last sample's values and writes
/// them (a [`ThreadBody`]: the VCD's lines or the FST's chains). The simulation thread only
/// copies the changes (some 65 of the paper's machine's 435 values a cycle), and the bytes
/// are the same whatever the timing (the thread takes the samples in the order sent). Chunks go
/// through a bounded channel (memory stays bounded) and come back to be reused (no
/// allocation per sample, nor per chunk once a few circulate).
struct SampleStream {
    tx: std::sync::mpsc::SyncSender<Vec<u64>>,
    back: std::sync::mpsc::Receiver<Vec<u64>>,
    /// Samples not yet sent: each its cycle, its number of changes, then each change's
    /// position and value, in `chunk[..at]` (the chunk is `chunk_words` long, written in
    /// place: one bound check per sample, none per change).
    chunk: Vec<u64>,
    at: usize,
    /// Words of a chunk (at least one sample with every value changed).
    chunk_words: usize,
    /// Set by the thread once the waveform passed its size limit: the run then stops.
    over: Arc<AtomicBool>,
    handle: std::thread::JoinHandle<std::result::Result<BodyEnd, BodyError>>,
}

/// Words of a sample chunk: 512 KiB, about 500 samples of the paper's machine.
const CHUNK_WORDS: usize = 1 << 16;

/// What a waveform body's thread ends with.
pub(crate) struct BodyEnd {
    pub(crate) file: File,
    pub(crate) timestamps: u64,
}

/// Why a waveform body's thread stopped.
pub(crate) enum BodyError {
    Io(io::Error),
    /// The size limit passed (a usage error, exit status 2).
    Limit(String),
}

/// A waveform body that takes the samples on the stream's thread.
pub(crate) trait ThreadBody: Body + Send + 'static {
    /// Values per sample.
    fn values(&self) -> usize;
    /// Before the first sample (the VCD writes its header).
    fn begin(&mut self) -> io::Result<()> {
        Ok(())
    }
    /// The sample at `t`, in the window `win`: its changes, position and value in turn.
    fn sample(
        &mut self,
        win: Window,
        t: u64,
        changes: &[u64],
    ) -> std::result::Result<(), BodyError>;
    /// After the last sample: the file, written out, and the `#t` lines (time changes).
    fn end(self) -> io::Result<BodyEnd>;
}

/// Takes the chunks until the channel closes, each sample in turn (its cycle, its number of
/// changes, the changes); every chunk goes back to be filled again.
fn run_body<B: ThreadBody>(
    mut body: B,
    win: Window,
    rx: std::sync::mpsc::Receiver<Vec<u64>>,
    back: std::sync::mpsc::Sender<Vec<u64>>,
) -> std::result::Result<BodyEnd, BodyError> {
    body.begin().map_err(BodyError::Io)?;
    let mut failed = None;
    for chunk in rx {
        let mut rest = &chunk[..];
        while failed.is_none() && rest.len() >= 2 {
            let (t, n) = (rest[0], 2 * rest[1] as usize);
            let Some(changes) = rest.get(2..2 + n) else {
                failed = Some(BodyError::Io(io::Error::other("a truncated sample record")));
                break;
            };
            if let Err(e) = body.sample(win, t, changes) {
                failed = Some(e);
            }
            rest = &rest[2 + n..];
        }
        // Back as it is (its length kept, so only its tail is zeroed again). The writer may
        // be gone (finished or dropped): nothing to hand back to.
        let _ = back.send(chunk);
    }
    if let Some(e) = failed {
        return Err(e);
    }
    body.end().map_err(BodyError::Io)
}

impl SampleStream {
    /// Starts the thread on `body`, which raises `over` when the run is to stop.
    fn start<B: ThreadBody>(body: B, win: Window, over: Arc<AtomicBool>) -> Self {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<u64>>(2);
        let (back_tx, back) = std::sync::mpsc::channel();
        let chunk_words = CHUNK_WORDS.max(2 + 2 * body.values());
        // A chunk is zeroed to its full length once; one sent goes over cut to its samples and
        // comes back so, and only that tail (under one sample) is zeroed again.
        let handle = std::thread::spawn(move || run_body(body, win, rx, back_tx));
        SampleStream {
            tx,
            back,
            chunk: vec![0; chunk_words],
            at: 0,
            chunk_words,
            over,
            handle,
        }
    }

    /// Queues the sample at `t`: the values at the positions `changed`.
    #[inline]
    fn push(&mut self, t: u64, values: &[u64], changed: &[u32]) {
        let words = 2 + 2 * changed.len();
        if self.at + words > self.chunk_words {
            self.send();
        }
        let Some(rec) = self.chunk.get_mut(self.at..self.at + words) else {
            // A sample longer than a chunk: `chunk_words` holds every value changed.
            unreachable!("a sample record is at most 2 + 2 × values words");
        };
        self.at += words;
        let (head, pairs) = rec.split_at_mut(2);
        head[0] = t;
        head[1] = changed.len() as u64;
        for (p, &i) in pairs.chunks_exact_mut(2).zip(changed) {
            // A stage shift (`Probe::shifts_stages`) is an entry, not a position: no value.
            p[0] = i as u64;
            p[1] = values.get(i as usize).copied().unwrap_or(0);
        }
    }

    /// Hands the chunk's samples to the thread, taking a returned chunk (or a new one) in
    /// its place.
    fn send(&mut self) {
        let mut next = self.back.try_recv().unwrap_or_default();
        next.resize(self.chunk_words, 0);
        let mut full = std::mem::replace(&mut self.chunk, next);
        full.truncate(self.at);
        self.at = 0;
        // A closed channel: the thread stopped on an error, which `finish` reports.
        let _ = self.tx.send(full);
    }

    /// Sends the last samples and waits for the thread.
    fn finish(mut self) -> std::result::Result<BodyEnd, BodyError> {
        if self.at > 0 {
            self.send();
        }
        drop(self.tx);
        self.handle
            .join()
            .map_err(|_| BodyError::Io(io::Error::other("the waveform writer thread panicked")))?
    }
}

/// The cycle of the last sample (None before the first) and whether the window is open,
/// and what a sample at `t` does with them.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Clock {
    t: Option<u64>,
    window_open: bool,
}

/// What a sample does once its cycle is checked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Step {
    /// Inside the open window: compare with the last sample and write the changes.
    Changes,
    /// Take the values without writing them.
    Take,
    /// Take the values and open the window here with all of them (`$dumpvars`).
    TakeAndOpen,
}

impl Clock {
    /// Moves on to the sample at `t`: whether the window opens at `win.from` first, between
    /// the last sample and this one (the clock jumped over `from`: the values holding at
    /// `from` are the last sample's), and what the sample itself does.
    fn step(&mut self, win: Window, t: u64) -> io::Result<(bool, Step)> {
        let mut open_at_from = false;
        match self.t {
            Some(prev) if t <= prev => {
                return Err(io::Error::other(format!(
                    "cycle {t} after cycle {prev}: time must increase"
                )));
            }
            Some(prev) if !self.window_open && prev < win.from && t > win.from => {
                open_at_from = true;
                self.window_open = true;
            }
            _ => {}
        }
        let first = self.t.is_none();
        self.t = Some(t);
        let step = if !win.contains(t) {
            Step::Take
        } else if self.window_open && !first {
            Step::Changes
        } else if !self.window_open {
            // No sample before `from` (or this one is at `from`): open here.
            self.window_open = true;
            Step::TakeAndOpen
        } else {
            Step::Take
        };
        Ok((open_at_from, step))
    }
}

/// A waveform's body taking samples (the VCD's and the FST's, each on its thread).
pub(crate) trait Body {
    /// The window clock and the last sample's values.
    fn state(&mut self) -> (&mut Clock, &mut [u64]);
    /// Opens the window at `t`: `#t` and every declared value (those of the last sample).
    fn dump_all(&mut self, t: u64) -> io::Result<()>;
    /// Takes the sample's `changes` (position and value in turn, positions ascending) and
    /// writes `#t` and the changed declared values (nothing when none is declared).
    fn write_changes(&mut self, t: u64, changes: &[u64]) -> io::Result<()>;

    /// The sample at `t`, in the window `win`: its `changes`, position and value in turn.
    fn take_sample(&mut self, win: Window, t: u64, changes: &[u64]) -> io::Result<()> {
        let (open_at_from, step) = self.state().0.step(win, t)?;
        if open_at_from {
            self.dump_all(win.from)?;
        }
        match step {
            Step::Changes => self.write_changes(t, changes),
            Step::Take => apply(self.state().1, changes),
            Step::TakeAndOpen => {
                apply(self.state().1, changes)?;
                self.dump_all(t)
            }
        }
    }
}

/// A sample record's entries as (position, value): the words `SampleStream::push` wrote,
/// position and value in turn (or a stage shift and zero, which [`apply_changes`] expands).
#[inline(always)]
pub(crate) fn entries(record: &[u64]) -> impl Iterator<Item = (u64, u64)> + '_ {
    record.chunks_exact(2).map(|c| (c[0], c[1]))
}

/// Applies a sample record's changes to `values` (the last sample's), its stage shifts
/// expanded, writing nothing.
pub(crate) fn apply(values: &mut [u64], record: &[u64]) -> io::Result<()> {
    apply_changes(&mut KeepValues(values), entries(record)).map_err(io::Error::from)
}

/// The VCD body, on its thread: the last sample's values, the window, and the formatted
/// bytes on their way to the file.
struct VcdBody {
    slots: Vec<Slot>,
    /// Per position: how its lines are written (from `slots`, which only a text's line
    /// reads per change).
    formats: Vec<LineFormat>,
    /// Signal order of the header (indices into `slots`).
    declared: Vec<usize>,
    /// The last sample's values (those holding now).
    prev: Vec<u64>,
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
    /// The size limit in bytes (see [`set_wave_limit`]).
    limit: u64,
    path: PathBuf,
    over: Arc<AtomicBool>,
}

impl ThreadBody for VcdBody {
    fn values(&self) -> usize {
        self.prev.len()
    }

    fn begin(&mut self) -> io::Result<()> {
        // Through the buffer (the body's blocks start at the file's start).
        let head = std::mem::take(&mut self.head);
        self.out.put_all(&head)
    }

    /// One sample, as `VcdWriter::sample` describes; then the size limit, looked at every
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
}

impl VcdBody {
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
            put_text(self.out.window(self.margin), f, &self.slots[i], v)
        } else {
            let w = self.out.window(LINE);
            put_line(w.try_into().expect("LINE bytes"), f, v)
        };
        self.out.advance(n);
        Ok(())
    }
}

impl Body for VcdBody {
    fn state(&mut self) -> (&mut Clock, &mut [u64]) {
        (&mut self.clock, &mut self.prev)
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

/// One signal of the layout, with what writing its changes needs, built once.
#[derive(Clone)]
struct Slot {
    scope: String,
    name: String,
    width: u32,
    kind: SignalKind,
    /// True when the header declared it (inside the scope filter).
    declared: bool,
    /// Its VCD id as text (for the hand-formatted lines).
    id_text: Vec<u8>,
    /// The id and a newline, zero-padded to 8 bytes (written as one fixed-size copy), and
    /// how many of its bytes count.
    id_nl: [u8; 8],
    id_nl_len: usize,
    /// A text signal's value lines, one per name: `s<name> <id>\n` (VCD).
    text_lines: Vec<Vec<u8>>,
    /// A text signal's names (whitespace as '_', empty as "-").
    names: Vec<String>,
    /// Its FST id when declared in an FST.
    fst_id: Option<FstSignalId>,
}

/// Streams probe samples into a VCD file. Build with [`VcdWriter::create`], hand it to
/// `Machine::run` as the probe, then call [`VcdWriter::finish`].
///
/// Each sample is one flat value array (position = signal id, fixed by the layout the probe
/// declared once) with the positions that changed (`sample_changes`; `sample`'s whole arrays
/// are compared with the last here). The changes are queued to the waveform's thread
/// (`SampleStream`), which writes them: a VCD's lines formatted by
/// hand into a block written out whole (`VcdBody`), an FST's through `fst-writer` (`FstBody`).
pub struct VcdWriter {
    path: PathBuf,
    /// The temporary file beside `path`; dropped unfinished, it is removed, so no
    /// half-written VCD is left.
    tmp: Option<TempFile>,
    /// The VCD header (the `vcd` crate writes it into memory; it goes out first).
    out: Option<vcd::Writer<Vec<u8>>>,
    /// The VCD's file, until the header is written and its thread takes it.
    file: Option<File>,
    /// The waveform body's thread (from the header on).
    stream: Option<SampleStream>,
    /// The FST's header writer instead of `out` when the path ends in `.fst`.
    fst: Option<FstHeaderWriter<BufWriter<File>>>,
    opts: VcdOptions,
    slots: Vec<Slot>,
    /// Signal order of the header (indices into `slots`).
    declared: Vec<usize>,
    /// The last sample's cycle (the thread keeps the values and the window).
    last_t: Option<u64>,
    /// The last sample's values, for [`Probe::sample`]'s whole arrays (compared with them
    /// here), and the positions found changed (reused).
    last: Vec<u64>,
    changed: Vec<u32>,
    /// Which form the samples come in, once the first came: whole arrays (`sample`) or
    /// change lists (`sample_changes`). One writer takes one form: `last` follows only the
    /// first.
    whole: Option<bool>,
    /// True once the layout is declared and the header written.
    header_done: bool,
    samples: u64,
    timestamps: u64,
    /// The first error; later calls do nothing and `finish` reports it.
    error: Option<String>,
    /// A usage error found while writing (a scope filter matching nothing, the size limit
    /// passed): reported as exit status 2, and the run stops early (`Probe::stop`).
    usage: Option<String>,
    /// The VCD's size limit in bytes (see [`set_wave_limit`]).
    limit: u64,
}

/// Hand the VCD body to the file past this many buffered bytes.
const VCD_BLOCK_BYTES: usize = 1 << 20;

impl VcdWriter {
    /// A writer streaming to a temporary file beside `path` (created with its directory).
    pub fn create(path: &Path, opts: VcdOptions) -> Result<Self> {
        let (tmp, f) = TempFile::create(path)?;
        let (out, fst, file) = match WaveFormat::of(path) {
            WaveFormat::Vcd => (Some(vcd::Writer::new(Vec::new())), None, Some(f)),
            WaveFormat::Fst => {
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
                let h = FstHeaderWriter::new(buf, &info)
                    .map_err(|e| Error::io(tmp.tmp_path(), io::Error::other(e.to_string())))?;
                (None, Some(h), None)
            }
        };
        Ok(VcdWriter {
            path: path.to_path_buf(),
            tmp: Some(tmp),
            out,
            file,
            stream: None,
            fst,
            opts,
            slots: Vec::new(),
            declared: Vec::new(),
            last_t: None,
            last: Vec::new(),
            changed: Vec::new(),
            whole: None,
            header_done: false,
            samples: 0,
            timestamps: 0,
            error: None,
            usage: None,
            limit: WAVE_LIMIT.load(Ordering::Relaxed),
        })
    }

    /// Flushes, and renames the file into place. On an error the temporary file is removed
    /// and nothing appears at the target path.
    pub fn finish(mut self) -> Result<VcdSummary> {
        if !self.header_done && self.error.is_none() {
            // No layout at all: still a valid (empty) VCD.
            if let Err(e) = self.write_header() {
                self.fail(format!("writing: {e}"));
            }
        }
        // The thread saw every sample sent before any error found here, so its error comes
        // first.
        let mut body_end = None;
        match self.stream.take().map(SampleStream::finish) {
            Some(Ok(end)) => body_end = Some(end),
            Some(Err(BodyError::Limit(m))) => self.usage = Some(m),
            Some(Err(BodyError::Io(e))) => self.error = Some(format!("writing: {e}")),
            None => {}
        }
        if let Some(u) = self.usage.take() {
            // Dropping `self` removes the temporary file.
            return Err(Error::Usage(u));
        }
        if let Some(e) = self.error.take() {
            // Dropping `self` removes the temporary file.
            return Err(Error::Check(format!("{}: {e}", self.path.display())));
        }
        let end = body_end.expect("finish runs once, after the header");
        self.timestamps = end.timestamps;
        let done = crate::output::sync_file(&end.file).and_then(|()| end.file.metadata());
        let done = done.map(|m| m.len());
        let tmp = self.tmp.take().expect("finish runs once");
        let bytes = done.map_err(|e| Error::io(tmp.tmp_path(), e))?;
        tmp.persist()?;
        let signals = self
            .declared
            .iter()
            .map(|&i| {
                let s = &self.slots[i];
                Signal {
                    scope: s.scope.clone(),
                    name: s.name.clone(),
                    width: s.width,
                    kind: s.kind,
                }
            })
            .collect();
        Ok(VcdSummary {
            path: self.path.clone(),
            signals,
            window: self.opts.window,
            samples: self.samples,
            timestamps: self.timestamps,
            bytes,
        })
    }

    /// True when a sample of `n` values at `t` (a whole array or not) is to be written: the
    /// layout declared, as many values as signals, the same form as the first sample's, time
    /// increasing (else the error is recorded).
    fn accepts(&mut self, t: u64, n: usize, whole: bool) -> bool {
        if self.error.is_some() {
            return false;
        }
        if *self.whole.get_or_insert(whole) != whole {
            self.fail("a probe handed both whole samples and change lists");
            return false;
        }
        if !self.header_done {
            self.fail("a probe sampled before declaring its signals");
            return false;
        }
        if n != self.slots.len() {
            let msg = format!("cycle {t}: {n} values for {} signals", self.slots.len());
            self.fail(msg);
            return false;
        }
        if self.stream.is_none() {
            // The header failed (an error recorded above).
            return false;
        }
        if let Some(prev) = self.last_t.filter(|&p| t <= p) {
            self.fail(format!(
                "writing: cycle {t} after cycle {prev}: time must increase"
            ));
            return false;
        }
        self.last_t = Some(t);
        self.samples += 1;
        true
    }

    /// Hands the sample's changes to the thread, which writes them (`VcdBody`, `FstBody`).
    fn queue(&mut self, t: u64, values: &[u64], changed: &[u32]) {
        if let Some(s) = &mut self.stream {
            s.push(t, values, changed);
        }
    }

    /// Records `e` as the first error.
    fn fail(&mut self, e: impl Into<String>) {
        if self.error.is_none() {
            self.error = Some(e.into());
        }
    }

    /// Writes the header: scope tree, variables, `$enddefinitions`.
    fn write_header(&mut self) -> io::Result<()> {
        self.header_done = true;
        let filter = self.opts.scope.clone();
        let keep: Vec<usize> = (0..self.slots.len())
            .filter(|&i| {
                filter
                    .as_ref()
                    .is_none_or(|f| f.matches(&self.slots[i].scope))
            })
            .collect();
        if let (Some(f), true) = (&filter, keep.is_empty() && !self.slots.is_empty()) {
            let msg = format!(
                "--vcd-scope {:?} matches no signal (scopes look like machine.memory.arbiter, machine.cluster_0.icu.stage_0, machine.cluster_0.ctu_0); nothing written",
                crate::error::shown(&f.pattern)
            );
            self.usage = Some(msg.clone());
            return Err(io::Error::other(msg));
        }
        // The scope tree, each level's children in first-seen order.
        let mut root = ScopeNode::default();
        for &i in &keep {
            let mut node = &mut root;
            for part in self.slots[i].scope.split('.') {
                node = node.child(part);
            }
            node.vars.push(i);
        }
        let over = Arc::new(AtomicBool::new(false));
        if let Some(mut h) = self.fst.take() {
            let mut order = Vec::new();
            declare_fst(&mut h, &root, &mut self.slots, &mut order).map_err(fst_err)?;
            let b = h.finish().map_err(fst_err)?;
            let handles = self.slots.iter().map(|s| FstHandle {
                id: s.fst_id,
                text: s.kind == SignalKind::Text,
                width: fst_width(s),
            });
            let handles = handles.collect();
            let texts = self
                .slots
                .iter_mut()
                .map(|s| std::mem::take(&mut s.text_lines));
            let body = FstBody::new(
                b,
                handles,
                texts.collect(),
                order.clone(),
                self.opts.fst_pack,
            )?;
            self.stream = Some(SampleStream::start(body, self.opts.window, over));
            self.declared = order;
            return Ok(());
        }
        let w = self.out.as_mut().expect("open until finish");
        w.version(concat!("shellsim ", env!("CARGO_PKG_VERSION")))?;
        w.comment("one time unit is one clock cycle of the machine; #t is the cycle number")?;
        if self.opts.window != Window::ALL {
            w.comment(&format!(
                "cycle window {}:{}",
                self.opts.window.from, self.opts.window.to
            ))?;
        }
        if let Some(f) = &filter {
            w.comment(&format!("scope filter {:?}", f.pattern))?;
        }
        w.timescale(1, TimescaleUnit::NS)?;
        let mut order = Vec::new();
        declare(w, &root, &mut self.slots, &mut order)?;
        w.enddefinitions()?;
        // The header goes out ahead of the body, which the body's thread writes from now on.
        let head = std::mem::take(w.writer());
        let margin = self
            .slots
            .iter()
            .flat_map(|s| s.text_lines.iter().map(Vec::len))
            .fold(LINE, usize::max);
        let body = VcdBody {
            formats: self.slots.iter().map(LineFormat::of).collect(),
            slots: self.slots.clone(),
            declared: order.clone(),
            prev: vec![0; self.slots.len()],
            clock: Clock::default(),
            now: 0,
            stamped: false,
            samples: 0,
            timestamps: 0,
            head,
            out: BlockOut::new(
                self.file.take().expect("the VCD's file until the header"),
                VCD_BLOCK_BYTES + 1 + margin,
                VCD_BLOCK_BYTES,
                self.tmp.as_ref().is_some_and(TempFile::is_temporary),
            ),
            margin,
            limit: self.limit,
            path: self.path.clone(),
            over: over.clone(),
        };
        self.stream = Some(SampleStream::start(body, self.opts.window, over));
        self.declared = order;
        Ok(())
    }
}

impl Probe for VcdWriter {
    fn declare(&mut self, signals: &[SignalDecl]) {
        if self.error.is_some() {
            return;
        }
        if self.header_done {
            self.fail("the probe declared its signals twice");
            return;
        }
        let mut seen = std::collections::HashSet::new();
        for d in signals {
            if !(1..=64).contains(&d.width) {
                self.fail(format!(
                    "{}.{}: width {} is not in 1..=64",
                    d.scope, d.name, d.width
                ));
                return;
            }
            if !seen.insert((d.scope.as_str(), d.name)) {
                self.fail(format!("{}.{} declared twice", d.scope, d.name));
                return;
            }
        }
        self.slots = signals
            .iter()
            .map(|d| {
                let (kind, names) = match d.kind {
                    HwKind::Bits => (SignalKind::Bits, Vec::new()),
                    HwKind::Fixed { frac } => (SignalKind::Fixed { frac }, Vec::new()),
                    HwKind::Text(names) => {
                        (SignalKind::Text, names.iter().map(|n| token(n)).collect())
                    }
                };
                Slot {
                    scope: d.scope.clone(),
                    name: d.name.to_string(),
                    width: d.width,
                    kind,
                    declared: false,
                    id_text: Vec::new(),
                    id_nl: [0; 8],
                    id_nl_len: 0,
                    text_lines: Vec::new(),
                    names,
                    fst_id: None,
                }
            })
            .collect();
        self.last = vec![0; self.slots.len()];
        if let Err(e) = self.write_header() {
            self.fail(format!("writing: {e}"));
        }
    }

    /// A whole value array: compared here with the last sample's.
    fn sample(&mut self, t: u64, values: &[u64]) {
        if !self.accepts(t, values.len(), true) {
            return;
        }
        let mut changed = std::mem::take(&mut self.changed);
        changed.clear();
        for (i, (last, &v)) in self.last.iter_mut().zip(values).enumerate() {
            if *last != v {
                *last = v;
                changed.push(i as u32);
            }
        }
        self.queue(t, values, &changed);
        self.changed = changed;
    }

    fn sample_changes(&mut self, t: u64, values: &[u64], changed: &[u32]) {
        let n = values.len();
        // A stage shift last (its ICU the layout's last signals, its t unchanged) is checked
        // on the thread, with every shift (`apply_changes`).
        let past = |&i: &u32| i & STAGE_SHIFT == 0 && i as usize >= n;
        if changed.len() > n || changed.last().is_some_and(past) {
            self.fail(format!(
                "cycle {t}: a change list of {} positions up to {:?} for {n} values",
                changed.len(),
                changed.last()
            ));
            return;
        }
        if self.accepts(t, n, false) {
            self.queue(t, values, changed);
        }
    }

    /// A VCD's thread moves an advanced ICU's later stages itself (`apply_changes`): the
    /// simulation thread, which bounds a VCD run, saves ~10 % of its instructions. An FST's
    /// does not: an FST run is bound by the work of its three threads together, to which
    /// the move adds (BENCHMARKS.md, session 10).
    fn shifts_stages(&self) -> bool {
        self.out.is_some()
    }

    fn stop(&self) -> bool {
        self.usage.is_some()
            || self
                .stream
                .as_ref()
                .is_some_and(|s| s.over.load(Ordering::Relaxed))
    }
}

/// The default size limit of a VCD: 2 GiB (a whole ratio-100 run is about 6.3 GB).
pub const DEFAULT_WAVE_LIMIT: u64 = 2 << 30;

static WAVE_LIMIT: std::sync::atomic::AtomicU64 =
    std::sync::atomic::AtomicU64::new(DEFAULT_WAVE_LIMIT);

/// Sets the size limit of the VCDs written from now on (`--wave-limit`): a writer whose
/// file passes it stops the run and reports a usage error, leaving nothing behind.
pub fn set_wave_limit(bytes: u64) {
    WAVE_LIMIT.store(bytes, std::sync::atomic::Ordering::Relaxed);
}

/// A VCD string token: whitespace becomes '_', empty becomes "-".
fn token(s: &str) -> String {
    if s.is_empty() {
        "-".into()
    } else {
        s.chars()
            .map(|c| if c.is_whitespace() { '_' } else { c })
            .collect()
    }
}

/// A level of the scope tree.
#[derive(Default)]
struct ScopeNode {
    name: String,
    vars: Vec<usize>,
    children: Vec<ScopeNode>,
}

impl ScopeNode {
    /// The child named `name`, added at the end if new.
    fn child(&mut self, name: &str) -> &mut ScopeNode {
        let i = match self.children.iter().position(|c| c.name == name) {
            Some(i) => i,
            None => {
                self.children.push(ScopeNode {
                    name: name.to_string(),
                    ..Default::default()
                });
                self.children.len() - 1
            }
        };
        &mut self.children[i]
    }
}

/// Declares `node`'s children: a `$scope module` each, its variables, then its sub-scopes.
fn declare<W: Write>(
    w: &mut vcd::Writer<W>,
    node: &ScopeNode,
    slots: &mut [Slot],
    order: &mut Vec<usize>,
) -> io::Result<()> {
    for c in &node.children {
        w.add_module(&c.name)?;
        for &i in &c.vars {
            let s = &mut slots[i];
            let id = match s.kind {
                SignalKind::Text => w.add_var(VarType::String, 1, &s.name, None)?,
                _ if s.width == 1 => w.add_wire(1, &s.name)?,
                _ => w.add_var(
                    VarType::Wire,
                    s.width,
                    &s.name,
                    Some(ReferenceIndex::Range(s.width as i32 - 1, 0)),
                )?,
            };
            s.declared = true;
            s.id_text = id.to_string().into_bytes();
            // Seven characters number 94^7 signals.
            assert!(s.id_text.len() < 8, "VCD id {id} too long");
            s.id_nl[..s.id_text.len()].copy_from_slice(&s.id_text);
            s.id_nl[s.id_text.len()] = b'\n';
            s.id_nl_len = s.id_text.len() + 1;
            s.text_lines = s
                .names
                .iter()
                .map(|n| format!("s{n} {id}\n").into_bytes())
                .collect();
            order.push(i);
        }
        declare(w, c, slots, order)?;
        w.upscope()?;
    }
    Ok(())
}

/// Declares `node`'s children in the FST, as [`declare`] does in the VCD.
fn declare_fst<W: Write + io::Seek>(
    h: &mut FstHeaderWriter<W>,
    node: &ScopeNode,
    slots: &mut [Slot],
    order: &mut Vec<usize>,
) -> fst_writer::Result<()> {
    for c in &node.children {
        h.scope(&c.name, "", FstScopeType::Module)?;
        for &i in &c.vars {
            let s = &mut slots[i];
            let id = h.var(
                &s.name,
                FstSignalType::bit_vec(fst_width(s)),
                FstVarType::Wire,
                FstVarDirection::Implicit,
                None,
            )?;
            s.declared = true;
            s.fst_id = Some(id);
            s.text_lines = s.names.iter().map(|n| fst_text_bits(n)).collect();
            s.text_lines.push(fst_text_bits("-"));
            order.push(i);
        }
        declare_fst(h, c, slots, order)?;
        h.up_scope()?;
    }
    Ok(())
}

/// A signal's width in the FST: a text's is [`FST_TEXT_CHARS`] ASCII characters.
fn fst_width(s: &Slot) -> u32 {
    match s.kind {
        SignalKind::Text => 8 * FST_TEXT_CHARS,
        _ => s.width,
    }
}

/// A text as FST writes it: [`FST_TEXT_CHARS`] ASCII characters, right-aligned and
/// NUL-padded (a longer text keeps its tail), as '0'/'1' bytes MSB first.
fn fst_text_bits(t: &str) -> Vec<u8> {
    let bytes = t.as_bytes();
    let n = FST_TEXT_CHARS as usize;
    let tail = &bytes[bytes.len().saturating_sub(n)..];
    let mut buf = Vec::with_capacity(8 * n);
    for _ in tail.len()..n {
        buf.extend_from_slice(b"00000000");
    }
    for &c in tail {
        buf.extend_from_slice(&BIN8[c as usize]);
    }
    buf
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

/// How the body writes one signal's value lines, by position: built once from its [`Slot`]
/// when the header is written. Ten bytes, so a whole layout's (435 signals on the paper's
/// machine) stays in the first-level cache, where the slots (a few hundred bytes each, on
/// as many cache lines) are not read per change.
#[derive(Clone, Copy, Debug, Default)]
struct LineFormat {
    class: LineClass,
    /// The id and a newline, zero-padded to 8 bytes, and how many of its bytes count (as
    /// [`Slot::id_nl`]).
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
    /// Slot `s`'s format (hidden when its signal is outside the scope filter).
    fn of(s: &Slot) -> Self {
        let class = match s.kind {
            _ if !s.declared => LineClass::Hidden,
            SignalKind::Text => LineClass::Text,
            _ if s.width == 1 => LineClass::Bit,
            _ => LineClass::Vector,
        };
        LineFormat {
            class,
            id_nl: s.id_nl,
            id_nl_len: s.id_nl_len as u8,
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
fn put_text(w: &mut [u8], f: &LineFormat, slot: &Slot, v: u64) -> usize {
    if let Some(l) = slot.text_lines.get(v as usize) {
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

    #[test]
    fn windows_parse_with_open_ends() {
        assert_eq!(Window::parse("5:9").unwrap(), Window { from: 5, to: 9 });
        assert_eq!(
            Window::parse("100:").unwrap(),
            Window {
                from: 100,
                to: u64::MAX
            }
        );
        assert_eq!(Window::parse(":7").unwrap(), Window { from: 0, to: 7 });
        assert!(Window::parse("9:5").is_err());
        assert!(Window::parse("9").is_err());
        assert!(Window::parse("a:5").is_err());
    }

    #[test]
    fn scope_filters_glob_or_substring() {
        let f = ScopeFilter::new("machine.cluster_0.*");
        assert!(f.matches("machine.cluster_0.icu.stage_3"));
        assert!(!f.matches("machine.cluster_1.icu"));
        assert!(!f.matches("machine.cluster_0"));
        let f = ScopeFilter::new("*.ctu_?");
        assert!(f.matches("machine.cluster_1.ctu_0"));
        assert!(!f.matches("machine.cluster_1.ctu_0.jobs"));
        let f = ScopeFilter::new("icu");
        assert!(f.matches("machine.cluster_1.icu.stage_0"));
        assert!(!f.matches("machine.memory"));
    }

    fn decl(scope: &str, name: &'static str, width: u32, kind: HwKind) -> SignalDecl {
        SignalDecl {
            scope: scope.to_string(),
            name,
            width,
            kind,
        }
    }

    /// A hand-driven run: header, changes only, strictly increasing timestamps, strings.
    #[test]
    fn writes_changes_only() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.vcd");
        let mut w = VcdWriter::create(&p, VcdOptions::default()).unwrap();
        w.declare(&[
            decl("top.a", "x", 4, HwKind::Bits),
            decl("top.a", "v", 1, HwKind::Bits),
            decl("top", "state", 1, HwKind::Text(&["IDLE", "BUSY WAIT"])),
            decl("top.a", "t", 8, HwKind::Fixed { frac: 4 }),
        ]);
        for (t, v) in [(0u64, 0u64), (1, 0), (2, 3), (5, 3), (6, 1)] {
            let raw = (-(v as i64)) as u64 & 0xFF;
            w.sample(t, &[v, (v > 0) as u64, (v > 2) as u64, raw]);
        }
        let s = w.finish().unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert_eq!(s.signals.len(), 4);
        assert_eq!(s.signals[0].full_name(), "top.state");
        assert!(text.contains("$var string 1 ! state $end"), "{text}");
        assert!(text.contains("$var wire 4 \" x [3:0] $end"), "{text}");
        assert!(text.contains("sBUSY_WAIT !"), "{text}");
        assert!(text.contains("b11111101 $"), "{text}"); // -3 in 8 bits
        let stamps: Vec<&str> = text.lines().filter(|l| l.starts_with('#')).collect();
        assert_eq!(stamps, ["#0", "#2", "#6"]);
        assert!(!dir.path().read_dir().unwrap().any(|e| e
            .unwrap()
            .file_name()
            .to_string_lossy()
            .ends_with(".tmp")));
    }

    /// The hand-formatted lines are the `vcd` crate's.
    #[test]
    fn value_lines_are_the_vcd_crates() {
        let mut slot = Slot {
            scope: "m".into(),
            name: "x".into(),
            width: 40,
            kind: SignalKind::Bits,
            declared: true,
            id_text: b"%+".to_vec(),
            id_nl: *b"%+\n\0\0\0\0\0",
            id_nl_len: 3,
            text_lines: Vec::new(),
            names: Vec::new(),
            fst_id: None,
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
            let n = put_line(&mut w, &LineFormat::of(&slot), v);
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
        slot.width = 1;
        let n = put_line(&mut w, &LineFormat::of(&slot), 1);
        assert_eq!(&w[..n], b"1%+\n");
        let n = put_time(&mut w, 1234567);
        assert_eq!(&w[..n], b"#1234567\n");
        let n = put_time(&mut w, 0);
        assert_eq!(&w[..n], b"#0\n");
        let n = put_time(&mut w, u64::MAX);
        assert_eq!(&w[..n], format!("#{}\n", u64::MAX).as_bytes());
    }

    /// The window opens with the values holding at `from`, even between two samples.
    #[test]
    fn a_window_opens_with_the_state_at_from() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("w.vcd");
        let opts = VcdOptions {
            window: Window { from: 4, to: 8 },
            scope: None,
            ..Default::default()
        };
        let mut w = VcdWriter::create(&p, opts).unwrap();
        w.declare(&[decl("m", "x", 8, HwKind::Bits)]);
        for (t, v) in [(0u64, 1u64), (2, 2), (6, 3), (7, 4), (9, 5), (12, 6)] {
            w.sample(t, &[v]);
        }
        w.finish().unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        let body = text.split("$enddefinitions $end\n").nth(1).unwrap();
        assert_eq!(body, "#4\n$dumpvars\nb10 !\n$end\n#6\nb11 !\n#7\nb100 !\n");
    }

    #[test]
    fn no_sample_gives_a_valid_empty_vcd() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("e.vcd");
        let s = VcdWriter::create(&p, VcdOptions::default())
            .unwrap()
            .finish()
            .unwrap();
        assert!(s.signals.is_empty());
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.ends_with("$enddefinitions $end\n"), "{text}");
    }

    /// A writer to `x.vcd` in a new directory, one 8-bit signal declared and sampled once
    /// (value 1 at cycle 0); the directory, the path and the writer.
    fn one_signal_writer() -> (tempfile::TempDir, PathBuf, VcdWriter) {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.vcd");
        let mut w = VcdWriter::create(&p, VcdOptions::default()).unwrap();
        w.declare(&[decl("m", "x", 8, HwKind::Bits)]);
        w.sample(0, &[1]);
        (dir, p, w)
    }

    #[test]
    fn an_unfinished_writer_leaves_nothing() {
        let (dir, _, w) = one_signal_writer();
        drop(w);
        assert_eq!(dir.path().read_dir().unwrap().count(), 0);
    }

    /// The writer's thread finds the size limit at the same sample whatever its timing:
    /// the run stops (`stop`) soon after, and the error names that sample's cycle.
    #[test]
    fn the_size_limit_is_found_at_the_same_sample_every_time() {
        let dir = tempfile::tempdir().unwrap();
        for _ in 0..3 {
            let p = dir.path().join("l.vcd");
            let mut w = VcdWriter::create(&p, VcdOptions::default()).unwrap();
            w.limit = 1000;
            w.declare(&[decl("m", "x", 32, HwKind::Bits)]);
            let mut sent = 0;
            for t in 0..1_000_000u64 {
                if w.stop() {
                    break;
                }
                w.sample(t, &[t.wrapping_mul(0x9E37_79B9) & 0xFFFF_FFFF]);
                sent += 1;
            }
            assert!((1024..1_000_000).contains(&sent), "{sent} samples");
            match w.finish() {
                Err(Error::Usage(m)) => {
                    assert!(
                        m.contains("--wave-limit (1000 bytes) at cycle 1023,"),
                        "{m}"
                    )
                }
                other => panic!("{:?}", other.map(|s| s.bytes)),
            }
            assert_eq!(dir.path().read_dir().unwrap().count(), 0);
        }
    }

    #[test]
    fn a_sample_of_another_length_is_an_error() {
        let (_dir, p, mut w) = one_signal_writer();
        w.sample(1, &[1, 2]);
        assert!(w.finish().is_err());
        assert!(!p.exists());
    }

    /// A sample sequence with a window opening between samples, texts and wide values.
    fn samples() -> Vec<(u64, Vec<u64>)> {
        (0..60u64)
            .map(|k| {
                let t = 3 * k + (k % 3);
                (
                    t,
                    vec![k % 5, (k / 3) & 1, k % 2, (k * k * 977) & 0xFFFF_FFFF],
                )
            })
            .collect()
    }

    fn layout() -> Vec<SignalDecl> {
        vec![
            decl("top.a", "x", 4, HwKind::Bits),
            decl("top.a", "v", 1, HwKind::Bits),
            decl("top", "state", 1, HwKind::Text(&["IDLE", "BUSY"])),
            decl("top.b", "w", 32, HwKind::Bits),
        ]
    }

    /// Each writer form's file for `samples()`, in the window 40:140.
    fn written(ext: &str, change_lists: bool) -> Vec<u8> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(format!("t.{ext}"));
        let opts = VcdOptions {
            window: Window::parse("40:140").unwrap(),
            ..VcdOptions::default()
        };
        let mut w = VcdWriter::create(&p, opts).unwrap();
        w.declare(&layout());
        let mut last = vec![0u64; 4];
        for (t, v) in samples() {
            if change_lists {
                let changed: Vec<u32> = (0..4u32)
                    .filter(|&i| v[i as usize] != last[i as usize])
                    .collect();
                w.sample_changes(t, &v, &changed);
                last = v;
            } else {
                w.sample(t, &v);
            }
        }
        let s = w.finish().unwrap();
        assert!(s.timestamps > 20, "{s:?}");
        std::fs::read(&p).unwrap()
    }

    #[test]
    fn change_lists_give_the_same_vcd_as_whole_samples() {
        assert_eq!(written("vcd", true), written("vcd", false));
    }

    #[test]
    fn change_lists_give_the_same_fst_as_whole_samples() {
        assert_eq!(written("fst", true), written("fst", false));
    }

    #[test]
    fn a_writer_taking_whole_samples_and_change_lists_is_an_error() {
        let (_dir, p, mut w) = one_signal_writer();
        w.sample_changes(1, &[2], &[0]);
        let e = w.finish().unwrap_err().to_string();
        assert!(e.contains("both whole samples and change lists"), "{e}");
        assert!(!p.exists());
    }
}
