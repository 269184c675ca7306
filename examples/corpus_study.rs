//! The corpus study of issue 30: the float reference against the untimed fixed-point model
//! on closed scenes no one tuned for (src/scene/gen/corpus.rs), over fractional widths, at
//! 10^5 random rays per scene and width (four sampled sources × 25,000), written as the
//! Markdown table of docs/corpus-study.md:
//! `cargo run --release --example corpus_study -- [small|large] [RAYS_PER_SOURCE] > docs/corpus-study.md`
//! (25,000 rays per source by default; 2,500,000 gives 10^7 per scene and width, which
//! ci/corpus-study.sbatch runs as a Slurm array, one task per scene and width).
//! The machine equals the fixed-point model ray for ray (checked by every `run` and
//! `matrix --model machine`), so its leaks are the fixed model's.

use rayon::prelude::*;
use shellsim::fixed::check::check;
use shellsim::fixed::records::HostFixed;
use shellsim::reference::orient::closure;
use shellsim::reference::rays::{hemisphere_rays, Directions, Origins};
use shellsim::reference::tracer::Tracer;
use shellsim::scene::gen::corpus::{corpus, CorpusSize};
use std::path::Path;

fn main() {
    let large = std::env::args().nth(1).as_deref() == Some("large");
    let rays: usize = std::env::args()
        .nth(2)
        .map_or(25_000, |s| s.parse().expect("RAYS_PER_SOURCE is a count"));
    let scenes = corpus(if large {
        CorpusSize::Large
    } else {
        CorpusSize::Small
    });
    let widths: &[u32] = if large { &[12] } else { &[8, 10, 12, 14, 16] };
    // `SHARD=header` prints the header only; `SHARD=i` the row of case i alone (cases are
    // scene-major over the widths), for a Slurm array (ci/corpus-study.sbatch).
    let shard = std::env::var("SHARD").ok();
    let case: Option<usize> = match shard.as_deref() {
        None | Some("header") => None,
        Some(i) => Some(i.parse().expect("SHARD is `header` or a case number")),
    };
    if let Some(i) = case {
        assert!(
            i < scenes.len() * widths.len(),
            "SHARD={i}: there are {} cases",
            scenes.len() * widths.len()
        );
    }
    if case.is_none() {
        header(large, rays);
    }
    if shard.as_deref() == Some("header") {
        return;
    }
    // `ONLY=NAME` and `WIDTH=F` narrow a run to one scene and width (for a closer look).
    let only = case
        .map(|i| scenes[i / widths.len()].name.clone())
        .or_else(|| std::env::var("ONLY").ok());
    let width: Option<u32> = case
        .map(|i| widths[i % widths.len()])
        .or_else(|| std::env::var("WIDTH").ok().and_then(|w| w.parse().ok()));

    let widths: Vec<u32> = widths
        .iter()
        .copied()
        .filter(|&f| width.is_none_or(|w| w == f))
        .collect();
    for scene in scenes
        .iter()
        .filter(|s| only.as_ref().is_none_or(|o| &s.name == o))
    {
        let cell = scene.bounds.scale() / 20.0;
        let tracer = Tracer::new(scene, cell).expect("a corpus scene builds");
        let closed = closure(scene, &tracer).closed();
        let n = scene.patches.len();
        let sources = [0, n / 3, n / 2, n - 1];
        let rows: Vec<String> = widths
            .par_iter()
            .map(|&f| {
                let mut cfg = shellsim_hw::config::paper().datapath;
                cfg.frac_bits = f;
                cfg.t_frac_bits = f;
                let host = HostFixed::new(scene, Path::new(&scene.name), cfg, cell)
                    .expect("a corpus scene fits");
                let (mut esc, mut leaks, mut crowded, mut mism, mut unex, mut sig) = (0, 0, 0, 0, 0, 0.0f64);
                let mut pass = true;
                for &s in &sources {
                    let set = hemisphere_rays(
                        &scene.patches[s],
                        rays,
                        Directions::Random,
                        Origins::Patch,
                        s as u64,
                    );
                    let r = check(&tracer, &host, &set, s as u32, Default::default());
                    esc += r.escaped_float;
                    leaks += r.leaked;
                    crowded += r.leaked_crowded;
                    mism += r.mismatches;
                    unex += r.unexplained_mismatches;
                    sig = sig.max(r.ff_err_sigmas);
                    if let (Some(l), Ok(_)) = (r.leaks.first(), std::env::var("SHOW_LEAKS")) {
                        eprintln!("{} F={f} source {s}: {l:?}", scene.name);
                    }
                    pass &= r.verdict(None).is_ok();
                }
                format!(
                    "| {} | {n} | {} | {f} | {} | {esc} | {leaks} ({crowded}) | {mism} | {unex} | {sig:.2} | {} |",
                    scene.name,
                    if closed { "yes" } else { "no" },
                    rays * sources.len(),
                    if pass { "pass" } else { "fail" }
                )
            })
            .collect();
        for r in rows {
            println!("{r}");
        }
    }
}

/// The table's title, legend and header.
fn header(large: bool, rays: usize) {
    println!("# Corpus study (issue 30)\n");
    println!(
        "Generated by `cargo run --release --example corpus_study -- {} {rays}`: per scene and fractional \
         width F, {rays} random rays from each of four sources (ids 0, n/3, n/2, n − 1, seeded by \
         the id), the float reference against the untimed fixed-point model (`check`). `closed`: \
         the float reference's closure probe (`scene info`). `leaks`: rays the fixed-point model \
         lost where the float reference hit a patch (in brackets: of those, rays whose origin no lattice point 2 LSB clear of every patch could hold — a source only a few LSBs wide; watertightness is promised for the others). `σ`: the largest form-factor error over the \
         four sources in units of the float estimate's sampling error. `verdict`: `check`'s. \
         As a Slurm array of one task per row: ci/corpus-study.sbatch \
         (`bash ci/slurm-check.sh --study ci/corpus-study.sbatch` runs it on a private one-node \
         cluster: 40 tasks and the merge, 1,106 s on 2 cores).\n",
        if large { "large" } else { "small" }
    );
    println!("| scene | patches | closed | F | rays | float escaped | leaks | mismatches | unexplained | σ | verdict |");
    println!("| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |");
}
