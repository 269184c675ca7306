//! Datapath configuration: the formats of coordinates, directions and t (the `[datapath]`
//! table of hw/configs/*.toml), validated, with every intermediate width derived from them.

use super::ConfigError;
use crate::datapath::format::{Fault, Format, Formats};
use serde::{Deserialize, Serialize};

/// The `[datapath]` table. Unknown keys are errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatapathConfig {
    /// F: fractional bits of coordinates, directions, shear factors (LSB 2^-F).
    pub frac_bits: u32,
    /// Integer bits (with sign) of coordinates relative to the grid origin; 2 gives
    /// [-2, 2), room for the unit cube and the differences of its points.
    pub coord_int_bits: u32,
    /// Fractional bits of t.
    pub t_frac_bits: u32,
    /// Integer bits (with sign) of t: t must reach the grid's diagonal.
    pub t_int_bits: u32,
    /// Width of a global-memory word, for record sizes.
    pub word_bits: u32,
    /// Margin, in coordinate LSBs, by which the host's cell table lists a patch in cells it
    /// comes near (the datapath's hit point may lie a few LSBs off the quantized polygon).
    pub cell_margin_lsb: u32,
}

impl DatapathConfig {
    /// The derived formats; an error names the key that makes them impossible.
    pub fn formats(&self) -> Result<Formats, ConfigError> {
        let err = |key: &str, what: String| ConfigError {
            key: key.into(),
            what,
        };
        if !(4..=30).contains(&self.frac_bits) {
            return Err(err(
                "frac_bits",
                format!("{} is outside 4..=30", self.frac_bits),
            ));
        }
        if !(1..=12).contains(&self.coord_int_bits) {
            return Err(err(
                "coord_int_bits",
                format!("{} is outside 1..=12", self.coord_int_bits),
            ));
        }
        if !(4..=40).contains(&self.t_frac_bits) || self.t_frac_bits > self.frac_bits + 10 {
            return Err(err(
                "t_frac_bits",
                format!(
                    "{} is outside 4..=40 or more than frac_bits + 10",
                    self.t_frac_bits
                ),
            ));
        }
        if !(2..=16).contains(&self.t_int_bits) {
            return Err(err(
                "t_int_bits",
                format!("{} is outside 2..=16", self.t_int_bits),
            ));
        }
        if !(32..=512).contains(&self.word_bits) || !self.word_bits.is_multiple_of(32) {
            return Err(err(
                "word_bits",
                format!("{} is not a multiple of 32 in 32..=512", self.word_bits),
            ));
        }
        if self.cell_margin_lsb > 1 << 16 {
            return Err(err(
                "cell_margin_lsb",
                format!("{} is absurdly large", self.cell_margin_lsb),
            ));
        }
        if (self.cell_margin_lsb as i64) < crate::datapath::dda::OVERSHOOT_LSB {
            return Err(err(
                "cell_margin_lsb",
                format!(
                    "{} is below {}: the datapath's hit point may lie that far off a quantized patch, and the walk's overshoot past the grid's faces reaches that far",
                    self.cell_margin_lsb,
                    crate::datapath::dda::OVERSHOOT_LSB
                ),
            ));
        }
        let f = self.frac_bits;
        let ci = self.coord_int_bits;
        // |v - o| < 2^ci; ray space |p_kx − sx·p_kz| < 2^(ci+1) (|sx| ≤ 1), |sz·p_kz| < 2^(ci+1).
        let translated = Format::new(ci + 1, f);
        let ray_space = Format::new(ci + 2, f);
        // e = xa·yb − ya·xb: |e| < 2·2^(2(ci+1)); sums of three: two more bits.
        let edge = Format::new(2 * ray_space.int_bits, 2 * f);
        let det = Format::new(edge.int_bits + 2, 2 * f);
        let t_num = Format::new(edge.int_bits + ray_space.int_bits + 1, 3 * f);
        let t = Format::new(self.t_int_bits, self.t_frac_bits);
        for (name, fm) in [("coordinates", Format::new(ci, f)), ("t", t)] {
            if fm.bits() > 62 {
                return Err(err(name, format!("{fm} is wider than a 62-bit register")));
            }
        }
        // The divider forms t_num·2^(Ft−F) before dividing; it must fit an i128.
        let div_bits = t_num.bits() + self.t_frac_bits.saturating_sub(f);
        if div_bits > 126 {
            return Err(err(
                "frac_bits",
                format!("the divider would need {div_bits} bits (at most 126)"),
            ));
        }
        Ok(Formats {
            coord: Format::new(ci, f),
            dir: Format::new(2, f),
            shear: Format::new(2, f),
            translated,
            ray_space,
            edge,
            det,
            t_num,
            t,
            word_bits: self.word_bits,
            fault: Fault::None,
        })
    }
}

