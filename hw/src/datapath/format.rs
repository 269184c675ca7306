//! Number formats of the datapath: signed two's-complement fixed point `Q(int).(frac)`, the
//! conversion from host floats (through `fixed`), and the explicit rounding points.
//!
//! The datapath carries raw integers (`i64` registers, `i128` for exact wide products) with
//! formats chosen at run time, because the bit-width sweep varies them; `fixed`'s types fix
//! their fractional bits at compile time, so they serve here for the exact conversion from
//! `f64` and for printing values as decimals.

use fixed::types::I64F64;
use serde::Serialize;

/// A signed fixed-point format: `int_bits` integer bits including the sign, `frac_bits`
/// fractional bits. The value of raw integer `r` is `r · 2^-frac_bits`; the range is
/// `[-2^(int_bits-1), 2^(int_bits-1))`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Format {
    pub int_bits: u32,
    pub frac_bits: u32,
}

impl Format {
    /// A format of `int_bits` integer (with sign) and `frac_bits` fractional bits.
    pub const fn new(int_bits: u32, frac_bits: u32) -> Self {
        Format {
            int_bits,
            frac_bits,
        }
    }

    /// Total width in bits.
    pub const fn bits(self) -> u32 {
        self.int_bits + self.frac_bits
    }

    /// The largest raw value.
    pub const fn max_raw(self) -> i128 {
        (1i128 << (self.bits() - 1)) - 1
    }

    /// The smallest raw value.
    pub const fn min_raw(self) -> i128 {
        -(1i128 << (self.bits() - 1))
    }

    /// True when raw value `r` fits.
    #[inline]
    pub const fn fits(self, r: i128) -> bool {
        r >= self.min_raw() && r <= self.max_raw()
    }

    /// One unit in the last place, as a float.
    pub fn lsb(self) -> f64 {
        (-(self.frac_bits as f64)).exp2()
    }

    /// Rounds `x` to the nearest representable value (ties to even) — the host's one
    /// rounding point on the way in. `None` when `x` is not finite or does not fit.
    ///
    /// `x` is first converted exactly to `I64F64` by `fixed` (exact for |x| ≥ 2^-11, which
    /// covers every value that matters at 30 or fewer fractional bits), then rounded.
    pub fn quantize(self, x: f64) -> Option<i64> {
        if !x.is_finite() {
            return None;
        }
        let wide = I64F64::checked_from_num(x)?.to_bits();
        let r = round_shift_even(wide, 64 - self.frac_bits);
        (self.fits(r) && self.bits() <= 64).then_some(r as i64)
    }

    /// The value of raw `r` as a float (exact for widths up to 53 bits).
    pub fn to_f64(self, r: i128) -> f64 {
        r as f64 * self.lsb()
    }

    /// The value of raw `r` as a decimal string (exact, through `fixed`).
    pub fn to_decimal(self, r: i64) -> String {
        I64F64::from_bits((r as i128) << (64 - self.frac_bits)).to_string()
    }
}

impl std::fmt::Display for Format {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Q{}.{}", self.int_bits, self.frac_bits)
    }
}

/// Shifts right by `s` bits rounding half up (towards +∞ on ties): add half an LSB of the
/// result, then an arithmetic shift. One adder in hardware; the datapath's rounding points.
#[inline]
pub const fn round_shift(x: i128, s: u32) -> i128 {
    if s == 0 {
        x
    } else {
        (x + (1i128 << (s - 1))) >> s
    }
}

/// Shifts right by `s` bits rounding to nearest, ties to even (the host's conversions).
#[inline]
pub const fn round_shift_even(x: i128, s: u32) -> i128 {
    if s == 0 {
        return x;
    }
    let q = x >> s;
    let rem = x - (q << s);
    let half = 1i128 << (s - 1);
    if rem > half || (rem == half && q & 1 == 1) {
        q + 1
    } else {
        q
    }
}

