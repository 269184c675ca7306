//! A large output streamed past the page cache: the VCD body's bytes go out in whole aligned
//! blocks with `O_DIRECT` (Linux), written on a thread of their own while the next block
//! fills, so writing half a gigabyte neither copies it into the page cache nor makes the
//! kernel find fresh pages for it — on the virtual machines this project runs on, that copy
//! was most of a ratio-10 VCD run (measured in issue 13; `git log -p BENCHMARKS.md`). Where direct I/O is refused
//! (a filesystem without it, a device asking for more alignment, a file that is not regular)
//! the file goes on buffered from that byte on; the bytes are the same either way.

use std::fs::File;
use std::io::{self, Write};
use std::sync::mpsc::{channel, sync_channel, Receiver, Sender, SyncSender};
use std::thread::JoinHandle;

/// Alignment of a direct write: of the buffer's address, its length and the file offset.
pub(crate) const DIRECT_ALIGN: usize = 4096;

/// Blocks in circulation: one filling, one being written.
const BLOCKS: usize = 2;

/// One buffer: `bytes[base..base + cap]` (`base` aligns it).
struct Block {
    bytes: Vec<u8>,
    base: usize,
}

impl Block {
    fn new(cap: usize) -> Self {
        let bytes = vec![0; cap + DIRECT_ALIGN];
        let base = bytes.as_ptr().align_offset(DIRECT_ALIGN).min(DIRECT_ALIGN);
        Block { bytes, base }
    }
}

/// A block's first `n` bytes to write, and whether they are the file's last.
type Job = (Block, usize, bool);

/// A byte buffer handed to its file in aligned blocks: filled from the front; at
/// [`BlockOut::write_out`] its whole blocks go to the writing thread and the rest (under a
/// block) moves to the front of the next buffer.
pub(crate) struct BlockOut {
    cur: Block,
    cap: usize,
    /// The next byte to fill: `cur.bytes[cur.base..pos]` are filled.
    pos: usize,
    /// Bytes past which [`BlockOut::is_full`] is true (under `cap`: the caller keeps each
    /// window within `cap − full`), and the `pos` that is.
    full: usize,
    full_at: usize,
    /// Bytes handed on to be written.
    handed: u64,
    /// Blocks to the writing thread, and back once written.
    tx: Option<SyncSender<Job>>,
    back: Receiver<Block>,
    thread: Option<JoinHandle<io::Result<File>>>,
}

impl BlockOut {
    /// A buffer of `cap` bytes for `file`, full past `full` bytes, and the thread that
    /// writes it: directly when `try_direct` and the system allows it. Only a file of its
    /// own may be tried so (the flag belongs to the open file, which a duplicated standard
    /// output shares with the shell).
    pub(crate) fn new(file: File, cap: usize, full: usize, try_direct: bool) -> Self {
        // Room for a block past the rest a hand-on leaves.
        let cap = cap.max(2 * DIRECT_ALIGN);
        let full = full.min(cap);
        let (tx, rx) = sync_channel::<Job>(BLOCKS);
        let (back_tx, back) = channel();
        for _ in 1..BLOCKS {
            let _ = back_tx.send(Block::new(cap));
        }
        let thread = std::thread::spawn(move || write_blocks(file, try_direct, rx, back_tx));
        let cur = Block::new(cap);
        BlockOut {
            pos: cur.base,
            full,
            full_at: cur.base + full,
            cur,
            cap,
            handed: 0,
            tx: Some(tx),
            back,
            thread: Some(thread),
        }
    }

    /// Bytes filled and not yet handed on.
    #[inline(always)]
    pub(crate) fn filled(&self) -> usize {
        self.pos - self.cur.base
    }

    /// More than the `full` bytes given at [`BlockOut::new`] are filled.
    #[inline(always)]
    pub(crate) fn is_full(&self) -> bool {
        self.pos > self.full_at
    }

    /// Bytes handed on to be written so far.
    pub(crate) fn written(&self) -> u64 {
        self.handed
    }