impl Formats {
    /// A rough hardware cost of one ICU datapath: Σ over multipliers of (a bits × b bits)
    /// and Σ over adders of their width, from the datapath's stage list (see `datapath`).
    pub fn cost(&self) -> HardwareCost {
        let c = self.coord.bits() as u64;
        let tr = self.translated.bits() as u64;
        let sh = self.shear.bits() as u64;
        let rs = self.ray_space.bits() as u64;
        let e = self.edge.bits() as u64;
        let dt = self.det.bits() as u64;
        let tn = self.t_num.bits() as u64;
        let t = self.t.bits() as u64;
        let n = 4; // vertices per patch (quads)
        let multiplier_bits =
            // shear: 3 products per vertex (sx·pz, sy·pz, sz·pz)
            n * 3 * tr * sh
            // edge functions: 2 products per edge, 5 edges (4 + the diagonal)
            + 5 * 2 * rs * rs
            // interpolation: 3 products e·z
            + 3 * e * rs;
        let adder_bits = n * 3 * c      // translate
            + n * 2 * rs                // shear subtractions
            + 5 * e                     // edge differences
            + 2 * dt + 2 * tn           // det and numerator sums
            + tn * t                    // divider: one subtractor per quotient bit
            + t + 32; // compare (t and id)
        HardwareCost {
            multiplier_bits,
            adder_bits,
        }
    }
}

/// A rough area measure of the datapath: multiplier bit-products and adder bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct HardwareCost {
    pub multiplier_bits: u64,
    pub adder_bits: u64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_formats_derive() {
        let f = super::super::paper().datapath.formats().unwrap();
        assert_eq!(f.coord, Format::new(2, 12));
        assert_eq!(f.edge, Format::new(8, 24));
        assert!(f.t_num.bits() < 127);
    }

    /// A whole file whose `[datapath]` table is `datapath` (the other tables from paper.toml).
    fn file(datapath: &str) -> String {
        let head =
            &super::super::PAPER_TOML[..super::super::PAPER_TOML.find("[datapath]").unwrap()];
        format!("{head}[datapath]\n{datapath}")
    }

    /// The `[datapath]` table of a whole file, through the one parser.
    fn parse(text: &str) -> Result<DatapathConfig, ConfigError> {
        super::super::MachineConfig::from_toml_str(text).map(|c| c.datapath)
    }

    #[test]
    fn unknown_and_impossible_keys_are_errors() {
        let e = parse(&file("frac_bits = 20\n")).unwrap_err();
        assert!(e.what.contains("missing field"), "{e}");
        let ok = "frac_bits = 20\ncoord_int_bits = 2\nt_frac_bits = 20\nt_int_bits = 3\nword_bits = 32\ncell_margin_lsb = 4\n";
        assert!(parse(&file(ok)).is_ok());
        let e = parse(&file(&format!("{ok}colour = 1\n"))).unwrap_err();
        assert!(e.what.contains("unknown field"), "{e}");
        let e = parse(&file(&ok.replace("= 20\ncoord", "= 99\ncoord"))).unwrap_err();
        assert_eq!(e.key, "frac_bits");
    }
}
