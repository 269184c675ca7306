//! Writing outputs: the one writer of every file shellsim writes, aware of what the path is.
//! A regular file or a path that does not exist is written to a [`TempFile`] beside it and
//! renamed into place when complete, so an interrupted or failed run never leaves a
//! half-written file that looks complete; a symlink is followed and its target replaced
//! (the link is kept); a character device, FIFO or socket (`/dev/null`, `/dev/stdout`) is
//! written to directly, never renamed over; `-` is standard output. [`check_outputs`] checks
//! every output path of a command before any work starts (a directory where a file is
//! wanted, a missing or read-only parent, two options naming one file). Temporary files
//! are listed in a registry that the SIGINT/SIGTERM handler ([`install_signal_handlers`])
//! removes before exiting with 130/143. Standard output is written through `out!`/`outln!`,
//! which never panic on a closed pipe: the failure is kept and reported at the end
//! ([`stdout_result`]). JSON reports are pretty-printed with a final newline.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::Write;
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, MutexGuard};

/// Temporary files not yet renamed into place: removed by the signal handler.
static TEMPS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn temps() -> MutexGuard<'static, Vec<PathBuf>> {
    TEMPS.lock().unwrap_or_else(|p| p.into_inner())
}

/// True for `-`, standard output.
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// `path` with every symlink of its last component followed (relative links against the
/// link's directory; at most 40 links, like the kernel). A dangling link gives its target.
pub fn resolve(path: &Path) -> PathBuf {
    let mut p = path.to_path_buf();
    for _ in 0..40 {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => match std::fs::read_link(&p) {
                Ok(t) if t.is_absolute() => p = t,
                Ok(t) => p = p.parent().unwrap_or(Path::new("")).join(t),
                Err(_) => return p,
            },
            _ => return p,
        }
    }
    p
}

/// What a resolved output path is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// A regular file, or nothing yet: written atomically.
    File,
    /// A character or block device, FIFO or socket: written directly.
    Stream,
    Directory,
}

fn kind(target: &Path) -> Kind {
    match std::fs::metadata(target) {
        Ok(m) if m.is_dir() => Kind::Directory,
        Ok(m) if !m.is_file() => Kind::Stream,
        _ => Kind::File,
    }
}

/// True when `path` is written through a temporary file renamed into place (a regular
/// file or a new one), false for a device, FIFO, socket or `-`.
pub fn is_file_path(path: &Path) -> bool {
    !is_stdout(path) && kind(&resolve(path)) == Kind::File
}

