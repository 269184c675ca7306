//! Two solutions of the same scene compared patch by patch: the relative difference of each
//! patch's luminance, its maximum and RMS, and both in units of the float estimator's own
//! noise (the RMS relative difference of two float solutions from different seeds, over √2).

use crate::radiosity::render::luminance;
use serde::Serialize;

/// The comparison of solution `b` against the reference `a`.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    pub reference: String,
    pub model: String,
    /// Patches compared (those whose reference luminance is above 0).
    pub patches: usize,
    /// max_i |Y_b − Y_a| / Y_a.
    pub max_rel: f64,
    /// The patch where it is largest.
    pub max_rel_patch: u32,
    /// √(mean_i ((Y_b − Y_a) / Y_a)²).
    pub rms_rel: f64,
    /// The float estimator's noise per patch: RMS relative difference of two float
    /// solutions from different seeds, over √2.
    pub noise_rms_rel: f64,
    pub max_in_noise_units: f64,
    pub rms_in_noise_units: f64,
    /// The patches whose difference exceeds [`MAX_NOISE_UNITS`] noise units, ascending.
    pub beyond_noise: Vec<u32>,
}

/// The difference, in units of the float estimator's noise, above which two models are
/// said to disagree on a patch (`radiosity --compare` exits 1): with a few hundred patches
/// the largest of noise-like differences stays near 3 (cornell and scene1 measure 0.6–0.7,
/// scene2 1.2 between the machine and the float reference).
pub const MAX_NOISE_UNITS: f64 = 3.0;

impl Comparison {
    /// `Err(Error::Check)` naming the patches where the two models differ by more than
    /// [`MAX_NOISE_UNITS`] noise units.
    pub fn verdict(&self) -> crate::error::Result<()> {
        if self.beyond_noise.is_empty() {
            return Ok(());
        }
        let list: Vec<String> = self
            .beyond_noise
            .iter()
            .take(12)
            .map(u32::to_string)
            .collect();
        Err(crate::error::Error::Check(format!(
            "{} and {} differ by more than {MAX_NOISE_UNITS} noise units on {} patches ({}{}), at most {:.2} on patch {}: a model leaks, or patches lie closer than the datapath's LSB (see `shellsim check --source ID` on one of them)",
            self.model,
            self.reference,
            self.beyond_noise.len(),
            list.join(", "),
            if self.beyond_noise.len() > 12 { ", …" } else { "" },
            self.max_in_noise_units,
            self.max_rel_patch
        )))
    }
}

/// Per patch: (Y_b − Y_a) / Y_a (0 where Y_a is 0).
pub fn relative(a: &[[f64; 3]], b: &[[f64; 3]]) -> Vec<f64> {
    a.iter()
        .zip(b)
        .map(|(x, y)| {
            let (ya, yb) = (luminance(*x), luminance(*y));
            if ya > 0.0 {
                (yb - ya) / ya
            } else {
                0.0
            }
        })
        .collect()
}

fn rms(v: &[f64], mask: &[bool]) -> f64 {
    let (s, n) = v
        .iter()
        .zip(mask)
        .filter(|(_, m)| **m)
        .fold((0.0, 0usize), |(s, n), (x, _)| (s + x * x, n + 1));
    if n == 0 {
        0.0
    } else {
        (s / n as f64).sqrt()
    }
}

/// Compares `b` (model `model`) against `a` (model `reference`); `a2` is a second float
/// solution from another seed, for the noise.
pub fn compare(
    reference: &str,
    a: &[[f64; 3]],
    model: &str,
    b: &[[f64; 3]],
    a2: &[[f64; 3]],
) -> Comparison {
    let mask: Vec<bool> = a.iter().map(|x| luminance(*x) > 0.0).collect();
    let rel = relative(a, b);
    let noise = relative(a, a2);
    let (mut max_rel, mut max_rel_patch) = (0.0f64, 0u32);
    for (i, r) in rel.iter().enumerate() {
        if mask[i] && r.abs() > max_rel {
            max_rel = r.abs();
            max_rel_patch = i as u32;
        }
    }
    let rms_rel = rms(&rel, &mask);
    let noise_rms_rel = rms(&noise, &mask) / std::f64::consts::SQRT_2;
    let units = |x: f64| {
        if noise_rms_rel > 0.0 {
            x / noise_rms_rel
        } else {
            0.0
        }
    };
    let beyond_noise = (0..rel.len() as u32)
        .filter(|&i| mask[i as usize] && units(rel[i as usize].abs()) > MAX_NOISE_UNITS)
        .collect();
    Comparison {
        beyond_noise,
        reference: reference.to_string(),
        model: model.to_string(),
        patches: mask.iter().filter(|m| **m).count(),
        max_rel,
        max_rel_patch,
        rms_rel,
        noise_rms_rel,
        max_in_noise_units: units(max_rel),
        rms_in_noise_units: units(rms_rel),
    }
}
