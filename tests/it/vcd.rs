//! The machine's VCD waveform read back by an independent parser (the `vcd` crate's
//! `Parser`): link transfer counts in the waveform equal the run's statistics, every unit has
//! its scope, time only moves forward, runs are byte-identical, the cycle window and the scope
//! filter keep exactly what they should, and the .gtkw names only signals the VCD declares.
//!
//! Reproduce a waveform by hand with
//! `shellsim run --scene scenes/scene1.json --hw hw/configs/small.toml --ratio 1 --vcd waves/x.vcd`.

use crate::common;

use shellsim::machine::run::{RunSpec, RunStats};
use shellsim::wave::{gtkw, sucl};
use shellsim::wave::{FstPack, ScopeFilter, WaveOptions, WaveSummary, WaveWriter, Window};
use shellsim_hw::config::MachineConfig;
use shellsim_hw::machine::TickOrder;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// A value read from the waveform.
#[derive(Clone, Debug, PartialEq, Eq)]
enum V {
    Bits(u64),
    Text(String),
}

/// A declared variable.
#[derive(Clone, Debug)]
struct Var {
    /// Full dotted name: `machine.cluster_0.icu.stage_3.valid`.
    name: String,
    width: u32,
    is_string: bool,
    /// `(time, value)` changes in file order.
    changes: Vec<(u64, V)>,
}

impl Var {
    fn scope(&self) -> &str {
        self.name.rsplit_once('.').map_or("", |(s, _)| s)
    }

    fn leaf(&self) -> &str {
        self.name.rsplit_once('.').map_or(&self.name, |(_, n)| n)
    }

    /// The value holding at time `t` (the last change at or before it).
    fn at(&self, t: u64) -> Option<&V> {
        self.changes
            .iter()
            .take_while(|(ct, _)| *ct <= t)
            .last()
            .map(|(_, v)| v)
    }

    fn last(&self) -> &V {
        &self
            .changes
            .last()
            .expect("a dumped variable has a value")
            .1
    }

    fn last_bits(&self) -> u64 {
        match self.last() {
            V::Bits(b) => *b,
            V::Text(t) => panic!("{} is a string ({t})", self.name),
        }
    }
}

/// A waveform as the `vcd` crate's parser reads it.
struct Wave {
    vars: BTreeMap<String, Var>,
    /// Every scope declared, dotted.
    scopes: BTreeSet<String>,
    /// Every `#t`, in file order.
    timestamps: Vec<u64>,
    /// Times at which a `$dumpvars` block started.
    dumpvars_at: Vec<u64>,
}

impl Wave {
    fn var(&self, name: &str) -> &Var {
        self.vars
            .get(name)
            .unwrap_or_else(|| panic!("{name} is not in the waveform"))
    }

    /// The final `transfers` of every link scope (one with valid, ready, occupancy and
    /// transfers), by scope.
    fn link_transfers(&self) -> BTreeMap<String, u64> {
        let mut leaves: HashMap<&str, BTreeSet<&str>> = HashMap::new();
        for v in self.vars.values() {
            leaves.entry(v.scope()).or_default().insert(v.leaf());
        }
        leaves
            .iter()
            .filter(|(_, l)| {
                ["valid", "ready", "occupancy", "transfers"]
                    .iter()
                    .all(|x| l.contains(x))
            })
            .map(|(s, _)| {
                (
                    s.to_string(),
                    self.var(&format!("{s}.transfers")).last_bits(),
                )
            })
            .collect()
    }
}

/// Parses a VCD file with `vcd::Parser`.
fn read(path: &Path) -> Wave {
    let f = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    let mut p = vcd::Parser::new(f);
    let header = p.parse_header().unwrap();
    let mut vars = BTreeMap::new();
    let mut scopes = BTreeSet::new();
    let mut by_code: HashMap<vcd::IdCode, String> = HashMap::new();
    fn walk(
        items: &[vcd::ScopeItem],
        prefix: &str,
        vars: &mut BTreeMap<String, Var>,
        scopes: &mut BTreeSet<String>,
        by_code: &mut HashMap<vcd::IdCode, String>,
    ) {
        for i in items {
            match i {
                vcd::ScopeItem::Scope(s) => {
                    let name = if prefix.is_empty() {
                        s.identifier.clone()
                    } else {
                        format!("{prefix}.{}", s.identifier)
                    };
                    assert_eq!(s.scope_type, vcd::ScopeType::Module);
                    scopes.insert(name.clone());
                    walk(&s.items, &name, vars, scopes, by_code);
                }
                vcd::ScopeItem::Var(v) => {
                    let name = format!("{prefix}.{}", v.reference);
                    let is_string = v.var_type == vcd::VarType::String;
                    if !is_string {
                        assert_eq!(v.var_type, vcd::VarType::Wire, "{name}");
                        // Vectors carry their range; scalars none.
                        let want =
                            (v.size > 1).then(|| vcd::ReferenceIndex::Range(v.size as i32 - 1, 0));
                        assert_eq!(v.index, want, "{name}");
                    }
                    assert!(
                        by_code.insert(v.code, name.clone()).is_none(),
                        "{name}: code reused"
                    );
                    let var = Var {
                        name: name.clone(),
                        width: v.size,
                        is_string,
                        changes: vec![],
                    };
                    assert!(
                        vars.insert(name.clone(), var).is_none(),
                        "{name} declared twice"
                    );
                }
                vcd::ScopeItem::Comment(_) => {}
                _ => {}
            }
        }
    }
    walk(&header.items, "", &mut vars, &mut scopes, &mut by_code);
    assert_eq!(
        header.timescale,
        Some((1, vcd::TimescaleUnit::NS)),
        "one time unit per cycle"
    );
    assert!(
        header.date.is_none(),
        "no date: runs must be byte-identical"
    );
    let mut timestamps = vec![];
    let mut dumpvars_at = vec![];
    let mut t = None;
    for cmd in p {
        let cmd = cmd.unwrap();
        let mut set = |code: &vcd::IdCode, v: V| {
            let t = t.expect("a value before the first timestamp");
            let name = &by_code[code];
            let var = vars.get_mut(name).unwrap();
            if let Some((_, prev)) = var.changes.last() {
                assert_ne!(prev, &v, "{name} at {t}: rewritten without a change");
            }
            var.changes.push((t, v));
        };
        match cmd {
            vcd::Command::Timestamp(x) => {
                timestamps.push(x);
                t = Some(x);
            }
            vcd::Command::ChangeScalar(c, v) => set(&c, V::Bits((v == vcd::Value::V1) as u64)),
            vcd::Command::ChangeVector(c, bits) => {
                let mut b = 0u64;
                for v in bits.iter() {
                    assert!(matches!(v, vcd::Value::V0 | vcd::Value::V1));
                    b = (b << 1) | (v == vcd::Value::V1) as u64;
                }
                set(&c, V::Bits(b));
            }
            vcd::Command::ChangeString(c, s) => set(&c, V::Text(s)),
            vcd::Command::Begin(vcd::SimulationCommand::Dumpvars) => {
                dumpvars_at.push(t.expect("$dumpvars after a timestamp"))
            }
            vcd::Command::End(_) => {}
            other => panic!("unexpected {other:?}"),
        }
    }
    Wave {
        vars,
        scopes,
        timestamps,
        dumpvars_at,
    }
}

