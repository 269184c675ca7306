//! Co-simulation: builds the Verilated co-simulation top once per configuration (cached by
//! the hash of everything it is built from), streams a cycle-by-cycle record through it —
//! which jobs are offered, when the result side is ready, what the model's ICU accepts and
//! sends, and every stage register of every job as the model computes it — and turns the
//! harness's first mismatch into a message naming the stage, the vector, the field and both
//! values.
//!
//! The ICU's handshake comes from the model's own ICU (hw/src/units/icu.rs) ticked on links
//! with a seeded back-pressure pattern, so the RTL is held to the model's stalls cycle for
//! cycle; the DDA step is one registered stage with the same handshake.

use super::layout::{first_difference, Packer, Params, Unit};
use super::vectors::{dda_expected, dda_inputs, icu_expected, icu_inputs, DdaJob, IcuJob};
use crate::error::{Error, Result};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use shellsim_hw::datapath::record::{PatchRecord, RayRecord};
use shellsim_hw::link::{Link, UnitId};
use shellsim_hw::msg::{Job, JobResult, RemoteResult};
use shellsim_hw::units::icu::{Icu, IcuPorts};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

/// When jobs arrive and when results may leave: each cycle a new job is offered with
/// probability `offer` and the result side takes one with probability `take`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Pressure {
    pub offer: f64,
    pub take: f64,
    pub seed: u64,
}

impl Pressure {
    /// A job every cycle, never a stall: the pipeline's full rate.
    pub const FULL: Pressure = Pressure {
        offer: 1.0,
        take: 1.0,
        seed: 0,
    };
}

/// A built co-simulation model.
#[derive(Clone, Debug)]
pub struct Built {
    pub binary: PathBuf,
    /// Seconds the build took (0 when it came from the cache).
    pub build_seconds: f64,
    pub cached: bool,
}

