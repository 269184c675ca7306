//! The radiosity solution per RGB channel, B = E + ρ H with H the irradiance the matrix
//! gives, in one of two systems: `gather` (default) is the textbook B = E + ρ F B (each
//! patch gathers along its own row), exact in energy only for a reciprocal matrix; `power`
//! distributes the power leaving each patch along its own row — the rays the machine cast
//! from it — so Σ power is conserved exactly whatever the sampling error, at the price of
//! more noise on small patches (few rays from other patches land on them). Each is solved by Gauss-Seidel
//! or by progressive refinement (Southwell shooting); both methods reach the same system's
//! solution to the tolerance. The energy balance and the per-patch CSV.

use crate::error::{Error, Result};
use crate::output::write_atomic;
use crate::radiosity::matrix::FormMatrix;
use crate::scene::Scene;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// How to solve.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Gauss-Seidel sweeps over the patches in id order.
    Gs,
    /// Southwell shooting (progressive refinement).
    Shoot,
}

impl Method {
    /// The method's name in a sentence.
    pub fn describe(self) -> &'static str {
        match self {
            Method::Gs => "Gauss-Seidel",
            Method::Shoot => "Southwell shooting",
        }
    }
}

/// Which linear system the matrix stands for.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum System {
    /// B_i = E_i + ρ_i Σ_j F_ij B_j: patch i gathers along its row; the energy balance is
    /// off by the matrix's departure from reciprocity (A_i F_ij = A_j F_ji).
    Gather,
    /// A_j B_j = A_j E_j + ρ_j Σ_i F_ij A_i B_i: patch i's power goes out along row i (the
    /// rays cast from i), so emitted = absorbed + escaped + back exactly.
    Power,
}

impl System {
    /// The system's name in a sentence.
    pub fn describe(self) -> &'static str {
        match self {
            System::Gather => "gathering system",
            System::Power => "power system",
        }
    }
}

/// When to stop: the residual max_i,c |E + ρ H − B| over max E is at most `tol`, or
/// after `max_iter` sweeps (Gauss-Seidel) or `max_iter` × n shots.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SolveParams {
    pub method: Method,
    pub system: System,
    pub tol: f64,
    pub max_iter: usize,
}

impl Default for SolveParams {
    fn default() -> Self {
        SolveParams {
            method: Method::Gs,
            system: System::Gather,
            tol: 1e-12,
            max_iter: 10_000,
        }
    }
}

/// The energy balance of a solution (power = area × radiosity, per channel summed over RGB
/// and divided by 3): what is emitted equals what is absorbed plus what escapes plus what
/// lands on back sides — exactly in the `power` system, up to the matrix's departure from
/// reciprocity in `gather`.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Energy {
    /// Σ A_i E_i.
    pub emitted: f64,
    /// Σ A_i B_i: the power leaving all patches.
    pub leaving: f64,
    /// Σ A_i (1 − ρ_i) H_i: the irradiance H_i the system gives, less what is reflected.
    pub absorbed: f64,
    /// Σ A_i B_i × (escaped weight of row i): the power leaving into no patch.
    pub escaped: f64,
    /// Σ A_i B_i × (back-side weight of row i): the power absorbed by back sides.
    pub back: f64,
    /// (emitted − absorbed − escaped − back) / emitted.
    pub imbalance: f64,
}

/// A solution.
#[derive(Clone, Debug, Serialize)]
pub struct Solution {
    pub method: Method,
    pub system: System,
    /// Per patch, RGB.
    #[serde(skip)]
    pub b: Vec<[f64; 3]>,
    /// Sweeps (Gauss-Seidel) or shots (shooting).
    pub iterations: usize,
    /// max_i,c |E + ρ H − B| / max E at the end.
    pub residual: f64,
    pub converged: bool,
    pub energy: Energy,
}

/// The system as incoming lists: H_j = Σ w B_k over `inc[j]` = [(k, w)], k ascending.
struct Links {
    inc: Vec<Vec<(u32, f64)>>,
}

