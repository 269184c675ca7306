//! The sweep specification of `shellsim explore` (TOML): which scenes, sources, model levels
//! and configuration values to try, as lists or ranges, expanded into the ordered list of
//! design points. Every point's machine configuration goes through the one configuration
//! parser (`config::parse`, hence `MachineConfig::from_toml_str`), so a value the machine
//! cannot take is refused exactly as in a `--hw` file; errors name the spec file, the line
//! and the key.
//!
//! The format (docs/manual/explore.md):
//!
//! ```toml
//! title = "scene2, bits against clusters"   # optional, heads the report
//! base = "paper"           # the configuration every point starts from: a name or a .toml file
//! reference_rays = 200000  # optional: rays of the high-ray float reference
//! timing = "auto"          # optional: the machine's timing level, cycle (default), queue or auto
//! auto_margin = 0.10       # optional (auto): the queue level's assumed relative error at first
//! auto_check = 0.10        # optional (auto): the share of machine points also run at the cycle level
//! scene = "../../scenes/scene2.json"        # paths relative to this file
//! level = ["fixed", "machine"]
//! ratio = { from = 1, to = 3 }              # a range: from, to (inclusive), step (default 1)
//! datapath.frac_bits = [8, 12, 16]          # any datapath.*, machine.*, balance.* key
//!
//! [[sweep]]                # optional: each block is one product, over the keys above
//! machine.clusters = [1, 2]  # (a key given here replaces the top-level one)
//! ```
//!
//! Keys besides the configuration's: `scene`, `source` (an id or a name; default 0), `level` (`float`,
//! `fixed`, `machine`; default `machine`), `ratio` (969 × ratio rays, default 1) or `rays`,
//! `directions` (`rings`, `malley`, `random`), `seed` (default 1), `cell`
//! (`machine.cell_size`), `shell_radius` (`machine.shell_radius`), `frac_bits` (both
//! `datapath.frac_bits` and `datapath.t_frac_bits`). The points are the cartesian product of
//! the lists in the order the keys are written (the first varies slowest), block by block;
//! `[[point]]` blocks are single points (every value a scalar). A knob a point's level does
//! not read (the float model reads only the rays and the grid, the fixed-point model also
//! the datapath) is left out of that point, so it does not multiply the point.
//!
//! `timing` times every machine point with the cycle model (`cycle`), with the queueing
//! network over the untimed model's results (`queue`, `shellsim run --level queue`), or
//! (`auto`) with the network first and the cycle model only where a point may reach the
//! front of error against cycles ([`crate::explore::auto`]).

use crate::config::{self, ConfigSource};
use crate::error::{Error, Result};
use crate::paper::PAPER_RAYS;
use crate::radiosity::matrix::{self, MatrixSpec, Model};
use crate::reference::rays::Directions;
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use shellsim_hw::config::MachineConfig;
use std::path::{Path, PathBuf};

/// The most points a spec may expand to.
pub const MAX_POINTS: usize = 1_000_000;

/// The most ratio a point may ask for (as `shellsim size`).
pub const MAX_RATIO: usize = 100;

/// One value of a knob.
#[derive(Clone, Debug, PartialEq)]
pub enum Val {
    Int(i64),
    Float(f64),
    Str(String),
    Bool(bool),
}

impl std::fmt::Display for Val {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Val::Int(v) => write!(f, "{v}"),
            Val::Float(v) => write!(f, "{}", crate::error::short(*v)),
            Val::Str(v) => write!(f, "{v}"),
            Val::Bool(v) => write!(f, "{v}"),
        }
    }
}

/// A key of the spec with its values, where it is written.
#[derive(Clone, Debug)]
struct Entry {
    key: String,
    line: usize,
    values: Vec<Val>,
}

/// A knob's value in one point, as the report names it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Knob {
    pub key: String,
    pub value: String,
}

/// An axis of the study: a key and every value it takes, in first-seen order.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Axis {
    pub key: String,
    pub values: Vec<String>,
}

/// One design point.
#[derive(Clone, Debug)]
pub struct Point {
    /// Its place in the spec's order.
    pub index: usize,
    /// Into [`Spec::scenes`].
    pub scene: usize,
    pub source: u32,
    pub level: Model,
    pub rays: usize,
    pub directions: Directions,
    pub seed: u64,
    /// The configuration (lengths may still be `auto`), validated.
    pub config: MachineConfig,
    /// Every key the spec gives this point, in the spec's order.
    pub knobs: Vec<Knob>,
}