/// The Verilator build of `unit` for `p` (with FST tracing when `trace`), from `sources`
/// (name, text) — the committed RTL unless a test passes a mutated copy.
pub fn build(p: &Params, unit: Unit, trace: bool, sources: &[(&str, &str)]) -> Result<Built> {
    if !super::have("verilator") {
        return Err(super::missing_tool("verilator", "verilator"));
    }
    let pkg = super::package_sv(p, "the configuration");
    let side = trace && unit == Unit::Icu;
    let top = super::top_sv(p, unit, side);
    let shape = super::shape_h(p, unit, side);
    let mut parts: Vec<&str> = vec![
        &pkg,
        &top,
        &shape,
        super::HARNESS,
        if trace { "fst" } else { "" },
    ];
    for (n, t) in sources {
        parts.push(n);
        parts.push(t);
    }
    let key = super::hash_of(&parts);
    let dir = super::cache_dir().join(format!("{}-{key}", unit.name()));
    let binary = dir.join("obj").join("cosim");
    if binary.is_file() {
        return Ok(Built {
            binary,
            build_seconds: 0.0,
            cached: true,
        });
    }
    let start = Instant::now();
    // Built beside its final place and renamed in whole: a concurrent or interrupted build
    // never leaves a half-built model where a finished one is looked for.
    let tmp = super::cache_dir().join(format!("{}-{key}.tmp{}", unit.name(), std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    let src = tmp.join("src");
    std::fs::create_dir_all(&src).map_err(|e| Error::io(&src, e))?;
    let mut files = vec![
        ("shellsim_cfg.sv".to_string(), pkg.clone()),
        ("cosim_top.sv".to_string(), top.clone()),
        ("cosim_shape.h".to_string(), shape.clone()),
        ("harness.cpp".to_string(), super::HARNESS.to_string()),
    ];
    for (n, t) in sources {
        files.push((n.to_string(), t.to_string()));
    }
    for (n, t) in &files {
        std::fs::write(src.join(n), t).map_err(|e| Error::io(&src.join(n), e))?;
    }
    let module_file = format!("{}.sv", unit.module());
    let mut cmd = Command::new("verilator");
    cmd.current_dir(&tmp)
        .args([
            "--cc",
            "--exe",
            "--build",
            "-j",
            "2",
            "-O3",
            "--x-assign",
            "fast",
        ])
        .args([
            "--x-initial",
            "fast",
            "-Wno-fatal",
            "-Wno-lint",
            "-Wno-style",
        ])
        .args(["--top-module", "cosim_top", "-Mdir", "obj", "-o", "cosim"])
        .args([
            "-CFLAGS",
            &format!("-O2 -DCOSIM_TRACE={} -I../src", trace as u8),
        ]);
    if trace {
        cmd.arg("--trace-fst");
    }
    cmd.args([
        "src/shellsim_cfg.sv",
        &format!("src/{module_file}"),
        "src/cosim_top.sv",
        "src/harness.cpp",
    ]);
    let out = cmd
        .output()
        .map_err(|e| Error::io(Path::new("verilator"), e))?;
    if !out.status.success() {
        let log = String::from_utf8_lossy(&out.stderr);
        let first: Vec<&str> = log
            .lines()
            .filter(|l| l.contains("Error"))
            .take(8)
            .collect();
        return Err(Error::Check(format!(
            "verilator could not build the {} for this configuration (in {}):\n{}",
            unit.name(),
            tmp.display(),
            if first.is_empty() {
                log.lines().take(12).collect::<Vec<_>>().join("\n")
            } else {
                first.join("\n")
            }
        )));
    }
    let _ = std::fs::remove_dir_all(&dir);
    if std::fs::rename(&tmp, &dir).is_err() && !binary.is_file() {
        return Err(Error::Check(format!(
            "could not move the build to {}",
            dir.display()
        )));
    }
    let _ = std::fs::remove_dir_all(&tmp);
    Ok(Built {
        binary,
        build_seconds: start.elapsed().as_secs_f64(),
        cached: false,
    })
}

/// What a replay found.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Replay {
    pub unit: &'static str,
    pub vectors: u64,
    pub cycles: u64,
    pub stalled_cycles: u64,
    pub hits: u64,
    pub pressure: Pressure,
}

/// Wall-clock figures of a replay, kept apart from its results.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Timing {
    pub seconds: f64,
    pub vectors_per_second: f64,
}

/// The harness's mismatch report, decoded.
fn mismatch(line: &str, p: &Params, unit: Unit, jobs_desc: &dyn Fn(u32) -> String) -> Error {
    let kv = |k: &str| -> Option<&str> {
        line.split_whitespace()
            .find_map(|w| w.strip_prefix(k).and_then(|r| r.strip_prefix('=')))
    };
    if kv("kind") == Some("stage") {
        let stages = p.stages(unit);
        let k: usize = kv("stage").and_then(|s| s.parse().ok()).unwrap_or(0);
        let tag: u32 = kv("tag").and_then(|s| s.parse().ok()).unwrap_or(0);
        let words = |h: &str| -> Vec<u32> {
            let digits: Vec<u32> = h.chars().rev().filter_map(|c| c.to_digit(16)).collect();
            let mut w = vec![0u32; digits.len().div_ceil(8) + 1];
            for (i, d) in digits.iter().enumerate() {
                w[i / 8] |= d << (4 * (i % 8));
            }
            w
        };
        if let (Some(st), Some(r), Some(m)) = (stages.get(k), kv("rtl"), kv("model")) {
            let (rw, mw) = (words(r), words(m));
            let what = match first_difference(st, &rw, &mw) {
                Some((field, e, a, b)) => {
                    let fld = st.fields.iter().find(|f| f.name == field);
                    let el = if fld.is_some_and(|f| f.count > 1) {
                        format!("[{e}]")
                    } else {
                        String::new()
                    };
                    format!("field {field}{el}: RTL {a:#x}, model {b:#x}")
                }
                None => "the bits differ".into(),
            };
            return Error::Check(format!(
                "co-simulation of the {}: stage {k} `{}` (Rust: {}) differs at vector {tag}{}, cycle {}: {what} (bits as unsigned)",
                unit.name(),
                st.name,
                st.rust,
                Some(jobs_desc(tag))
                    .filter(|d| !d.is_empty())
                    .map(|d| format!(" ({d})"))
                    .unwrap_or_default(),
                kv("cycle").unwrap_or("?")
            ));
        }
    }
    Error::Check(format!(
        "co-simulation of the {}: the handshake differs from the model's: {line}",
        unit.name()
    ))
}

