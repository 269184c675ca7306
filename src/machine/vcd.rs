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
//! **Changes only.** The writer keeps the last value of every signal and writes a `#t` line
//! only when something declared changed at cycle t. The machine probes after every clock edge
//! it simulates; cycles skipped by its cycle jump change nothing, so the waveform is the same.
//!
//! **Options.** A cycle window `[from, to]`: nothing outside it is written, but the values
//! holding at `from` are dumped in full (`$dumpvars`) so the window opens on a complete state.
//! A scope filter (a glob with `*`/`?`, or else a substring, on the full dotted scope):
//! signals outside it are not declared at all.
//!
//! **Output.** Streamed through a `BufWriter` into a temporary file beside the target, renamed
//! into place by [`VcdWriter::finish`] (dropping an unfinished writer deletes it), so memory
//! stays bounded on long runs and a failed run leaves no half-written VCD. The header holds no
//! date, so the same run gives a byte-identical file.

use crate::error::{Error, Result};
use crate::output::TempFile;
use fst_writer::{
    FstBodyWriter, FstFileType, FstHeaderWriter, FstInfo, FstScopeType, FstSignalId, FstSignalType,
    FstVarDirection, FstVarType,
};
use shellsim_hw::trace::Probe;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use vcd::{IdCode, ReferenceIndex, SimulationCommand, TimescaleUnit, Value, VarType};

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

/// The FST writer, in its two phases: header (scopes and variables), then value changes.
enum Fst {
    Header(FstHeaderWriter<BufWriter<File>>),
    Body(FstBodyWriter<BufWriter<File>>),
}

/// Flush the FST's value changes into a compressed section past this many buffered bytes,
/// so memory stays bounded on long runs.
const FST_FLUSH_BYTES: usize = 8 << 20;

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
}

impl Default for VcdOptions {
    fn default() -> Self {
        VcdOptions {
            window: Window::ALL,
            scope: None,
        }
    }
}

/// How a signal is reported and shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SignalKind {
    /// An unsigned value (`Probe::bits`).
    Bits,
    /// A string: an FSM state name (`Probe::text`).
    Text,
    /// Raw signed fixed point with `frac` fractional bits (`Probe::fixed`).
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

/// A value as last reported.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Val {
    Bits(u64),
    Text(String),
}

/// A value as a probe call reports it (borrowed, so an unchanged string costs no allocation).
#[derive(Clone, Copy, Debug)]
enum ValRef<'a> {
    Bits(u64),
    Text(&'a str),
}

impl Val {
    /// True when `v` is the same value.
    fn equals(&self, v: ValRef) -> bool {
        match (self, v) {
            (Val::Bits(a), ValRef::Bits(b)) => *a == b,
            (Val::Text(a), ValRef::Text(b)) => a == b,
            _ => false,
        }
    }

    /// Takes the value `v`, reusing a string's buffer.
    fn set(&mut self, v: ValRef) {
        match (&mut *self, v) {
            (Val::Text(a), ValRef::Text(b)) => {
                a.clear();
                a.push_str(b);
            }
            (_, ValRef::Bits(b)) => *self = Val::Bits(b),
            (_, ValRef::Text(b)) => *self = Val::Text(b.to_string()),
        }
    }
}

/// One position in a sample: the k-th probe call of every sample reports the same signal.
struct Slot {
    scope: String,
    name: String,
    width: u32,
    kind: SignalKind,
    /// Its VCD id when declared (inside the scope filter).
    id: Option<IdCode>,
    /// The id as text, for the hand-formatted vector lines.
    id_text: String,
    /// Its FST id when declared in an FST.
    fst_id: Option<FstSignalId>,
    value: Val,
    /// Changed in the current sample.
    dirty: bool,
}

