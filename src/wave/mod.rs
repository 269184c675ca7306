//! Waveforms of the machine: a [`Probe`] ([`WaveWriter`]) that streams the machine's signals
//! into a VCD or an FST file, and the GTKWave save file and Surfer command file beside it
//! ([`gtkw`], [`sucl`]).
//!
//! The first sample declares every signal (`signal`: one scope per unit); each sample after
//! it is one flat value array with the positions whose value changed since the last (the
//! machine finds them while filling the array; a caller of [`Probe::sample`] hands whole
//! arrays, which the writer compares with the last). The machine probes after every clock
//! edge it simulates; cycles skipped by its cycle jump change nothing, so the waveform is the
//! same.
//!
//! What is kept is the caller's choice ([`WaveOptions`]: a cycle window, a scope filter, the
//! FST's packing, a size limit). The changes go to the waveform's own thread (`stream`), which
//! writes them in the order sent through the format's body (`vcd`, `fst`; the VCD's blocks
//! through `blockfile`) into a temporary file beside the target, renamed into place by
//! [`WaveWriter::finish`] (dropping an unfinished writer deletes it), so memory stays bounded
//! on long runs and a failed run leaves no half-written file.

mod blockfile;
mod fst;
pub mod gtkw;
mod options;
mod signal;
mod stream;
pub mod sucl;
mod vcd;

pub use options::{FstPack, ScopeFilter, WaveFormat, WaveOptions, Window, DEFAULT_WAVE_LIMIT};
pub use signal::{state_bits, Signal, SignalKind, WaveSummary};

use crate::error::{Error, Result};
use crate::output::TempFile;
use fst::{FstBody, FstHeader};
use shellsim_hw::trace::{Pipeline, Probe, SignalDecl, SignalKind as HwKind, STAGE_SHIFT};
use signal::{token, Slot};
use std::fs::File;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use stream::{BodyError, SampleStream};
use vcd::VcdBody;

/// Streams probe samples into a waveform file (VCD, or FST for a `.fst` path). Build with [`WaveWriter::create`], hand it to
/// `Machine::run` as the probe, then call [`WaveWriter::finish`].
///
/// Each sample is one flat value array (position = signal id, fixed by the layout the probe
/// declared once) with the positions that changed (`sample_changes`; `sample`'s whole arrays
/// are compared with the last here). The changes are queued to the waveform's thread
/// (`SampleStream`), which writes them: a VCD's lines formatted by hand into a block written
/// out whole (`vcd::VcdBody`), an FST's through `fst-writer` (`fst::FstBody`).
pub struct WaveWriter {
    path: PathBuf,
    /// The temporary file beside `path`; dropped unfinished, it is removed, so no
    /// half-written VCD is left.
    tmp: Option<TempFile>,
    format: WaveFormat,
    /// Until the layout is declared: the file (a VCD's header is written into memory and
    /// goes out first) or the FST's header writer.
    start: Option<Start>,
    /// The waveform body's thread (from the header on).
    stream: Option<SampleStream>,
    opts: WaveOptions,
    slots: Vec<Slot>,
    /// The pipelines the machine declared (the VCD's thread moves their stages).
    pipelines: Vec<Pipeline>,
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
    /// True once the probe declared its layout (even an empty one).
    layout_declared: bool,
    samples: u64,
    timestamps: u64,
    /// The first error; later calls do nothing and `finish` reports it.
    error: Option<String>,
    /// A usage error found while writing (a scope filter matching nothing, the size limit
    /// passed): reported as exit status 2, and the run stops early (`Probe::stop`).
    usage: Option<String>,
}

/// What a writer holds until its layout is declared.
enum Start {
    Vcd(File),
    Fst(FstHeader),
}

impl WaveWriter {
    /// A writer streaming to a temporary file beside `path` (created with its directory).
    pub fn create(path: &Path, opts: WaveOptions) -> Result<Self> {
        let (tmp, f) = TempFile::create(path)?;
        let format = WaveFormat::of(path);
        let start = match format {
            WaveFormat::Vcd => Start::Vcd(f),
            WaveFormat::Fst => Start::Fst(
                fst::header(f, &opts)
                    .map_err(|e| Error::io(tmp.tmp_path(), io::Error::other(e.to_string())))?,
            ),
        };
        Ok(WaveWriter {
            path: path.to_path_buf(),
            tmp: Some(tmp),
            format,
            start: Some(start),
            stream: None,
            opts,
            slots: Vec::new(),
            pipelines: Vec::new(),
            declared: Vec::new(),
            last_t: None,
            last: Vec::new(),
            changed: Vec::new(),
            whole: None,
            header_done: false,
            layout_declared: false,
            samples: 0,
            timestamps: 0,
            error: None,
            usage: None,
        })
    }