/// The committed small machine.
fn small() -> MachineConfig {
    common::config("small")
}

/// One waveform of scene1 on small.toml, ratio 1, with `opts`; returns the statistics, the
/// writer's summary and the .gtkw path.
fn run(dir: &Path, file: &str, opts: WaveOptions) -> (RunStats, WaveSummary, PathBuf) {
    let scene_file = common::scene_path("scene1.json");
    let scene = common::load("scene1.json");
    let spec = RunSpec {
        source: 0,
        ratio: 1,
        order: TickOrder::Forward,
    };
    let path = dir.join(file);
    let mut w = WaveWriter::create(&path, opts).unwrap();
    let out =
        shellsim::machine::run::run(&scene, &scene_file, &small(), &spec, Some(&mut w)).unwrap();
    assert_eq!(out.stats.mismatches_vs_fixed, 0);
    let summary = w.finish().unwrap();
    let g = gtkw::path_for(&path);
    gtkw::write(&g, &summary).unwrap();
    sucl::write(&sucl::path_for(&path), &summary).unwrap();
    read_back(&summary);
    (out.stats, summary, g)
}

/// Every waveform a test writes is read back by wellen (Surfer's reader, a dev-dependency,
/// so in every environment): it declares the summary's signals, and a VCD's changes as
/// wellen reads them are the ones its text holds.
fn read_back(summary: &WaveSummary) {
    let got = wellen_changes(&summary.path);
    let mut names: Vec<String> = summary.signals.iter().map(|s| s.full_name()).collect();
    names.sort();
    assert_eq!(got.keys().cloned().collect::<Vec<_>>(), names);
    if summary.path.extension().is_some_and(|e| e == "vcd") {
        let text = std::fs::read_to_string(&summary.path).unwrap();
        assert_eq!(got, changes_of(&text), "{}", summary.path.display());
    }
}

/// Every variable's `(time, value)` changes as wellen reads the file (VCD or FST), in
/// [`changes_of`]'s form (an FST's initial all-x values left out, as the VCD has none; an
/// FST's FSM state, an integer, named through its enum table).
fn wellen_changes(path: &Path) -> BTreeMap<String, Vec<(u64, String)>> {
    let mut w = wellen::simple::read(path)
        .unwrap_or_else(|e| panic!("wellen cannot read {}: {e}", path.display()));
    let h = w.hierarchy();
    type Table = Option<BTreeMap<String, String>>;
    let vars: Vec<(String, u32, wellen::SignalRef, Table)> = h
        .all_vars()
        .map(|r| {
            let v = &h[r];
            let width = v.length(h).unwrap_or(0);
            let table = v.enum_type(h).map(|(_, m)| {
                m.into_iter()
                    .map(|(value, name)| (value.to_string(), name.to_string()))
                    .collect()
            });
            (v.full_name(h), width, v.signal_ref(), table)
        })
        .collect();
    let refs: Vec<_> = vars.iter().map(|v| v.2).collect();
    w.load_signals(&refs);
    let times = w.time_table().to_vec();
    let mut out = BTreeMap::new();
    for (name, _, r, table) in vars {
        let sig = w.get_signal(r).expect("loaded");
        let mut ch = Vec::new();
        for (ti, v) in sig.iter_changes() {
            let v = match v {
                wellen::SignalValueRef::String(s) => s.to_string(),
                v => {
                    let bits = v.to_bit_string().expect("a bit vector");
                    if bits.chars().all(|c| c == 'x') {
                        continue;
                    }
                    match &table {
                        Some(t) => t
                            .get(&bits)
                            .unwrap_or_else(|| panic!("{name}: {bits} is not in its enum table"))
                            .clone(),
                        None => normalized(&bits),
                    }
                }
            };
            ch.push((times[ti as usize], v));
        }
        out.insert(name, ch);
    }
    out
}

/// A vector's bits as [`changes_of`] gives them: without leading zeros ("0" for zero).
fn normalized(v: &str) -> String {
    let z = v.trim_start_matches('0');
    if z.is_empty() {
        "0".into()
    } else {
        z.into()
    }
}

/// The full waveform, made once for all tests.
struct Full {
    _dir: tempfile::TempDir,
    stats: RunStats,
    summary: WaveSummary,
    gtkw: PathBuf,
    wave: Wave,
}

fn full() -> &'static Full {
    static FULL: OnceLock<Full> = OnceLock::new();
    FULL.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let (stats, summary, gtkw) = run(dir.path(), "full.vcd", WaveOptions::default());
        let wave = read(&summary.path);
        Full {
            _dir: dir,
            stats,
            summary,
            gtkw,
            wave,
        }
    })
}

