//! Shells and subshells: how the shelling machine works through one bundle of rays (a
//! sector, or in the low-resolution pass a subregion), with the work counted as the machine
//! does it.
//!
//! **Shells** are concentric about the source patch's centroid, `radius` apart. Every cell
//! step of a ray belongs to the shell holding the step's entry point,
//! `|o + t_enter·d − centroid|` — so one cell may be in shell 1 for one ray and shell 2
//! for another, and along one ray the shell index first falls (the ray leaves the patch
//! towards the point nearest the centroid) and then rises.
//!
//! Shells are processed in increasing order. Within a shell, the bundle's **remaining**
//! rays (not yet retired) step through the shell's cells; the shell's unprocessed cells
//! those rays step through, ordered by their least entry distance (then cell id) — the
//! *traversal order* — are cut into consecutive **subshells**, each adding at most
//! `subshell_max` new active patches (a single cell with more forms a subshell of its own).
//! For each subshell:
//! - *cells*: its nonempty cells in traversal order (a cell is nonempty when it lists a
//!   patch other than the source);
//! - *active patches*: the patches of those cells that the bundle has not loaded before
//!   (each patch is loaded once per bundle; the source is never loaded);
//! - *rays*: the remaining rays at its start;
//! - *traversals*: every cell step of a remaining ray through one of its cells (empty
//!   cells included: the CTU steps through them too);
//! - *intersections*: remaining rays × active patches — the bundle is tested against every
//!   active patch, as the ICU does, not just the patches of each ray's own cells.
//!
//! After a subshell, a ray **retires** when its best hit so far, plus a slack of 1e-9 of
//! the grid's diagonal (the float tracer's stopping slack), lies before the entry of every
//! cell step of the ray not yet processed — no unprocessed cell can hold a nearer hit, nor
//! an equally near one with a smaller id. A ray with no hit retires when it has no
//! unprocessed step left.
//!
//! **Invariant:** every remaining ray is tested against every active patch, and a ray
//! retires only when no unprocessed cell can hold a closer hit; so each ray's nearest hit
//! equals [`Tracer::trace`] with the source excluded (identical id and bits of t — a test
//! checks every ray of scene1 and scene2).
//!
//! **Invariant:** the work does not depend on the thread count: bundles are independent
//! and every order inside one is fixed (ray order, traversal order, patch id order).

use crate::reference::grid::Grid;
use crate::reference::tracer::{Hit, LocalRay, Ray, Tracer};
use glam::DVec3;
use rayon::prelude::*;
use std::collections::HashMap;

/// Shell parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShellParams {
    /// Radius step of the shells about the source's centroid (the paper's 0.289).
    pub radius: f64,
    /// Most new active patches a subshell may add (a single cell may exceed it).
    pub subshell_max: usize,
}

impl Default for ShellParams {
    /// The built-in configuration's `machine.shell_radius` (for a scene of scale 1, the
    /// unit cube: see `config::shell_radius`) and `machine.subshell_max_patches`
    /// (hw/configs/paper.toml).
    fn default() -> Self {
        let m = &crate::config::built_in().machine;
        ShellParams {
            radius: crate::config::shell_radius(m.shell_radius, 1.0),
            subshell_max: m.subshell_max_patches as usize,
        }
    }
}

/// One cell step of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// Linear cell id.
    pub cell: u32,
    /// The shell of the step's entry point.
    pub shell: u32,
    /// Ray parameter where the ray enters the cell.
    pub t_enter: f64,
    /// Distance of the entry point from the source's centroid.
    pub dist: f64,
}

/// The walks of a ray set: every cell each ray steps through, in order, until it leaves
/// the grid (the same stepping as [`Tracer::trace`], through [`Tracer::cells_along`]).
#[derive(Clone, Debug)]
pub struct Walks {
    offsets: Vec<usize>,
    steps: Vec<Step>,
}

impl Walks {
    /// Walks every ray of `rays` to the grid's end; shells about `centre`.
    pub fn new(tracer: &Tracer, rays: &[Ray], centre: DVec3, radius: f64) -> Walks {
        let per_ray: Vec<Vec<Step>> = rays
            .par_iter()
            .with_min_len(256)
            .map(|ray| {
                let mut v = Vec::with_capacity(48);
                tracer.cells_along(ray, f64::INFINITY, |cell, t_enter, _| {
                    let dist = (ray.o + ray.d * t_enter).distance(centre);
                    let shell = (dist / radius).floor().min(u32::MAX as f64) as u32;
                    v.push(Step {
                        cell: cell as u32,
                        shell,
                        t_enter,
                        dist,
                    });
                });
                v
            })
            .collect();
        let mut offsets = Vec::with_capacity(rays.len() + 1);
        offsets.push(0);
        let mut steps = Vec::with_capacity(per_ray.iter().map(Vec::len).sum());
        for v in per_ray {
            steps.extend(v);
            offsets.push(steps.len());
        }
        Walks { offsets, steps }
    }