impl Point {
    /// What the matrix code casts for this point on `model`.
    pub fn matrix_spec(&self, model: Model) -> MatrixSpec {
        MatrixSpec {
            model,
            rays: self.rays,
            directions: self.directions,
            seed: self.seed,
            sources: self.source..self.source + 1,
        }
    }

    /// `key=value` pairs joined by `;`.
    pub fn label(&self) -> String {
        knobs_label(&self.knobs)
    }
}

/// `key=value` pairs joined by `;`.
pub fn knobs_label(knobs: &[Knob]) -> String {
    knobs
        .iter()
        .map(|k| format!("{}={}", k.key, k.value))
        .collect::<Vec<_>>()
        .join(";")
}

/// A scene of the spec.
pub struct SpecScene {
    /// As written in the spec.
    pub written: String,
    /// Resolved against the spec's directory.
    pub path: PathBuf,
    pub scene: Scene,
    /// FNV-1a of the file's bytes (part of the spec's hash).
    pub bytes_hash: u64,
}

/// The timing level of a spec's machine points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Timing {
    /// The cycle-level machine.
    Cycle,
    /// The queueing network over the CTUs' walks (results from the untimed model).
    Queue,
    /// The network first; the cycle model for the points that may reach the front.
    Auto,
}

impl Timing {
    pub fn name(self) -> &'static str {
        match self {
            Timing::Cycle => "cycle",
            Timing::Queue => "queue",
            Timing::Auto => "auto",
        }
    }
}

/// The queue level's relative error `auto` assumes before it has measured any: the largest
/// over the paper's 76 machines (9.8 %, docs/paper/levels.csv), rounded up.
pub const AUTO_MARGIN: f64 = 0.10;

/// The share of machine points `auto` runs at both levels whatever the screen says, so that
/// the margin is measured on points the screen did not choose too.
pub const AUTO_CHECK: f64 = 0.10;

/// A parsed, expanded, validated spec.
pub struct Spec {
    pub file: PathBuf,
    pub title: String,
    pub scenes: Vec<SpecScene>,
    pub points: Vec<Point>,
    pub axes: Vec<Axis>,
    /// Rays of the float reference, when the spec sets them.
    pub reference_rays: Option<usize>,
    /// The machine points' timing level, and `auto`'s first margin.
    pub timing: Timing,
    pub auto_margin: f64,
    pub auto_check: f64,
    /// A hash of everything the results depend on (the points, their configurations, the
    /// scenes' bytes, the reference): shards of one spec carry the same.
    pub hash: String,
}

/// Keys only the top level may hold.
const TOP_ONLY: [&str; 6] = [
    "title",
    "base",
    "reference_rays",
    "timing",
    "auto_margin",
    "auto_check",
];

/// The knobs a point takes besides the configuration's tables.
const POINT_KEYS: [&str; 10] = [
    "scene",
    "source",
    "level",
    "ratio",
    "rays",
    "directions",
    "seed",
    "cell",
    "shell_radius",
    "frac_bits",
];

/// The configuration's tables a key may name (`datapath.frac_bits`).
const TABLES: [&str; 3] = ["datapath", "machine", "balance"];

/// "line L" of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    text.as_bytes()[..at.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// A scalar TOML value as a [`Val`].
fn scalar(v: &toml_edit::Value) -> Option<Val> {
    use toml_edit::Value as V;
    Some(match v {
        V::Integer(i) => Val::Int(*i.value()),
        V::Float(f) => Val::Float(*f.value()),
        V::String(s) => Val::Str(s.value().clone()),
        V::Boolean(b) => Val::Bool(*b.value()),
        _ => return None,
    })
}

/// The parser's state: the file and its text, for errors.
struct Parser<'a> {
    file: &'a Path,
    text: &'a str,
}

