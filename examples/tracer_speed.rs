//! Float tracer throughput on one thread, the one-ray path against the packet path, on the
//! paper's ray count (969 rings rays) from 50 sources; optionally writes the scene's
//! triangles (fans of the patches) and the rays as raw little-endian arrays for
//! `ci/embree_ratio.py`.
//!
//! `cargo run --release --example tracer_speed -- SCENE [--reps R] [--dump DIR]`, SCENE a
//! scene file or `cornell-N` (the Cornell room with N×N walls,
//! `scene gen corpus-subdivided-cornell --n N`). The grid is the sized default (`--cell
//! auto`). Prints one JSON line.

use shellsim::paper::PAPER_RAYS;
use shellsim::reference::rays::{hemisphere_rays, Directions, Origins};
use shellsim::reference::tracer::{Hit, Ray, TraceCounts, Tracer};
use shellsim::scene::Scene;
use shellsim_hw::config::Length;
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// Sources per scene.
const SOURCES: usize = 50;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().expect("a scene file or cornell-N");
    let opt = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .map(|i| args[i + 1].clone())
    };
    let reps: usize = opt("--reps").map_or(5, |r| r.parse().expect("--reps R"));
    let scene = match name.strip_prefix("cornell-") {
        Some(n) => shellsim::scene::gen::corpus::subdivided_cornell(n.parse().expect("cornell-N")),
        None => Scene::load(Path::new(name)).unwrap_or_else(|e| panic!("{e}")),
    };
    let cell = shellsim::config::cell_size(Length::Auto, scene.size());
    let tracer = Tracer::new(&scene, cell).unwrap();
    // Source k·N/50 with seed k: 50 ray sets even when the scene has fewer patches.
    let n = scene.patches.len();
    let bundles: Vec<(u32, Vec<Ray>)> = (0..SOURCES)
        .map(|k| {
            let src = k * n / SOURCES;
            let set = hemisphere_rays(
                &scene.patches[src],
                PAPER_RAYS,
                Directions::Rings,
                Origins::Patch,
                k as u64 + 1,
            );
            (src as u32, set.rays)
        })
        .collect();
    let rays: usize = bundles.iter().map(|(_, r)| r.len()).sum();

    let one = |out: &mut Vec<(Option<Hit>, TraceCounts)>| {
        out.clear();
        for (src, rs) in &bundles {
            out.extend(rs.iter().map(|r| tracer.trace_counted(r, Some(*src))));
        }
    };
    let packet = |out: &mut Vec<(Option<Hit>, TraceCounts)>| {
        out.clear();
        for (src, rs) in &bundles {
            let k = out.len();
            out.resize(k + rs.len(), (None, TraceCounts::default()));
            tracer.trace_packet(rs, Some(*src), &mut out[k..]);
        }
    };
    let (mut a, mut b) = (Vec::with_capacity(rays), Vec::with_capacity(rays));
    // Interleaved, min of `reps` each.
    let (mut t_one, mut t_packet, mut t_dda) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
    for _ in 0..reps {
        let s = Instant::now();
        one(&mut a);
        t_one = t_one.min(s.elapsed().as_secs_f64());
        let s = Instant::now();
        packet(&mut b);
        t_packet = t_packet.min(s.elapsed().as_secs_f64());
    }
    let equal = |a: &[(Option<Hit>, TraceCounts)], b: &[(Option<Hit>, TraceCounts)]| {
        a.len() == b.len()
            && a.iter().zip(b).all(|((ha, ca), (hb, cb))| {
                ca == cb
                    && match (ha, hb) {
                        (None, None) => true,
                        (Some(x), Some(y)) => x.patch == y.patch && x.t.to_bits() == y.t.to_bits(),
                        _ => false,
                    }
            })
    };
    let same = equal(&a, &b);
    // The grid walk alone (setup and the same number of steps, no patch tests): what the
    // counts oblige any exact path to do.
    let mut sink = 0usize;
    for _ in 0..reps {
        let s = Instant::now();
        let mut k = 0;
        for (_, rs) in &bundles {
            for r in rs {
                if let Some(mut d) = tracer.dda(r) {
                    for _ in 1..a[k].1.cells {
                        d.step();
                    }
                    sink = sink.wrapping_add(d.cell());
                }
                k += 1;
            }
        }
        t_dda = t_dda.min(s.elapsed().as_secs_f64());
    }
    std::hint::black_box(sink);
    let per =
        |f: fn(&TraceCounts) -> u32| a.iter().map(|(_, c)| f(c) as f64).sum::<f64>() / rays as f64;
    if let Some(dir) = opt("--dump") {
        dump(Path::new(&dir), &scene, &bundles, &a);
    }
    println!(
        "{{\"scene\":\"{}\",\"patches\":{},\"scale\":{},\"cell\":{},\"rays\":{},\"one_s\":{},\"packet_s\":{},\"dda_only_s\":{},\
         \"identical\":{},\"cells_per_ray\":{:.2},\"nonempty_per_ray\":{:.2},\"tests_per_ray\":{:.2}}}",
        scene.name,
        n,
        scene.bounds.scale(),
        cell,
        rays,
        t_one,
        t_packet,
        t_dda,
        same,
        per(|c| c.cells),
        per(|c| c.nonempty_cells),
        per(|c| c.tests)
    );
    assert!(same, "the paths differ");
}

/// Writes `tris.f64` (9 per triangle: a fan of each patch), `tri_patch.u32`, `rays.f64` (6
/// per ray: origin, direction), `ray_source.u32` and `hits.i64` (our nearest patch, −1 for
/// none), all little-endian.
fn dump(
    dir: &Path,
    scene: &Scene,
    bundles: &[(u32, Vec<Ray>)],
    hits: &[(Option<Hit>, TraceCounts)],
) {
    std::fs::create_dir_all(dir).unwrap();
    let file = |name: &str| std::io::BufWriter::new(std::fs::File::create(dir.join(name)).unwrap());
    let (mut tris, mut tri_patch) = (file("tris.f64"), file("tri_patch.u32"));
    for (id, p) in scene.patches.iter().enumerate() {
        let v = &p.vertices;
        for k in 1..v.len() - 1 {
            for x in [v[0], v[k], v[k + 1]] {
                for c in x.to_array() {
                    tris.write_all(&c.to_le_bytes()).unwrap();
                }
            }
            tri_patch.write_all(&(id as u32).to_le_bytes()).unwrap();
        }
    }
    let (mut rays, mut srcs, mut out) =
        (file("rays.f64"), file("ray_source.u32"), file("hits.i64"));
    for (src, rs) in bundles {
        for r in rs {
            for c in r.o.to_array().into_iter().chain(r.d.to_array()) {
                rays.write_all(&c.to_le_bytes()).unwrap();
            }
            srcs.write_all(&src.to_le_bytes()).unwrap();
        }
    }
    for (h, _) in hits {
        let id = h.map_or(-1i64, |h| h.patch as i64);
        out.write_all(&id.to_le_bytes()).unwrap();
    }
}
