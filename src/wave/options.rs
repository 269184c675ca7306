//! What a waveform writer is asked for: its format (from the path), a cycle window, a scope
//! filter, how an FST is packed and a size limit — passed in, no process-wide setting.
//!
//! A cycle window `[from, to]`: nothing outside it is written, but the values holding at
//! `from` are dumped in full (`$dumpvars`) so the window opens on a complete state. A scope
//! filter (a glob with `*`/`?`, or else a substring, on the full dotted scope): signals
//! outside it are not declared at all.

use std::path::Path;

/// The waveform's file format, from the path's extension: `.fst` is FST, anything else VCD.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WaveFormat {
    Vcd,
    /// FST (GTKWave's compressed format) through the `fst-writer` crate (fst.rs).
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

    /// The pattern as given.
    pub fn pattern(&self) -> &str {
        &self.pattern
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

/// What the writer is asked to keep, and how.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WaveOptions {
    pub window: Window,
    pub scope: Option<ScopeFilter>,
    /// How an FST's value changes are compressed (a VCD's are not).
    pub fst_pack: FstPack,
    /// The size limit of a VCD in bytes (`--wave-limit`): a writer whose file passes it
    /// stops the run and reports a usage error, leaving nothing behind.
    pub limit: u64,
}

impl Default for WaveOptions {
    fn default() -> Self {
        WaveOptions {
            window: Window::ALL,
            scope: None,
            fst_pack: FstPack::Zlib,
            limit: DEFAULT_WAVE_LIMIT,
        }
    }
}

/// The default size limit of a VCD: 2 GiB (a whole ratio-100 run is about 6.3 GB).
pub const DEFAULT_WAVE_LIMIT: u64 = 2 << 30;

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
}
