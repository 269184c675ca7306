//! Resource limits, stated and overridable: the largest input file read
//! ([`DEFAULT_MAX_INPUT`], 1 GiB; `SHELLSIM_MAX_INPUT`) and the most memory a job may plan
//! to use ([`DEFAULT_MAX_MEMORY`], 16 GiB, or half the machine's memory if less;
//! `SHELLSIM_MAX_MEMORY`; never past the process's RLIMIT_AS or its cgroup's limit). Inputs are read through [`read_input`], which stops one byte past
//! the limit, so `--scene /dev/zero` ends with an error instead of filling memory; a job
//! whose estimate ([`check_memory`]) is past the limit is refused before it allocates.
//! Values are bytes, with an optional `K`, `M`, `G` or `T` suffix (powers of 1024).

use crate::error::{Error, Result};
use std::io::Read;
use std::path::Path;

/// The largest input file read by default: 1 GiB.
pub const DEFAULT_MAX_INPUT: u64 = 1 << 30;

/// The most memory a job may plan to use by default: 16 GiB (or half the machine's memory,
/// if that is less).
pub const DEFAULT_MAX_MEMORY: u64 = 16 << 30;

/// The environment variable overriding [`DEFAULT_MAX_INPUT`].
pub const MAX_INPUT_VAR: &str = "SHELLSIM_MAX_INPUT";

/// The environment variable overriding [`DEFAULT_MAX_MEMORY`].
pub const MAX_MEMORY_VAR: &str = "SHELLSIM_MAX_MEMORY";

/// Parses `1073741824`, `512M`, `1G`.
pub fn parse_bytes(s: &str) -> Option<u64> {
    let s = s.trim();
    let (num, shift) = match s.chars().last()?.to_ascii_uppercase() {
        'K' => (&s[..s.len() - 1], 10),
        'M' => (&s[..s.len() - 1], 20),
        'G' => (&s[..s.len() - 1], 30),
        'T' => (&s[..s.len() - 1], 40),
        _ => (s, 0),
    };
    num.trim().parse::<u64>().ok()?.checked_mul(1u64 << shift)
}

/// A limit from `var`, or `default`; a value that does not parse is a usage error.
fn limit(var: &str, default: u64) -> Result<u64> {
    match std::env::var(var) {
        Ok(v) => parse_bytes(&v).ok_or_else(|| {
            Error::Usage(format!(
                "${var} = {:?}: not a byte count (e.g. 1073741824, 512M, 1G)",
                crate::error::shown(&v)
            ))
        }),
        Err(_) => Ok(default),
    }
}

/// The largest input file read.
pub fn max_input() -> Result<u64> {
    limit(MAX_INPUT_VAR, DEFAULT_MAX_INPUT)
}

/// Half of MemTotal from /proc/meminfo, if it can be read.
fn half_the_machine() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024 / 2)
}

/// The address-space limit (`ulimit -v`, RLIMIT_AS) from /proc/self/limits, if one is set.
fn address_space_limit() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?;
    // "Max address space   <soft>   <hard>   bytes": the soft limit binds.
    line.split_whitespace().nth(3)?.parse().ok()
}

/// The memory limit of this process's cgroup (v2 `memory.max`, or v1
/// `memory.limit_in_bytes`) — what a Slurm job or a container gets — if one is set.
fn cgroup_limit() -> Option<u64> {
    let cgroups = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let mut best: Option<u64> = None;
    for line in cgroups.lines() {
        // "0::/path" (v2) or "N:memory:/path" (v1).
        let mut parts = line.splitn(3, ':');
        let (_, controllers, path) = (parts.next()?, parts.next()?, parts.next()?);
        let file = if controllers.is_empty() {
            format!("/sys/fs/cgroup{path}/memory.max")
        } else if controllers.split(',').any(|c| c == "memory") {
            format!("/sys/fs/cgroup/memory{path}/memory.limit_in_bytes")
        } else {
            continue;
        };
        if let Some(v) = std::fs::read_to_string(file)
            .ok()
            .and_then(|t| t.trim().parse::<u64>().ok())
        {
            best = Some(best.map_or(v, |b| b.min(v)));
        }
    }
    best
}

/// The most memory a job may plan to use: `SHELLSIM_MAX_MEMORY`, else the smaller of
/// 16 GiB and half the machine's memory — and never more than the process's address-space
/// limit (RLIMIT_AS) or its cgroup's memory limit, whichever is smallest.
pub fn max_memory() -> Result<u64> {
    Ok(memory_limit()?.0)
}

/// [`max_memory`] and what would raise it.
fn memory_limit() -> Result<(u64, &'static str)> {
    let default = half_the_machine().map_or(DEFAULT_MAX_MEMORY, |h| h.min(DEFAULT_MAX_MEMORY));
    let mut best = (
        limit(MAX_MEMORY_VAR, default)?,
        "$SHELLSIM_MAX_MEMORY raises it",
    );
    for (l, what) in [
        (
            address_space_limit(),
            "the process's address-space limit, ulimit -v, binds",
        ),
        (
            cgroup_limit(),
            "the cgroup's memory limit (a Slurm job's or a container's) binds",
        ),
    ] {
        if let Some(l) = l.filter(|&l| l < best.0) {
            best = (l, what);
        }
    }
    Ok(best)
}