impl Parser<'_> {
    fn err(&self, line: usize, key: &str, what: impl Into<String>) -> Error {
        Error::input(self.file, format!("line {line}: {key}"), what)
    }

    /// The values of `key = value` (a scalar, a nonempty list of scalars, or a range).
    fn values(
        &self,
        key: &str,
        line: usize,
        v: &toml_edit::Value,
        single: bool,
    ) -> Result<Vec<Val>> {
        use toml_edit::Value as V;
        let vals = match v {
            V::Array(a) => {
                if a.is_empty() {
                    return Err(self.err(line, key, "an empty list: give at least one value"));
                }
                a.iter()
                    .map(|x| {
                        scalar(x).ok_or_else(|| {
                            self.err(
                                line,
                                key,
                                "a list may hold only numbers, strings or booleans",
                            )
                        })
                    })
                    .collect::<Result<Vec<_>>>()?
            }
            V::InlineTable(t) => self.range(key, line, t)?,
            x => vec![scalar(x).ok_or_else(|| self.err(line, key, "not a value"))?],
        };
        if single && vals.len() != 1 {
            return Err(self.err(
                line,
                key,
                "a [[point]] takes one value per key, not a list or range",
            ));
        }
        Ok(vals)
    }

    /// `{ from = A, to = B, step = S }`: A, A+S, … up to B inclusive.
    fn range(&self, key: &str, line: usize, t: &toml_edit::InlineTable) -> Result<Vec<Val>> {
        for (k, _) in t.iter() {
            if !["from", "to", "step"].contains(&k) {
                return Err(self.err(
                    line,
                    key,
                    format!("unknown range key `{k}`: a range is {{ from = A, to = B, step = S }}"),
                ));
            }
        }
        let get = |k: &str| -> Result<Option<Val>> {
            match t.get(k) {
                None => Ok(None),
                Some(v) => match scalar(v) {
                    Some(x @ (Val::Int(_) | Val::Float(_))) => Ok(Some(x)),
                    _ => Err(self.err(line, key, format!("range `{k}` is not a number"))),
                },
            }
        };
        let (Some(from), Some(to)) = (get("from")?, get("to")?) else {
            return Err(self.err(line, key, "a range needs `from` and `to`"));
        };
        let step = get("step")?.unwrap_or(Val::Int(1));
        let empty = |a: String, b: String| {
            self.err(
                line,
                key,
                format!("an empty range: from {a} is above to {b}"),
            )
        };
        const MAX_VALUES: u64 = 100_000;
        match (from, to, step) {
            (Val::Int(a), Val::Int(b), Val::Int(s)) => {
                if s <= 0 {
                    return Err(self.err(line, key, format!("range step {s} is not positive")));
                }
                if a > b {
                    return Err(empty(a.to_string(), b.to_string()));
                }
                let n = (b as i128 - a as i128) / s as i128 + 1;
                if n > MAX_VALUES as i128 {
                    return Err(self.err(
                        line,
                        key,
                        format!("a range of {n} values (at most {MAX_VALUES})"),
                    ));
                }
                // Each value lies in a..=b, so it fits; the product may not fit i64.
                Ok((0..n)
                    .map(|i| Val::Int((a as i128 + i * s as i128) as i64))
                    .collect())
            }
            (a, b, s) => {
                let f = |v: &Val| match v {
                    Val::Int(i) => *i as f64,
                    Val::Float(x) => *x,
                    _ => f64::NAN,
                };
                let (a, b, s) = (f(&a), f(&b), f(&s));
                if !(a.is_finite() && b.is_finite() && s.is_finite()) {
                    return Err(self.err(line, key, "a range's numbers must be finite"));
                }
                if s <= 0.0 {
                    return Err(self.err(line, key, format!("range step {s} is not positive")));
                }
                if a > b {
                    return Err(empty(a.to_string(), b.to_string()));
                }
                let n = ((b - a) / s + 1e-9).floor() + 1.0;
                if n > MAX_VALUES as f64 {
                    return Err(self.err(
                        line,
                        key,
                        format!("a range of {n} values (at most {MAX_VALUES})"),
                    ));
                }
                Ok((0..n as u64)
                    .map(|i| Val::Float(a + i as f64 * s))
                    .collect())
            }
        }
    }

    /// The entries of one table (the top level or a block), dotted configuration keys
    /// flattened; `top` allows the top-only keys.
    fn entries(
        &self,
        t: &toml_edit::Table,
        top: bool,
        single: bool,
        out: &mut Vec<Entry>,
        other: &mut Vec<(String, usize, toml_edit::Item)>,
    ) -> Result<()> {
        for (k, item) in t.iter() {
            let line = t
                .key(k)
                .and_then(|key| key.span())
                .map_or(0, |s| line_of(self.text, s.start));
            if TABLES.contains(&k) {
                let sub: Vec<(String, usize, &toml_edit::Value)> = match item {
                    toml_edit::Item::Table(st) => st
                        .iter()
                        .map(|(sk, si)| {
                            let l = st
                                .key(sk)
                                .and_then(|key| key.span())
                                .map_or(line, |s| line_of(self.text, s.start));
                            si.as_value()
                                .map(|v| (sk.to_string(), l, v))
                                .ok_or_else(|| self.err(l, &format!("{k}.{sk}"), "not a value"))
                        })
                        .collect::<Result<_>>()?,
                    toml_edit::Item::Value(toml_edit::Value::InlineTable(it)) => {
                        it.iter().map(|(sk, v)| (sk.to_string(), line, v)).collect()
                    }
                    _ => {
                        return Err(self.err(
                            line,
                            k,
                            format!("`{k}` is a table of configuration keys ({k}.KEY = …)"),
                        ))
                    }
                };
                for (sk, l, v) in sub {
                    let key = format!("{k}.{sk}");
                    let values = self.values(&key, l, v, single)?;
                    out.push(Entry {
                        key,
                        line: l,
                        values,
                    });
                }
                continue;
            }
            if matches!(k, "sweep" | "point") && top {
                other.push((k.to_string(), line, item.clone()));
                continue;
            }
            if TOP_ONLY.contains(&k) && !top {
                return Err(self.err(line, k, "may be given only at the top of the spec"));
            }
            if !TOP_ONLY.contains(&k) && !POINT_KEYS.contains(&k) {
                return Err(self.err(
                    line,
                    k,
                    format!(
                        "unknown key; a spec's keys are {}, {}, datapath.*, machine.*, balance.* and [[sweep]] / [[point]] blocks",
                        TOP_ONLY.join(", "),
                        POINT_KEYS.join(", ")
                    ),
                ));
            }
            let v = item
                .as_value()
                .ok_or_else(|| self.err(line, k, "not a value (a table here?)"))?;
            let values = self.values(k, line, v, single)?;
            out.push(Entry {
                key: k.to_string(),
                line,
                values,
            });
        }
        Ok(())
    }
}

