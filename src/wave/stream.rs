//! The sample stream between the simulation thread and the waveform's own thread: each
//! sample goes over as its cycle, its number of changes and each change's position and value
//! (the simulation thread only copies the changes), and the thread hands them to the
//! waveform's [`Body`] (the VCD's lines in vcd.rs, the FST's chains in fst.rs) in the order sent, so the
//! bytes do not depend on the timing. Here too the window clock every body keeps.

use super::options::Window;
use shellsim_hw::trace::{apply_changes, KeepValues, Pipeline};
use std::fs::File;
use std::io;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

/// The waveform body's thread, fed by the simulation thread: each sample goes over as its
/// cycle, its number of changes and each change's position and value, one record after
/// another in large chunks; the thread applies them to the last sample's values and writes
/// them (a [`Body`]: the VCD's lines or the FST's chains). The simulation thread only
/// copies the changes (some 65 of the paper's machine's 435 values a cycle), and the bytes
/// are the same whatever the timing (the thread takes the samples in the order sent). Chunks go
/// through a bounded channel (memory stays bounded) and come back to be reused (no
/// allocation per sample, nor per chunk once a few circulate).
pub(crate) struct SampleStream {
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
    pub(crate) over: Arc<AtomicBool>,
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

/// Takes the chunks until the channel closes, each sample in turn (its cycle, its number of
/// changes, the changes); every chunk goes back to be filled again.
fn run_body<B: Body>(
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
    pub(crate) fn start<B: Body>(body: B, win: Window, over: Arc<AtomicBool>) -> Self {
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
    pub(crate) fn push(&mut self, t: u64, values: &[u64], changed: &[u32]) {
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
            // A pipeline's entry (`Probe::shifts_stages`) is not a position: no value.
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
    pub(crate) fn finish(mut self) -> std::result::Result<BodyEnd, BodyError> {
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
pub(crate) enum Step {
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
    pub(crate) fn step(&mut self, win: Window, t: u64) -> io::Result<(bool, Step)> {
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

/// A waveform's body (the VCD's lines, the FST's chains), on the stream's thread: it takes
/// each sample's changes in order and writes them.
pub(crate) trait Body: Send + 'static {
    /// Values per sample.
    fn values(&self) -> usize;
    /// Before the first sample (the VCD writes its header).
    fn begin(&mut self) -> io::Result<()> {
        Ok(())
    }
    /// The window clock, the last sample's values and the pipelines the probe declared.
    fn state(&mut self) -> (&mut Clock, &mut [u64], &[Pipeline]);
    /// Opens the window at `t`: the time and every declared value (those of the last
    /// sample).
    fn dump_all(&mut self, t: u64) -> io::Result<()>;
    /// Takes the sample's `changes` (position and value in turn, positions ascending) and
    /// writes the time and the changed declared values (nothing when none is declared).
    fn write_changes(&mut self, t: u64, changes: &[u64]) -> io::Result<()>;
    /// After the last sample: the file, written out, and the time changes written.
    fn end(self) -> io::Result<BodyEnd>;

    /// The sample at `t`, in the window `win`: its `changes`, position and value in turn.
    fn take_sample(&mut self, win: Window, t: u64, changes: &[u64]) -> io::Result<()> {
        let (open_at_from, step) = self.state().0.step(win, t)?;
        if open_at_from {
            self.dump_all(win.from)?;
        }
        match step {
            Step::Changes => self.write_changes(t, changes),
            Step::Take => {
                let (_, values, pipelines) = self.state();
                apply(values, pipelines, changes)
            }
            Step::TakeAndOpen => {
                let (_, values, pipelines) = self.state();
                apply(values, pipelines, changes)?;
                self.dump_all(t)
            }
        }
    }

    /// [`Body::take_sample`], and whatever else a body checks per sample (the VCD's size
    /// limit).
    fn sample(
        &mut self,
        win: Window,
        t: u64,
        changes: &[u64],
    ) -> std::result::Result<(), BodyError> {
        self.take_sample(win, t, changes).map_err(BodyError::Io)
    }
}

/// A sample record's entries as (position, value): the words `SampleStream::push` wrote,
/// position and value in turn (or a pipeline's entry and zero, which [`apply_changes`] expands).
#[inline(always)]
pub(crate) fn entries(record: &[u64]) -> impl Iterator<Item = (u64, u64)> + '_ {
    record.chunks_exact(2).map(|c| (c[0], c[1]))
}

/// Applies a sample record's changes to `values` (the last sample's), its advanced
/// `pipelines` shifted, writing nothing.
pub(crate) fn apply(values: &mut [u64], pipelines: &[Pipeline], record: &[u64]) -> io::Result<()> {
    apply_changes(&mut KeepValues(values, pipelines), entries(record)).map_err(io::Error::from)
}
