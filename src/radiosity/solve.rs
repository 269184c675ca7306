//! The radiosity solution B = E + ρ F B per RGB channel: Gauss-Seidel (gathering, rows of
//! F) and progressive refinement by Southwell shooting (the unshot radiosity of the patch
//! with the most unshot power goes out along its column of F). Both solve the same linear
//! system to the same residual, so they agree to the tolerance; the energy balance and the
//! per-patch CSV.

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
    /// Gauss-Seidel sweeps over the rows in id order.
    Gs,
    /// Southwell shooting (progressive refinement).
    Shoot,
}

/// When to stop: the residual max_i,c |E + ρ F B − B| over max E is at most `tol`, or
/// after `max_iter` sweeps (Gauss-Seidel) or `max_iter` × n shots.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SolveParams {
    pub method: Method,
    pub tol: f64,
    pub max_iter: usize,
}

impl Default for SolveParams {
    fn default() -> Self {
        SolveParams {
            method: Method::Gs,
            tol: 1e-12,
            max_iter: 10_000,
        }
    }
}

/// The energy balance of a solution (power = area × radiosity, per channel summed over RGB
/// and divided by 3): what is emitted equals what is absorbed plus what escapes, up to the
/// matrix's departure from reciprocity (0 for an exactly reciprocal matrix).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Energy {
    /// Σ A_i E_i.
    pub emitted: f64,
    /// Σ A_i B_i: the power leaving all patches.
    pub leaving: f64,
    /// Σ A_i (1 − ρ_i) H_i, with H_i = Σ_j F_ij B_j the irradiance gathered.
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
    /// Per patch, RGB.
    #[serde(skip)]
    pub b: Vec<[f64; 3]>,
    /// Sweeps (Gauss-Seidel) or shots (shooting).
    pub iterations: usize,
    /// max_i,c |E + ρ F B − B| / max E at the end.
    pub residual: f64,
    pub converged: bool,
    pub energy: Energy,
}

fn emission(scene: &Scene) -> Vec<[f64; 3]> {
    scene.patches.iter().map(|p| p.emission.rgb()).collect()
}

fn reflectance(scene: &Scene) -> Vec<[f64; 3]> {
    scene.patches.iter().map(|p| p.reflectance.rgb()).collect()
}

/// (F B)_i, gathered in id order.
fn gather(m: &FormMatrix, b: &[[f64; 3]], i: usize) -> [f64; 3] {
    let mut h = [0.0; 3];
    for &(j, f) in &m.rows[i].entries {
        for c in 0..3 {
            h[c] += f * b[j as usize][c];
        }
    }
    h
}

/// The residual max_i,c |E + ρ F B − B| over max E (1 when nothing emits).
pub fn residual(m: &FormMatrix, scene: &Scene, b: &[[f64; 3]]) -> f64 {
    let e = emission(scene);
    let rho = reflectance(scene);
    let scale = e.iter().flatten().fold(0.0f64, |a, &x| a.max(x));
    let scale = if scale > 0.0 { scale } else { 1.0 };
    (0..m.n)
        .map(|i| {
            let h = gather(m, b, i);
            (0..3)
                .map(|c| (e[i][c] + rho[i][c] * h[c] - b[i][c]).abs())
                .fold(0.0f64, f64::max)
        })
        .fold(0.0f64, f64::max)
        / scale
}

/// The energy balance of `b`.
pub fn energy(m: &FormMatrix, scene: &Scene, b: &[[f64; 3]]) -> Energy {
    let (mut emitted, mut leaving, mut absorbed, mut escaped, mut back) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (i, p) in scene.patches.iter().enumerate() {
        let a = p.area();
        let e = p.emission.rgb();
        let rho = p.reflectance.rgb();
        let h = gather(m, b, i);
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

/// Solves B = E + ρ F B for the full matrix `m` of `scene`. `Error::Param` when the matrix
/// is not full or a parameter is out of range.
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
    let (b, iterations) = match p.method {
        Method::Gs => gauss_seidel(m, scene, p),
        Method::Shoot => shoot(m, scene, p),
    };
    let residual = residual(m, scene, &b);
    Ok(Solution {
        method: p.method,
        iterations,
        residual,
        converged: residual <= p.tol,
        energy: energy(m, scene, &b),
        b,
    })
}

/// Gauss-Seidel: B_i ← E_i + ρ_i Σ_j F_ij B_j, rows in id order, until the residual is
/// below the tolerance (checked after each sweep).
fn gauss_seidel(m: &FormMatrix, scene: &Scene, p: SolveParams) -> (Vec<[f64; 3]>, usize) {
    let e = emission(scene);
    let rho = reflectance(scene);
    let mut b = e.clone();
    for sweep in 1..=p.max_iter {
        for i in 0..m.n {
            let h = gather(m, &b, i);
            for c in 0..3 {
                b[i][c] = e[i][c] + rho[i][c] * h[c];
            }
        }
        if residual(m, scene, &b) <= p.tol {
            return (b, sweep);
        }
    }
    (b, p.max_iter)
}

/// Southwell shooting on the same system: U (unshot radiosity) starts at E; each shot takes
/// the patch i with the most unshot power max_c A_i |U_i,c| (ties to the lower id), adds
/// ρ_j F_ji U_i to B_j and U_j for every j (column i of F; for a reciprocal matrix
/// F_ji = A_i F_ij / A_j, the classic form) and sets U_i to 0. Stops when the unshot
/// radiosity is below the tolerance; the residual of this system is exactly U.
fn shoot(m: &FormMatrix, scene: &Scene, p: SolveParams) -> (Vec<[f64; 3]>, usize) {
    let e = emission(scene);
    let rho = reflectance(scene);
    let area: Vec<f64> = scene.patches.iter().map(|q| q.area()).collect();
    let scale = e.iter().flatten().fold(0.0f64, |a, &x| a.max(x));
    let scale = if scale > 0.0 { scale } else { 1.0 };
    // Columns: col[i] = [(j, F_ji)], j ascending.
    let mut col: Vec<Vec<(u32, f64)>> = vec![Vec::new(); m.n];
    for r in &m.rows {
        for &(i, f) in &r.entries {
            col[i as usize].push((r.source, f));
        }
    }
    let mut b = e.clone();
    let mut u = e;
    let max_shots = p.max_iter.saturating_mul(m.n.max(1));
    for shot in 0..max_shots {
        let mut best = 0usize;
        let mut best_power = -1.0f64;
        let mut max_u = 0.0f64;
        for i in 0..m.n {
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
        for &(j, f) in &col[best] {
            let j = j as usize;
            for c in 0..3 {
                let d = rho[j][c] * f * ui[c];
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