    /// The steps of ray `i`, in order.
    #[inline]
    pub fn of(&self, i: usize) -> &[Step] {
        &self.steps[self.offsets[i]..self.offsets[i + 1]]
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.offsets.len() - 1
    }

    /// True when there are no rays.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// One subshell of a bundle: the unit of work of the machine, the paper's s' (see the module
/// doc). The `Schedule` (schedule.rs) lists these as they are.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Subshell {
    /// The shell it belongs to.
    pub shell: u32,
    /// Its index within the shell (0 for the first).
    pub part: u32,
    /// Nonempty cells in traversal order (linear cell ids).
    pub cells: Vec<u32>,
    /// Active patches: loaded here, first time for the bundle; in traversal order of their
    /// first cell, ascending within a cell.
    pub patches: Vec<u32>,
    /// Remaining rays at its start (ray ids of the ray set), ascending.
    pub rays: Vec<u32>,
    /// Cell steps of those rays through its cells (empty cells included).
    pub traversals: u64,
}

impl Subshell {
    /// Ray/patch intersection computations: remaining rays × active patches.
    pub fn intersections(&self) -> u64 {
        self.rays.len() as u64 * self.patches.len() as u64
    }
}

/// How one bundle was worked through.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BundleRun {
    /// The subshells in processing order.
    pub subshells: Vec<Subshell>,
    /// Per ray of the bundle (bundle order): the nearest hit found.
    pub hits: Vec<Option<Hit>>,
    /// Per ray: the index of the subshell after which it retired; `None` for a ray that
    /// stepped through no cell (it misses the grid) and so took no work.
    pub retired_after: Vec<Option<u32>>,
    /// Per ray: its intersection computations (the active patches of every subshell it
    /// was remaining in). They sum to the bundle's intersections.
    pub ray_intersections: Vec<u64>,
    /// Per ray: its cell steps counted as traversals. They sum to the bundle's traversals.
    pub ray_traversals: Vec<u64>,
}

impl BundleRun {
    /// Σ intersections over the subshells.
    pub fn intersections(&self) -> u64 {
        self.subshells.iter().map(Subshell::intersections).sum()
    }
    /// Σ traversals over the subshells.
    pub fn traversals(&self) -> u64 {
        self.subshells.iter().map(|s| s.traversals).sum()
    }
    /// Patches loaded (each once per bundle).
    pub fn patch_loads(&self) -> u64 {
        self.subshells.iter().map(|s| s.patches.len() as u64).sum()
    }
    /// Number of distinct shells.
    pub fn shells(&self) -> usize {
        let mut n = 0;
        let mut last = None;
        for s in &self.subshells {
            if last != Some(s.shell) {
                n += 1;
                last = Some(s.shell);
            }
        }
        n
    }
    /// For each patch loaded, the subshell that loaded it.
    pub fn loaded_in(&self) -> HashMap<u32, u32> {
        let mut m = HashMap::new();
        for (i, s) in self.subshells.iter().enumerate() {
            for &p in &s.patches {
                m.insert(p, i as u32);
            }
        }
        m
    }
}

/// A ray set prepared for shelling from one source patch: walks, prepared rays, slacks.
pub struct Caster<'a> {
    pub tracer: &'a Tracer,
    pub rays: &'a [Ray],
    pub walks: Walks,
    pub source: u32,
    pub params: ShellParams,
    /// The rays in the tracer's frame, for its patch tests.
    prepared: Vec<LocalRay>,
    slack_t: Vec<f64>,
}