impl Links {
    fn new(m: &FormMatrix, scene: &Scene, system: System) -> Links {
        let inc = match system {
            System::Gather => m.rows.iter().map(|r| r.entries.clone()).collect(),
            System::Power => {
                let area: Vec<f64> = scene.patches.iter().map(|q| q.area()).collect();
                let mut inc: Vec<Vec<(u32, f64)>> = vec![Vec::new(); m.n];
                for r in &m.rows {
                    let i = r.source as usize;
                    for &(j, f) in &r.entries {
                        inc[j as usize].push((r.source, f * area[i] / area[j as usize]));
                    }
                }
                inc
            }
        };
        Links { inc }
    }

    /// H_j, summed in list order.
    fn irradiance(&self, b: &[[f64; 3]], j: usize) -> [f64; 3] {
        let mut h = [0.0; 3];
        for &(k, w) in &self.inc[j] {
            for c in 0..3 {
                h[c] += w * b[k as usize][c];
            }
        }
        h
    }

    /// The outgoing lists: out[k] = [(j, w)] for every (k, w) in inc[j], j ascending.
    fn outgoing(&self) -> Vec<Vec<(u32, f64)>> {
        let mut out: Vec<Vec<(u32, f64)>> = vec![Vec::new(); self.inc.len()];
        for (j, l) in self.inc.iter().enumerate() {
            for &(k, w) in l {
                out[k as usize].push((j as u32, w));
            }
        }
        out
    }
}

fn emission(scene: &Scene) -> Vec<[f64; 3]> {
    scene.patches.iter().map(|p| p.emission.rgb()).collect()
}

fn reflectance(scene: &Scene) -> Vec<[f64; 3]> {
    scene.patches.iter().map(|p| p.reflectance.rgb()).collect()
}

fn emission_scale(e: &[[f64; 3]]) -> f64 {
    let scale = e.iter().flatten().fold(0.0f64, |a, &x| a.max(x));
    if scale > 0.0 {
        scale
    } else {
        1.0
    }
}

/// The residual max_i,c |E + ρ H − B| over max E (1 when nothing emits) in `system`.
pub fn residual(m: &FormMatrix, scene: &Scene, system: System, b: &[[f64; 3]]) -> f64 {
    residual_of(&Links::new(m, scene, system), scene, b)
}

fn residual_of(l: &Links, scene: &Scene, b: &[[f64; 3]]) -> f64 {
    let e = emission(scene);
    let rho = reflectance(scene);
    (0..l.inc.len())
        .map(|i| {
            let h = l.irradiance(b, i);
            (0..3)
                .map(|c| (e[i][c] + rho[i][c] * h[c] - b[i][c]).abs())
                .fold(0.0f64, f64::max)
        })
        .fold(0.0f64, f64::max)
        / emission_scale(&e)
}

/// The energy balance of `b` in `system`.
pub fn energy(m: &FormMatrix, scene: &Scene, system: System, b: &[[f64; 3]]) -> Energy {
    energy_of(&Links::new(m, scene, system), m, scene, b)
}

fn energy_of(l: &Links, m: &FormMatrix, scene: &Scene, b: &[[f64; 3]]) -> Energy {
    let (mut emitted, mut leaving, mut absorbed, mut escaped, mut back) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (i, p) in scene.patches.iter().enumerate() {
        let a = p.area();
        let e = p.emission.rgb();
        let rho = p.reflectance.rgb();
        let h = l.irradiance(b, i);
        for c in 0..3 {
            emitted += a * e[c] / 3.0;
            leaving += a * b[i][c] / 3.0;
            absorbed += a * (1.0 - rho[c]) * h[c] / 3.0;
            escaped += a * b[i][c] * m.rows[i].escaped / 3.0;
            back += a * b[i][c] * m.rows[i].back / 3.0;
        }
    }
    Energy {
        emitted,
        leaving,
        absorbed,
        escaped,
        back,
        imbalance: if emitted > 0.0 {
            (emitted - absorbed - escaped - back) / emitted
        } else {
            0.0
        },
    }
}