/// The directory a file at `target` lives in (`.` for a bare name).
fn parent_dir(target: &Path) -> PathBuf {
    match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// An output file being written. For a regular file (or a new one) it is a temporary file
/// beside the target (`.NAME.PID.N.tmp`, created with its directory) that
/// [`TempFile::persist`] renames into place; dropped without that, it is removed. For a
/// device, FIFO or `-` it is the target itself, and `persist` does nothing.
#[derive(Debug)]
pub struct TempFile {
    path: PathBuf,
    target: PathBuf,
    /// The temporary file; `None` when writing directly.
    tmp: Option<PathBuf>,
    persisted: bool,
}

impl TempFile {
    /// Opens the output `path` (see the type); returns it and the open file to write.
    pub fn create(path: &Path) -> Result<(TempFile, File)> {
        let direct = |target: PathBuf, f: File| {
            Ok((
                TempFile {
                    path: path.to_path_buf(),
                    target,
                    tmp: None,
                    persisted: false,
                },
                f,
            ))
        };
        if is_stdout(path) {
            use std::os::fd::AsFd;
            let fd = std::io::stdout()
                .as_fd()
                .try_clone_to_owned()
                .map_err(|e| Error::io(path, e))?;
            return direct(path.to_path_buf(), File::from(fd));
        }
        let target = resolve(path);
        match kind(&target) {
            Kind::Directory => {
                return Err(Error::Usage(format!(
                    "{}: is a directory, not a file",
                    path.display()
                )))
            }
            Kind::Stream => {
                let f = std::fs::OpenOptions::new()
                    .write(true)
                    .open(&target)
                    .map_err(|e| Error::io(path, e))?;
                return direct(target, f);
            }
            Kind::File => {}
        }
        let dir = parent_dir(&target);
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "out".into());
        // The process id and a counter: two threads writing one target never share a name.
        static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let tmp = dir.join(format!(".{name}.{}.{n}.tmp", std::process::id()));
        // Listed before it exists, so that an interrupt in between still removes it.
        temps().push(tmp.clone());
        let f = match File::create(&tmp) {
            Ok(f) => f,
            Err(e) => {
                temps().retain(|t| *t != tmp);
                return Err(Error::io(&tmp, e));
            }
        };
        // A replaced file keeps its permission mode (0600 stays 0600).
        if let Ok(m) = std::fs::metadata(&target) {
            if let Err(e) = f.set_permissions(m.permissions()) {
                drop(f);
                let _ = std::fs::remove_file(&tmp);
                temps().retain(|t| *t != tmp);
                return Err(Error::io(&tmp, e));
            }
        }
        Ok((
            TempFile {
                path: path.to_path_buf(),
                target,
                tmp: Some(tmp),
                persisted: false,
            },
            f,
        ))
    }

    /// The target path, as given.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// True when it writes a fresh temporary file (not a device, FIFO or standard output).
    pub fn is_temporary(&self) -> bool {
        self.tmp.is_some()
    }

    /// The path being written: the temporary file, or the target when writing directly.
    pub fn tmp_path(&self) -> &Path {
        self.tmp.as_deref().unwrap_or(&self.target)
    }

    /// Renames the temporary file into place (write and sync it first). On an error the
    /// temporary file is removed and nothing appears at the target path.
    pub fn persist(mut self) -> Result<()> {
        if let Some(tmp) = &self.tmp {
            // Under the registry's lock: the signal handler sees the file either still
            // temporary (and removes it) or complete under its name, never in between.
            let mut list = temps();
            std::fs::rename(tmp, &self.target).map_err(|e| Error::io(&self.path, e))?;
            list.retain(|t| t != tmp);
        }
        self.persisted = true;
        Ok(())
    }
}

impl Drop for TempFile {
    /// A temporary file never renamed into place is removed.
    fn drop(&mut self) {
        if let (false, Some(tmp)) = (self.persisted, &self.tmp) {
            let _ = std::fs::remove_file(tmp);
            temps().retain(|t| t != tmp);
        }
    }
}

/// Writes `bytes` to `path`: atomically (a [`TempFile`] renamed into place) for a regular
/// file, directly for a device, FIFO or `-`.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let (tmp, mut f) = TempFile::create(path)?;
    f.write_all(bytes).map_err(|e| Error::io(path, e))?;
    if tmp.tmp.is_some() {
        f.sync_all().map_err(|e| Error::io(path, e))?;
    }
    drop(f);
    tmp.persist()
}

/// Writes `path` atomically, as [`write_atomic`], by streaming: `write` writes into a
/// buffered writer, so nothing beyond the buffer is held in memory.
pub fn write_atomic_with(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    let (tmp, f) = TempFile::create(path)?;
    let mut w = std::io::BufWriter::with_capacity(1 << 20, f);
    write(&mut w).map_err(|e| Error::io(path, e))?;
    let f = w
        .into_inner()
        .map_err(|e| Error::io(path, e.into_error()))?;
    if tmp.tmp.is_some() {
        f.sync_all().map_err(|e| Error::io(path, e))?;
    }
    drop(f);
    tmp.persist()
}

/// Syncs `f` to disk when it is a regular file (a device or FIFO cannot be synced, and
/// need not be).
pub fn sync_file(f: &File) -> std::io::Result<()> {
    if f.metadata()?.is_file() {
        f.sync_all()?;
    }
    Ok(())
}

/// `value` as pretty-printed JSON ending in a newline.
pub fn json_string(value: &impl serde::Serialize) -> String {
    serde_json::to_string_pretty(value).expect("our reports serialize") + "\n"
}

