//! The one description of what the RTL's ports and stage registers hold: names, widths and
//! order. From it come the parameter package and the co-simulation top (mod.rs), the packed
//! vectors the harness replays (vectors.rs), and the decoding of a mismatch into the field
//! that differs — so the Rust model, the SystemVerilog and the harness cannot disagree on a
//! bit position.

use shellsim_hw::config::{Formats, MachineConfig};
use shellsim_hw::datapath::divider::DividerShape;

/// One field: `count` elements of `width` bits, element 0 at the lowest bits (the RTL's
/// flattened arrays, `[i*W +: W]`). `sv` is the RTL signal (a port or `u.register`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Field {
    pub name: String,
    pub sv: String,
    pub width: u32,
    pub count: u32,
}

impl Field {
    fn new(name: &str, sv: &str, width: u32, count: u32) -> Field {
        Field {
            name: name.into(),
            sv: sv.into(),
            width,
            count,
        }
    }

    /// Total bits.
    pub fn bits(&self) -> u32 {
        self.width * self.count
    }
}

/// A stage register: its name, its Rust counterpart, its valid and tag signals and fields.
#[derive(Clone, Debug)]
pub struct Stage {
    pub name: String,
    pub rust: &'static str,
    pub valid: String,
    pub tag: String,
    pub fields: Vec<Field>,
}

impl Stage {
    /// Total bits.
    pub fn bits(&self) -> u32 {
        self.fields.iter().map(Field::bits).sum()
    }
}

/// Which RTL unit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    Icu,
    Dda,
}

impl Unit {
    /// The SystemVerilog module.
    pub fn module(self) -> &'static str {
        match self {
            Unit::Icu => "shellsim_icu",
            Unit::Dda => "shellsim_dda",
        }
    }

    /// The name used in messages and file names.
    pub fn name(self) -> &'static str {
        match self {
            Unit::Icu => "icu",
            Unit::Dda => "dda",
        }
    }
}

/// Every width of the RTL for one configuration (the package `shellsim_cfg`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Params {
    pub f: Formats,
    pub div: DividerShape,
    /// Coordinate, shear, translated, ray-space, edge, det, numerator and t widths.
    pub cw: u32,
    pub sw: u32,
    pub tw: u32,
    pub rw: u32,
    pub ew: u32,
    pub dw: u32,
    pub nw: u32,
    pub ttw: u32,
    /// DDA: cell index bits, N_a bits (signed), D_a bits, and the comparisons' width.
    pub cb: u32,
    pub nbw: u32,
    pub denw: u32,
    pub pw: u32,
    pub overshoot: i64,
}

impl Params {
    /// The widths of `cfg`'s datapath and divider.
    pub fn new(cfg: &MachineConfig) -> crate::Result<Params> {
        let f = cfg.datapath.formats().map_err(|e| crate::Error::Param {
            key: e.key.clone(),
            what: e.what.clone(),
        })?;
        let div = DividerShape::new(&f, cfg.machine.divider_bits_per_stage);
        let cw = f.coord.bits();
        let nbw = cw + 2;
        let denw = f.dir.frac_bits + 2;
        let ft = f.t.frac_bits;
        let p = Params {
            f,
            div,
            cw,
            sw: f.shear.bits(),
            tw: f.translated.bits(),
            rw: f.ray_space.bits(),
            ew: f.edge.bits(),
            dw: f.det.bits(),
            nw: f.t_num.bits(),
            ttw: f.t.bits(),
            cb: cw,
            nbw,
            denw,
            pw: (nbw + denw + 1).max(nbw + ft).max(f.t.bits() + denw + 1) + 2,
            overshoot: shellsim_hw::datapath::dda::OVERSHOOT_LSB,
        };
        if !p.div.fits_i128() || p.nw + 2 > 126 || p.pw > 126 {
            return Err(crate::Error::Param {
                key: "frac_bits".into(),
                what: format!(
                    "{} gives registers wider than the co-simulation's 126 bits (divider {} bits)",
                    f.coord.frac_bits, p.div.cmpw
                ),
            });
        }
        Ok(p)
    }

