//! Memory record formats: the patch record, the ray record and the cell table, as the host
//! writes them into global memory — fields packed densely (LSB first) into words with `bitvec`.
//!
//! Patch record: `last_vertex_is_copy` (1 bit: a triangle repeats its third vertex), the
//! patch id (24 bits), then 4 vertices × (x, y, z) in the coordinate format. Ray record: the
//! ray id (32 bits), origin (coordinate format), direction (direction format), the ray-space
//! axes kz (2 bits) and swap (1 bit), and the shear factors sx, sy, sz (shear format) that
//! the host precomputes in exact integer arithmetic. Cell table entry: the index of the
//! cell's first patch id in the id list (32 bits) and the count (16 bits); id list: 24 bits
//! per id.

use crate::datapath::format::round_div;
use crate::datapath::format::Formats;
use bitvec::prelude::*;

/// Bits of a patch id.
pub const PATCH_ID_BITS: u32 = 24;
/// Bits of a ray id.
pub const RAY_ID_BITS: u32 = 32;

/// A patch as the datapath sees it: vertex coordinates in the coordinate format (raw).
/// Triangles repeat their last vertex so every record has the same size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PatchRecord {
    pub id: u32,
    pub n_verts: u8,
    pub v: [[i64; 3]; 4],
}

/// A ray as the datapath sees it, with its ray-space set-up precomputed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RayRecord {
    pub id: u32,
    /// Origin, coordinate format.
    pub o: [i64; 3],
    /// Direction, direction format.
    pub d: [i64; 3],
    /// Ray-space axes: z is the direction's largest component; x, y swapped when d_kz < 0
    /// (keeps the winding of projected polygons).
    pub kx: u8,
    pub ky: u8,
    pub kz: u8,
    /// Shear: sx = d_kx/d_kz, sy = d_ky/d_kz, sz = 1/d_kz (shear format, rounded to nearest).
    pub sx: i64,
    pub sy: i64,
    pub sz: i64,
}

impl RayRecord {
    /// Builds a ray record from a quantized origin and direction (not all zero). The
    /// divisions are exact-integer rounded divisions (the host does them once per ray).
    pub fn new(id: u32, o: [i64; 3], d: [i64; 3], f: &Formats) -> Self {
        let a = d.map(|x| x.unsigned_abs());
        let kz = if a[0] > a[1] {
            if a[0] > a[2] {
                0
            } else {
                2
            }
        } else if a[1] > a[2] {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let fs = f.shear.frac_bits;
        let one = 1i128 << f.dir.frac_bits;
        let s = |num: i128| round_div(num << fs, d[kz] as i128) as i64;
        RayRecord {
            id,
            o,
            d,
            kx: kx as u8,
            ky: ky as u8,
            kz: kz as u8,
            sx: s(d[kx] as i128),
            sy: s(d[ky] as i128),
            sz: s(one),
        }
    }
}

/// Appends the low `bits` bits of `x` (two's complement) to `out`, LSB first.
fn push(out: &mut BitVec<u32, Lsb0>, x: i64, bits: u32) {
    for b in 0..bits {
        out.push((x >> b) & 1 == 1);
    }
}

/// Reads a signed field of `bits` bits at `*at`, advancing it.
fn take(src: &BitSlice<u32, Lsb0>, at: &mut usize, bits: u32) -> i64 {
    let mut x: i64 = 0;
    for b in 0..bits as usize {
        if src[*at + b] {
            x |= 1 << b;
        }
    }
    *at += bits as usize;
    // Sign-extend.
    let shift = 64 - bits;
    (x << shift) >> shift
}

/// Reads an unsigned field.
fn take_u(src: &BitSlice<u32, Lsb0>, at: &mut usize, bits: u32) -> u64 {
    let mut x: u64 = 0;
    for b in 0..bits as usize {
        if src[*at + b] {
            x |= 1 << b;
        }
    }
    *at += bits as usize;
    x
}

/// Record sizes in bits and memory words for a set of formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct RecordSizes {
    pub patch_bits: u32,
    pub patch_words: u32,
    pub ray_bits: u32,
    pub ray_words: u32,
    pub cell_entry_bits: u32,
    pub id_entry_bits: u32,
}

impl RecordSizes {
    pub fn of(f: &Formats) -> Self {
        let w = f.word_bits;
        let patch_bits = 1 + PATCH_ID_BITS + 12 * f.coord.bits();
        let ray_bits = RAY_ID_BITS + 3 * f.coord.bits() + 3 * f.dir.bits() + 3 + 3 * f.shear.bits();
        RecordSizes {
            patch_bits,
            patch_words: patch_bits.div_ceil(w),
            ray_bits,
            ray_words: ray_bits.div_ceil(w),
            cell_entry_bits: 48,
            id_entry_bits: PATCH_ID_BITS,
        }
    }
}

impl PatchRecord {
    /// The record packed into memory words.
    pub fn pack(&self, f: &Formats) -> Vec<u32> {
        let mut bits: BitVec<u32, Lsb0> = BitVec::new();
        bits.push(self.n_verts == 3);
        push(&mut bits, self.id as i64, PATCH_ID_BITS);
        for v in &self.v {
            for &c in v {
                push(&mut bits, c, f.coord.bits());
            }
        }
        words(bits, f.word_bits)
    }