/// The one value a top-only key holds.
fn top_value<'e>(entries: &'e [Entry], key: &str) -> Option<&'e Entry> {
    entries.iter().find(|e| e.key == key)
}

/// Parses and expands the spec `file`.
pub fn load(file: &Path) -> Result<Spec> {
    let text = crate::limits::read_input_string(file)?;
    parse(&text, file)
}

/// Parses and expands a spec's `text` (named `file`; scene and configuration paths are
/// relative to its directory).
pub fn parse(text: &str, file: &Path) -> Result<Spec> {
    let p = Parser { file, text };
    let doc = toml_edit::ImDocument::parse(text).map_err(|e| {
        let place = e.span().map_or_else(
            || "toml".to_string(),
            |s| format!("line {}", line_of(text, s.start)),
        );
        Error::input(file, place, e.message().trim().to_string())
    })?;
    let mut top = Vec::new();
    let mut blocks = Vec::new();
    p.entries(doc.as_table(), true, false, &mut top, &mut blocks)?;
    let dir = file.parent().unwrap_or(Path::new(".")).to_path_buf();
    // Top-only keys.
    let one = |key: &str| -> Result<Option<(Val, usize)>> {
        match top_value(&top, key) {
            None => Ok(None),
            Some(e) if e.values.len() == 1 => Ok(Some((e.values[0].clone(), e.line))),
            Some(e) => Err(p.err(e.line, key, "takes one value, not a list")),
        }
    };
    let title = match one("title")? {
        None => file
            .file_stem()
            .map_or("explore".into(), |s| s.to_string_lossy().into_owned()),
        Some((Val::Str(s), _)) => s,
        Some((_, l)) => return Err(p.err(l, "title", "is not a string")),
    };
    let base = match one("base")? {
        None => *config::built_in(),
        Some((Val::Str(s), l)) => {
            let src = if s.ends_with(".toml") || s.contains('/') {
                ConfigSource::File(dir.join(&s))
            } else {
                ConfigSource::Named(s)
            };
            config::load(&src).map_err(|e| match e {
                Error::Input {
                    file: f,
                    place,
                    what,
                } => p.err(l, "base", format!("{}: {place}: {what}", f.display())),
                e => e,
            })?
        }
        Some((_, l)) => return Err(p.err(l, "base", "is not a configuration name or file")),
    };
    let reference_rays = match one("reference_rays")? {
        None => None,
        Some((Val::Int(n), l)) => {
            let max = crate::reference::rays::MAX_RAYS as i64;
            if !(1..=max).contains(&n) {
                return Err(p.err(
                    l,
                    "reference_rays",
                    format!("{n} is out of range (1..={max})"),
                ));
            }
            Some(n as usize)
        }
        Some((_, l)) => return Err(p.err(l, "reference_rays", "is not a ray count")),
    };
    let timing = match one("timing")? {
        None => Timing::Cycle,
        Some((Val::Str(s), l)) => match s.as_str() {
            "cycle" => Timing::Cycle,
            "queue" => Timing::Queue,
            "auto" => Timing::Auto,
            _ => {
                return Err(p.err(
                    l,
                    "timing",
                    format!("{s:?} is not a timing level (cycle, queue or auto)"),
                ))
            }
        },
        Some((_, l)) => return Err(p.err(l, "timing", "is not a string (cycle, queue or auto)")),
    };
    let auto_margin = match one("auto_margin")? {
        None => AUTO_MARGIN,
        Some((Val::Float(m), l)) => {
            if !(m > 0.0 && m < 1.0) {
                return Err(p.err(l, "auto_margin", format!("{m} is not in (0, 1)")));
            }
            if timing != Timing::Auto {
                return Err(p.err(l, "auto_margin", "is read only with timing = \"auto\""));
            }
            m
        }
        Some((_, l)) => {
            return Err(p.err(
                l,
                "auto_margin",
                "is not a relative error (a number in (0, 1))",
            ))
        }
    };
    let auto_check = match one("auto_check")? {
        None => AUTO_CHECK,
        Some((v @ (Val::Float(_) | Val::Int(_)), l)) => {
            let c = match v {
                Val::Float(c) => c,
                Val::Int(i) => i as f64,
                _ => unreachable!("matched above"),
            };
            if !(0.0..=1.0).contains(&c) {
                return Err(p.err(l, "auto_check", format!("{c} is not in [0, 1]")));
            }
            if timing != Timing::Auto {
                return Err(p.err(l, "auto_check", "is read only with timing = \"auto\""));
            }
            c
        }
        Some((_, l)) => {
            return Err(p.err(
                l,
                "auto_check",
                "is not a share of the machine points (a number in [0, 1])",
            ))
        }
    };
    top.retain(|e| !TOP_ONLY.contains(&e.key.as_str()));
    // The products: the top level alone, or one per block.
    let mut products: Vec<Vec<Entry>> = Vec::new();
    for (kind, line, item) in &blocks {
        let tables: Vec<&toml_edit::Table> = match item {
            toml_edit::Item::ArrayOfTables(a) => a.iter().collect(),
            _ => return Err(p.err(*line, kind, format!("write [[{kind}]] blocks"))),
        };
        for t in tables {
            let mut own = Vec::new();
            p.entries(t, false, kind == "point", &mut own, &mut Vec::new())?;
            let mut axes = top.clone();
            for e in own {
                match axes.iter_mut().find(|a| a.key == e.key) {
                    Some(a) => *a = e,
                    None => axes.push(e),
                }
            }
            products.push(axes);
        }
    }
    if blocks.is_empty() {
        products.push(top.clone());
    }
    let total: usize = products
        .iter()
        .map(|es| es.iter().map(|e| e.values.len()).product::<usize>())
        .sum();
    if total > MAX_POINTS {
        return Err(Error::input(
            file,
            "points",
            format!("the spec expands to {total} points (at most {MAX_POINTS})"),
        ));
    }
    let mut b = Builder {
        p: &p,
        dir: &dir,
        base,
        scenes: Vec::new(),
        points: Vec::new(),
        axes: Vec::new(),
        seen: std::collections::HashSet::new(),
    };
    for es in &products {
        if !es.iter().any(|e| e.key == "scene") {
            return Err(Error::input(
                file,
                "scene",
                "missing: name at least one scene file (scene = \"…\")",
            ));
        }
        let mut pick = vec![0usize; es.len()];
        loop {
            let chosen: Vec<(&Entry, &Val)> = es
                .iter()
                .zip(&pick)
                .map(|(e, &i)| (e, &e.values[i]))
                .collect();
            b.point(&chosen)?;
            // Odometer: the last key varies fastest.
            let mut k = es.len();
            loop {
                if k == 0 {
                    break;
                }
                k -= 1;
                pick[k] += 1;
                if pick[k] < es[k].values.len() {
                    break;
                }
                pick[k] = 0;
            }
            if pick.iter().all(|&i| i == 0) {
                break;
            }
        }
    }
    // The axes: every key's values in first-seen order (a set per axis: linear in the
    // points, where a search of the list was quadratic in a long list of values).
    let mut seen: Vec<std::collections::HashSet<String>> = Vec::new();
    for pt in &b.points {
        for k in &pt.knobs {
            let i = match b.axes.iter().position(|a| a.key == k.key) {
                Some(i) => i,
                None => {
                    b.axes.push(Axis {
                        key: k.key.clone(),
                        values: Vec::new(),
                    });
                    seen.push(Default::default());
                    b.axes.len() - 1
                }
            };
            if seen[i].insert(k.value.clone()) {
                b.axes[i].values.push(k.value.clone());
            }
        }
    }
    let mut spec = Spec {
        file: file.to_path_buf(),
        title,
        scenes: b.scenes,
        points: b.points,
        axes: b.axes,
        reference_rays,
        timing,
        auto_margin,
        auto_check,
        hash: String::new(),
    };
    spec.hash = spec_hash(&spec);
    Ok(spec)
}