/// One record of the stream.
struct Stream<W: Write> {
    w: W,
    words: u64,
}

impl<W: Write> Stream<W> {
    fn word(&mut self, x: u32) -> std::io::Result<()> {
        self.words += 1;
        self.w.write_all(&x.to_le_bytes())
    }
    fn words(&mut self, xs: &[u32]) -> std::io::Result<()> {
        self.words += xs.len() as u64;
        let mut bytes = [0u8; 256];
        for chunk in xs.chunks(64) {
            for (i, x) in chunk.iter().enumerate() {
                bytes[4 * i..4 * i + 4].copy_from_slice(&x.to_le_bytes());
            }
            self.w.write_all(&bytes[..4 * chunk.len()])?;
        }
        Ok(())
    }
}

/// Runs the harness `bin`, feeding it with `feed`, and reads its verdict.
fn run_harness(
    bin: &Path,
    fst: Option<&Path>,
    feed: &mut dyn FnMut(&mut Stream<&mut dyn Write>) -> std::io::Result<()>,
) -> Result<std::result::Result<String, String>> {
    let mut cmd = Command::new(bin);
    if let Some(f) = fst {
        cmd.arg("--fst").arg(f);
    }
    let mut child = cmd
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| Error::io(bin, e))?;
    let stdin = child.stdin.take().expect("piped");
    let mut buf = std::io::BufWriter::with_capacity(1 << 20, stdin);
    let fed = {
        let mut s = Stream {
            w: &mut buf as &mut dyn Write,
            words: 0,
        };
        feed(&mut s).and_then(|_| s.word(0xFFFF_FFFF))
    };
    // A harness that stopped at a mismatch closes its input: the broken pipe is expected.
    let _ = buf.flush();
    drop(buf);
    let out = child.wait_with_output().map_err(|e| Error::io(bin, e))?;
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    let line = text
        .lines()
        .find(|l| l.starts_with("MISMATCH") || l.starts_with("OK"));
    match (out.status.code(), line) {
        (Some(0), Some(l)) if fed.is_ok() => Ok(Ok(l.to_string())),
        (Some(1), Some(l)) => Ok(Err(l.to_string())),
        _ => Err(Error::Check(format!(
            "the co-simulation harness {} failed ({}): {}{}",
            bin.display(),
            out.status,
            String::from_utf8_lossy(&out.stderr)
                .lines()
                .take(5)
                .collect::<Vec<_>>()
                .join("; "),
            fed.err()
                .map(|e| format!(" (stream: {e})"))
                .unwrap_or_default()
        ))),
    }
}