    /// The package's parameters, in order, with a comment each.
    pub fn package(&self) -> Vec<(&'static str, i64, &'static str)> {
        let f = &self.f;
        vec![
            (
                "F",
                f.coord.frac_bits as i64,
                "fractional bits of coordinates, directions, shear",
            ),
            (
                "CI",
                f.coord.int_bits as i64,
                "integer bits of coordinates (with sign)",
            ),
            ("FT", f.t.frac_bits as i64, "fractional bits of t"),
            ("TI", f.t.int_bits as i64, "integer bits of t"),
            ("CW", self.cw as i64, "coordinate"),
            ("SW", self.sw as i64, "shear factor"),
            ("TW", self.tw as i64, "translated vertex (v − o)"),
            ("RW", self.rw as i64, "ray-space x, y, z"),
            ("EW", self.ew as i64, "edge function"),
            ("DW", self.dw as i64, "interpolation denominator"),
            ("NW", self.nw as i64, "interpolation numerator"),
            ("TTW", self.ttw as i64, "t"),
            (
                "DIV_BITS",
                self.div.bits_per_stage as i64,
                "quotient bits per divider stage",
            ),
            ("DIV_STAGES", self.div.stages as i64, "divider stages"),
            ("QF", self.div.qf as i64, "quotient bits"),
            (
                "SHIFT_N",
                self.div.shift_n as i64,
                "numerator shift to the t format",
            ),
            (
                "SHIFT_D",
                self.div.shift_d as i64,
                "denominator shift to the t format",
            ),
            ("XW", self.div.xw as i64, "dividend X = 2N + D'"),
            ("YW", self.div.yw as i64, "divisor Y = 2D'"),
            ("CMPW", self.div.cmpw as i64, "the divider's comparisons"),
            ("CB", self.cb as i64, "DDA cell index"),
            ("NBW", self.nbw as i64, "DDA N_a (signed)"),
            ("DENW", self.denw as i64, "DDA D_a = |d_a|"),
            ("PW", self.pw as i64, "DDA cross products"),
            (
                "OVERSHOOT",
                self.overshoot,
                "LSBs the walk goes on past the grid face it leaves",
            ),
        ]
    }

    /// The input fields of `unit`, in the order of the co-simulation top's `in_bus`.
    pub fn inputs(&self, unit: Unit) -> Vec<Field> {
        match unit {
            Unit::Icu => vec![
                Field::new("o", "in_o", self.cw, 3),
                Field::new("kx", "in_kx", 2, 1),
                Field::new("ky", "in_ky", 2, 1),
                Field::new("kz", "in_kz", 2, 1),
                Field::new("sx", "in_sx", self.sw, 1),
                Field::new("sy", "in_sy", self.sw, 1),
                Field::new("sz", "in_sz", self.sw, 1),
                Field::new("quad", "in_quad", 1, 1),
                Field::new("v", "in_v", self.cw, 12),
            ],
            Unit::Dda => vec![
                Field::new("c", "in_c", self.cb, 3),
                Field::new("dims", "in_dims", self.cb, 3),
                Field::new("step", "in_step", 2, 3),
                Field::new("n", "in_n", self.nbw, 3),
                Field::new("den", "in_den", self.denw, 3),
                Field::new("cell", "in_cell", self.nbw, 1),
                Field::new("entry_num", "in_entry_num", self.nbw, 1),
                Field::new("entry_den", "in_entry_den", self.denw, 1),
                Field::new("pinned", "in_pinned", 3, 1),
                Field::new("t", "in_t", self.ttw, 1),
            ],
        }
    }