impl Spec {
    /// The spec timed at level `t` instead of its own (`explore run --timing`), its hash
    /// recomputed.
    pub fn with_timing(mut self, t: Timing) -> Spec {
        self.timing = t;
        self.hash = spec_hash(&self);
        self
    }
}

/// Builds points from chosen values.
struct Builder<'a> {
    p: &'a Parser<'a>,
    dir: &'a Path,
    base: MachineConfig,
    scenes: Vec<SpecScene>,
    points: Vec<Point>,
    axes: Vec<Axis>,
    /// The points made so far, by what they run: a knob the point's level does not read
    /// does not make another point.
    seen: std::collections::HashSet<String>,
}

/// Whether a point of `level` reads knob `key`: the float model reads the rays and the
/// grid, the fixed-point model also the datapath, the machine everything.
fn reads(level: Model, key: &str) -> bool {
    match key {
        "scene" | "source" | "level" | "ratio" | "rays" | "directions" | "seed" | "cell"
        | "machine.cell_size" => true,
        k if k == "frac_bits" || k.starts_with("datapath.") => level != Model::Float,
        _ => level == Model::Machine,
    }
}

impl Builder<'_> {
    fn point(&mut self, chosen: &[(&Entry, &Val)]) -> Result<()> {
        let p = self.p;
        let index = self.points.len();
        let int = |e: &Entry, v: &Val, lo: i64, hi: i64| -> Result<i64> {
            match v {
                Val::Int(i) if (lo..=hi).contains(i) => Ok(*i),
                Val::Int(i) => {
                    Err(p.err(e.line, &e.key, format!("{i} is out of range ({lo}..={hi})")))
                }
                x => Err(p.err(e.line, &e.key, format!("{x} is not an integer"))),
            }
        };
        let string = |e: &Entry, v: &Val| -> Result<String> {
            match v {
                Val::Str(s) => Ok(s.clone()),
                x => Err(p.err(e.line, &e.key, format!("{x} is not a string"))),
            }
        };
        let (mut scene, mut source, mut level) = (None, None::<(&Entry, &Val)>, Model::Machine);
        // The level first: a knob it does not read is left out of the point.
        let reads_level = chosen
            .iter()
            .find(|(e, _)| e.key == "level")
            .and_then(|(_, v)| match v {
                Val::Str(s) => Model::parse(s),
                _ => None,
            })
            .unwrap_or(Model::Machine);
        let (mut ratio, mut rays) = (None::<(usize, &Entry)>, None::<(usize, &Entry)>);
        let (mut directions, mut seed) = (Directions::Rings, 1u64);
        let mut table = toml::Value::try_from(self.base).expect("a configuration serializes");
        let mut set_keys: Vec<(&Entry, Vec<String>)> = Vec::new();
        for &(e, v) in chosen {
            match e.key.as_str() {
                "scene" => {
                    let w = string(e, v)?;
                    let i = match self.scenes.iter().position(|s| s.written == w) {
                        Some(i) => i,
                        None => {
                            let path = self.dir.join(&w);
                            // An error in the scene names the spec's line and the scene file.
                            let in_scene = |err: Error| match err {
                                Error::Input { file, place, what } => p.err(
                                    e.line,
                                    "scene",
                                    format!("{}: {place}: {what}", file.display()),
                                ),
                                err => err,
                            };
                            let s = Scene::load(&path).map_err(in_scene)?;
                            let bytes = crate::limits::read_input(&path).map_err(in_scene)?;
                            let bytes_hash = fnv1a(&bytes, FNV_START);
                            self.scenes.push(SpecScene {
                                written: w,
                                path,
                                scene: s,
                                bytes_hash,
                            });
                            self.scenes.len() - 1
                        }
                    };
                    scene = Some((i, e));
                }
                "source" => source = Some((e, v)),
                "level" => {
                    let s = string(e, v)?;
                    level = Model::parse(&s).ok_or_else(|| {
                        p.err(
                            e.line,
                            &e.key,
                            format!("{s:?} is not a model level (float, fixed or machine)"),
                        )
                    })?;
                }
                "ratio" => ratio = Some((int(e, v, 1, MAX_RATIO as i64)? as usize, e)),
                "rays" => {
                    rays = Some((
                        int(e, v, 1, crate::reference::rays::MAX_RAYS as i64)? as usize,
                        e,
                    ))
                }
                "directions" => {
                    let s = string(e, v)?;
                    directions = clap::ValueEnum::from_str(&s, false).map_err(|_| {
                        p.err(
                            e.line,
                            &e.key,
                            format!("{s:?} is not a ray set (rings, malley or random)"),
                        )
                    })?;
                }
                "seed" => seed = int(e, v, 0, i64::MAX)? as u64,
                key if !reads(reads_level, key) => {}
                key => {
                    let targets: Vec<String> = match key {
                        "cell" => vec!["machine.cell_size".into()],
                        "shell_radius" => vec!["machine.shell_radius".into()],
                        "frac_bits" => {
                            vec!["datapath.frac_bits".into(), "datapath.t_frac_bits".into()]
                        }
                        k => vec![k.to_string()],
                    };
                    for t in &targets {
                        set_value(p, &mut table, e, t, v)?;
                    }
                    set_keys.push((e, targets));
                }
            }
        }
        let (scene, scene_entry) = scene.expect("checked: every product has a scene");
        // A source by id or by name (a group, object or material naming one patch).
        let source = match source {
            None => 0,
            Some((e, Val::Str(name))) => {
                let sc = &self.scenes[scene];
                crate::scene::PatchRef::Name(name.clone())
                    .resolve(&sc.scene, &sc.path)
                    .map_err(|err| {
                        let what = match err {
                            Error::Input { what, .. } | Error::Param { what, .. } => what,
                            err => err.to_string(),
                        };
                        p.err(e.line, &e.key, what)
                    })?
            }
            Some((e, v)) => int(e, v, 0, u32::MAX as i64)? as u32,
        };
        let rays = match (ratio, rays) {
            (Some(_), Some((_, e))) => {
                return Err(p.err(e.line, "rays", "give rays or ratio, not both"))
            }
            (_, Some((n, _))) => n,
            (Some((r, _)), None) => r * PAPER_RAYS,
            (None, None) => PAPER_RAYS,
        };
        // A scene is named by its name, not by the path the spec gives.
        let knobs: Vec<Knob> = chosen
            .iter()
            .filter(|(e, _)| reads(level, &e.key))
            .map(|(e, v)| Knob {
                key: e.key.clone(),
                value: if e.key == "scene" {
                    self.scenes[scene].scene.name.clone()
                } else {
                    v.to_string()
                },
            })
            .collect();
        let label = knobs_label(&knobs);
        // The configuration through the one parser; an error is placed at the key it names.
        let named = |place: &str, what: String| -> Error {
            match set_keys
                .iter()
                .find(|(_, ts)| ts.iter().any(|t| t == place))
            {
                Some((e, _)) => p.err(e.line, &e.key, what),
                None => Error::input(p.file, format!("point {index} ({label}): {place}"), what),
            }
        };
        let text = toml::to_string(&table).expect("a table serializes");
        let config = match config::parse(&text, p.file) {
            Ok(c) => c,
            Err(Error::Input { place, what, .. }) if place.starts_with("line ") => {
                // A type error: find the key that makes it.
                for (e, ts) in &set_keys {
                    let mut alone = toml::Value::try_from(self.base).expect("serializes");
                    for t in ts {
                        let v = chosen
                            .iter()
                            .find(|(c, _)| std::ptr::eq(*c, *e))
                            .map(|c| c.1)
                            .expect("chosen");
                        set_value(p, &mut alone, e, t, v)?;
                    }
                    if let Err(Error::Input {
                        place: pl, what: w, ..
                    }) = config::parse(&toml::to_string(&alone).expect("serializes"), p.file)
                    {
                        if pl.starts_with("line ") {
                            return Err(p.err(e.line, &e.key, w));
                        }
                    }
                }
                return Err(Error::input(
                    p.file,
                    format!("point {index} ({label})"),
                    what,
                ));
            }
            Err(Error::Input { place, what, .. }) => return Err(named(&place, what)),
            Err(e) => return Err(e),
        };
        let sc = &self.scenes[scene];
        if let Err(e) = config::resolve(&config, sc.scene.size()) {
            return Err(match e {
                Error::Input { place, what, .. } => named(&place, what),
                e => e,
            });
        }
        let pt = Point {
            index,
            scene,
            source,
            level,
            rays,
            directions,
            seed,
            config,
            knobs,
        };
        let checked =
            crate::reference::rays::check_source_and_rays(&sc.scene, &sc.path, source, rays)
                .and_then(|_| matrix::validate(&pt.matrix_spec(level), &sc.scene, &sc.path));
        if let Err(e) = checked {
            let what = match e {
                Error::Input { what, .. } | Error::Param { what, .. } => what,
                e => e.to_string(),
            };
            let line = chosen
                .iter()
                .find(|(e, _)| ["source", "rays", "ratio"].contains(&e.key.as_str()))
                .map_or(scene_entry.line, |(e, _)| e.line);
            return Err(Error::input(
                p.file,
                format!("line {line}: point {index} ({label})"),
                what,
            ));
        }
        let what = format!(
            "{scene}|{source}|{}|{rays}|{directions:?}|{seed}|{}",
            level.name(),
            pt.label()
        );
        if self.seen.insert(what) {
            self.points.push(pt);
        }
        Ok(())
    }
}