#[test]
fn link_transfers_in_the_waveform_equal_the_run_statistics() {
    let f = full();
    let s = &f.stats;
    let links = f.wave.link_transfers();
    let k = s.clusters[0].ctus.len();
    let mut expected: BTreeMap<String, u64> = BTreeMap::new();
    for (c, cl) in s.clusters.iter().enumerate() {
        let base = format!("machine.cluster_{c}");
        // The ICU pops the ray buffer; the patch buffer pops its store.
        expected.insert(format!("{base}.ray_buffer"), cl.icu.jobs_in);
        expected.insert(format!("{base}.patch_buffer"), cl.patch_buffer.patches_in);
        for (j, ctu) in cl.ctus.iter().enumerate() {
            expected.insert(format!("{base}.ctu_{j}.jobs"), ctu.jobs_issued);
            expected.insert(format!("{base}.ctu_{j}.results"), ctu.results);
            expected.insert(
                format!("machine.memory.arbiter.req_{c}_{j}"),
                ctu.patch_requests,
            );
        }
        // Every patch the buffer hands on arrives at one of its CTUs.
        let arrivals: u64 = (0..k)
            .map(|j| links[&format!("{base}.ctu_{j}.arrivals")])
            .sum();
        assert_eq!(arrivals, cl.patch_buffer.patches_in, "{base} arrivals");
        for j in 0..k {
            let a = format!("{base}.ctu_{j}.arrivals");
            expected.insert(a.clone(), links[&a]);
        }
        // The unit counters beside the links.
        assert_eq!(
            f.wave.var(&format!("{base}.icu.jobs_in")).last_bits(),
            cl.icu.jobs_in
        );
        for (j, ctu) in cl.ctus.iter().enumerate() {
            let v = f.wave.var(&format!("{base}.ctu_{j}.jobs_issued"));
            assert_eq!(v.last_bits(), ctu.jobs_issued);
            let st = f.wave.var(&format!("{base}.ctu_{j}.state"));
            assert!(st.is_string);
            assert_eq!(st.last(), &V::Text("DONE".into()), "every CTU ends DONE");
        }
    }
    assert_eq!(
        links, expected,
        "every link scope, checked against the statistics"
    );
    // Totals: Σ jobs links = Σ jobs issued; Σ requests = memory grants = patch loads.
    let jobs: u64 = links
        .iter()
        .filter(|(k, _)| k.ends_with(".jobs"))
        .map(|(_, v)| v)
        .sum();
    assert_eq!(jobs, s.jobs);
    let reqs: u64 = links
        .iter()
        .filter(|(k, _)| k.contains(".req_"))
        .map(|(_, v)| v)
        .sum();
    assert_eq!(reqs, s.memory.grants);
    assert_eq!(
        f.wave.var("machine.memory.grants").last_bits(),
        s.memory.grants
    );
    assert_eq!(s.patch_loads, s.memory.grants);
    // Everything drained at the end.
    for l in links.keys() {
        assert_eq!(f.wave.var(&format!("{l}.valid")).last_bits(), 0, "{l}");
        assert_eq!(f.wave.var(&format!("{l}.occupancy")).last_bits(), 0, "{l}");
    }
}

#[test]
fn the_header_declares_every_unit_scope() {
    let f = full();
    let cfg = small();
    let mut want = vec![
        "machine".to_string(),
        "machine.memory".into(),
        "machine.memory.arbiter".into(),
    ];
    for c in 0..cfg.machine.clusters {
        let base = format!("machine.cluster_{c}");
        want.push(base.clone());
        for u in ["icu", "ray_buffer", "patch_buffer"] {
            want.push(format!("{base}.{u}"));
        }
        for n in 0..cfg.pipeline_depth() {
            want.push(format!("{base}.icu.stage_{n}"));
        }
        for j in 0..cfg.machine.ctus_per_cluster {
            want.push(format!("machine.memory.arbiter.req_{c}_{j}"));
            for l in ["", ".jobs", ".results", ".arrivals"] {
                want.push(format!("{base}.ctu_{j}{l}"));
            }
        }
    }
    let want: BTreeSet<String> = want.into_iter().collect();
    assert_eq!(f.wave.scopes, want);
    // The fixed-point t of a stage is a wire of the t format's width.
    let t = f.wave.var("machine.cluster_0.icu.stage_0.t");
    assert_eq!(t.width, cfg.datapath.formats().unwrap().t.bits());
    assert_eq!(f.summary.signals.len(), f.wave.vars.len());
}

#[test]
fn every_icu_stage_holds_each_job_for_one_cycle() {
    // With no stall, every job spends one cycle in each stage: the cycles a stage's `valid`
    // is 1 add up to the ICU's jobs. The probe skips an empty ICU's stages (when it was
    // empty at the last sample too), so a stale stage would show here.
    let f = full();
    let depth = small().pipeline_depth();
    for (c, cl) in f.stats.clusters.iter().enumerate() {
        assert_eq!(cl.icu.stalled_cycles, 0, "cluster {c} stalled");
        assert!(cl.icu.idle_cycles > 0, "cluster {c} never empty");
        for n in 0..depth {
            let stage = format!("machine.cluster_{c}.icu.stage_{n}");
            let v = &f.wave.var(&format!("{stage}.valid")).changes;
            let mut held = 0;
            for (k, (t, x)) in v.iter().enumerate() {
                let end = v.get(k + 1).map_or(f.stats.cycles, |(u, _)| *u);
                if *x == V::Bits(1) {
                    held += end - t;
                }
            }
            assert_eq!(held, cl.icu.jobs_in, "{stage}");
            // An empty stage shows zeros.
            for leaf in ["ray", "patch", "t"] {
                let w = f.wave.var(&format!("{stage}.{leaf}"));
                for (t, x) in &w.changes {
                    if f.wave.var(&format!("{stage}.valid")).at(*t) == Some(&V::Bits(0)) {
                        assert_eq!(x, &V::Bits(0), "{stage}.{leaf} at {t}");
                    }
                }
            }
        }
    }
}

#[test]
fn timestamps_increase_strictly_and_stay_inside_the_run() {
    let f = full();
    let ts = &f.wave.timestamps;
    assert!(ts.len() > 100);
    assert!(
        ts.windows(2).all(|w| w[0] < w[1]),
        "timestamps not increasing"
    );
    assert_eq!(ts[0], 0);
    assert!(*ts.last().unwrap() < f.stats.cycles);
    assert_eq!(f.wave.dumpvars_at, [0]);
    // Every variable is dumped at the start.
    for v in f.wave.vars.values() {
        assert_eq!(v.changes[0].0, 0, "{}", v.name);
    }
    assert_eq!(f.summary.timestamps, ts.len() as u64);
    assert!(f.summary.samples > 0 && f.summary.samples <= f.stats.cycles);
}

#[test]
fn two_runs_give_byte_identical_files() {
    let f = full();
    let dir = tempfile::tempdir().unwrap();
    let (_, again, g) = run(dir.path(), "full.vcd", WaveOptions::default());
    assert_eq!(
        std::fs::read(&f.summary.path).unwrap(),
        std::fs::read(&again.path).unwrap(),
        "VCD differs between two identical runs"
    );
    assert_eq!(
        std::fs::read_to_string(&f.gtkw)
            .unwrap()
            .lines()
            .filter(|l| !l.contains("file]"))
            .collect::<Vec<_>>(),
        std::fs::read_to_string(&g)
            .unwrap()
            .lines()
            .filter(|l| !l.contains("file]"))
            .collect::<Vec<_>>(),
        "the .gtkw differs apart from its paths"
    );
}

