//! The divider's stages as the RTL builds them (hw/rtl/shellsim_icu.sv): rounding point B as
//! a restoring division, `bits_per_stage` quotient bits per pipeline stage.
//!
//! t = round(N / D′) to nearest, ties away from zero, is ⌊X / Y⌋ with X = 2N + D′ and
//! Y = 2D′ (N = num·2^(Ft−F) or num, D′ = den or den·2^(F−Ft): [`super::divide`]'s scaling).
//! The quotient is found over QF = stages × bits quotient bits, most significant first; X ≥
//! Y·2^QF (`ovf`) means t cannot fit. A job that cannot hit (no valid fraction, or num < 0)
//! divides 0 by 1. [`DividerStage`] is one stage register's contents; the last stage's
//! quotient equals [`super::divide`]'s t wherever that is a hit (tested below), which is what
//! lets the co-simulation compare every divider register of the RTL with the model.

use crate::datapath::format::Formats;
use crate::datapath::Interpolated;

/// The divider's geometry for a set of formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DividerShape {
    pub stages: u32,
    pub bits_per_stage: u32,
    /// Quotient bits (stages × bits per stage).
    pub qf: u32,
    /// Left shifts of the numerator and of the denominator.
    pub shift_n: u32,
    pub shift_d: u32,
    /// Widths of the dividend X, the divisor Y and the comparison.
    pub xw: u32,
    pub yw: u32,
    pub cmpw: u32,
}

impl DividerShape {
    /// The divider for `f` with `bits_per_stage` quotient bits per stage (the model's
    /// `divider_bits_per_stage`; stages = ⌈t bits / bits per stage⌉).
    pub fn new(f: &Formats, bits_per_stage: u32) -> Self {
        let stages = f.t.bits().div_ceil(bits_per_stage);
        let qf = stages * bits_per_stage;
        let ff = f.coord.frac_bits;
        let ft = f.t.frac_bits;
        let shift_n = ft.saturating_sub(ff);
        let shift_d = ff.saturating_sub(ft);
        let xw = (f.t_num.bits() - 1 + shift_n).max(f.det.bits() - 1 + shift_d) + 2;
        let yw = f.det.bits() + shift_d;
        let cmpw = xw.max(yw + qf) + 1;
        DividerShape {
            stages,
            bits_per_stage,
            qf,
            shift_n,
            shift_d,
            xw,
            yw,
            cmpw,
        }
    }

    /// Can every register be held in an `i128` (what the co-simulation compares)?
    pub fn fits_i128(&self) -> bool {
        self.cmpw <= 126
    }
}

/// One divider stage register (unsigned values).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DividerStage {
    /// The job may hit: a valid fraction with num ≥ 0.
    pub cand: bool,
    /// den < 2^F: a near-zero denominator (counted when `cand`).
    pub near_zero: bool,
    /// X ≥ Y·2^QF: the quotient cannot fit.
    pub ovf: bool,
    /// The partial remainder.
    pub r: u128,
    /// The quotient bits found so far (the rest zero).
    pub q: u128,
    pub y: u128,
}

/// Every divider stage's register for the fraction `q` (index 0 is the first stage).
pub fn stages(q: &Interpolated, f: &Formats, shape: &DividerShape) -> Vec<DividerStage> {
    let mut v = Vec::with_capacity(shape.stages as usize);
    for_each_stage(q, f, shape, |s| v.push(*s));
    v
}

/// Calls `each` with every divider stage's register for the fraction `q`, first to last.
pub fn for_each_stage(
    q: &Interpolated,
    f: &Formats,
    shape: &DividerShape,
    mut each: impl FnMut(&DividerStage),
) {
    let cand = q.valid && q.num >= 0;
    let (x, y) = if cand {
        (
            ((q.num as u128) << (shape.shift_n + 1)) + ((q.den as u128) << shape.shift_d),
            (q.den as u128) << (shape.shift_d + 1),
        )
    } else {
        (0, 1)
    };
    let mut s = DividerStage {
        cand,
        near_zero: cand && q.den < (1i128 << f.coord.frac_bits),
        ovf: x >= y << shape.qf,
        r: x,
        q: 0,
        y,
    };
    for j in 0..shape.stages {
        for k in 0..shape.bits_per_stage {
            let bit = shape.qf - 1 - j * shape.bits_per_stage - k;
            let ys = s.y << bit;
            if s.r >= ys {
                s.r -= ys;
                s.q |= 1 << bit;
            }
        }
        each(&s);
    }
}

/// The result stage from the last divider stage: t raw when a hit, and whether the quotient
/// saturated (t beyond its format).
pub fn result(last: &DividerStage, f: &Formats) -> (Option<i64>, bool) {
    let fits = !last.ovf && last.q <= f.t.max_raw() as u128;
    let hit = last.cand && fits;
    (hit.then_some(last.q as i64), last.cand && !fits)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::datapath::{divide, Exceptions};

    #[test]
    fn the_staged_division_equals_the_models_divide() {
        for (frac, t_frac, per) in [(12, 12, 4), (8, 12, 3), (16, 10, 4), (12, 12, 1)] {
            let mut cfg = crate::config::paper().datapath;
            cfg.frac_bits = frac;
            cfg.t_frac_bits = t_frac;
            let f = cfg.formats().unwrap();
            let shape = DividerShape::new(&f, per);
            assert!(shape.fits_i128());
            let mut seed = 0x9e37_79b9_7f4a_7c15u64;
            let mut next = || {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                seed
            };
            let (mut hits, mut sat) = (0, 0);
            for i in 0..200_000 {
                let den_bits = 1 + next() % (f.det.bits() as u64 - 2);
                let den = (next() % (1 << den_bits)) as i128;
                let num_bits = 1 + next() % (f.t_num.bits() as u64 - 2);
                let mut num = (next() % (1 << num_bits)) as i128;
                if i % 7 == 0 {
                    num = -num;
                }
                let q = Interpolated {
                    valid: den != 0 && i % 11 != 0,
                    num,
                    den,
                };
                let mut exc = Exceptions::default();
                let want = divide(&q, &f, &mut exc);
                let st = stages(&q, &f, &shape);
                assert_eq!(st.len() as u32, shape.stages);
                let (got, saturated) = result(st.last().unwrap(), &f);
                assert_eq!(got, want, "{q:?} at {frac}/{t_frac}");
                assert_eq!(saturated, exc.t_saturated == 1, "{q:?}");
                assert_eq!(st[0].near_zero, exc.near_zero_denominator == 1, "{q:?}");
                hits += want.is_some() as u32;
                sat += saturated as u32;
            }
            assert!(hits > 1000 && sat > 1000, "{hits} {sat}");
        }
    }
}