    /// The `len` bytes after those filled (the caller keeps `filled() + len` within the
    /// buffer's `cap`), to be counted in with [`BlockOut::advance`].
    #[inline(always)]
    pub(crate) fn window(&mut self, len: usize) -> &mut [u8] {
        &mut self.cur.bytes[self.pos..self.pos + len]
    }

    /// Counts `n` more bytes as filled.
    #[inline(always)]
    pub(crate) fn advance(&mut self, n: usize) {
        self.pos += n;
    }

    /// Appends `bytes` whole, handing blocks on as the buffer fills.
    pub(crate) fn put_all(&mut self, mut bytes: &[u8]) -> io::Result<()> {
        while !bytes.is_empty() {
            if self.filled() >= self.cap - DIRECT_ALIGN {
                self.write_out()?;
            }
            let k = bytes.len().min(self.cap - self.filled());
            self.window(k).copy_from_slice(&bytes[..k]);
            self.pos += k;
            bytes = &bytes[k..];
        }
        Ok(())
    }

    /// Hands the filled bytes' whole blocks on to be written (waiting for a free buffer
    /// when both are in use); the rest, under a block, starts the next buffer.
    pub(crate) fn write_out(&mut self) -> io::Result<()> {
        let at = self.filled();
        let n = at / DIRECT_ALIGN * DIRECT_ALIGN;
        if n == 0 {
            return Ok(());
        }
        let Ok(mut next) = self.back.recv() else {
            return Err(self.failed());
        };
        let (from, to) = (self.cur.base + n, self.pos);
        let rest = to - from;
        next.bytes[next.base..next.base + rest].copy_from_slice(&self.cur.bytes[from..to]);
        let full = std::mem::replace(&mut self.cur, next);
        self.send((full, n, false))?;
        self.handed += n as u64;
        (self.pos, self.full_at) = (self.cur.base + rest, self.cur.base + self.full);
        Ok(())
    }

    /// Hands every byte filled on and waits until all are written: the file back.
    pub(crate) fn finish(mut self) -> io::Result<File> {
        let at = self.filled();
        let last = std::mem::replace(&mut self.cur, Block::new(0));
        self.send((last, at, true))?;
        drop(self.tx.take());
        self.join()
    }

    fn send(&mut self, job: Job) -> io::Result<()> {
        let sent = self.tx.as_ref().is_some_and(|tx| tx.send(job).is_ok());
        if sent {
            Ok(())
        } else {
            Err(self.failed())
        }
    }

    /// The writing thread's error (it stopped).
    fn failed(&mut self) -> io::Error {
        drop(self.tx.take());
        match self.join() {
            Err(e) => e,
            Ok(_) => io::Error::other("the waveform's file writer stopped"),
        }
    }

    fn join(&mut self) -> io::Result<File> {
        match self.thread.take().map(JoinHandle::join) {
            Some(Ok(r)) => r,
            Some(Err(_)) => Err(io::Error::other("the waveform's file writer panicked")),
            None => Err(io::Error::other("the waveform's file writer is gone")),
        }
    }
}