/// Writes `value` as pretty-printed JSON (ending in a newline) to `path`, atomically.
pub fn write_json(path: &Path, value: &impl serde::Serialize) -> Result<()> {
    write_atomic(path, json_string(value).as_bytes())
}

/// A file-name-safe form of a name from data (a scene's `name`): ASCII letters, digits,
/// `-` and `_` are kept, everything else (`/`, `.`, control characters) becomes `_`, so a
/// name never leaves its output directory; an empty name is `scene`.
pub fn file_stem(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() {
        "scene".into()
    } else {
        s
    }
}

/// One output a command will write, for [`check_outputs`].
#[derive(Clone, Debug)]
pub struct Output {
    /// The option that names it (`--json`, `--out`, `--vcd (its .gtkw)`).
    pub option: String,
    pub path: PathBuf,
    /// A directory (`--out`) rather than a file.
    pub dir: bool,
}

impl Output {
    /// A file output named by `option`.
    pub fn file(option: &str, path: &Path) -> Output {
        Output {
            option: option.into(),
            path: path.to_path_buf(),
            dir: false,
        }
    }

    /// A directory output named by `option`.
    pub fn dir(option: &str, path: &Path) -> Output {
        Output {
            dir: true,
            ..Output::file(option, path)
        }
    }
}

/// The lexical absolute form of `p` (`.` and `..` folded, no file system access).
fn absolute(p: &Path) -> PathBuf {
    let p = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            c => out.push(c),
        }
    }
    out
}

/// A key that is equal for two paths naming the same file: the canonical directory (where
/// it exists) and the file name.
fn identity(target: &Path) -> PathBuf {
    let abs = absolute(target);
    match (abs.parent(), abs.file_name()) {
        (Some(d), Some(n)) => std::fs::canonicalize(d)
            .unwrap_or_else(|_| d.to_path_buf())
            .join(n),
        _ => abs,
    }
}

/// Checks that `dir` (or, when it does not exist yet, the nearest directory above it that
/// does, where it would be created) is a directory shellsim can write in.
fn check_writable(o: &Output, dir: &Path) -> Result<()> {
    let mut d = absolute(dir);
    while std::fs::symlink_metadata(&d).is_err() {
        if !d.pop() {
            return Ok(());
        }
    }
    let bad = |what: String| {
        Error::Usage(format!(
            "{} {}: {what}",
            o.option,
            crate::error::shown(&o.path.display().to_string())
        ))
    };
    match std::fs::metadata(&d) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => return Err(bad(format!("{} is not a directory", d.display()))),
        Err(e) => return Err(bad(format!("{}: {e}", d.display()))),
    }
    // The one sure test of writability (permissions, read-only file systems, root).
    let probe = d.join(format!(".shellsim-probe.{}", std::process::id()));
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => Err(bad(format!("cannot write in {}: {e}", d.display()))),
    }
}

/// Checks every output of a command before any work starts: a file output must not be a
/// directory, end in `/` or be a symlink loop, no name in a path may be longer than
/// [`NAME_MAX`] bytes, and a file's directory must be writable (or creatable); a directory
/// output must not be a file; no two outputs may name the same file (`-` counts as one
/// file). Existing file outputs are remembered, so that reading one of them as an input
/// afterwards is refused ([`check_input`]). Devices
/// and FIFOs are accepted as they are (several outputs may go to `/dev/null`). Errors are
/// `Error::Usage` naming the option (exit status 2). When an output is `-`, what the command
/// prints goes to standard error instead, so that standard output holds only that file.
pub fn check_outputs(outputs: &[Output]) -> Result<()> {
    let mut seen: Vec<(PathBuf, &Output)> = Vec::new();
    for o in outputs {
        let shown = crate::error::shown(&o.path.display().to_string());
        let usage = |what: &str| Error::Usage(format!("{} {shown}: {what}", o.option));
        if !is_stdout(&o.path) {
            check_path(o).map_err(|w| usage(&w))?;
        }
        if is_stdout(&o.path) {
            if o.dir {
                return Err(usage("a directory is needed here, not standard output"));
            }
            SUMMARY_TO_STDERR.store(true, Ordering::Relaxed);
        } else {
            let target = resolve(&o.path);
            match (kind(&target), o.dir) {
                (Kind::Directory, false) => {
                    return Err(usage("is a directory; name a file"));
                }
                (Kind::Directory, true) => check_writable(o, &target)?,
                (Kind::Stream, false) => continue,
                (Kind::Stream, true) | (Kind::File, true) if target.exists() => {
                    return Err(usage("is not a directory"));
                }
                (_, true) => check_writable(o, &target)?,
                (Kind::File, false) => check_writable(o, &parent_dir(&target))?,
            }
        }
        let id = if is_stdout(&o.path) {
            PathBuf::from("-")
        } else {
            identity(&resolve(&o.path))
        };
        if o.dir {
            continue;
        }
        if let Some((dev, ino)) = file_id(&o.path).filter(|_| !is_stdout(&o.path)) {
            OUTPUTS.lock().unwrap_or_else(|p| p.into_inner()).push((
                dev,
                ino,
                o.option.clone(),
                o.path.clone(),
            ));
        }
        if let Some((_, first)) = seen.iter().find(|(k, _)| *k == id) {
            return Err(Error::Usage(format!(
                "{} and {} name the same file ({shown}); give each output its own",
                first.option, o.option
            )));
        }
        seen.push((id, o));
    }
    Ok(())
}