impl<'a> Caster<'a> {
    /// Prepares `rays` leaving patch `source` (whose centroid is `centre`).
    pub fn new(
        tracer: &'a Tracer,
        rays: &'a [Ray],
        source: u32,
        centre: DVec3,
        params: ShellParams,
    ) -> Caster<'a> {
        let walks = Walks::new(tracer, rays, centre, params.radius);
        // The float tracer's stopping slack (1e-9 of the grid's diagonal), in units of t.
        let slack_len = 1e-9 * tracer.grid().aabb().extent().length();
        Caster {
            tracer,
            rays,
            walks,
            source,
            params,
            prepared: rays.iter().map(|r| tracer.prepare(r)).collect(),
            slack_t: rays.iter().map(|r| slack_len / r.d.length()).collect(),
        }
    }

    fn grid(&self) -> &Grid {
        self.tracer.grid()
    }

    /// Works through the bundle of rays `ids` (ids into the ray set; any order, each once).
    pub fn run_bundle(&self, ids: &[u32]) -> BundleRun {
        let n = ids.len();
        let grid = self.grid();
        let max_new = self.params.subshell_max.max(1);
        let mut run = BundleRun {
            subshells: Vec::new(),
            hits: vec![None; n],
            retired_after: vec![None; n],
            ray_intersections: vec![0; n],
            ray_traversals: vec![0; n],
        };
        let mut loaded = vec![false; self.tracer.patches.len()];
        // Remaining rays as bundle-local indices, ascending; rays off the grid never start.
        let mut alive: Vec<usize> = (0..n)
            .filter(|&i| !self.walks.of(ids[i] as usize).is_empty())
            .collect();
        let mut shells: Vec<u32> = alive
            .iter()
            .flat_map(|&i| self.walks.of(ids[i] as usize).iter().map(|s| s.shell))
            .collect();
        shells.sort_unstable();
        shells.dedup();
        for &k in &shells {
            if alive.is_empty() {
                break;
            }
            // cell → subshell index (within this shell) once processed.
            let mut part_of: HashMap<u32, u32> = HashMap::new();
            let mut part = 0u32;
            loop {
                // The shell's unprocessed cells that remaining rays step through, by least
                // entry distance, then cell id.
                let mut cand: Vec<(u32, f64)> = Vec::new();
                for &i in &alive {
                    for s in self.walks.of(ids[i] as usize) {
                        if s.shell == k && !part_of.contains_key(&s.cell) {
                            cand.push((s.cell, s.dist));
                        }
                    }
                }
                if cand.is_empty() {
                    break;
                }
                cand.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
                cand.dedup_by_key(|c| c.0);
                cand.sort_unstable_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
                // Cut the next subshell: consecutive cells until the new patches would
                // exceed the threshold.
                let mut cells = Vec::new();
                let mut patches: Vec<u32> = Vec::new();
                let mut new = Vec::new();
                for &(cell, _) in &cand {
                    let list = grid.patches_in(cell as usize);
                    let nonempty = list.iter().any(|&p| p != self.source);
                    new.clear();
                    new.extend(
                        list.iter()
                            .copied()
                            .filter(|&p| p != self.source && !loaded[p as usize]),
                    );
                    if !patches.is_empty() && patches.len() + new.len() > max_new {
                        break;
                    }
                    part_of.insert(cell, part);
                    if nonempty {
                        cells.push(cell);
                    }
                    for &p in &new {
                        loaded[p as usize] = true;
                    }
                    patches.extend_from_slice(&new);
                }
                // Traversals and intersections of the remaining rays.
                let mut traversals = 0u64;
                for &i in &alive {
                    let r = ids[i] as usize;
                    let steps = self
                        .walks
                        .of(r)
                        .iter()
                        .filter(|s| s.shell == k && part_of.get(&s.cell) == Some(&part))
                        .count() as u64;
                    traversals += steps;
                    run.ray_traversals[i] += steps;
                    run.ray_intersections[i] += patches.len() as u64;
                    let pr = &self.prepared[r];
                    let mut best = run.hits[i];
                    for &p in &patches {
                        if let Some(h) = self.tracer.hit_if_nearer(pr, p, &best) {
                            best = Some(h);
                        }
                    }
                    run.hits[i] = best;
                }
                let index = run.subshells.len() as u32;
                let mut rays: Vec<u32> = alive.iter().map(|&i| ids[i]).collect();
                rays.sort_unstable();
                run.subshells.push(Subshell {
                    shell: k,
                    part,
                    cells,
                    patches,
                    rays,
                    traversals,
                });
                // Retire the rays no unprocessed cell can improve.
                alive.retain(|&i| {
                    let r = ids[i] as usize;
                    let t_next = self
                        .walks
                        .of(r)
                        .iter()
                        .filter(|s| s.shell > k || (s.shell == k && !part_of.contains_key(&s.cell)))
                        .map(|s| s.t_enter)
                        .fold(f64::INFINITY, f64::min);
                    let retire = match run.hits[i] {
                        Some(h) => h.t + self.slack_t[r] < t_next,
                        None => t_next == f64::INFINITY,
                    };
                    if retire {
                        run.retired_after[i] = Some(index);
                    }
                    !retire
                });
                part += 1;
                if alive.is_empty() {
                    break;
                }
            }
        }
        debug_assert!(alive.is_empty(), "every ray retires by its last step");
        run
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::rays::{hemisphere_rays, Directions, Origins};
    use crate::scene::{Aabb, Patch, Scene};

    /// The unit cube's floor and ceiling, plus a field of small tiles at mid height.
    fn tiles() -> Scene {
        let q = |v: [[f64; 3]; 4]| {
            Patch::new(v.iter().map(|a| DVec3::from_array(*a)).collect(), 0.0, 0.5)
        };
        let mut patches = vec![
            q([[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]]),
            q([[0., 0., 1.], [0., 1., 1.], [1., 1., 1.], [1., 0., 1.]]),
        ];
        for i in 0..8 {
            for j in 0..8 {
                let (x, y) = (0.1 * i as f64 + 0.1, 0.1 * j as f64 + 0.1);
                let z = 0.3 + 0.05 * ((i + j) % 3) as f64;
                patches.push(q([
                    [x, y, z],
                    [x, y + 0.04, z],
                    [x + 0.04, y + 0.04, z],
                    [x + 0.04, y, z],
                ]));
            }
        }
        Scene {
            name: "tiles".into(),
            bounds: Aabb {
                lo: DVec3::ZERO,
                hi: DVec3::ONE,
            },
            patches,
        }
    }

    fn bundle() -> (Scene, Tracer, Vec<Ray>) {
        let s = tiles();
        let t = Tracer::new(&s, 0.05).unwrap();
        let set = hemisphere_rays(&s.patches[0], 500, Directions::Rings, Origins::Patch, 3);
        (s, t, set.rays)
    }

    #[test]
    fn nearest_hits_equal_the_tracer_and_patches_load_once() {
        let (s, tr, rays) = bundle();
        for max in [1, 4, 64, 10_000] {
            let c = Caster::new(
                &tr,
                &rays,
                0,
                s.patches[0].centroid(),
                ShellParams {
                    radius: 0.2,
                    subshell_max: max,
                },
            );
            let ids: Vec<u32> = (0..rays.len() as u32).collect();
            let run = c.run_bundle(&ids);
            for (i, r) in rays.iter().enumerate() {
                assert_eq!(run.hits[i], tr.trace(r, Some(0)), "ray {i}, max {max}");
            }
            let mut seen = std::collections::HashSet::new();
            for sub in &run.subshells {
                assert!(sub.patches.iter().all(|p| seen.insert(*p)), "loaded twice");
                assert!(!sub.patches.contains(&0), "the source is never loaded");
                // A subshell exceeds the threshold only with a single nonempty cell.
                assert!(sub.patches.len() <= max || sub.cells.len() == 1, "{sub:?}");
            }
            assert_eq!(
                run.intersections(),
                run.ray_intersections.iter().sum::<u64>()
            );
            assert_eq!(run.traversals(), run.ray_traversals.iter().sum::<u64>());
            assert!(run.retired_after.iter().all(Option::is_some));
        }
    }

    #[test]
    fn subshells_split_a_shell_and_rays_retire_monotonically() {
        let (s, tr, rays) = bundle();
        let c = Caster::new(
            &tr,
            &rays,
            0,
            s.patches[0].centroid(),
            ShellParams {
                radius: 0.289,
                subshell_max: 8,
            },
        );
        let ids: Vec<u32> = (0..rays.len() as u32).collect();
        let run = c.run_bundle(&ids);
        assert!(
            run.subshells.iter().any(|s| s.part > 0),
            "some shell was split"
        );
        // Remaining rays only shrink, and shells come in increasing order.
        for w in run.subshells.windows(2) {
            assert!(w[1].rays.iter().all(|r| w[0].rays.binary_search(r).is_ok()));
            assert!(
                w[0].shell < w[1].shell || (w[0].shell == w[1].shell && w[1].part == w[0].part + 1)
            );
        }
        // The patch a ray hits was active no later than the subshell it retired after.
        let loaded = run.loaded_in();
        let mut hits = 0;
        for (i, h) in run.hits.iter().enumerate() {
            if let Some(h) = h {
                assert!(loaded[&h.patch] <= run.retired_after[i].unwrap());
                hits += 1;
            }
        }
        assert!(hits > 20, "{hits}");
    }
}