/// Sets configuration key `key` (`table.name`) of `table` to `v`; the key must exist in the
/// base configuration and `v` must have its type (a number for a length).
fn set_value(p: &Parser, table: &mut toml::Value, e: &Entry, key: &str, v: &Val) -> Result<()> {
    let (t, k) = key
        .split_once('.')
        .expect("a configuration key is table.key");
    let tab = table
        .get_mut(t)
        .and_then(|x| x.as_table_mut())
        .expect("the configuration's tables serialize");
    let Some(old) = tab.get(k) else {
        let mut known: Vec<&str> = tab.keys().map(|s| s.as_str()).collect();
        known.sort();
        return Err(p.err(
            e.line,
            &e.key,
            format!("unknown key; the {t} table's keys are {}", known.join(", ")),
        ));
    };
    let length = matches!(key, "machine.cell_size" | "machine.shell_radius");
    let new = match (old, v) {
        (toml::Value::Integer(_), Val::Int(i)) => toml::Value::Integer(*i),
        (toml::Value::Float(_), Val::Int(i)) => toml::Value::Float(*i as f64),
        (toml::Value::Float(_), Val::Float(f)) => toml::Value::Float(*f),
        (toml::Value::String(_), Val::Str(s)) => toml::Value::String(s.clone()),
        (toml::Value::Boolean(_), Val::Bool(b)) => toml::Value::Boolean(*b),
        (_, Val::Float(f)) if length => toml::Value::Float(*f),
        (_, Val::Int(i)) if length => toml::Value::Float(*i as f64),
        (_, Val::Str(s)) if length => toml::Value::String(s.clone()),
        (o, v) => {
            return Err(p.err(
                e.line,
                &e.key,
                format!(
                    "{v} is not {}",
                    match o {
                        toml::Value::Integer(_) => "an integer",
                        toml::Value::Float(_) => "a number",
                        toml::Value::Boolean(_) => "true or false",
                        toml::Value::String(_) => "a string",
                        _ => "a value of this key's type",
                    }
                ),
            ))
        }
    };
    if let (Val::Float(f), true) = (v, length) {
        if !f.is_finite() {
            return Err(p.err(e.line, &e.key, format!("{f} is not a finite length")));
        }
    }
    tab.insert(k.to_string(), new);
    Ok(())
}