/// Streams probe samples into a VCD file. Build with [`VcdWriter::create`], hand it to
/// `Machine::run` as the probe, then call [`VcdWriter::finish`].
pub struct VcdWriter {
    path: PathBuf,
    /// The temporary file beside `path`; dropped unfinished, it is removed, so no
    /// half-written VCD is left.
    tmp: Option<TempFile>,
    out: Option<vcd::Writer<BufWriter<File>>>,
    /// The FST writer instead of `out` when the path ends in `.fst`.
    fst: Option<Fst>,
    /// A value as FST writes it: one ASCII '0'/'1' per bit, MSB first.
    fst_buf: Vec<u8>,
    opts: VcdOptions,
    slots: Vec<Slot>,
    /// Signal order of the header (indices into `slots`).
    declared: Vec<usize>,
    /// Slots changed in the current sample.
    dirty: Vec<usize>,
    /// Index of the next call within the current sample.
    pos: usize,
    /// The current sample's cycle (None before the first).
    t: Option<u64>,
    /// True once the header is written (after the first sample).
    header_done: bool,
    /// True once the window's opening dump is written.
    window_open: bool,
    samples: u64,
    /// This sample takes `report`'s fast path.
    fast: bool,
    timestamps: u64,
    /// The first error; later calls do nothing and `finish` reports it.
    error: Option<String>,
    /// A usage error found while writing (a scope filter matching nothing, the size limit
    /// passed): reported as exit status 2, and the run stops early (`Probe::stop`).
    usage: Option<String>,
    /// The VCD's size limit in bytes (see [`set_wave_limit`]).
    limit: u64,
    scratch: String,
}

impl VcdWriter {
    /// A writer streaming to a temporary file beside `path` (created with its directory).
    pub fn create(path: &Path, opts: VcdOptions) -> Result<Self> {
        let (tmp, f) = TempFile::create(path)?;
        let buf = BufWriter::with_capacity(1 << 16, f);
        let (out, fst) = match WaveFormat::of(path) {
            WaveFormat::Vcd => (Some(vcd::Writer::new(buf)), None),
            WaveFormat::Fst => {
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
                (None, Some(Fst::Header(h)))
            }
        };
        Ok(VcdWriter {
            path: path.to_path_buf(),
            tmp: Some(tmp),
            out,
            fst,
            fst_buf: Vec::new(),
            opts,
            slots: Vec::new(),
            declared: Vec::new(),
            dirty: Vec::new(),
            pos: 0,
            t: None,
            header_done: false,
            window_open: false,
            samples: 0,
            fast: false,
            timestamps: 0,
            error: None,
            usage: None,
            limit: WAVE_LIMIT.load(std::sync::atomic::Ordering::Relaxed),
            scratch: String::new(),
        })
    }