    /// The stage registers of `unit`, first to last.
    pub fn stages(&self, unit: Unit) -> Vec<Stage> {
        let st = |name: &str, rust: &'static str, reg: &str, fields: Vec<Field>| Stage {
            name: name.into(),
            rust,
            valid: format!("u.{reg}_valid"),
            tag: format!("u.{reg}_tag"),
            fields,
        };
        let f = |name: &str, sv: &str, w: u32, n: u32| Field::new(name, sv, w, n);
        // Element j of a flattened array of w-bit elements.
        let slice = |sig: &str, j: u32, w: u32| format!("{sig}[{} +: {w}]", j * w);
        match unit {
            Unit::Icu => {
                let mut v = vec![
                    st(
                        "translate",
                        "datapath::translate",
                        "r0",
                        vec![
                            f("quad", "u.r0_quad", 1, 1),
                            f("p", "u.r0_p", self.tw, 12),
                            f("kx", "u.r0_kx", 2, 1),
                            f("ky", "u.r0_ky", 2, 1),
                            f("kz", "u.r0_kz", 2, 1),
                            f("sx", "u.r0_sx", self.sw, 1),
                            f("sy", "u.r0_sy", self.sw, 1),
                            f("sz", "u.r0_sz", self.sw, 1),
                        ],
                    ),
                    st(
                        "shear",
                        "datapath::shear",
                        "r1",
                        vec![
                            f("quad", "u.r1_quad", 1, 1),
                            f("x", "u.r1_x", self.rw, 4),
                            f("y", "u.r1_y", self.rw, 4),
                            f("z", "u.r1_z", self.rw, 4),
                        ],
                    ),
                    st(
                        "edges",
                        "datapath::edges",
                        "r2",
                        vec![
                            f("quad", "u.r2_quad", 1, 1),
                            f("inside", "u.r2_inside", 1, 1),
                            f("orient_neg", "u.r2_orient_neg", 1, 1),
                            f("z", "u.r2_z", self.rw, 4),
                            f("e", "u.r2_e", self.ew, 4),
                            f("diag", "u.r2_diag", self.ew, 1),
                        ],
                    ),
                    st(
                        "interpolate",
                        "datapath::interpolate",
                        "r3",
                        vec![
                            f("ok", "u.r3_ok", 1, 1),
                            f("num", "u.r3_num", self.nw, 1),
                            f("den", "u.r3_den", self.dw, 1),
                        ],
                    ),
                ];
                for j in 0..self.div.stages {
                    v.push(Stage {
                        name: format!("divide{j}"),
                        rust: "datapath::divider::stages",
                        valid: format!("u.rd_valid[{j}]"),
                        tag: format!("u.rd_tag[{} +: 32]", 32 * j),
                        fields: vec![
                            f("cand", &format!("u.rd_cand[{j}]"), 1, 1),
                            f("near_zero", &format!("u.rd_nz[{j}]"), 1, 1),
                            f("ovf", &format!("u.rd_ovf[{j}]"), 1, 1),
                            f("r", &slice("u.rd_r", j, self.div.xw), self.div.xw, 1),
                            f("q", &slice("u.rd_q", j, self.div.qf), self.div.qf, 1),
                            f("y", &slice("u.rd_y", j, self.div.yw), self.div.yw, 1),
                        ],
                    });
                }
                v.push(st(
                    "result",
                    "units::icu (the result register)",
                    "rr",
                    vec![
                        f("hit", "u.rr_hit", 1, 1),
                        f("t", "u.rr_t", self.ttw, 1),
                        f("near_zero", "u.rr_nz", 1, 1),
                        f("saturated", "u.rr_sat", 1, 1),
                    ],
                ));
                v
            }
            Unit::Dda => vec![Stage {
                name: "step".into(),
                rust: "datapath::dda::FixedDda::step",
                valid: "u.out_valid".into(),
                tag: "u.out_tag".into(),
                fields: vec![
                    f("moved", "u.out_moved", 1, 1),
                    f("c", "u.out_c", self.cb, 3),
                    f("n", "u.out_n", self.nbw, 3),
                    f("entry_num", "u.out_entry_num", self.nbw, 1),
                    f("entry_den", "u.out_entry_den", self.denw, 1),
                    f("pinned", "u.out_pinned", 3, 1),
                    f("exit_beyond", "u.out_exit_beyond", 1, 1),
                    f("entry_beyond", "u.out_entry_beyond", 1, 1),
                    f("entry_at_or_beyond", "u.out_entry_at_or_beyond", 1, 1),
                ],
            }],
        }
    }
}