/// Replays `jobs` through the RTL ICU `bin` against the model's ICU under `pr`.
pub fn replay_icu(
    p: &Params,
    bin: &Path,
    jobs: &[IcuJob],
    pr: Pressure,
    fst: Option<&Path>,
    describe: &dyn Fn(u32) -> String,
) -> Result<(Replay, Timing)> {
    let start = Instant::now();
    let f = p.f;
    let mut rng = Pcg64::seed_from_u64(pr.seed);
    let mut icu = Icu::new(p.div.stages);
    let depth = icu.depth();
    let mut input: Link<Job> = Link::new(1).wired(UnitId::RayBuffer(0), UnitId::Icu(0));
    let mut results: Vec<Link<JobResult>> =
        vec![Link::new(1).wired(UnitId::Icu(0), UnitId::Ctu(0, 0))];
    let mut remote: Link<RemoteResult> = Link::new(1);
    let mut expected_t: Vec<Option<i64>> = Vec::with_capacity(jobs.len());
    let rays: Vec<RayRecord> = jobs.iter().map(|j| j.ray).collect();
    let patches: Vec<PatchRecord> = jobs.iter().map(|j| j.patch).collect();
    let (mut cycles, mut stalled, mut hits) = (0u64, 0u64, 0u64);
    let (ins, sts) = (p.inputs(Unit::Icu), p.stages(Unit::Icu));
    let wi = ins.iter().map(|f| f.bits()).sum::<u32>().div_ceil(32) as usize;
    let ws = sts.iter().map(|f| f.bits()).sum::<u32>().div_ceil(32) as usize;
    let icu_widths = super::vectors::widths(&sts);
    let (mut scratch, mut inb, mut exp) = (Vec::new(), Packer::default(), Packer::default());
    let mut snapshot: Vec<u32> = Vec::new();
    if fst.is_some() && depth > 32 {
        return Err(Error::Param {
            key: "divider_bits_per_stage".into(),
            what: format!("gives {depth} ICU stages: a side-by-side waveform shows at most 32"),
        });
    }
    let mut model_error: Option<String> = None;
    let verdict = run_harness(bin, fst, &mut |s| {
        let mut next = 0usize;
        loop {
            if let Some(_r) = results[0].peek() {
                if pr.take >= 1.0 || rng.gen_bool(pr.take) {
                    let r = results[0].pop(UnitId::Ctu(0, 0));
                    let want = expected_t[r.slot as usize];
                    if r.t != want && model_error.is_none() {
                        model_error = Some(format!(
                            "the model's ICU gave t {:?} for vector {}, its stages {:?}",
                            r.t, r.slot, want
                        ));
                    }
                    hits += r.t.is_some() as u64;
                    results[0].commit();
                }
            }
            let mut new_job: Option<u32> = None;
            if input.is_empty() && next < jobs.len() && (pr.offer >= 1.0 || rng.gen_bool(pr.offer))
            {
                let j = &jobs[next];
                let t = icu_expected(p, &icu_widths, j, &mut scratch, &mut exp);
                expected_t.push(t);
                icu_inputs(&ins, j, &mut inb);
                new_job = Some(next as u32);
                input.push(
                    UnitId::RayBuffer(0),
                    Job {
                        ray: next as u32,
                        slot: next as u32,
                        patch: next as u32,
                        ctu: 0,
                        owner: 0,
                    },
                );
                input.commit();
                next += 1;
            }
            if next >= jobs.len() && input.is_empty() && icu.is_empty() && results[0].is_empty() {
                return Ok(());
            }
            let in_valid = input.valid();
            let out_ready = results[0].can_push();
            if fst.is_some() {
                snapshot.clear();
                let (mut mask, mut t_last) = (0u32, 0i64);
                let (mut rays_k, mut patches_k) = ([0u32; 32], [0u32; 32]);
                let mut k = 0;
                icu.for_each_stage(|v, r, pa, t| {
                    mask |= (v as u32) << k;
                    rays_k[k] = r as u32;
                    patches_k[k] = pa as u32;
                    if let Some(t) = t {
                        t_last = t;
                    }
                    k += 1;
                });
                snapshot.push(mask);
                snapshot.extend_from_slice(&rays_k[..depth]);
                snapshot.extend_from_slice(&patches_k[..depth]);
                snapshot.extend([t_last as u32, (t_last >> 32) as u32]);
            }
            let last_valid = icu.stage_job(depth - 1).is_some();
            let in_ready = !last_valid || out_ready;
            let before = icu.stats.results_out;
            let mut io = IcuPorts {
                cluster: 0,
                input: &mut input,
                results: &mut results,
                remote: &mut remote,
            };
            icu.tick(&mut io, &rays, &patches, &f);
            let accepted = in_valid && input.peek().is_none();
            if accepted != (in_valid && in_ready) && model_error.is_none() {
                model_error = Some(format!(
                    "the model's ICU accepted {accepted} at cycle {cycles}"
                ));
            }
            let fired = icu.stats.results_out > before;
            input.commit();
            results[0].commit();
            let fire_tag = if fired {
                results[0].peek().map(|r| r.slot)
            } else {
                None
            };
            stalled += (last_valid && !out_ready) as u64;
            let flags = in_valid as u32
                | (out_ready as u32) << 1
                | (in_ready as u32) << 2
                | (fired as u32) << 3
                | (new_job.is_some() as u32) << 4
                | (fst.is_some() as u32) << 5;
            s.word(flags)?;
            if let Some(tag) = new_job {
                s.word(tag)?;
                inb.pad_to(wi);
                exp.pad_to(ws);
                s.words(&inb.words)?;
                s.words(&exp.words)?;
            }
            if let Some(t) = fire_tag {
                s.word(t)?;
            }
            if fst.is_some() {
                s.words(&snapshot)?;
            }
            cycles += 1;
        }
    })?;
    if let Some(e) = model_error {
        return Err(Error::Check(e));
    }
    match verdict {
        Ok(_) => {
            let secs = start.elapsed().as_secs_f64();
            Ok((
                Replay {
                    unit: "icu",
                    vectors: jobs.len() as u64,
                    cycles,
                    stalled_cycles: stalled,
                    hits,
                    pressure: pr,
                },
                Timing {
                    seconds: secs,
                    vectors_per_second: jobs.len() as f64 / secs.max(1e-9),
                },
            ))
        }
        Err(line) => Err(mismatch(&line, p, Unit::Icu, describe)),
    }
}