/// FNV-1a, 64 bits: a stable hash (the standard library's may change between releases).
pub fn fnv1a(bytes: &[u8], mut h: u64) -> u64 {
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x100_0000_01b3);
    }
    h
}

/// The FNV-1a offset basis.
pub const FNV_START: u64 = 0xcbf2_9ce4_8422_2325;

/// The spec's hash: its points (levels, rays, configurations, knobs), the scenes' names
/// and bytes, the reference's ray count and, unless it is the cycle level, the timing.
fn spec_hash(spec: &Spec) -> String {
    let mut h = fnv1a(b"shellsim explore 1\n", FNV_START);
    for s in &spec.scenes {
        h = fnv1a(s.scene.name.as_bytes(), h);
        h = fnv1a(&s.bytes_hash.to_le_bytes(), h);
    }
    for pt in &spec.points {
        let line = format!(
            "{} {} {} {} {} {:?} {} {}\n",
            pt.index,
            pt.scene,
            pt.source,
            pt.level.name(),
            pt.rays,
            pt.directions,
            pt.seed,
            pt.label()
        );
        h = fnv1a(line.as_bytes(), h);
        h = fnv1a(
            toml::to_string(&pt.config).expect("serializes").as_bytes(),
            h,
        );
    }
    h = fnv1a(format!("{:?}", spec.reference_rays).as_bytes(), h);
    if spec.timing != Timing::Cycle {
        let t = format!(
            "timing {} {} {}",
            spec.timing.name(),
            spec.auto_margin,
            spec.auto_check
        );
        h = fnv1a(t.as_bytes(), h);
    }
    format!("{h:016x}")
}