    /// Unpacks a record written by [`PatchRecord::pack`].
    pub fn unpack(words: &[u32], f: &Formats) -> Self {
        let src = words.view_bits::<Lsb0>();
        let mut at = 0;
        let tri = src[0];
        at += 1;
        let id = take_u(src, &mut at, PATCH_ID_BITS) as u32;
        let mut v = [[0i64; 3]; 4];
        for p in &mut v {
            for c in p.iter_mut() {
                *c = take(src, &mut at, f.coord.bits());
            }
        }
        PatchRecord {
            id,
            n_verts: if tri { 3 } else { 4 },
            v,
        }
    }
}

impl RayRecord {
    /// The record packed into memory words.
    pub fn pack(&self, f: &Formats) -> Vec<u32> {
        let mut bits: BitVec<u32, Lsb0> = BitVec::new();
        push(&mut bits, self.id as i64, RAY_ID_BITS);
        for &c in &self.o {
            push(&mut bits, c, f.coord.bits());
        }
        for &c in &self.d {
            push(&mut bits, c, f.dir.bits());
        }
        push(&mut bits, self.kz as i64, 2);
        bits.push(self.kx != (self.kz + 1) % 3);
        for s in [self.sx, self.sy, self.sz] {
            push(&mut bits, s, f.shear.bits());
        }
        words(bits, f.word_bits)
    }

    /// Unpacks a record written by [`RayRecord::pack`].
    pub fn unpack(words: &[u32], f: &Formats) -> Self {
        let src = words.view_bits::<Lsb0>();
        let mut at = 0;
        let id = take_u(src, &mut at, RAY_ID_BITS) as u32;
        let mut o = [0i64; 3];
        for c in &mut o {
            *c = take(src, &mut at, f.coord.bits());
        }
        let mut d = [0i64; 3];
        for c in &mut d {
            *c = take(src, &mut at, f.dir.bits());
        }
        let kz = take_u(src, &mut at, 2) as u8;
        let swap = src[at];
        at += 1;
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        if swap {
            std::mem::swap(&mut kx, &mut ky);
        }
        let sx = take(src, &mut at, f.shear.bits());
        let sy = take(src, &mut at, f.shear.bits());
        let sz = take(src, &mut at, f.shear.bits());
        RayRecord {
            id,
            o,
            d,
            kx,
            ky,
            kz,
            sx,
            sy,
            sz,
        }
    }
}

/// Pads a bit stream to whole memory words; the result holds `word_bits / 32` u32 per word
/// (the configuration keeps `word_bits` a multiple of 32).
fn words(mut bits: BitVec<u32, Lsb0>, word_bits: u32) -> Vec<u32> {
    let n = (bits.len() as u32).div_ceil(word_bits) * word_bits;
    bits.resize(n as usize, false);
    bits.into_vec()
}

/// The cell table in hardware form: per cell (x fastest) the first index into `ids` and
/// the count; `ids` holds patch ids.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct CellTable {
    pub dims: [u32; 3],
    /// Cell edge in coordinate LSBs (cells are cubes on the fixed-point grid).
    pub cell_raw: i64,
    pub first: Vec<u32>,
    pub count: Vec<u16>,
    pub ids: Vec<u32>,
}

impl CellTable {
    /// The patch ids of cell `c` (linear index).
    #[inline]
    pub fn patches_in(&self, c: usize) -> &[u32] {
        let f = self.first[c] as usize;
        &self.ids[f..f + self.count[c] as usize]
    }

    /// Linear index of cell coordinates.
    #[inline]
    pub fn index(&self, c: [u32; 3]) -> usize {
        (c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])) as usize
    }

    /// Size of the table in memory words (entries and the id list).
    pub fn words(&self, word_bits: u32) -> u64 {
        let cells = self.first.len() as u64;
        let bits = cells * 48 + self.ids.len() as u64 * PATCH_ID_BITS as u64;
        bits.div_ceil(word_bits as u64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_round_trip_through_memory_words() {
        let f = crate::config::paper().datapath.formats().unwrap();
        let p = PatchRecord {
            id: 0xABCDE,
            n_verts: 3,
            v: [
                [1, -2, 3],
                [f.coord.max_raw() as i64, 0, -1],
                [f.coord.min_raw() as i64, 5, 6],
                [7, 8, 9],
            ],
        };
        let w = p.pack(&f);
        assert_eq!(w.len() as u32, RecordSizes::of(&f).patch_words);
        assert_eq!(PatchRecord::unpack(&w, &f), p);
        let one = 1i64 << f.dir.frac_bits;
        let r = RayRecord::new(77, [10, 20, 30], [-one / 2, one / 4, -one / 8 * 7], &f);
        assert_eq!(r.kz, 2);
        let w = r.pack(&f);
        assert_eq!(w.len() as u32, RecordSizes::of(&f).ray_words);
        assert_eq!(RayRecord::unpack(&w, &f), r);
    }

    #[test]
    fn shear_factors_are_rounded_quotients() {
        let f = crate::config::paper().datapath.formats().unwrap();
        let one = 1i64 << f.dir.frac_bits;
        let r = RayRecord::new(0, [0; 3], [one / 2, -one / 4, one], &f);
        assert_eq!((r.kx, r.ky, r.kz), (0, 1, 2));
        assert_eq!(r.sx, one / 2);
        assert_eq!(r.sy, -one / 4);
        assert_eq!(r.sz, one);
        let r = RayRecord::new(0, [0; 3], [0, 0, -one], &f);
        assert_eq!((r.kx, r.ky), (1, 0), "x and y swap when d_kz < 0");
        assert_eq!(r.sz, -one);
    }
}