/// Replays DDA vectors through the RTL DDA step `bin` (one registered stage) under `pr`.
pub fn replay_dda(
    p: &Params,
    bin: &Path,
    jobs: &[DdaJob],
    pr: Pressure,
    describe: &dyn Fn(u32) -> String,
) -> Result<(Replay, Timing)> {
    let start = Instant::now();
    let mut rng = Pcg64::seed_from_u64(pr.seed ^ 0xdda);
    let ins = p.inputs(Unit::Dda);
    let stage = p.stages(Unit::Dda).remove(0);
    let wi = ins.iter().map(|f| f.bits()).sum::<u32>().div_ceil(32) as usize;
    let ws = stage.bits().div_ceil(32) as usize;
    let (mut cycles, mut stalled) = (0u64, 0u64);
    let verdict = run_harness(bin, None, &mut |s| {
        let mut next = 0usize;
        let mut offered = false;
        let mut reg: Option<u32> = None;
        let mut out_ready = true;
        loop {
            let mut new_job = None;
            if !offered && next < jobs.len() && (pr.offer >= 1.0 || rng.gen_bool(pr.offer)) {
                let j = &jobs[next];
                let (mut i, mut e) = (dda_inputs(&ins, j), dda_expected(p, &stage, j));
                i.pad_to(wi);
                e.pad_to(ws);
                new_job = Some((next as u32, i, e));
                offered = true;
                next += 1;
            }
            if !offered && reg.is_none() && next >= jobs.len() {
                return Ok(());
            }
            if reg.is_some() {
                out_ready = pr.take >= 1.0 || rng.gen_bool(pr.take);
            }
            let in_ready = reg.is_none() || out_ready;
            let fire = reg.filter(|_| out_ready);
            stalled += !in_ready as u64;
            let flags = offered as u32
                | (out_ready as u32) << 1
                | (in_ready as u32) << 2
                | (fire.is_some() as u32) << 3
                | (new_job.is_some() as u32) << 4;
            s.word(flags)?;
            if let Some((tag, i, e)) = &new_job {
                s.word(*tag)?;
                s.words(&i.words)?;
                s.words(&e.words)?;
            }
            if let Some(t) = fire {
                s.word(t)?;
            }
            if in_ready {
                reg = offered.then_some((next - 1) as u32);
                offered = false;
            }
            cycles += 1;
        }
    })?;
    match verdict {
        Ok(_) => {
            let secs = start.elapsed().as_secs_f64();
            Ok((
                Replay {
                    unit: "dda",
                    vectors: jobs.len() as u64,
                    cycles,
                    stalled_cycles: stalled,
                    hits: 0,
                    pressure: pr,
                },
                Timing {
                    seconds: secs,
                    vectors_per_second: jobs.len() as f64 / secs.max(1e-9),
                },
            ))
        }
        Err(line) => Err(mismatch(&line, p, Unit::Dda, describe)),
    }
}