#[test]
fn a_cycle_window_keeps_only_its_cycles_and_opens_with_the_full_state() {
    let f = full();
    let win = Window {
        from: 5000,
        to: 6000,
    };
    let dir = tempfile::tempdir().unwrap();
    let (_, s, _) = run(
        dir.path(),
        "win.vcd",
        WaveOptions {
            window: win,
            scope: None,
            ..Default::default()
        },
    );
    let w = read(&s.path);
    assert!(
        s.bytes < f.summary.bytes / 4,
        "{} vs {}",
        s.bytes,
        f.summary.bytes
    );
    assert_eq!(w.timestamps[0], win.from);
    assert_eq!(w.dumpvars_at, [win.from]);
    assert!(w.timestamps.iter().all(|&t| win.contains(t)));
    assert_eq!(
        w.vars.keys().collect::<Vec<_>>(),
        f.wave.vars.keys().collect::<Vec<_>>()
    );
    // The window holds exactly the full waveform's values, cycle by cycle, from `from` to `to`.
    for (name, v) in &w.vars {
        let full = f.wave.var(name);
        assert_eq!(
            v.changes[0],
            (win.from, full.at(win.from).unwrap().clone()),
            "{name}"
        );
        let inside: Vec<_> = full
            .changes
            .iter()
            .filter(|(t, _)| win.from < *t && *t <= win.to)
            .collect();
        assert_eq!(v.changes[1..].iter().collect::<Vec<_>>(), inside, "{name}");
    }
    // The same window between two samples (no cycle there) still opens at `from`.
    let gap = f
        .wave
        .timestamps
        .windows(2)
        .find(|p| p[1] - p[0] > 2)
        .expect("some cycle with no change");
    let win2 = Window {
        from: gap[0] + 1,
        to: gap[1] + 10,
    };
    let (_, s2, _) = run(
        dir.path(),
        "gap.vcd",
        WaveOptions {
            window: win2,
            scope: None,
            ..Default::default()
        },
    );
    let w2 = read(&s2.path);
    assert_eq!(w2.dumpvars_at, [win2.from]);
    for (name, v) in &w2.vars {
        assert_eq!(v.at(win2.from), f.wave.var(name).at(win2.from), "{name}");
        assert_eq!(v.at(win2.to), f.wave.var(name).at(win2.to), "{name}");
    }
}

#[test]
fn a_scope_filter_declares_only_matching_signals() {
    let f = full();
    let dir = tempfile::tempdir().unwrap();
    for (pattern, keep) in [
        (
            "machine.cluster_0.*",
            &(|s: &str| s.starts_with("machine.cluster_0.")) as &dyn Fn(&str) -> bool,
        ),
        ("icu", &|s: &str| s.contains("icu")),
        ("*.ctu_?", &|s: &str| {
            s.ends_with(".ctu_0") || s.ends_with(".ctu_1")
        }),
    ] {
        let (_, s, g) = run(
            dir.path(),
            "scoped.vcd",
            WaveOptions {
                window: Window::ALL,
                scope: Some(ScopeFilter::new(pattern)),
                ..Default::default()
            },
        );
        let w = read(&s.path);
        assert!(s.bytes < f.summary.bytes, "{pattern}: not smaller");
        let want: Vec<&String> = f
            .wave
            .vars
            .iter()
            .filter(|(_, v)| keep(v.scope()))
            .map(|(k, _)| k)
            .collect();
        assert!(!want.is_empty(), "{pattern} keeps something");
        assert_eq!(w.vars.keys().collect::<Vec<_>>(), want, "{pattern}");
        // Kept signals have the full run's history (timestamps only where they change).
        for (name, v) in &w.vars {
            assert_eq!(v.changes, f.wave.var(name).changes, "{pattern}: {name}");
        }
        let changed: BTreeSet<u64> = w
            .vars
            .values()
            .flat_map(|v| v.changes.iter().map(|c| c.0))
            .collect();
        assert_eq!(
            w.timestamps,
            changed.into_iter().collect::<Vec<_>>(),
            "{pattern}"
        );
        check_gtkw(&g, &w);
    }
}

#[test]
fn the_gtkw_names_only_signals_of_the_vcd_and_all_of_them() {
    let f = full();
    check_gtkw(&f.gtkw, &f.wave);
    let text = std::fs::read_to_string(&f.gtkw).unwrap();
    // By name, relative to the save file beside it (a moved pair still opens).
    let name = f.summary.path.file_name().unwrap().to_string_lossy();
    assert!(text.contains(&format!("[dumpfile] \"{name}\"\n")), "{text}");
    assert!(!text.contains("[dumpfile] \"/"), "{text}");
    // Fixed-point t as a signed decimal with the t format's fractional bits as its shift.
    let frac = small().datapath.formats().unwrap().t.frac_bits;
    assert!(text.contains(&format!(
        "@40000420\n[fpshift_count] {frac}\nmachine.cluster_0.icu.stage_0.t["
    )));
}

/// Every signal line of the .gtkw names a variable of `w` (vectors with their `[w-1:0]`
/// range, as GTKWave names them), every variable is named once, and groups balance.
fn check_gtkw(path: &Path, w: &Wave) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut named = BTreeSet::new();
    let mut flags = 0u64;
    let mut depth = 0i32;
    for line in text.lines() {
        if let Some(hex) = line.strip_prefix('@') {
            flags = u64::from_str_radix(hex, 16).unwrap();
        } else if let Some(label) = line.strip_prefix('-') {
            assert!(!label.is_empty());
            if flags & gtkw::TR_GRP_BEGIN != 0 {
                depth += 1;
            } else if flags & gtkw::TR_GRP_END != 0 {
                depth -= 1;
                assert!(depth >= 0, "group closed twice");
            }
        } else if line.starts_with('[') || line.starts_with('*') {
            continue;
        } else {
            // An aliased trace (the overview's): `+{label} name`.
            let line = match line.strip_prefix("+{") {
                Some(r) => r.split_once("} ").expect("+{label} name").1,
                None => line,
            };
            assert_eq!(
                flags & (gtkw::TR_GRP_BEGIN | gtkw::TR_GRP_END | gtkw::TR_BLANK),
                0
            );
            let (name, width) = match line.strip_suffix(']').and_then(|l| l.rsplit_once('[')) {
                Some((n, range)) => {
                    let (msb, lsb) = range.split_once(':').unwrap();
                    assert_eq!(lsb, "0");
                    (n, msb.parse::<u32>().unwrap() + 1)
                }
                None => (line, 1),
            };
            let v = w
                .vars
                .get(name)
                .unwrap_or_else(|| panic!("{path:?} names {line}, not in the VCD"));
            assert_eq!(v.width, width, "{line}");
            // A signal of the overview appears again in its unit's group.
            named.insert(name.to_string());
        }
    }
    assert_eq!(depth, 0, "groups left open");
    assert_eq!(named, w.vars.keys().cloned().collect::<BTreeSet<_>>());
}

