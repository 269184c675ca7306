//! Faces whose front side faces out of the enclosure, found with the float tracer.
//!
//! **Rule.** For each patch, [`ORIENT_RAYS`] Malley rays (seeded) are cast over its front
//! hemisphere and as many over its back hemisphere. A ray *escapes* when it hits nothing; it
//! *sees the outside* when it escapes or hits a patch's back side (inside a consistently
//! oriented enclosure every ray from a front side hits a front side, or leaves through an
//! opening). The patch faces outward when
//! 1. every front ray escapes and at most half of its back rays do (its front sees only the
//!    outside, its back sees the scene: a wall turned out of the room, or every wall of a
//!    file wound the other way), or
//! 2. the fraction of front rays that see the outside exceeds that of the back rays by more
//!    than [`ORIENT_MARGIN`] (a face of a block turned into the block, whose front then sees
//!    the block's other faces from behind).
//!
//! The margin keeps a light just below the ceiling, whose back sees the ceiling's front,
//! from being counted. Not found: a light turned to face the ceiling (both sides see front
//! sides), and a closed object whose faces are *all* turned inward (an enclosure of its own).

use crate::reference::rays::{hemisphere_rays, Directions, Origins, RaySet};
use crate::reference::tracer::Tracer;
use crate::scene::{Patch, Scene};
use rayon::prelude::*;

/// Rays per side of each patch.
pub const ORIENT_RAYS: usize = 64;

/// How much more often (as a fraction of the rays) a patch's front rays must see the
/// outside than its back rays for rule 2.
pub const ORIENT_MARGIN: f64 = 0.5;

/// Seed of the rays' origins and directions.
pub const ORIENT_SEED: u64 = 1;

/// What one side's rays saw: the fractions that escaped and that saw the outside.
fn side(tracer: &Tracer, set: &RaySet, source: u32) -> (f64, f64) {
    let (mut escaped, mut back) = (0usize, 0usize);
    for r in &set.rays {
        match tracer.trace(r, Some(source)) {
            None => escaped += 1,
            Some(h) if tracer.patches[h.patch as usize].normal.dot(r.d) > 0.0 => back += 1,
            Some(_) => {}
        }
    }
    let n = set.len() as f64;
    (escaped as f64 / n, (escaped + back) as f64 / n)
}

/// The ids of the patches of `scene` (traced by `tracer`) whose front side faces out of the
/// enclosure, by the rule above; deterministic, in id order.
pub fn outward_faces(scene: &Scene, tracer: &Tracer) -> Vec<u32> {
    let rays = |p: &Patch| {
        hemisphere_rays(
            p,
            ORIENT_RAYS,
            Directions::Malley,
            Origins::Patch,
            ORIENT_SEED,
        )
    };
    (0..scene.patches.len() as u32)
        .into_par_iter()
        .filter(|&id| {
            let p = &scene.patches[id as usize];
            let mut turned = p.clone();
            turned.flip();
            let (front_esc, front_out) = side(tracer, &rays(p), id);
            let (back_esc, back_out) = side(tracer, &rays(&turned), id);
            (front_esc == 1.0 && back_esc <= 0.5) || front_out > back_out + ORIENT_MARGIN
        })
        .collect()
}

/// What the closure probe found: a scene is *closed* when no probe ray escapes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Closure {
    /// Probe rays cast ([`ORIENT_RAYS`] Malley rays from each patch's front side).
    pub rays: u64,
    pub escaped: u64,
    /// A patch from which a probe ray escaped (the smallest id), if any.
    pub open_at: Option<u32>,
}

impl Closure {
    /// True when no probe ray escaped: a leak from this scene is a model's fault.
    pub fn closed(&self) -> bool {
        self.escaped == 0
    }
}

/// The closure probe of `scene` with the float reference: [`ORIENT_RAYS`] Malley rays
/// (seed [`ORIENT_SEED`]) from every patch's front side; deterministic.
pub fn closure(scene: &Scene, tracer: &Tracer) -> Closure {
    let escaped: Vec<u64> = (0..scene.patches.len() as u32)
        .into_par_iter()
        .map(|id| {
            let set = hemisphere_rays(
                &scene.patches[id as usize],
                ORIENT_RAYS,
                Directions::Malley,
                Origins::Patch,
                ORIENT_SEED,
            );
            set.rays
                .iter()
                .filter(|r| tracer.trace(r, Some(id)).is_none())
                .count() as u64
        })
        .collect();
    Closure {
        rays: (ORIENT_RAYS * scene.patches.len()) as u64,
        escaped: escaped.iter().sum(),
        open_at: escaped.iter().position(|&e| e > 0).map(|p| p as u32),
    }
}