/// What `shellsim cosim` runs.
#[derive(Clone, Debug)]
pub struct Options {
    pub cfg: shellsim_hw::config::MachineConfig,
    /// ICU vectors in all (the DDA gets a quarter as many states).
    pub vectors: u64,
    /// Scenes whose walks give vectors (name, scene).
    pub scenes: Vec<(String, crate::scene::Scene)>,
    pub seed: u64,
    /// The back-pressure of the cycle-by-cycle run.
    pub pressure: Pressure,
    /// Where the RTL ICU's waveform of the first vectors goes (FST), if anywhere.
    pub fst: Option<PathBuf>,
}

/// What `shellsim cosim` found: every run's figures, bit-exact (a mismatch is an error).
#[derive(Clone, Debug, serde::Serialize)]
pub struct Report {
    pub frac_bits: u32,
    pub sources: super::vectors::Sources,
    pub runs: Vec<Replay>,
}

/// Wall-clock figures of one step of a co-simulation: its name, build seconds (0 for a
/// replay) and replay rate.
pub type Timings = Vec<(String, f64, Timing)>;

/// Jobs in one harness run at most (memory stays bounded at any vector count).
const CHUNK: usize = 1 << 20;

fn describe_icu<'a>(what: &str, jobs: &'a [IcuJob]) -> impl Fn(u32) -> String + 'a {
    let what = what.to_string();
    move |tag: u32| {
        let Some(j) = jobs.get(tag as usize) else {
            return what.clone();
        };
        format!(
            "{what}; ray o {:?} d {:?}, patch of {} vertices {:?}",
            j.ray.o,
            j.ray.d,
            j.patch.n_verts,
            &j.patch.v[..j.patch.n_verts as usize]
        )
    }
}