/// Refuses a scene whose light is never absorbed: in a channel, a set of patches that
/// reflect all they receive (reflectance 1) and whose rays never leave the set (no escape,
/// no back side), reached by an emitter, holds ever more energy — B = E + ρFB has no finite
/// solution and no solver converges. Bad input in `file` (exit status 2) naming the channel
/// and a patch, checked before solving.
pub fn check_solvable(m: &FormMatrix, scene: &Scene, file: &Path) -> Result<()> {
    let n = scene.patches.len();
    if m.rows.len() != n {
        return Ok(());
    }
    // Reversed edges j ← i for F_ij > 0, to walk back from the patches that lose light.
    let mut into: Vec<Vec<u32>> = vec![Vec::new(); n];
    for r in &m.rows {
        for &(j, f) in &r.entries {
            if f > 0.0 && (j as usize) < n {
                into[j as usize].push(r.source);
            }
        }
    }
    const NAMES: [&str; 3] = ["red", "green", "blue"];
    for (c, channel) in NAMES.iter().enumerate() {
        // Patches that lose light (absorb some, or let some escape or reach a back side),
        // and every patch whose light reaches one of them.
        let mut ok = vec![false; n];
        let mut stack: Vec<u32> = Vec::new();
        for (i, r) in m.rows.iter().enumerate() {
            let rho = scene.patches[i].reflectance.rgb()[c];
            if rho < 1.0 || r.escaped + r.back > 1e-12 {
                ok[i] = true;
                stack.push(i as u32);
            }
        }
        while let Some(j) = stack.pop() {
            for &i in &into[j as usize] {
                if !ok[i as usize] {
                    ok[i as usize] = true;
                    stack.push(i);
                }
            }
        }
        if ok.iter().all(|&o| o) {
            continue;
        }
        // Light from an emitter that reaches a lossless patch is never absorbed.
        let mut seen = vec![false; n];
        let mut stack: Vec<u32> = (0..n as u32)
            .filter(|&i| scene.patches[i as usize].emission.rgb()[c] > 0.0)
            .collect();
        for &i in &stack {
            seen[i as usize] = true;
        }
        while let Some(i) = stack.pop() {
            if !ok[i as usize] {
                let lossless = ok.iter().filter(|&&o| !o).count();
                return Err(Error::input(
                    file,
                    "reflectance",
                    format!(
                        "the {channel} light reaches {lossless} patches of reflectance 1 whose rays never leave them (patch {i} is one): it is never absorbed and the radiosity has no finite solution; give some of them a reflectance below 1, or open the scene"
                    ),
                ));
            }
            for &(j, f) in &m.rows[i as usize].entries {
                if f > 0.0 && (j as usize) < n && !seen[j as usize] {
                    seen[j as usize] = true;
                    stack.push(j);
                }
            }
        }
    }
    Ok(())
}

/// Solves the matrix `m` of `scene` in `p.system`. `Error::Param` when the matrix is not
/// full or a parameter is out of range.
pub fn solve(m: &FormMatrix, scene: &Scene, p: SolveParams) -> Result<Solution> {
    if !m.is_full() || m.n != scene.patches.len() {
        return Err(Error::param(
            "matrix",
            format!(
                "has {} of the scene's {} rows: radiosity needs them all",
                m.rows.len(),
                scene.patches.len()
            ),
        ));
    }
    if !(p.tol.is_finite() && p.tol > 0.0) {
        return Err(Error::param(
            "tol",
            format!("{} must be a finite number above 0", p.tol),
        ));
    }
    if p.max_iter == 0 {
        return Err(Error::param("max_iter", "0 must be at least 1".to_string()));
    }
    let l = Links::new(m, scene, p.system);
    let (b, iterations) = match p.method {
        Method::Gs => gauss_seidel(&l, scene, p),
        Method::Shoot => shoot(&l, scene, p),
    };
    let residual = residual_of(&l, scene, &b);
    Ok(Solution {
        method: p.method,
        system: p.system,
        iterations,
        residual,
        converged: residual <= p.tol,
        energy: energy_of(&l, m, scene, &b),
        b,
    })
}