    /// Ends the last sample, flushes, and renames the file into place. On an error the
    /// temporary file is removed and nothing appears at the target path.
    pub fn finish(mut self) -> Result<VcdSummary> {
        self.end_sample();
        if !self.header_done && self.error.is_none() {
            // No sample at all: still a valid (empty) VCD.
            if let Err(e) = self.write_header() {
                self.fail(format!("writing: {e}"));
            }
        }
        if let Some(u) = self.usage.take() {
            // Dropping `self` removes the temporary file.
            return Err(Error::Usage(u));
        }
        if let Some(e) = self.error.take() {
            // Dropping `self` removes the temporary file.
            return Err(Error::Check(format!("{}: {e}", self.path.display())));
        }
        let done = match (self.out.take(), self.fst.take()) {
            (Some(mut w), _) => (|| -> io::Result<u64> {
                w.flush()?;
                let f = w.writer().get_ref();
                crate::output::sync_file(f)?;
                f.metadata().map(|m| m.len())
            })(),
            (None, Some(Fst::Body(b))) => (|| -> io::Result<u64> {
                let mut w = b.finish().map_err(fst_err)?;
                w.flush()?;
                let f = w.get_ref();
                crate::output::sync_file(f)?;
                f.metadata().map(|m| m.len())
            })(),
            _ => unreachable!("finish runs once, after the header"),
        };
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

    /// Records `e` as the first error.
    fn fail(&mut self, e: impl Into<String>) {
        if self.error.is_none() {
            self.error = Some(e.into());
        }
    }

    /// One probe call: checks the layout (first sample: adds the slot) and stages the value.
    fn report(&mut self, scope: &str, name: &str, width: u32, kind: SignalKind, v: ValRef) {
        // Fast path, after the header and off the layout-check samples: one slot lookup,
        // a width/kind check and a value compare.
        if self.fast {
            let i = self.pos;
            if let Some(s) = self.slots.get_mut(i) {
                if s.width == width && s.kind == kind {
                    self.pos += 1;
                    if !s.value.equals(v) {
                        s.value.set(v);
                        if !s.dirty && s.declared() {
                            s.dirty = true;
                            self.dirty.push(i);
                        }
                    }
                    return;
                }
            }
        }
        if self.error.is_some() {
            return;
        }
        if self.t.is_none() {
            self.fail("a probe reported a value before the first cycle()");
            return;
        }
        if !(1..=64).contains(&width) {
            self.fail(format!("{scope}.{name}: width {width} is not in 1..=64"));
            return;
        }
        let i = self.pos;
        self.pos += 1;
        if !self.header_done {
            if self
                .slots
                .iter()
                .any(|s| s.scope == scope && s.name == name)
            {
                self.fail(format!("{scope}.{name} reported twice in one sample"));
                return;
            }
            self.slots.push(Slot {
                scope: scope.to_string(),
                name: name.to_string(),
                width,
                kind,
                id: None,
                id_text: String::new(),
                fst_id: None,
                value: match v {
                    ValRef::Bits(b) => Val::Bits(b),
                    ValRef::Text(t) => Val::Text(t.to_string()),
                },
                dirty: true,
            });
            return;
        }
        let Some(s) = self.slots.get_mut(i) else {
            self.fail(format!(
                "{scope}.{name}: more signals than in the first sample"
            ));
            return;
        };
        // The layout check: width and kind on every call; the names (string compares) on the
        // first samples and every 64th (every sample in debug builds), which keeps the check
        // from dominating the writer's time.
        let full_check =
            cfg!(debug_assertions) || self.samples <= 4 || self.samples.is_multiple_of(64);
        if s.width != width
            || s.kind != kind
            || (full_check && (s.name != name || s.scope != scope))
        {
            let msg = format!(
                "signal {} of a sample is {scope}.{name}, but {}.{} in the first sample",
                i, s.scope, s.name
            );
            self.fail(msg);
            return;
        }
        if !s.value.equals(v) {
            s.value.set(v);
            if !s.dirty && s.declared() {
                s.dirty = true;
                self.dirty.push(i);
            }
        }
    }

    /// Writes the header: scope tree, variables, `$enddefinitions`.
    fn write_header(&mut self) -> io::Result<()> {
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
        if let Some(Fst::Header(_)) = &self.fst {
            let Some(Fst::Header(mut h)) = self.fst.take() else {
                unreachable!()
            };
            let mut order = Vec::new();
            declare_fst(&mut h, &root, &mut self.slots, &mut order).map_err(fst_err)?;
            self.fst = Some(Fst::Body(h.finish().map_err(fst_err)?));
            self.declared = order;
            for s in &mut self.slots {
                s.dirty = false;
            }
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
        self.declared = order;
        for s in &mut self.slots {
            s.dirty = false;
        }
        Ok(())
    }

    /// Ends the current sample: header after the first, then its changes if in the window.
    fn end_sample(&mut self) {
        let Some(t) = self.t else { return };
        if self.error.is_some() {
            return;
        }
        if self.header_done && self.pos != self.slots.len() {
            let msg = format!(
                "cycle {t}: {} signals reported, {} in the first sample",
                self.pos,
                self.slots.len()
            );
            self.fail(msg);
            return;
        }
        let r = (|| -> io::Result<()> {
            if !self.header_done {
                self.write_header()?;
                self.header_done = true;
            }
            let win = self.opts.window;
            if win.contains(t) {
                if !self.window_open {
                    // No sample before `from` (or this one is at `from`): open here.
                    self.dump_all(t)?;
                } else if self.dirty.iter().any(|&i| self.slots[i].declared()) {
                    self.write_changes(t)?;
                }
            }
            Ok(())
        })();
        for &i in &self.dirty {
            self.slots[i].dirty = false;
        }
        self.dirty.clear();
        if let Err(e) = r {
            self.fail(format!("writing: {e}"));
            return;
        }
        // The size limit, looked at every 1024 samples (the file lags its buffer by at most
        // 64 KiB).
        if self.samples.is_multiple_of(1024) {
            let bytes = self
                .out
                .as_mut()
                .and_then(|w| w.writer().get_ref().metadata().ok())
                .map_or(0, |m| m.len());
            if bytes > self.limit {
                let msg = format!(
                    "{}: the waveform passed --wave-limit ({} bytes) at cycle {t}, {:.0} bytes per cycle so far; the run was stopped and nothing written. Narrow it with --vcd-window FROM:TO or --vcd-scope PATTERN, or raise --wave-limit",
                    self.path.display(),
                    self.limit,
                    bytes as f64 / (t.max(1) as f64)
                );
                self.usage = Some(msg.clone());
                self.fail(msg);
            }
        }
    }

    /// `#t` and every declared value in a `$dumpvars` block; opens the window.
    fn dump_all(&mut self, t: u64) -> io::Result<()> {
        self.window_open = true;
        self.timestamps += 1;
        if let Some(Fst::Body(b)) = &mut self.fst {
            // FST has no $dumpvars: the first time's values are the initial state.
            b.time_change(t).map_err(fst_err)?;
            for &i in &self.declared {
                fst_value(b, &self.slots[i], &mut self.fst_buf)?;
            }
            return Ok(());
        }
        let w = self.out.as_mut().expect("open until finish");
        w.timestamp(t)?;
        w.begin(SimulationCommand::Dumpvars)?;
        for &i in &self.declared {
            write_value(w, &self.slots[i], &mut self.scratch)?;
        }
        w.end()
    }

    /// `#t` and the changed values.
    fn write_changes(&mut self, t: u64) -> io::Result<()> {
        self.timestamps += 1;
        if let Some(Fst::Body(b)) = &mut self.fst {
            b.time_change(t).map_err(fst_err)?;
            for &i in &self.dirty {
                fst_value(b, &self.slots[i], &mut self.fst_buf)?;
            }
            if self.timestamps.is_multiple_of(256) && b.size() > FST_FLUSH_BYTES {
                b.flush().map_err(fst_err)?;
            }
            return Ok(());
        }
        let w = self.out.as_mut().expect("open until finish");
        w.timestamp(t)?;
        for &i in &self.dirty {
            write_value(w, &self.slots[i], &mut self.scratch)?;
        }
        Ok(())
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

impl Probe for VcdWriter {
    fn stop(&self) -> bool {
        self.usage.is_some()
    }

    fn cycle(&mut self, t: u64) {
        self.end_sample();
        if self.error.is_some() {
            return;
        }
        if let Some(prev) = self.t {
            if t <= prev {
                self.fail(format!("cycle {t} after cycle {prev}: time must increase"));
                return;
            }
            // The window opens between two samples (the clock jumped over `from`): the
            // values holding at `from` are those of the previous sample.
            let win = self.opts.window;
            if !self.window_open && prev < win.from && t > win.from {
                if let Err(e) = self.dump_all(win.from) {
                    self.fail(format!("writing: {e}"));
                    return;
                }
            }
        }
        self.t = Some(t);
        self.pos = 0;
        self.samples += 1;
        // Samples that check the layout take the full path (see `report`).
        self.fast = self.header_done
            && self.error.is_none()
            && !(cfg!(debug_assertions) || self.samples <= 4 || self.samples.is_multiple_of(64));
    }

    fn bits(&mut self, scope: &str, name: &str, width: u32, value: u64) {
        let v = value & mask(width);
        self.report(scope, name, width, SignalKind::Bits, ValRef::Bits(v));
    }

    fn text(&mut self, scope: &str, name: &str, value: &str) {
        // VCD string values are single tokens: whitespace becomes '_', empty becomes "-".
        let v: std::borrow::Cow<str> = if value.is_empty() {
            "-".into()
        } else if value.contains(char::is_whitespace) {
            value
                .chars()
                .map(|c| if c.is_whitespace() { '_' } else { c })
                .collect::<String>()
                .into()
        } else {
            value.into()
        };
        self.report(scope, name, 1, SignalKind::Text, ValRef::Text(&v));
    }

    fn fixed(&mut self, scope: &str, name: &str, width: u32, frac: u32, raw: i64) {
        // Two's complement in `width` bits.
        let v = (raw as u64) & mask(width);
        self.report(
            scope,
            name,
            width,
            SignalKind::Fixed { frac },
            ValRef::Bits(v),
        );
    }
}

/// The low `width` bits.
fn mask(width: u32) -> u64 {
    if width >= 64 {
        u64::MAX
    } else {
        (1u64 << width) - 1
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
            s.id = Some(id);
            s.id_text = id.to_string();
            order.push(i);
        }
        declare(w, c, slots, order)?;
        w.upscope()?;
    }
    Ok(())
}

impl Slot {
    /// True when the header declared it (inside the scope filter).
    fn declared(&self) -> bool {
        self.id.is_some() || self.fst_id.is_some()
    }
}

/// An FST error as an I/O error (the writer reports every failure as "writing: …").
fn fst_err(e: fst_writer::FstWriteError) -> io::Error {
    match e {
        fst_writer::FstWriteError::Io(e) => e,
        e => io::Error::other(e.to_string()),
    }
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
            let width = match s.kind {
                SignalKind::Text => 8 * FST_TEXT_CHARS,
                _ => s.width,
            };
            let id = h.var(
                &s.name,
                FstSignalType::bit_vec(width),
                FstVarType::Wire,
                FstVarDirection::Implicit,
                None,
            )?;
            s.fst_id = Some(id);
            order.push(i);
        }
        declare_fst(h, c, slots, order)?;
        h.up_scope()?;
    }
    Ok(())
}

/// Writes one value change into the FST: the bits MSB first, a text as ASCII bytes.
fn fst_value<W: Write + io::Seek>(
    b: &mut FstBodyWriter<W>,
    s: &Slot,
    buf: &mut Vec<u8>,
) -> io::Result<()> {
    let id = s.fst_id.expect("only declared signals are written");
    buf.clear();
    match &s.value {
        Val::Bits(v) => {
            for k in (0..s.width).rev() {
                buf.push(b'0' + ((v >> k) & 1) as u8);
            }
        }
        Val::Text(t) => {
            let bytes = t.as_bytes();
            let n = FST_TEXT_CHARS as usize;
            let tail = &bytes[bytes.len().saturating_sub(n)..];
            for _ in tail.len()..n {
                buf.extend_from_slice(b"00000000");
            }
            for &c in tail {
                for k in (0..8).rev() {
                    buf.push(b'0' + ((c >> k) & 1));
                }
            }
        }
    }
    b.signal_change(id, buf).map_err(fst_err)
}

/// Writes one value change line.
fn write_value<W: Write>(w: &mut vcd::Writer<W>, s: &Slot, scratch: &mut String) -> io::Result<()> {
    let id = s.id.expect("only declared signals are written");
    match &s.value {
        Val::Text(v) => w.change_string(id, v),
        Val::Bits(v) if s.width == 1 => {
            w.change_scalar(id, if *v != 0 { Value::V1 } else { Value::V0 })
        }
        Val::Bits(v) => {
            // The crate's `change_vector` writes one `write!` per bit; this writes the same
            // line (leading zeros dropped, which VCD zero-extends) as bytes, no formatting.
            scratch.clear();
            scratch.push('b');
            let n = (64 - v.leading_zeros()).max(1);
            for b in (0..n).rev() {
                scratch.push(if (v >> b) & 1 == 1 { '1' } else { '0' });
            }
            scratch.push(' ');
            scratch.push_str(&s.id_text);
            scratch.push('\n');
            w.writer().write_all(scratch.as_bytes())
        }
    }
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

    /// A hand-driven run: header, changes only, strictly increasing timestamps, strings.
    #[test]
    fn writes_changes_only() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.vcd");
        let mut w = VcdWriter::create(&p, VcdOptions::default()).unwrap();
        for (t, v) in [(0u64, 0u64), (1, 0), (2, 3), (5, 3), (6, 1)] {
            w.cycle(t);
            w.bits("top.a", "x", 4, v);
            w.bits("top.a", "v", 1, (v > 0) as u64);
            w.text("top", "state", if v > 2 { "BUSY WAIT" } else { "IDLE" });
            w.fixed("top.a", "t", 8, 4, -(v as i64));
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

    /// The window opens with the values holding at `from`, even between two samples.
    #[test]
    fn a_window_opens_with_the_state_at_from() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("w.vcd");
        let opts = VcdOptions {
            window: Window { from: 4, to: 8 },
            scope: None,
        };
        let mut w = VcdWriter::create(&p, opts).unwrap();
        for (t, v) in [(0u64, 1u64), (2, 2), (6, 3), (7, 4), (9, 5), (12, 6)] {
            w.cycle(t);
            w.bits("m", "x", 8, v);
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

    #[test]
    fn an_unfinished_writer_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.vcd");
        {
            let mut w = VcdWriter::create(&p, VcdOptions::default()).unwrap();
            w.cycle(0);
            w.bits("m", "x", 8, 1);
        }
        assert_eq!(dir.path().read_dir().unwrap().count(), 0);
    }

    #[test]
    fn a_changed_layout_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.vcd");
        let mut w = VcdWriter::create(&p, VcdOptions::default()).unwrap();
        w.cycle(0);
        w.bits("m", "x", 8, 1);
        w.cycle(1);
        w.bits("m", "y", 8, 1);
        assert!(w.finish().is_err());
        assert!(!p.exists());
    }
}