/// `num / den` rounded to nearest, ties away from zero; `den != 0`. The divider's rounding.
#[inline]
pub const fn round_div(num: i128, den: i128) -> i128 {
    let (n, d) = if den < 0 { (-num, -den) } else { (num, den) };
    if n >= 0 {
        (2 * n + d) / (2 * d)
    } else {
        -((-2 * n + d) / (2 * d))
    }
}

/// Bits needed to hold every value of `|x| <= m` as a signed number.
pub fn signed_bits_for(m: u128) -> u32 {
    129 - (m as i128).leading_zeros().min(128)
}

/// The formats of every register and intermediate value of the datapath, derived from a
/// `DatapathConfig` (config/datapath.rs) so that no intermediate can overflow (each width is the exact bound).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Formats {
    /// Vertices and ray origins, relative to the grid origin.
    pub coord: Format,
    /// Ray direction components (a unit vector: |d| ≤ 1).
    pub dir: Format,
    /// Shear factors sx = d_kx/d_kz, sy = d_ky/d_kz (|s| ≤ 1) and sz = 1/d_kz (|sz| ≤ √3).
    pub shear: Format,
    /// Vertex minus origin.
    pub translated: Format,
    /// Ray-space x, y, z of a vertex (after the shear's rounding).
    pub ray_space: Format,
    /// Edge functions (exact products of ray-space coordinates).
    pub edge: Format,
    /// The interpolation denominator (sum of three edge functions).
    pub det: Format,
    /// The interpolation numerator Σ e_i·z_i.
    pub t_num: Format,
    /// t.
    pub t: Format,
    /// Memory word width.
    pub word_bits: u32,
    /// A deliberate fault, for mutation checks only ([`Fault::None`] from every
    /// configuration; never read from a file, never written out when absent).
    #[serde(skip_serializing_if = "Fault::is_none")]
    pub fault: Fault,
}

/// A deliberate datapath fault: what a verification suite must catch. A check that still
/// passes with one injected cannot be trusted to catch the real thing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub enum Fault {
    /// The datapath as designed.
    #[default]
    None,
    /// Rounding point A (the shear) truncates instead of rounding on the fourth vertex
    /// lane only — as one lane of a hardware shear built with a different rounding. A
    /// vertex shared by two patches in different lanes then lands on two lattice points,
    /// and the surface cracks.
    ShearLaneTruncates,
}

impl Fault {
    /// True for the datapath as designed.
    pub fn is_none(&self) -> bool {
        *self == Fault::None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantize_rounds_to_nearest_even_and_checks_range() {
        let f = Format::new(2, 4);
        assert_eq!(f.quantize(0.5), Some(8));
        assert_eq!(f.quantize(0.03125), Some(0)); // 0.5 LSB: tie to even (0)
        assert_eq!(f.quantize(0.09375), Some(2)); // 1.5 LSB: tie to even (2)
        assert_eq!(f.quantize(-0.09375), Some(-2));
        assert_eq!(f.quantize(1.9375), Some(31));
        assert_eq!(f.quantize(1.97), None, "rounds to 2.0, out of Q2.4");
        assert_eq!(f.quantize(-2.0), Some(-32));
        assert_eq!(f.quantize(f64::NAN), None);
        assert_eq!(f.quantize(f64::INFINITY), None);
        assert_eq!(f.to_decimal(-24), "-1.5");
    }

    #[test]
    fn rounding_helpers() {
        assert_eq!(round_shift(5, 1), 3); // 2.5 → 3
        assert_eq!(round_shift(-5, 1), -2); // -2.5 → -2 (half up)
        assert_eq!(round_shift_even(5, 1), 2);
        assert_eq!(round_shift_even(7, 1), 4);
        assert_eq!(round_div(7, 2), 4);
        assert_eq!(round_div(-7, 2), -4);
        assert_eq!(round_div(7, -2), -4);
        assert_eq!(round_div(1, 3), 0);
        assert_eq!(round_div(2, 3), 1);
        assert_eq!(signed_bits_for(0), 1);
        assert_eq!(signed_bits_for(1), 2);
        assert_eq!(signed_bits_for(127), 8);
        assert_eq!(signed_bits_for(128), 9);
    }
}