/// Gauss-Seidel: B_i ← E_i + ρ_i H_i, patches in id order, until the residual is below
/// the tolerance (checked after each sweep).
fn gauss_seidel(l: &Links, scene: &Scene, p: SolveParams) -> (Vec<[f64; 3]>, usize) {
    let e = emission(scene);
    let rho = reflectance(scene);
    let mut b = e.clone();
    for sweep in 1..=p.max_iter {
        for i in 0..b.len() {
            let h = l.irradiance(&b, i);
            for c in 0..3 {
                b[i][c] = e[i][c] + rho[i][c] * h[c];
            }
        }
        if residual_of(l, scene, &b) <= p.tol {
            return (b, sweep);
        }
    }
    (b, p.max_iter)
}

/// Southwell shooting on the same system: U (unshot radiosity) starts at E; each shot takes
/// the patch i with the most unshot power max_c A_i |U_i,c| (ties to the lower id), adds
/// ρ_j w U_i to B_j and U_j for every j that i reaches with weight w (in `power`, w =
/// F_ij A_i / A_j: Cohen's progressive refinement along the shooter's own row) and sets
/// U_i to 0. Stops when the unshot radiosity is below the tolerance; the residual of the
/// system is exactly U.
fn shoot(l: &Links, scene: &Scene, p: SolveParams) -> (Vec<[f64; 3]>, usize) {
    let e = emission(scene);
    let rho = reflectance(scene);
    let area: Vec<f64> = scene.patches.iter().map(|q| q.area()).collect();
    let scale = emission_scale(&e);
    let out = l.outgoing();
    let n = out.len();
    let mut b = e.clone();
    let mut u = e;
    let max_shots = p.max_iter.saturating_mul(n.max(1));
    for shot in 0..max_shots {
        let mut best = 0usize;
        let mut best_power = -1.0f64;
        let mut max_u = 0.0f64;
        for i in 0..n {
            let ui = u[i].iter().fold(0.0f64, |a, &x| a.max(x.abs()));
            max_u = max_u.max(ui);
            let pw = area[i] * ui;
            if pw > best_power {
                best_power = pw;
                best = i;
            }
        }
        if max_u / scale <= p.tol {
            return (b, shot);
        }
        let ui = u[best];
        u[best] = [0.0; 3];
        for &(j, w) in &out[best] {
            let j = j as usize;
            for c in 0..3 {
                let d = rho[j][c] * w * ui[c];
                b[j][c] += d;
                u[j][c] += d;
            }
        }
    }
    (b, max_shots)
}

/// The per-patch CSV: id, name, area, B r/g/b (shortest round-trip decimals). The name is
/// the patch's group/object or material name when it has one ([`crate::scene::Patch::label`],
/// quoted as RFC 4180 wants when it holds a comma, a quote or a line break), else `patch<id>`.
pub fn csv(scene: &Scene, b: &[[f64; 3]]) -> String {
    let mut s = String::from("id,name,area,b_r,b_g,b_b\n");
    for (i, (p, x)) in scene.patches.iter().zip(b).enumerate() {
        let name = match p.label() {
            Some(n) if n.contains([',', '"', '\n', '\r']) => {
                format!("\"{}\"", n.replace('"', "\"\""))
            }
            Some(n) => n.to_string(),
            None => format!("patch{i}"),
        };
        let _ = writeln!(s, "{i},{name},{},{},{},{}", p.area(), x[0], x[1], x[2]);
    }
    s
}

/// Writes [`csv`] to `path`, atomically.
pub fn write_csv(path: &Path, scene: &Scene, b: &[[f64; 3]]) -> Result<()> {
    write_atomic(path, csv(scene, b).as_bytes())
}