/// Bits packed LSB first into 32-bit words, as Verilator stores a wide signal.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Packer {
    pub words: Vec<u32>,
    pub bits: u32,
}

impl Packer {
    /// Appends the low `width` bits of `x` (two's complement), a word's worth at a time.
    pub fn push(&mut self, x: i128, width: u32) {
        let mut done = 0;
        while done < width {
            let at = self.bits + done;
            let (word, off) = ((at / 32) as usize, at % 32);
            if word >= self.words.len() {
                self.words.push(0);
            }
            let n = (32 - off).min(width - done);
            let chunk = if done >= 128 {
                (x >> 127) as u32
            } else {
                (x >> done) as u32
            };
            let mask = if n == 32 { u32::MAX } else { (1u32 << n) - 1 };
            self.words[word] |= (chunk & mask) << off;
            done += n;
        }
        self.bits += width;
    }

    /// Appends `values` as the elements of `field` (checked: one value per element).
    pub fn field(&mut self, field: &Field, values: &[i128]) {
        assert_eq!(values.len() as u32, field.count, "field {}", field.name);
        for &v in values {
            self.push(v, field.width);
        }
    }

    /// Empties the packer, keeping its buffer.
    pub fn clear(&mut self) {
        self.words.clear();
        self.bits = 0;
    }

    /// Pads to a whole number of `words`.
    pub fn pad_to(&mut self, words: usize) {
        self.words.resize(words, 0);
    }
}

/// Reads `width` bits at bit `at` of `words` as an unsigned number.
pub fn bits_at(words: &[u32], at: u32, width: u32) -> u128 {
    let mut x = 0u128;
    for b in 0..width.min(128) {
        let i = at + b;
        if words
            .get((i / 32) as usize)
            .is_some_and(|w| (w >> (i % 32)) & 1 == 1)
        {
            x |= 1 << b;
        }
    }
    x
}

/// The first element of `stage` whose bits differ between `rtl` and `model` (both the
/// stage's own bits from bit 0): the field's name, the element and the two values.
pub fn first_difference(
    stage: &Stage,
    rtl: &[u32],
    model: &[u32],
) -> Option<(String, u32, u128, u128)> {
    let mut at = 0;
    for fld in &stage.fields {
        for e in 0..fld.count {
            let (a, b) = (bits_at(rtl, at, fld.width), bits_at(model, at, fld.width));
            if a != b {
                return Some((fld.name.clone(), e, a, b));
            }
            at += fld.width;
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_fields_read_back_and_a_difference_is_named() {
        let mut p = Packer::default();
        p.push(-3, 5);
        p.push(0x1_2345_6789_abcd, 49);
        p.push(1, 1);
        assert_eq!(p.bits, 55);
        assert_eq!(bits_at(&p.words, 0, 5), 0b11101);
        assert_eq!(bits_at(&p.words, 5, 49), 0x1_2345_6789_abcd);
        assert_eq!(bits_at(&p.words, 54, 1), 1);
        let stage = Stage {
            name: "s".into(),
            rust: "",
            valid: String::new(),
            tag: String::new(),
            fields: vec![Field::new("a", "", 5, 1), Field::new("b", "", 7, 7)],
        };
        let mut q = p.clone();
        q.words[1] ^= 1 << 3; // bit 35: field b, element (35 − 5) / 7 = 4
        let d = first_difference(&stage, &q.words, &p.words).unwrap();
        assert_eq!((d.0.as_str(), d.1), ("b", 4));
        assert!(first_difference(&stage, &p.words, &p.words).is_none());
    }
}
