//! Property tests of the fixed-point datapath: on random patches and rays the fixed result
//! equals the float reference's unless the case falls in an explained class; a record value
//! outside its format is always reported as overflow.

use glam::DVec3;
use proptest::prelude::*;
use shellsim::fixed::check::check;
use shellsim::fixed::records::HostFixed;
use shellsim::reference::rays::RaySet;
use shellsim::reference::tracer::{Ray, Tracer};
use shellsim::scene::{Aabb, Patch, Scene};
use shellsim_hw::datapath::intersect;
use shellsim_hw::{DatapathConfig, Exceptions, PatchRecord, RayRecord};
use std::path::Path;

fn point() -> impl Strategy<Value = DVec3> {
    (0.05f64..0.95, 0.05f64..0.95, 0.05f64..0.95).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

/// A random valid patch: a triangle, or a parallelogram (always planar and convex).
fn patch() -> impl Strategy<Value = Patch> {
    (point(), point(), point(), any::<bool>()).prop_filter_map("degenerate", |(a, b, c, quad)| {
        let verts = if quad {
            vec![a, b, c, a + c - b]
        } else {
            vec![a, b, c]
        };
        let p = Patch::new(verts, 0.0, 0.5);
        let inside = p
            .vertices
            .iter()
            .all(|v| v.cmpge(DVec3::ZERO).all() && v.cmple(DVec3::ONE).all());
        (inside && p.check().is_ok() && p.area() > 1e-4).then_some(p)
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn fixed_equals_float_unless_explained(
        patches in prop::collection::vec(patch(), 1..6),
        o in point(),
        d in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
        aim in (0.0f64..1.0, 0.0f64..1.0, any::<bool>()),
        frac_bits in 10u32..=24,
    ) {
        // Half the rays are aimed at a point of the first patch (on or near an edge when a
        // weight is near 0), so that most cases are hits rather than misses.
        let d = if aim.2 {
            let v = &patches[0].vertices;
            let (u, w) = (aim.0 * aim.0, aim.1);
            let target = v[0] + (v[1] - v[0]) * (1.0 - u) * w + (v[2] - v[0]) * (1.0 - u) * (1.0 - w) * u;
            target - o
        } else {
            DVec3::new(d.0, d.1, d.2)
        };
        prop_assume!(d.length() > 0.05);
        let scene = Scene {
            name: "prop".into(),
            bounds: Aabb { lo: DVec3::ZERO, hi: DVec3::ONE },
            patches,
        };
        let cfg = DatapathConfig { frac_bits, t_frac_bits: frac_bits, ..shellsim_hw::config::paper().datapath };
        let tracer = Tracer::new(&scene, 0.05).unwrap();
        let host = HostFixed::new(&scene, Path::new("prop"), cfg, 0.05).unwrap();
        let set = RaySet { rays: vec![Ray { o, d }], weights: vec![1.0] };
        // No source to exclude: use an id past the end.
        let r = check(&tracer, &host, &set, u32::MAX, Default::default());
        prop_assert_eq!(r.unexplained_mismatches, 0, "{:?}", r.unexplained);
    }

    #[test]
    fn out_of_format_values_are_always_reported(
        v in prop::collection::vec(-(1i64 << 26)..(1i64 << 26), 12),
        o in prop::collection::vec(-(1i64 << 21)..(1i64 << 21), 3),
    ) {
        let cfg = shellsim_hw::config::paper().datapath;
        let f = cfg.formats().unwrap();
        let mut p = PatchRecord { id: 0, n_verts: 4, v: [[0; 3]; 4] };
        for k in 0..4 {
            for a in 0..3 {
                p.v[k][a] = v[3 * k + a];
            }
        }
        let r = RayRecord::new(0, [o[0], o[1], o[2]], [0, 0, 1 << f.dir.frac_bits], &f);
        let mut exc = Exceptions::default();
        let _ = intersect(&r, &p, &f, &mut exc);
        let out_of_range = p.v.iter().any(|vk| (0..3).any(|a| !f.translated.fits((vk[a] - r.o[a]) as i128)));
        prop_assert_eq!(exc.overflow > 0, out_of_range);
    }
}