/// A byte count as people read it: `9.6 GB`, `512 kB`, `17 B`.
pub fn human(bytes: u64) -> String {
    let b = bytes as f64;
    match bytes {
        0..1_000 => format!("{bytes} B"),
        1_000..1_000_000 => format!("{:.1} kB", b / 1e3),
        1_000_000..1_000_000_000 => format!("{:.1} MB", b / 1e6),
        _ => format!("{:.1} GB", b / 1e9),
    }
}

/// Reads the input file `path`, at most [`max_input`] bytes: a longer one (or an endless
/// device) is bad input naming the limit and how to raise it. A file that is also one of
/// the command's outputs is refused first (`output::check_input`).
pub fn read_input(path: &Path) -> Result<Vec<u8>> {
    crate::output::check_input(path)?;
    read_capped(path)
}

/// [`read_input`] without the check against the outputs.
fn read_capped(path: &Path) -> Result<Vec<u8>> {
    let limit = max_input()?;
    let f = std::fs::File::open(path).map_err(|e| Error::unreadable(path, e))?;
    let mut bytes = Vec::new();
    f.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| Error::unreadable(path, e))?;
    if bytes.len() as u64 > limit {
        return Err(Error::input(
            path,
            "file",
            format!(
                "larger than the input limit of {limit} bytes ({}); set ${MAX_INPUT_VAR} to raise it",
                human(limit)
            ),
        ));
    }
    Ok(bytes)
}

/// [`read_input`] for a file that must be a regular file (a material library, a point file,
/// a matrix's summary): a FIFO, device or socket is refused before it is opened, so that a
/// FIFO with no writer cannot block the run.
pub fn read_regular(path: &Path) -> Result<Vec<u8>> {
    regular(path)?;
    read_input(path)
}

/// [`read_regular`] for a file shellsim wrote into an output directory and reads back to
/// resume or merge (explore's `spec.json`, point files, cached references): capped, a
/// regular file, but not refused for being in an output.
pub fn read_own(path: &Path) -> Result<Vec<u8>> {
    regular(path)?;
    read_capped(path)
}

/// Refuses `path` unless it is a regular file.
fn regular(path: &Path) -> Result<()> {
    let m = std::fs::metadata(path).map_err(|e| Error::unreadable(path, e))?;
    if !m.is_file() {
        let what = if m.is_dir() {
            "a directory"
        } else {
            "a FIFO, device or socket"
        };
        return Err(Error::input(
            path,
            "file",
            format!("is {what}, not a regular file"),
        ));
    }
    Ok(())
}

/// `bytes` as UTF-8 text, or unreadable input in `path`.
pub fn utf8(path: &Path, bytes: Vec<u8>) -> Result<String> {
    String::from_utf8(bytes).map_err(|_| {
        Error::unreadable(
            path,
            std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                "stream did not contain valid UTF-8",
            ),
        )
    })
}

/// [`read_input`] as UTF-8 text; text that is not UTF-8 is unreadable input.
pub fn read_input_string(path: &Path) -> Result<String> {
    utf8(path, read_input(path)?)
}

/// Refuses a job whose memory `estimate` (bytes) is past [`max_memory`]: `Error::Param`
/// on `key` (the flag or parameter that asked for it), the value first, then the estimate
/// and the limit.
pub fn check_memory(key: &str, value: &str, what: &str, estimate: u64) -> Result<()> {
    let (limit, raise) = memory_limit()?;
    if estimate > limit {
        return Err(Error::param(
            key,
            format!(
                "{value}: {what} would need about {} of memory, more than the limit of {} ({raise})",
                human(estimate),
                human(limit)
            ),
        ));
    }
    Ok(())
}

/// Refuses a machine whose state (estimated from its configuration) is past
/// [`max_memory`]: a usage error (exit status 2) with the estimate and the limit.
pub fn check_machine_memory(estimate: u64) -> Result<()> {
    let (limit, raise) = memory_limit()?;
    if estimate > limit {
        return Err(Error::Usage(format!(
            "the machine configuration (clusters × CTUs, ray buffer, patch buffer and request queue capacities) would need about {} of memory for its state, more than the limit of {} ({raise}); make the machine or its buffers smaller",
            human(estimate),
            human(limit)
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_counts_parse_with_suffixes() {
        assert_eq!(parse_bytes("1024"), Some(1024));
        assert_eq!(parse_bytes("512M"), Some(512 << 20));
        assert_eq!(parse_bytes("1g"), Some(1 << 30));
        assert_eq!(parse_bytes("x"), None);
        assert_eq!(parse_bytes("99999999999T"), None);
        assert_eq!(human(9_600_000_000), "9.6 GB");
    }
}