#[test]
fn the_cli_writes_the_gtkw_beside_the_vcd() {
    let dir = tempfile::tempdir().unwrap();
    let vcd = dir.path().join("waves/x.vcd");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_shellsim"))
        .args(["run", "--scene"])
        .arg(common::scene_path("scene1.json"))
        .arg("--hw")
        .arg(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("hw/configs/small.toml"))
        .args([
            "--ratio",
            "1",
            "--vcd-window",
            "100:200",
            "--vcd-scope",
            "icu",
            "--vcd",
        ])
        .arg(&vcd)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let w = read(&vcd);
    assert!(w.timestamps.iter().all(|&t| (100..=200).contains(&t)));
    assert!(w.vars.keys().all(|k| k.contains("icu")));
    check_gtkw(&dir.path().join("waves/x.gtkw"), &w);
    // Nothing else left in the directory (no temporary files).
    let names: BTreeSet<String> = std::fs::read_dir(dir.path().join("waves"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        [
            "x.gtkw".to_string(),
            "x.sucl".to_string(),
            "x.vcd".to_string()
        ]
        .into()
    );
    // The window and scope options need --vcd.
    let bad = std::process::Command::new(env!("CARGO_BIN_EXE_shellsim"))
        .args(["run", "--scene", "x.json", "--vcd-window", "1:2"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
}

/// Opens the save file in a real GTKWave (needs `gtkwave` and `xvfb-run`, e.g. Debian's
/// packages of those names): every trace is found, formats as written, and the fixed-point
/// t shows as a decimal. `.ci/run` installs both, and in CI (CI set) their absence fails
/// the test; on a developer's machine without them it says so and passes. The same for an
/// FST's save file, whose fixed-point values carry their binary point in the range
/// (`t[2:-12]`) and whose overview shows the CTUs' states by the names of their enum table.
#[test]
fn gtkwave_opens_the_save_file_with_every_signal() {
    let have = |tool: &str| {
        std::process::Command::new("sh")
            .args(["-c", &format!("command -v {tool}")])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if !(have("gtkwave") && have("xvfb-run")) {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must install gtkwave and xvfb (.ci/run does)"
        );
        eprintln!("gtkwave or xvfb-run not installed: the GTKWave check did not run");
        return;
    }
    let f = full();
    gtkwave_lists(&f.gtkw, f.wave.vars.len(), None);
    let dir = tempfile::tempdir().unwrap();
    let opts = WaveOptions {
        window: Window { from: 0, to: 400 },
        ..WaveOptions::default()
    };
    let (_, fst, g) = run(dir.path(), "g.fst", opts);
    let text = std::fs::read_to_string(&g).unwrap();
    assert!(text.contains("@100000028\n+{c0 ctu0 state} machine.cluster_0.ctu_0.state[2:0]\n"));
    assert!(text.contains("\nmachine.cluster_0.icu.stage_0.t[2:-12]\n"));
    let values = gtkwave_lists(&g, fst.signals.len(), Some(100));
    let names = shellsim_hw::units::ctu::CtuState::NAMES;
    let states: Vec<&String> = values
        .iter()
        .filter(|(name, _)| name.starts_with("c0 ctu") && name.ends_with(" state"))
        .map(|(_, v)| v)
        .collect();
    assert!(!states.is_empty());
    for v in states {
        assert!(names.contains(&v.as_str()), "a state shown as {v:?}");
    }
}

/// GTKWave's traces after loading the save file `gtkw` (of a waveform of `vars`
/// variables): asserts each signal was found, and returns each trace's name and its value
/// at the marker set at `marker` (empty where GTKWave computes none, as in closed groups).
fn gtkwave_lists(gtkw: &Path, vars: usize, marker: Option<u64>) -> Vec<(String, String)> {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("list.tcl");
    let listing = dir.path().join("traces.txt");
    let set = marker.map_or(String::new(), |m| format!("gtkwave::setMarker {m}\n"));
    std::fs::write(
        &script,
        format!(
            "{set}set f [open {{{}}} w]\n\
             set n [gtkwave::getTotalNumTraces]\n\
             for {{set i 0}} {{$i < $n}} {{incr i}} {{\n\
             puts $f \"[gtkwave::getTraceNameFromIndex $i]\\t[format %x [gtkwave::getTraceFlagsFromIndex $i]]\\t[gtkwave::getTraceValueAtMarkerFromIndex $i]\"\n\
             }}\n\
             close $f\n\
             gtkwave::/File/Quit\n",
            listing.display()
        ),
    )
    .unwrap();
    let st = std::process::Command::new("xvfb-run")
        .args(["-a", "gtkwave", "-S"])
        .arg(&script)
        .arg(gtkw)
        .output()
        .expect("xvfb-run and gtkwave installed");
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let text = std::fs::read_to_string(&listing).unwrap();
    let traces: Vec<Vec<&str>> = text.lines().map(|l| l.split('\t').collect()).collect();
    let groups = traces
        .iter()
        .filter(|t| u64::from_str_radix(t[1], 16).is_ok_and(|fl| fl & gtkw::TR_GRP_BEGIN != 0))
        .count();
    // The overview's traces repeat signals of the unit groups.
    let overview = std::fs::read_to_string(gtkw)
        .unwrap()
        .lines()
        .filter(|l| l.starts_with("+{"))
        .count();
    assert_eq!(
        traces.len(),
        vars + overview + 2 * groups,
        "{}: a signal was not found",
        gtkw.display()
    );
    traces
        .iter()
        .map(|t| (t[0].to_string(), t.get(2).unwrap_or(&"").to_string()))
        .collect()
}

/// Every variable's `(time, value)` changes from a VCD's text, by full dotted name: vectors
/// without leading zeros, strings as text; in `fst2vcd -e`'s VCD of an FST, a variable under
/// an enum table's reference (`$attrbegin misc 07 "" HANDLE $end` before its `$var`) named
/// through that table (`$attrbegin misc 07 NAME COUNT LITERALS… VALUES… HANDLE $end`).
fn changes_of(text: &str) -> BTreeMap<String, Vec<(u64, String)>> {
    let mut scope: Vec<String> = Vec::new();
    let mut names: HashMap<String, (String, u32, Option<u64>)> = HashMap::new();
    let mut tables: HashMap<u64, HashMap<String, String>> = HashMap::new();
    let mut pending: Option<u64> = None;
    let mut out: BTreeMap<String, Vec<(u64, String)>> = BTreeMap::new();
    let mut t = 0u64;
    for line in text.lines() {
        let tok: Vec<&str> = line.split_whitespace().collect();
        match tok.first().copied() {
            Some("$scope") => scope.push(tok[2].to_string()),
            Some("$upscope") => {
                scope.pop();
            }
            Some("$attrbegin") if tok.get(1..3) == Some(&["misc", "07"][..]) => {
                let handle: u64 = tok[tok.len() - 2].parse().unwrap();
                if tok[3] == "\"\"" {
                    pending = Some(handle);
                } else {
                    let n: usize = tok[4].parse().unwrap();
                    let (lits, vals) = (&tok[5..5 + n], &tok[5 + n..5 + 2 * n]);
                    let map = vals
                        .iter()
                        .zip(lits)
                        .map(|(v, l)| (v.to_string(), l.to_string()))
                        .collect();
                    tables.insert(handle, map);
                }
            }
            Some("$var") => {
                let w: u32 = tok[2].parse().unwrap();
                let name = tok[4].split('[').next().unwrap();
                let full = format!("{}.{}", scope.join("."), name);
                names.insert(tok[3].to_string(), (full, w, pending.take()));
            }
            Some(x) if x.starts_with('#') => t = x[1..].parse().unwrap(),
            Some(x)
                if (x.starts_with('b') || x.starts_with('s'))
                    && tok.len() == 2
                    && names.contains_key(tok[1]) =>
            {
                let (n, w, table) = &names[tok[1]];
                let v = match (x.strip_prefix('s'), table) {
                    (Some(text), _) => text.to_string(),
                    (None, Some(h)) => {
                        let bits = format!("{:0>w$}", &x[1..], w = *w as usize);
                        match tables[h].get(&bits) {
                            Some(name) => name.clone(),
                            // fst2vcd's initial all-x value
                            None => bits,
                        }
                    }
                    (None, None) => normalized(&x[1..]),
                };
                out.entry(n.clone()).or_default().push((t, v));
            }
            Some(x)
                if (x.starts_with('0') || x.starts_with('1'))
                    && x.len() > 1
                    && names.contains_key(&x[1..]) =>
            {
                let (n, ..) = &names[&x[1..]];
                out.entry(n.clone())
                    .or_default()
                    .push((t, x[..1].to_string()));
            }
            _ => {}
        }
    }
    out
}

/// The FST at `path` as `fst2vcd -e` writes it (enum tables named), or `None` where
/// `fst2vcd` is missing outside CI (see [`have_fst2vcd`]).
fn fst2vcd_text(path: &Path) -> Option<String> {
    if !have_fst2vcd() {
        return None;
    }
    let o = std::process::Command::new("fst2vcd")
        .arg("-e")
        .arg(path)
        .output()
        .unwrap();
    assert!(o.status.success(), "fst2vcd -e {}", path.display());
    Some(String::from_utf8(o.stdout).unwrap())
}

/// True when GTKWave's `fst2vcd` runs (.ci/run installs it with gtkwave).
fn have_fst2vcd() -> bool {
    let ok = std::process::Command::new("fst2vcd")
        .arg("-h")
        .output()
        .is_ok();
    // CI installs it: there a missing reader is a failure, not a skipped check.
    assert!(
        ok || std::env::var_os("CI").is_none(),
        "fst2vcd (GTKWave) is not installed, and CI is set: .ci/run installs it"
    );
    if !ok {
        eprintln!("fst2vcd (GTKWave) is not installed; .ci/run installs it");
    }
    ok
}

/// The FST of a run with `opts`, read back by wellen (everywhere) and by GTKWave's `fst2vcd`
/// (where installed; CI installs it), two independent readers, holds exactly the VCD's value
/// changes of the same run: same scopes and names, same times, same values, FSM states
/// included.
fn fst_matches_vcd(opts: WaveOptions) {
    let dir = tempfile::tempdir().unwrap();
    let (_, v, _) = run(dir.path(), "w.vcd", opts.clone());
    let (_, f, _) = run(dir.path(), "w.fst", opts);
    assert_eq!(v.signals, f.signals);
    let from_vcd = changes_of(&std::fs::read_to_string(&v.path).unwrap());
    assert_eq!(from_vcd.len(), v.signals.len());
    assert_eq!(
        wellen_changes(&f.path),
        from_vcd,
        "wellen's reading of the FST"
    );
    let Some(text) = fst2vcd_text(&f.path) else {
        return;
    };
    let from_fst = changes_of(&text);
    assert_eq!(
        from_fst.keys().collect::<Vec<_>>(),
        from_vcd.keys().collect::<Vec<_>>()
    );
    for (name, ch) in &from_vcd {
        // FST starts every signal unknown (all x) before its first value; the VCD has no
        // such entry.
        let fst: Vec<_> = from_fst[name]
            .iter()
            .filter(|(_, v)| !v.chars().all(|c| c == 'x' || c == '?'))
            .cloned()
            .collect();
        assert_eq!(&fst, ch, "{name}");
    }
}

/// A cycle window: the FST holds exactly the VCD's value changes.
#[test]
fn the_fst_holds_exactly_the_vcds_value_changes() {
    fst_matches_vcd(WaveOptions {
        window: Window {
            from: 100,
            to: 3000,
        },
        scope: None,
        ..Default::default()
    });
}

/// A cycle window and a scope filter together: the FST holds exactly the VCD's value
/// changes, of the filtered signals only.
#[test]
fn a_windowed_scope_filtered_fst_holds_exactly_the_vcds_value_changes() {
    fst_matches_vcd(WaveOptions {
        window: Window {
            from: 500,
            to: 2500,
        },
        scope: Some(ScopeFilter::new("machine.cluster_1.*")),
        ..Default::default()
    });
}

/// LZ4 sections (`--fst-pack lz4`): the FST holds exactly the VCD's value changes, and
/// it is not the zlib file (the pack was applied).
#[test]
fn an_lz4_fst_holds_exactly_the_vcds_value_changes() {
    let opts = WaveOptions {
        window: Window {
            from: 100,
            to: 3000,
        },
        scope: None,
        fst_pack: FstPack::Lz4,
        ..WaveOptions::default()
    };
    fst_matches_vcd(opts.clone());
    let dir = tempfile::tempdir().unwrap();
    let (_, lz4, _) = run(dir.path(), "lz4.fst", opts.clone());
    let zlib = WaveOptions {
        fst_pack: FstPack::Zlib,
        ..opts
    };
    let (_, zlib, _) = run(dir.path(), "zlib.fst", zlib);
    assert_ne!(
        std::fs::read(&lz4.path).unwrap(),
        std::fs::read(&zlib.path).unwrap()
    );
}

/// The FST (compressed on the compressor thread) is byte-identical between two identical runs.
#[test]
fn two_runs_give_byte_identical_fsts() {
    let dir = tempfile::tempdir().unwrap();
    let (_, a, _) = run(dir.path(), "a.fst", WaveOptions::default());
    let (_, b, _) = run(dir.path(), "b.fst", WaveOptions::default());
    assert!(a.bytes > 0);
    assert_eq!(
        std::fs::read(&a.path).unwrap(),
        std::fs::read(&b.path).unwrap(),
        "FST differs between two identical runs"
    );
}

/// A probe that keeps the scopes `keep` says and records the layout the machine declares.
struct Keeping {
    keep: fn(&str) -> bool,
    declared: Vec<String>,
    samples: u64,
}

impl shellsim_hw::trace::Probe for Keeping {
    fn wants(&self, scope: &str) -> bool {
        (self.keep)(scope)
    }
    fn declare(
        &mut self,
        signals: &[shellsim_hw::trace::SignalDecl],
        _: &[shellsim_hw::trace::Pipeline],
    ) {
        self.declared = signals.iter().map(|d| d.scope.clone()).collect();
    }
    fn sample(&mut self, _: u64, _: &[u64]) {
        self.samples += 1;
    }
}

/// The scope filter is applied where the machine declares its signals: a unit the probe
/// keeps nothing of is neither declared nor sampled (so it costs nothing per cycle), and the
/// units it keeps are declared whole.
#[test]
fn the_machine_declares_only_the_units_a_probe_wants() {
    let scene_file = common::scene_path("scene1.json");
    let scene = common::load("scene1.json");
    let spec = RunSpec {
        source: 0,
        ratio: 1,
        order: TickOrder::Forward,
    };
    let layout = |keep: fn(&str) -> bool| {
        let mut p = Keeping {
            keep,
            declared: Vec::new(),
            samples: 0,
        };
        shellsim::machine::run::run(&scene, &scene_file, &small(), &spec, Some(&mut p)).unwrap();
        assert!(p.samples > 0);
        p.declared
    };
    let all = layout(|_| true);
    let one = layout(|s| s.starts_with("machine.cluster_1.ctu_0"));
    assert!(
        !one.is_empty() && one.len() < all.len() / 4,
        "{} of {}",
        one.len(),
        all.len()
    );
    assert!(
        one.iter().all(|s| s.starts_with("machine.cluster_1.ctu_0")),
        "{one:?}"
    );
    let want: Vec<&String> = all
        .iter()
        .filter(|s| s.starts_with("machine.cluster_1.ctu_0"))
        .collect();
    assert_eq!(one.iter().collect::<Vec<_>>(), want);
    assert!(layout(|_| false).is_empty());
}

/// An FST's FSM states are small integers named by FST enum tables: each state variable of
/// wellen's reading has a table, which lists the VCD's names (then "-") in order, valued
/// 0, 1, … in the signal's width; read through it, the state takes the VCD's strings at the
/// same times (so a table naming the values wrongly, or a state written as anything but its
/// index, fails); and GTKWave's `fst2vcd -e` shows the same table.
#[test]
fn the_fsts_fsm_states_carry_enum_tables_with_the_vcds_names() {
    let dir = tempfile::tempdir().unwrap();
    let opts = WaveOptions {
        window: Window { from: 0, to: 1500 },
        ..WaveOptions::default()
    };
    let (_, v, _) = run(dir.path(), "e.vcd", opts.clone());
    let (_, f, _) = run(dir.path(), "e.fst", opts);
    let names = shellsim_hw::units::ctu::CtuState::NAMES;
    let states: Vec<&shellsim::wave::Signal> = f
        .signals
        .iter()
        .filter(|s| matches!(s.kind, shellsim::wave::SignalKind::Text { .. }))
        .collect();
    assert!(states.len() >= 2, "the small machine has CTUs");
    let w = wellen::simple::read(&f.path).unwrap();
    let h = w.hierarchy();
    let from_vcd = changes_of(&std::fs::read_to_string(&v.path).unwrap());
    let from_fst = wellen_changes(&f.path);
    let width = shellsim::wave::state_bits(names.len() as u32);
    assert_eq!(width, 3);
    for s in &states {
        let var = h
            .all_vars()
            .map(|r| &h[r])
            .find(|x| x.full_name(h) == s.full_name())
            .unwrap_or_else(|| panic!("{} not in the FST", s.full_name()));
        assert_eq!(var.length(h), Some(width), "{}", s.full_name());
        let (_, table) = var
            .enum_type(h)
            .unwrap_or_else(|| panic!("{}: no enum table", s.full_name()));
        let want: Vec<(String, String)> = names
            .iter()
            .chain(&["-"])
            .enumerate()
            .map(|(k, n)| (format!("{k:03b}"), n.to_string()))
            .collect();
        let got: Vec<(String, String)> = table
            .iter()
            .map(|(v, n)| (v.to_string(), n.to_string()))
            .collect();
        assert_eq!(got, want, "{}", s.full_name());
        let seen: BTreeSet<&str> = from_vcd[&s.full_name()]
            .iter()
            .map(|(_, x)| x.as_str())
            .collect();
        assert!(seen.len() >= 3, "{}: {seen:?}", s.full_name());
        assert_eq!(
            from_fst[&s.full_name()],
            from_vcd[&s.full_name()],
            "{}",
            s.full_name()
        );
    }
    let Some(text) = fst2vcd_text(&f.path) else {
        return;
    };
    let table = format!(
        "$attrbegin misc 07 state {} {} - {} 1 $end",
        names.len() + 1,
        names.join(" "),
        (0..=names.len())
            .map(|k| format!("{k:03b}"))
            .collect::<Vec<_>>()
            .join(" ")
    );
    assert!(text.contains(&table), "fst2vcd shows no table {table}");
    // One table, referred to by every state.
    assert_eq!(text.matches("$attrbegin misc 07 state ").count(), 1);
    assert_eq!(
        text.matches("$attrbegin misc 07 \"\" 1 $end").count(),
        states.len()
    );
}

/// Surfer's commands, from its command parser (gitlab.com/surfer-project/surfer,
/// libsurfer/src/command_parser.rs, `get_parser`: the commands its prompt and command files
/// take once a file is loaded); a .sucl may use only these.
const SURFER_COMMANDS: &[&str] = &[
    "load_file",
    "load_url",
    "load_state",
    "run_command_file",
    "run_command_file_from_url",
    "switch_file",
    "variable_add",
    "generator_add",
    "item_focus",
    "item_set_color",
    "item_set_background_color",
    "item_set_format",
    "item_unset_color",
    "item_unset_background_color",
    "item_unfocus",
    "item_rename",
    "zoom_fit",
    "scope_add",
    "scope_add_recursive",
    "scope_add_as_group",
    "scope_add_as_group_recursive",
    "scope_select",
    "stream_add",
    "stream_select",
    "divider_add",
    "config_reload",
    "theme_select",
    "reload",
    "remove_unavailable",
    "scroll_to_start",
    "scroll_to_end",
    "goto_start",
    "goto_end",
    "zoom_in",
    "zoom_out",
    "toggle_menu",
    "toggle_side_panel",
    "toggle_fullscreen",
    "toggle_tick_lines",
    "variable_add_from_scope",
    "variable_set_name_type",
    "variable_force_name_type",
    "goto_cursor",
    "goto_marker",
    "group_marked",
    "group_dissolve",
    "group_fold_all",
    "group_unfold_all",
    "timeline_add",
    "cursor_set",
    "marker_set",
    "marker_remove",
    "show_controls",
    "show_mouse_gestures",
    "show_quick_start",
    "show_logs",
    "generator_add_from_stream",
    "preference_set_clock_highlight",
    "preference_set_hierarchy_style",
    "preference_set_arrow_key_bindings",
    "dump_tree",
    "group_fold_recursive",
    "group_unfold_recursive",
    "save_state",
    "save_state_as",
    "show_marker_window",
    "viewport_add",
    "viewport_remove",
    "transition_next",
    "transition_previous",
    "transaction_next",
    "transaction_prev",
    "copy_value",
    "pause_simulation",
    "unpause_simulation",
    "undo",
    "redo",
    "wcp_server_start",
    "wcp_server_stop",
    "exit",
];

/// Surfer's built-in formats (translators) a .sucl may name (libsurfer/src/translation/:
/// `UnsignedTranslator` and its siblings' `name()`; an unknown name panics Surfer's
/// `get_translator`).
const SURFER_FORMATS: &[&str] = &[
    "Binary",
    "Hexadecimal",
    "Octal",
    "Unsigned",
    "Signed",
    "ASCII",
    "Signed fixed point",
    "Unsigned fixed point",
];

/// The Surfer command file beside a VCD's and an FST's .gtkw: every command is one Surfer
/// knows, it loads the waveform beside it, adds exactly the .gtkw's overview signals (each a
/// variable of the waveform as wellen reads it), focuses only items it added and that are
/// vectors before giving them a format Surfer has, and ends zoomed to fit.
#[test]
fn the_sucl_beside_every_gtkw_adds_the_overview_in_surfers_commands() {
    let dir = tempfile::tempdir().unwrap();
    let opts = WaveOptions {
        window: Window { from: 0, to: 600 },
        ..WaveOptions::default()
    };
    for file in ["s.vcd", "s.fst"] {
        let (_, summary, g) = run(dir.path(), file, opts.clone());
        let path = sucl::path_for(&summary.path);
        assert_eq!(path.file_stem(), g.file_stem());
        let text = std::fs::read_to_string(&path).unwrap();
        let w = wellen::simple::read(&summary.path).unwrap();
        let h = w.hierarchy();
        let vars: BTreeMap<String, u32> = h
            .all_vars()
            .map(|r| (h[r].full_name(h), h[r].length(h).unwrap_or(0)))
            .collect();
        let mut added: Vec<String> = Vec::new();
        let mut focused: Option<usize> = None;
        let mut commands = Vec::new();
        for line in text.lines() {
            let line = line.split('#').next().unwrap().trim();
            if line.is_empty() {
                continue;
            }
            let (cmd, arg) = line.split_once(' ').unwrap_or((line, ""));
            assert!(SURFER_COMMANDS.contains(&cmd), "{cmd} is not Surfer's");
            commands.push(cmd);
            match cmd {
                "load_file" => assert_eq!(arg, file),
                "variable_add" => {
                    assert!(vars.contains_key(arg), "{arg} is not in {file}");
                    added.push(arg.to_string());
                }
                "item_focus" => {
                    let hex: String = arg
                        .chars()
                        .map(|c| char::from_digit(c as u32 - 'a' as u32, 16).unwrap())
                        .collect();
                    let i = usize::from_str_radix(&hex, 16).unwrap();
                    assert!(i < added.len(), "item {arg} is not added yet");
                    assert!(vars[&added[i]] > 1, "{} is not a vector", added[i]);
                    focused = Some(i);
                }
                "item_set_format" => {
                    assert!(focused.is_some(), "a format for no item");
                    assert!(SURFER_FORMATS.contains(&arg), "{arg} is not Surfer's");
                }
                "item_unfocus" => focused = None,
                "zoom_fit" => {}
                other => panic!("{other} is not expected"),
            }
        }
        assert_eq!(commands.first(), Some(&"load_file"));
        assert_eq!(commands.last(), Some(&"zoom_fit"));
        // The overview of the .gtkw: its aliased traces, by name without their range.
        let gtkw_text = std::fs::read_to_string(&g).unwrap();
        let overview: Vec<String> = gtkw_text
            .lines()
            .filter_map(|l| l.strip_prefix("+{"))
            .map(|l| {
                let name = l.split_once("} ").unwrap().1;
                name.split('[').next().unwrap().to_string()
            })
            .collect();
        assert!(!overview.is_empty());
        assert_eq!(added, overview, "{file}");
    }
}

/// An FST declares each fixed-point value with its binary point in its range (`t[2:-12]`
/// for 15 bits with 12 fractional), which wellen reads as the variable's index, so Surfer
/// scales the value by 2^lsb; the VCD keeps `[w-1:0]` (its header unchanged).
#[test]
fn an_fsts_fixed_point_values_carry_their_binary_point() {
    let dir = tempfile::tempdir().unwrap();
    let opts = WaveOptions {
        window: Window { from: 0, to: 300 },
        ..WaveOptions::default()
    };
    let frac = small().datapath.formats().unwrap().t.frac_bits as i64;
    for file in ["b.fst", "b.vcd"] {
        let (_, summary, _) = run(dir.path(), file, opts.clone());
        let w = wellen::simple::read(&summary.path).unwrap();
        let h = w.hierarchy();
        let mut fixed = 0;
        for s in &summary.signals {
            let shellsim::wave::SignalKind::Fixed { frac: f } = s.kind else {
                continue;
            };
            let var = h
                .all_vars()
                .map(|r| &h[r])
                .find(|x| x.full_name(h) == s.full_name())
                .unwrap();
            let idx = var.index().expect("a vector has a range");
            let want = if file.ends_with("fst") {
                (s.width as i64 - 1 - f as i64, -(f as i64))
            } else {
                (s.width as i64 - 1, 0)
            };
            assert_eq!((idx.msb(), idx.lsb()), want, "{}", s.full_name());
            if s.name == "t" {
                assert_eq!(f as i64, frac);
            }
            fixed += 1;
        }
        assert!(fixed > 0, "no fixed-point signal in {file}");
    }
}