/// The writing thread: each block's bytes in turn, directly while the file takes it, the
/// block handed back; after the last, direct writes off and the file returned.
impl Drop for BlockOut {
    /// Unfinished (the run stopped on an error): the thread ends after the block it holds,
    /// and is waited for, so nothing writes to the file once the body is gone.
    fn drop(&mut self) {
        drop(self.tx.take());
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn write_blocks(
    file: File,
    try_direct: bool,
    rx: Receiver<Job>,
    back: Sender<Block>,
) -> io::Result<File> {
    let regular = file.metadata().is_ok_and(|m| m.is_file());
    let mut w = Direct {
        direct: try_direct && regular && set_direct(&file, true),
        file,
    };
    for (block, n, last) in rx {
        if last && n % DIRECT_ALIGN != 0 {
            w.buffered()?;
        }
        w.write(&block.bytes[block.base..block.base + n])?;
        if last {
            // Every byte is written: clearing the flag only spares later users of the file
            // its rules, so a failure to is not the run's.
            let _ = w.buffered();
            return Ok(w.file);
        }
        // The writer may be gone (an error on its side): nothing to hand back to.
        let _ = back.send(block);
    }
    Err(io::Error::other(
        "the waveform's file ended without its last block",
    ))
}

/// A file and whether it takes direct writes (its offset a whole number of blocks while so).
struct Direct {
    file: File,
    direct: bool,
}

impl Direct {
    /// Writes `bytes` (a whole number of blocks while direct), going on buffered when a
    /// direct write is refused or comes back short of a block.
    fn write(&mut self, bytes: &[u8]) -> io::Result<()> {
        let mut done = 0;
        while done < bytes.len() {
            match self.file.write(&bytes[done..]) {
                Ok(0) => return Err(io::ErrorKind::WriteZero.into()),
                Ok(k) => {
                    done += k;
                    if self.direct && k % DIRECT_ALIGN != 0 {
                        self.buffered()?;
                    }
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) if self.direct && e.kind() == io::ErrorKind::InvalidInput => {
                    self.buffered()?;
                }
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }

    /// Turns direct writes off for the rest of the file.
    fn buffered(&mut self) -> io::Result<()> {
        if !self.direct {
            return Ok(());
        }
        self.direct = false;
        if set_direct(&self.file, false) {
            Ok(())
        } else {
            Err(io::Error::other("cannot turn direct writes off"))
        }
    }
}

/// Sets or clears `O_DIRECT` on `file`: true when done.
#[cfg(target_os = "linux")]
fn set_direct(file: &File, on: bool) -> bool {
    use rustix::fs::{fcntl_getfl, fcntl_setfl, OFlags};
    let Ok(flags) = fcntl_getfl(file) else {
        return false;
    };
    let flags = if on {
        flags | OFlags::DIRECT
    } else {
        flags.difference(OFlags::DIRECT)
    };
    fcntl_setfl(file, flags).is_ok()
}

/// Direct writes are used on Linux only: elsewhere the file stays buffered.
#[cfg(not(target_os = "linux"))]
fn set_direct(_: &File, on: bool) -> bool {
    !on
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bytes come out the same in any cut: a header of an odd length longer than the
    /// buffer, blocks handed on part way, a short tail.
    fn blocks_give_the_bytes_put(try_direct: bool) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.bin");
        let cap = 3 * DIRECT_ALIGN;
        let mut o = BlockOut::new(File::create(&path).unwrap(), cap, cap - 64, try_direct);
        let mut want = Vec::new();
        let head: Vec<u8> = (0..30_001u32).map(|i| (i * 7 % 251) as u8).collect();
        o.put_all(&head).unwrap();
        want.extend_from_slice(&head);
        for k in 0..5000u32 {
            let line = format!("b{k:b} {}\n", k % 97);
            if o.is_full() {
                o.write_out().unwrap();
            }
            o.window(line.len()).copy_from_slice(line.as_bytes());
            o.advance(line.len());
            want.extend_from_slice(line.as_bytes());
        }
        let written = o.written() + o.filled() as u64;
        o.finish().unwrap();
        assert_eq!(written, want.len() as u64);
        assert_eq!(std::fs::read(&path).unwrap(), want);
    }

    /// Direct writes where the filesystem takes them.
    #[test]
    fn direct_blocks_give_the_bytes_put() {
        blocks_give_the_bytes_put(true);
    }

    /// Buffered writes (a filesystem refusing direct I/O).
    #[test]
    fn buffered_blocks_give_the_bytes_put() {
        blocks_give_the_bytes_put(false);
    }

    /// A file that cannot be written reports the error (no panic, no hang).
    #[test]
    fn a_failing_file_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.bin");
        std::fs::write(&path, b"").unwrap();
        let read_only = File::open(&path).unwrap();
        let mut o = BlockOut::new(read_only, 2 * DIRECT_ALIGN, DIRECT_ALIGN, true);
        let mut failed = false;
        for _ in 0..4 {
            o.window(DIRECT_ALIGN).fill(b'x');
            o.advance(DIRECT_ALIGN);
            if o.write_out().is_err() {
                failed = true;
                break;
            }
        }
        assert!(failed || o.finish().is_err());
    }
}
