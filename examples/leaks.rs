//! Diagnostic: lists the rays the fixed-point model loses where the float reference hits a
//! patch (`[FRAC_BITS=F] cargo run --release --example leaks -- SCENE RAYS [rings|malley|random]`).
use shellsim::fixed::records::HostFixed;
use shellsim::reference::rays::{hemisphere_rays, Directions, Origins};
use shellsim::reference::tracer::Tracer;
use shellsim_hw::Exceptions;
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = Path::new(&args[1]);
    let n: usize = args[2].parse().unwrap();
    let dirs = match args.get(3).map(|s| s.as_str()) {
        Some("random") => Directions::Random,
        Some("malley") => Directions::Malley,
        _ => Directions::Rings,
    };
    let scene = shellsim::scene::Scene::load(path).unwrap();
    let tr = Tracer::new(&scene, 0.05 * scene.bounds.scale()).unwrap();
    let mut cfg = shellsim_hw::config::paper().datapath;
    if let Some(f) = std::env::var("FRAC_BITS").ok().and_then(|f| f.parse().ok()) {
        cfg.frac_bits = f;
        cfg.t_frac_bits = f;
    }
    let host = HostFixed::new(&scene, path, cfg, 0.05 * scene.bounds.scale()).unwrap();
    let mut total = 0;
    let only: Option<u32> = std::env::var("SOURCE").ok().and_then(|s| s.parse().ok());
    for s in (0..scene.patches.len() as u32).filter(|s| only.is_none_or(|o| o == *s)) {
        let seed = if args.get(4).map(String::as_str) == Some("by-source") {
            s as u64
        } else {
            1
        };
        let set = hemisphere_rays(&scene.patches[s as usize], n, dirs, Origins::Patch, seed);
        let mut esc = 0;
        let mut fesc = 0;
        let mut crowded = 0;
        for (k, ray) in set.rays.iter().enumerate() {
            let fl = tr.trace(ray, Some(s));
            if fl.is_none() {
                fesc += 1;
            }
            let (r, pl) = host.ray_placed(k as u32, ray, s).unwrap();
            if pl != shellsim::fixed::origin::Placement::Clear {
                crowded += 1;
                if crowded <= 2 {
                    println!("src {s} ray {k} {pl:?} o {:?}", ray.o);
                }
            }
            let mut e = Exceptions::default();
            let h = host.scene.nearest_grid(&r, Some(s), &mut e).0;
            if h.is_none() && fl.is_some() {
                esc += 1;
                let hb = host.scene.nearest_brute(&r, Some(s), &mut e);
                if esc <= 3 {
                    println!("src {s} ray {k} o {:?} d {:?} oq {:?} dq {:?} float {:?} brute {:?} exc {:?}", ray.o, ray.d, r.o, r.d, fl, hb, e);
                }
            }
        }
        if esc > 0 || fesc > 0 || crowded > 0 {
            println!("source {s}: fixed escaped {esc}, float escaped {fesc}, crowded {crowded}");
        }
        total += esc;
    }
    println!("total {total}");
}