/// The outputs [`check_outputs`] found existing: (device, inode, option, path as given), so
/// that an input read afterwards ([`check_input`]) that is one of them is refused.
static OUTPUTS: Mutex<Vec<(u64, u64, String, PathBuf)>> = Mutex::new(Vec::new());

/// (device, inode) of the file `path` names, through symlinks; `None` when it does not
/// exist (or cannot be reached).
fn file_id(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

/// Refuses to read `input` when it is the same file (same device and inode, through
/// symlinks and hard links) as an output [`check_outputs`] accepted: writing the output
/// would replace the input. Called by the capped reader (`limits::read_input`) on every
/// input, which commands read before their work starts. `Error::Usage` (exit status 2).
pub fn check_input(input: &Path) -> Result<()> {
    let Some(id) = file_id(input) else {
        return Ok(());
    };
    let outputs = OUTPUTS.lock().unwrap_or_else(|p| p.into_inner());
    for (dev, ino, option, path) in outputs.iter() {
        // Checked again, so that a file removed and its inode reused is not mistaken.
        if (*dev, *ino) == id && file_id(path) == Some(id) {
            return Err(Error::Usage(format!(
                "{option} {}: is the input {} (the same file); writing it would replace the input, name another output",
                crate::error::shown(&path.display().to_string()),
                crate::error::shown(&input.display().to_string())
            )));
        }
    }
    Ok(())
}

/// The most bytes of one name in a path (Linux's NAME_MAX).
pub const NAME_MAX: usize = 255;

/// ELOOP on Linux: too many levels of symbolic links.
const ELOOP: i32 = 40;

/// Refuses a path that cannot name an output file: a name in it longer than [`NAME_MAX`]
/// bytes, a trailing `/` on a file, a symlink loop (in the last name or on the way).
fn check_path(o: &Output) -> std::result::Result<(), String> {
    use std::os::unix::ffi::OsStrExt;
    let bytes = o.path.as_os_str().as_bytes();
    for c in o.path.components() {
        let n = c.as_os_str().len();
        if n > NAME_MAX {
            return Err(format!(
                "a name in it is {n} bytes long, more than the {NAME_MAX} a file system allows"
            ));
        }
    }
    if !o.dir && bytes.ends_with(b"/") {
        return Err("ends in `/`, which names a directory; name a file (drop the `/`)".into());
    }
    let looped = |e: &std::io::Error| e.raw_os_error() == Some(ELOOP);
    if let Err(e) = std::fs::metadata(&o.path) {
        if looped(&e) {
            return Err("is a loop of symbolic links; name a file".into());
        }
    }
    let target = resolve(&o.path);
    if std::fs::symlink_metadata(&target).is_ok_and(|m| m.file_type().is_symlink()) {
        return Err("is a loop of symbolic links (or a chain of more than 40); name a file".into());
    }
    Ok(())
}

/// Set when an output is standard output: the command's own lines go to standard error.
static SUMMARY_TO_STDERR: AtomicBool = AtomicBool::new(false);

/// The first failure to write standard output (a closed pipe, a full disk).
static STDOUT_ERROR: Mutex<Option<std::io::Error>> = Mutex::new(None);

/// Prints to standard output (or standard error, see [`check_outputs`]) without panicking:
/// the first failure is kept for [`stdout_result`] and later output is dropped.
pub fn print(args: std::fmt::Arguments) {
    if SUMMARY_TO_STDERR.load(Ordering::Relaxed) {
        let _ = std::io::stderr().write_fmt(args);
        return;
    }
    let mut err = STDOUT_ERROR.lock().unwrap_or_else(|p| p.into_inner());
    if err.is_none() {
        if let Err(e) = std::io::stdout().write_fmt(args) {
            *err = Some(e);
        }
    }
}

/// Flushes standard output; the first failure to write it, as an error on `<standard
/// output>` (exit status 1: the outputs were written, the printed summary was lost).
pub fn stdout_result() -> Result<()> {
    let mut err = STDOUT_ERROR.lock().unwrap_or_else(|p| p.into_inner());
    if err.is_none() {
        if let Err(e) = std::io::stdout().flush() {
            *err = Some(e);
        }
    }
    match err.take() {
        None => Ok(()),
        Some(e) => Err(Error::io(Path::new("<standard output>"), e)),
    }
}

/// `print!` through [`print`].
macro_rules! out {
    ($($t:tt)*) => { $crate::output::print(format_args!($($t)*)) };
}

/// `println!` through [`print`].
macro_rules! outln {
    () => { $crate::output::print(format_args!("\n")) };
    ($($t:tt)*) => { $crate::output::print(format_args!("{}\n", format_args!($($t)*))) };
}

#[allow(unused_imports)]
pub(crate) use {out, outln};

/// Installs the SIGINT/SIGTERM handler: it removes every temporary file still listed (a
/// VCD being streamed, a report not yet renamed into place), says so on standard error and
/// exits with 128 + the signal (130 for SIGINT, 143 for SIGTERM). Files already renamed
/// into place are complete; nothing is left under a final name half-written.
pub fn install_signal_handlers() {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(sig) = signals.forever().next() {
            // Held to the end: no file is persisted after this point.
            let list = temps();
            for t in list.iter() {
                let _ = std::fs::remove_file(t);
            }
            let name = if sig == SIGINT { "SIGINT" } else { "SIGTERM" };
            let _ = writeln!(
                std::io::stderr(),
                "interrupted ({name}): {} temporary file(s) removed, no output left incomplete",
                list.len()
            );
            std::process::exit(128 + sig);
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_stems_never_leave_the_directory() {
        assert_eq!(file_stem("scene2"), "scene2");
        assert_eq!(file_stem("../../etc/x"), "______etc_x");
        assert_eq!(file_stem(""), "scene");
        assert_eq!(file_stem("a\u{1b}[2Jb"), "a__2Jb");
    }

    #[test]
    fn a_symlink_resolves_to_its_target() {
        let d = tempfile::tempdir().unwrap();
        let t = d.path().join("t.json");
        std::os::unix::fs::symlink("t.json", d.path().join("l.json")).unwrap();
        assert_eq!(resolve(&d.path().join("l.json")), t);
        assert_eq!(resolve(&t), t);
    }

    #[test]
    fn one_file_named_twice_is_refused() {
        let d = tempfile::tempdir().unwrap();
        let a = d.path().join("a.json");
        let b = d.path().join("sub/../a.json");
        std::fs::create_dir(d.path().join("sub")).unwrap();
        let e = check_outputs(&[Output::file("--json", &a), Output::file("--svg", &b)]);
        assert!(
            matches!(&e, Err(Error::Usage(m)) if m.contains("--json and --svg")),
            "{e:?}"
        );
        let c = d.path().join("c.json");
        check_outputs(&[Output::file("--json", &a), Output::file("--svg", &c)]).unwrap();
    }
}