    /// Flushes, and renames the file into place. On an error the temporary file is removed
    /// and nothing appears at the target path.
    pub fn finish(mut self) -> Result<WaveSummary> {
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
            .map(|&i| self.slots[i].sig.clone())
            .collect();
        Ok(WaveSummary {
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
        let filter = self.opts.scope.as_ref();
        let keep: Vec<usize> = (0..self.slots.len())
            .filter(|&i| filter.is_none_or(|f| f.matches(&self.slots[i].sig.scope)))
            .collect();
        // The machine leaves out the units the filter keeps nothing of (`Probe::wants`): a
        // declared layout with nothing kept matched nothing, whether or not it is empty.
        if let (Some(f), true) = (filter, keep.is_empty() && self.layout_declared) {
            let msg = format!(
                "--vcd-scope {:?} matches no signal (scopes look like machine.memory.arbiter, machine.cluster_0.icu.stage_0, machine.cluster_0.ctu_0); nothing written",
                crate::error::shown(f.pattern())
            );
            self.usage = Some(msg.clone());
            return Err(io::Error::other(msg));
        }
        let over = Arc::new(AtomicBool::new(false));
        let win = self.opts.window;
        let (stream, order) = match self.start.take().expect("the header is written once") {
            Start::Fst(h) => {
                let (body, order) = FstBody::new(h, &self.slots, &keep, self.opts.fst_pack)?;
                (SampleStream::start(body, win, over), order)
            }
            Start::Vcd(file) => {
                let temporary = self.tmp.as_ref().is_some_and(TempFile::is_temporary);
                let (body, order) = VcdBody::new(
                    &self.slots,
                    &keep,
                    &self.opts,
                    file,
                    temporary,
                    &self.path,
                    over.clone(),
                )?;
                let body = body.with_pipelines(&self.pipelines);
                (SampleStream::start(body, win, over), order)
            }
        };
        self.stream = Some(stream);
        self.declared = order;
        Ok(())
    }
}

impl Probe for WaveWriter {
    fn declare(&mut self, signals: &[SignalDecl], pipelines: &[Pipeline]) {
        if self.error.is_some() {
            return;
        }
        if self.header_done {
            self.fail("the probe declared its signals twice");
            return;
        }
        self.layout_declared = true;
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
                    HwKind::Text(names) => (
                        SignalKind::Text {
                            states: names.len() as u32,
                        },
                        names.iter().map(|n| token(n)).collect(),
                    ),
                };
                Slot {
                    sig: Signal {
                        scope: d.scope.clone(),
                        name: d.name.to_string(),
                        width: d.width,
                        kind,
                    },
                    names,
                }
            })
            .collect();
        if let Some(p) = pipelines.iter().find(|p| !p.fits_in(signals.len())) {
            self.fail(format!(
                "a pipeline {p:?} that does not fit the {} signals",
                signals.len()
            ));
            return;
        }
        self.pipelines = pipelines.to_vec();
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
        // A pipeline's entry last (its ICU the layout's last signals, its t unchanged) is
        // checked on the thread, with every entry (`apply_changes`).
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
    /// the move adds (measured in issue 13; `git log -p BENCHMARKS.md`).
    fn shifts_stages(&self) -> bool {
        self.format == WaveFormat::Vcd
    }

    /// Inside the scope filter: the machine leaves the other units out of the layout.
    fn wants(&self, scope: &str) -> bool {
        self.opts.scope.as_ref().is_none_or(|f| f.matches(scope))
    }

    fn stop(&self) -> bool {
        self.usage.is_some()
            || self
                .stream
                .as_ref()
                .is_some_and(|s| s.over.load(Ordering::Relaxed))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let mut w = WaveWriter::create(&p, WaveOptions::default()).unwrap();
        w.declare(
            &[
                decl("top.a", "x", 4, HwKind::Bits),
                decl("top.a", "v", 1, HwKind::Bits),
                decl("top", "state", 1, HwKind::Text(&["IDLE", "BUSY WAIT"])),
                decl("top.a", "t", 8, HwKind::Fixed { frac: 4 }),
            ],
            &[],
        );
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

    /// The window opens with the values holding at `from`, even between two samples.
    #[test]
    fn a_window_opens_with_the_state_at_from() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("w.vcd");
        let opts = WaveOptions {
            window: Window { from: 4, to: 8 },
            scope: None,
            ..Default::default()
        };
        let mut w = WaveWriter::create(&p, opts).unwrap();
        w.declare(&[decl("m", "x", 8, HwKind::Bits)], &[]);
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
        let s = WaveWriter::create(&p, WaveOptions::default())
            .unwrap()
            .finish()
            .unwrap();
        assert!(s.signals.is_empty());
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.ends_with("$enddefinitions $end\n"), "{text}");
    }

    /// A writer to `x.vcd` in a new directory, one 8-bit signal declared and sampled once
    /// (value 1 at cycle 0); the directory, the path and the writer.
    fn one_signal_writer() -> (tempfile::TempDir, PathBuf, WaveWriter) {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.vcd");
        let mut w = WaveWriter::create(&p, WaveOptions::default()).unwrap();
        w.declare(&[decl("m", "x", 8, HwKind::Bits)], &[]);
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
            let opts = WaveOptions {
                limit: 1000,
                ..WaveOptions::default()
            };
            let mut w = WaveWriter::create(&p, opts).unwrap();
            w.declare(&[decl("m", "x", 32, HwKind::Bits)], &[]);
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
        let opts = WaveOptions {
            window: Window::parse("40:140").unwrap(),
            ..WaveOptions::default()
        };
        let mut w = WaveWriter::create(&p, opts).unwrap();
        w.declare(&layout(), &[]);
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