/// Runs the co-simulation: builds both units, replays the ICU's vectors at full rate (in
/// chunks), a part of them again under back-pressure, and the DDA's states.
pub fn run(o: &Options, progress: &mut dyn FnMut(&str)) -> Result<(Report, Timings)> {
    use super::vectors::*;
    let p = Params::new(&o.cfg)?;
    let mut timings = vec![];
    let icu = build(&p, Unit::Icu, o.fst.is_some(), super::SOURCES)?;
    timings.push((
        "build icu".to_string(),
        icu.build_seconds,
        Timing::default(),
    ));
    let dda = build(&p, Unit::Dda, false, super::SOURCES)?;
    timings.push((
        "build dda".to_string(),
        dda.build_seconds,
        Timing::default(),
    ));
    let n = o.vectors as usize;
    let mut sources = Sources::default();
    let mut runs = vec![];
    // Scenes and stability cases first (their share of n), then directed and random.
    let mut real: Vec<IcuJob> = vec![];
    let mut walks: Vec<DdaJob> = vec![];
    for (name, scene) in &o.scenes {
        let cell = scene.bounds.scale() / 20.0;
        let host =
            crate::fixed::records::HostFixed::new(scene, Path::new(name), o.cfg.datapath, cell)?;
        let before = real.len();
        scene_jobs(scene, &host, 16, 64, &mut real, &mut walks);
        real.truncate(before + (n * 3 / 10 / o.scenes.len().max(1)).max(1));
    }
    keep_fitting_icu(&p, &mut real);
    sources.scenes = real.len() as u64;
    let before = real.len();
    let cases = crate::stability::all_cases().len().max(1);
    sources.stability_cases = stability_jobs(&p, 400, o.seed, (n / 10 / cases).max(1), &mut real);
    sources.stability = (real.len() - before) as u64;
    if real.len() > n {
        return Err(Error::Usage(format!(
            "--vectors {n} is fewer than the scenes' and the stability cases' {} vectors: ask for at least that many",
            real.len()
        )));
    }
    let mut done = 0usize;
    let mut chunk_no = 0u64;
    let mut first = true;
    let mut full_seconds = 0.0;
    while done < n {
        let mut jobs: Vec<IcuJob> = if first {
            std::mem::take(&mut real)
        } else {
            vec![]
        };
        let room = CHUNK.min(n - done).saturating_sub(jobs.len());
        let directed = room / 2;
        let seed = o.seed.wrapping_add(chunk_no);
        jobs.extend(directed_and_random(&p, directed, seed, true));
        jobs.extend(directed_and_random(&p, room - directed, seed, false));
        sources.directed += directed as u64;
        sources.random += (room - directed) as u64;
        progress(&format!("icu: vectors {}..{}", done, done + jobs.len()));
        let label = if first {
            "scene, stability, directed or random vector"
        } else {
            "directed or random vector"
        };
        let (r, t) = replay_icu(
            &p,
            &icu.binary,
            &jobs,
            Pressure::FULL,
            if first { o.fst.as_deref() } else { None },
            &describe_icu(label, &jobs),
        )?;
        full_seconds += t.seconds;
        done += jobs.len();
        merge(&mut runs, r);
        first = false;
        chunk_no += 1;
    }
    timings.push((
        "icu at full rate".to_string(),
        0.0,
        Timing {
            seconds: full_seconds,
            vectors_per_second: n as f64 / full_seconds.max(1e-9),
        },
    ));
    // The cycle-by-cycle run under back-pressure.
    let bp = directed_and_random(&p, n.min(1 << 18), o.seed ^ 0xbac, true);
    progress(&format!("icu under back-pressure: {} vectors", bp.len()));
    let (r, t) = replay_icu(
        &p,
        &icu.binary,
        &bp,
        o.pressure,
        None,
        &describe_icu("back-pressure vector", &bp),
    )?;
    timings.push(("icu back-pressure".to_string(), 0.0, t));
    runs.push(r);
    // The DDA: the scenes' walks, then random walks.
    let m = (n / 4).clamp(1, CHUNK);
    keep_fitting_dda(&p, &mut walks);
    walks.truncate(m / 2);
    let more = m - walks.len();
    walks.extend(random_dda(&p, more, o.seed));
    progress(&format!("dda: {} states", walks.len()));
    let desc = |tag: u32| {
        walks
            .get(tag as usize)
            .map(|j| format!("state {:?}, t {}", j.regs, j.t))
            .unwrap_or_default()
    };
    let (r, t) = replay_dda(&p, &dda.binary, &walks, o.pressure, &desc)?;
    timings.push(("dda".to_string(), 0.0, t));
    runs.push(r);
    Ok((
        Report {
            frac_bits: p.f.coord.frac_bits,
            sources,
            runs,
        },
        timings,
    ))
}

/// Adds a chunk's figures to the full-rate ICU run.
fn merge(runs: &mut Vec<Replay>, r: Replay) {
    match runs
        .iter_mut()
        .find(|x| x.unit == r.unit && x.pressure == r.pressure)
    {
        Some(x) => {
            x.vectors += r.vectors;
            x.cycles += r.cycles;
            x.stalled_cycles += r.stalled_cycles;
            x.hits += r.hits;
        }
        None => runs.push(r),
    }
}
