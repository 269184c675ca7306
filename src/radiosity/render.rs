//! Pictures of a radiosity solution: one primary ray per pixel through the float tracer
//! (so every model is seen through the same pixels), each hit patch shown with its
//! radiosity — flat, or smooth by vertex averaging — tone-mapped by one fixed curve whose
//! exposure comes from the scene alone (the same for every model); a false-colour
//! difference image with a scale bar; PNG through the `image` crate.

use crate::error::{Error, Result};
use crate::output::write_atomic;
use crate::reference::tracer::{Ray, Tracer};
use crate::scene::Scene;
use glam::DVec3;
use serde::Serialize;
use std::collections::HashMap;
use std::path::Path;

/// The scene's up axis (0, 1, 2 for x, y, z) and why: against the emitters' mean normal
/// when they face mostly along one axis (a ceiling light faces down), else the file's
/// convention — y for OBJ, z for shellsim's JSON scenes.
pub fn up_axis(scene: &Scene, file: &Path) -> (usize, &'static str) {
    let n: glam::DVec3 = scene
        .patches
        .iter()
        .filter(|p| p.emission.is_nonzero())
        .map(|p| p.area_vector())
        .sum();
    if n.length() > 0.0 {
        let m = n.abs();
        let a = if m.x >= m.y && m.x >= m.z {
            0
        } else if m.y >= m.z {
            1
        } else {
            2
        };
        if n.abs()[a] >= 0.9 * n.length() && n[a] < 0.0 {
            return (a, "the emitters face down along it");
        }
    }
    let obj = file
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
    if obj {
        (1, "OBJ files are y-up")
    } else {
        (2, "shellsim's JSON scenes are z-up")
    }
}

/// A pinhole camera: eye, the point looked at, the up direction, vertical field of view in
/// degrees.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Camera {
    pub eye: [f64; 3],
    pub look: [f64; 3],
    pub up: [f64; 3],
    pub fov: f64,
}

impl Camera {
    /// From the scene's bounds and its up axis `up` (0, 1, 2 for x, y, z; [`up_axis`]):
    /// inside the room, 1 % of the depth in front of the wall that closes the front (the
    /// high side of the depth axis — y for z-up scenes, z for y-up ones, as OBJ files look
    /// down −z), at 40 % of the height, looking slightly up at the far wall (60 % of the
    /// height) so a ceiling light is in view, 80° field of view.
    pub fn default_for(scene: &Scene, up: usize) -> Camera {
        let (lo, hi) = (scene.bounds.lo, scene.bounds.hi);
        let c = (lo + hi) * 0.5;
        let ext = hi - lo;
        let depth = if up == 2 { 1 } else { 2 };
        let mut eye = c;
        eye[depth] = hi[depth] - 0.01 * ext[depth];
        eye[up] = lo[up] + 0.4 * ext[up];
        let mut look = c;
        look[depth] = lo[depth];
        look[up] = lo[up] + 0.6 * ext[up];
        let mut u = [0.0; 3];
        u[up] = 1.0;
        Camera {
            eye: eye.to_array(),
            look: look.to_array(),
            up: u,
            fov: 80.0,
        }
    }

    /// Parses `ex,ey,ez,lx,ly,lz,ux,uy,uz,fov` (ten finite numbers; the view direction and
    /// up not parallel, 0 < fov < 180). The error says what is wrong.
    pub fn parse(s: &str) -> std::result::Result<Camera, String> {
        let v: Vec<f64> = s
            .split(',')
            .map(|x| {
                x.trim()
                    .parse::<f64>()
                    .map_err(|_| format!("{x:?} is not a number"))
            })
            .collect::<std::result::Result<_, _>>()?;
        if v.len() != 10 {
            return Err(format!(
                "{} numbers given; want 10: eye x,y,z, look x,y,z, up x,y,z, fov in degrees",
                v.len()
            ));
        }
        if let Some(x) = v.iter().find(|x| !x.is_finite()) {
            return Err(format!("{x} is not finite"));
        }
        let cam = Camera {
            eye: [v[0], v[1], v[2]],
            look: [v[3], v[4], v[5]],
            up: [v[6], v[7], v[8]],
            fov: v[9],
        };
        if !(cam.fov > 0.0 && cam.fov < 180.0) {
            return Err(format!(
                "fov {} must lie strictly between 0 and 180 degrees",
                cam.fov
            ));
        }
        let (_, r, u) = cam
            .basis()
            .ok_or("the eye equals the look point, or up is parallel to the view")?;
        let _ = (r, u);
        Ok(cam)
    }

    /// Forward, right and up unit vectors (None when degenerate).
    fn basis(&self) -> Option<(DVec3, DVec3, DVec3)> {
        let f = DVec3::from_array(self.look) - DVec3::from_array(self.eye);
        let f = f.try_normalize()?;
        let r = f.cross(DVec3::from_array(self.up)).try_normalize()?;
        Some((f, r, r.cross(f)))
    }

    /// The primary ray through the centre of pixel (x, y) of a w × h image (y down).
    fn ray(&self, basis: (DVec3, DVec3, DVec3), x: u32, y: u32, w: u32, h: u32) -> Ray {
        let (f, r, u) = basis;
        let s = (self.fov.to_radians() * 0.5).tan();
        let px = ((x as f64 + 0.5) / w as f64 * 2.0 - 1.0) * s * w as f64 / h as f64;
        let py = (1.0 - (y as f64 + 0.5) / h as f64 * 2.0) * s;
        Ray {
            o: DVec3::from_array(self.eye),
            d: f + r * px + u * py,
        }
    }
}

/// Shading of the pictures.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Shading {
    /// Each patch in its own radiosity.
    Flat,
    /// Radiosity averaged at the vertices (over the patches meeting there with the same
    /// normal, area-weighted) and interpolated over each patch.
    Smooth,
}

/// What each pixel sees: the patch hit and the point, from the float tracer.
pub struct HitBuffer {
    pub width: u32,
    pub height: u32,
    pub hits: Vec<Option<(u32, DVec3)>>,
}

/// Casts one primary ray per pixel (rows in parallel; the result is independent of the
/// thread count).
pub fn cast(tracer: &Tracer, cam: &Camera, width: u32, height: u32) -> HitBuffer {
    use rayon::prelude::*;
    let basis = cam.basis().expect("a validated camera");
    let hits = (0..height)
        .into_par_iter()
        .flat_map_iter(|y| {
            (0..width).map(move |x| {
                let ray = cam.ray(basis, x, y, width, height);
                tracer
                    .trace(&ray, None)
                    .map(|h| (h.patch, ray.o + ray.d * h.t))
            })
        })
        .collect();
    HitBuffer {
        width,
        height,
        hits,
    }
}

/// The exposure of the tone map, from the scene alone: the mean radiosity of an enclosure
/// with the scene's emitted power and its area-weighted mean reflectance,
/// (Σ A E / Σ A) / (1 − ρ̄).
pub fn exposure(scene: &Scene) -> f64 {
    let area: f64 = scene.patches.iter().map(|p| p.area()).sum();
    let mut power = 0.0;
    let mut rho = 0.0;
    for p in &scene.patches {
        let a = p.area();
        power += a * p.emission.rgb().iter().sum::<f64>() / 3.0;
        rho += a * p.reflectance.rgb().iter().sum::<f64>() / 3.0;
    }
    let b = power / area / (1.0 - (rho / area).min(0.95));
    if b > 0.0 {
        b
    } else {
        1.0
    }
}

/// The tone map: 1 − exp(−B / (1.5 × exposure)) per channel, then the sRGB curve, 8 bits.
pub fn tone(b: [f64; 3], exposure: f64) -> [u8; 3] {
    let mut out = [0u8; 3];
    for c in 0..3 {
        let x = 1.0 - (-b[c].max(0.0) / (1.5 * exposure)).exp();
        let s = if x <= 0.003_130_8 {
            12.92 * x
        } else {
            1.055 * x.powf(1.0 / 2.4) - 0.055
        };
        out[c] = (s.clamp(0.0, 1.0) * 255.0).round() as u8;
    }
    out
}

/// Per patch and vertex, the radiosity averaged at that vertex (see [`Shading::Smooth`]).
fn vertex_radiosity(scene: &Scene, b: &[[f64; 3]]) -> Vec<Vec<[f64; 3]>> {
    let key = |v: DVec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
    let mut at: HashMap<[u64; 3], Vec<u32>> = HashMap::new();
    for (i, p) in scene.patches.iter().enumerate() {
        for v in &p.vertices {
            at.entry(key(*v)).or_default().push(i as u32);
        }
    }
    let normals: Vec<DVec3> = scene.patches.iter().map(|p| p.normal()).collect();
    let areas: Vec<f64> = scene.patches.iter().map(|p| p.area()).collect();
    scene
        .patches
        .iter()
        .enumerate()
        .map(|(i, p)| {
            p.vertices
                .iter()
                .map(|v| {
                    let mut s = [0.0; 3];
                    let mut w = 0.0;
                    // In id order, so the sum does not depend on the map's order.
                    for &j in &at[&key(*v)] {
                        let j = j as usize;
                        if normals[i].dot(normals[j]) > 0.99 {
                            for c in 0..3 {
                                s[c] += areas[j] * b[j][c];
                            }
                            w += areas[j];
                        }
                    }
                    [s[0] / w, s[1] / w, s[2] / w]
                })
                .collect()
        })
        .collect()
}

/// Barycentric interpolation of vertex values over the fan triangle (v0, vk, vk+1) of a
/// convex polygon that holds `p`.
fn interpolate(verts: &[DVec3], vals: &[[f64; 3]], p: DVec3) -> [f64; 3] {
    let n = verts.len();
    let mut best = (f64::NEG_INFINITY, [0.0; 3]);
    for k in 1..n - 1 {
        let (a, b, c) = (verts[0], verts[k], verts[k + 1]);
        let nrm = (b - a).cross(c - a);
        let d = nrm.length_squared();
        let w1 = (c - b).cross(p - b).dot(nrm) / d;
        let w2 = (a - c).cross(p - c).dot(nrm) / d;
        let w3 = 1.0 - w1 - w2;
        let m = w1.min(w2).min(w3);
        if m > best.0 {
            let mut v = [0.0; 3];
            for ch in 0..3 {
                v[ch] = w1 * vals[0][ch] + w2 * vals[k][ch] + w3 * vals[k + 1][ch];
            }
            best = (m, v);
        }
    }
    best.1
}

/// An 8-bit RGB picture.
pub type Picture = image::RgbImage;

/// The picture of solution `b` (per patch RGB) through `hits`.
pub fn picture(scene: &Scene, hits: &HitBuffer, b: &[[f64; 3]], shading: Shading) -> Picture {
    let exp = exposure(scene);
    let vb = (shading == Shading::Smooth).then(|| vertex_radiosity(scene, b));
    let mut img = Picture::new(hits.width, hits.height);
    for (k, h) in hits.hits.iter().enumerate() {
        let px = match h {
            None => [0, 0, 0],
            Some((id, p)) => {
                let id = *id as usize;
                let v = match &vb {
                    None => b[id],
                    Some(vb) => interpolate(&scene.patches[id].vertices, &vb[id], *p),
                };
                tone(v, exp)
            }
        };
        img.put_pixel(k as u32 % hits.width, k as u32 / hits.width, image::Rgb(px));
    }
    img
}

/// Luminance (Rec. 709) of an RGB radiosity.
pub fn luminance(b: [f64; 3]) -> f64 {
    0.2126 * b[0] + 0.7152 * b[1] + 0.0722 * b[2]
}

/// A diverging colour map on [−1, 1]: blue, white at 0, red.
fn diverging(x: f64) -> [u8; 3] {
    let x = x.clamp(-1.0, 1.0);
    let (r, g, b) = if x >= 0.0 {
        (1.0, 1.0 - 0.85 * x, 1.0 - 0.9 * x)
    } else {
        (1.0 + 0.9 * x, 1.0 + 0.7 * x, 1.0)
    };
    [
        (r * 255.0).round() as u8,
        (g * 255.0).round() as u8,
        (b * 255.0).round() as u8,
    ]
}

/// The smallest of 1, 2, 5 × 10^k at or above `x` (x > 0).
pub fn nice_scale(x: f64) -> f64 {
    let e = x.log10().floor();
    for m in [1.0, 2.0, 5.0, 10.0] {
        let s = m * 10f64.powf(e);
        if s >= x * (1.0 - 1e-12) {
            return s;
        }
    }
    10f64.powf(e + 1.0)
}

/// The scale of a difference picture: the nice value (1, 2, 5 × 10^k) at or above the
/// largest |relative difference| of the patches the picture shows (`dark` patches, with no
/// light in A, have none); at least `floor`.
pub fn visible_scale(hits: &HitBuffer, rel: &[f64], dark: &[bool], floor: f64) -> f64 {
    let m = hits
        .hits
        .iter()
        .flatten()
        .filter(|(id, _)| !dark[*id as usize])
        .fold(0.0f64, |m, (id, _)| m.max(rel[*id as usize].abs()));
    nice_scale(m.max(floor))
}

/// The false-colour picture of the signed relative difference (Y_b − Y_a) / Y_a of each
/// patch's luminance, on ±`scale`, with a scale bar and its labels (as fractions: 0.01 is
/// 1 %) below. Pixels that see no patch (the rays leave the scene) are black; patches
/// with no light in A (`dark`: no relative difference to show) are grey.
pub fn difference_picture(hits: &HitBuffer, rel: &[f64], dark: &[bool], scale: f64) -> Picture {
    let bar_h = 40;
    let (w, h) = (hits.width, hits.height);
    let mut img = Picture::from_pixel(w, h + bar_h, image::Rgb([255, 255, 255]));
    for (k, hit) in hits.hits.iter().enumerate() {
        let px = match hit {
            None => [0, 0, 0],
            Some((id, _)) if dark[*id as usize] => [128, 128, 128],
            Some((id, _)) => diverging(rel[*id as usize] / scale),
        };
        img.put_pixel(k as u32 % w, k as u32 / w, image::Rgb(px));
    }
    // The bar: 10 % margins, 12 px high, under the picture.
    let (x0, x1) = (w / 10, w - w / 10);
    for x in x0..x1 {
        let t = (x - x0) as f64 / (x1 - x0 - 1).max(1) as f64 * 2.0 - 1.0;
        for y in h + 4..h + 16 {
            img.put_pixel(x, y, image::Rgb(diverging(t)));
        }
    }
    // Labels as fractions (0.01 = 1 %): the glyphs are digits and signs only.
    let label = |v: f64| format!("{}", (v * 1e9).round() / 1e9);
    let glyph_w = |s: &str| s.len() as u32 * 4 * 2;
    let lo = format!("-{}", label(scale));
    let hi = format!("+{}", label(scale));
    draw_text(&mut img, x0, h + 20, &lo, 2);
    draw_text(&mut img, (x0 + x1) / 2 - glyph_w("0") / 2, h + 20, "0", 2);
    draw_text(&mut img, x1.saturating_sub(glyph_w(&hi)), h + 20, &hi, 2);
    img
}

/// 3 × 5 glyphs of the characters the scale bar and the labels need (rows top down, 3
/// bits each): digits, signs and the letters of the model names.
fn glyph(c: char) -> [u8; 5] {
    match c {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 1, 1],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        '.' => [0, 0, 0, 0, 2],
        '-' => [0, 0, 7, 0, 0],
        '+' => [0, 2, 7, 2, 0],
        'a' => [0, 7, 1, 7, 7],
        'c' => [0, 7, 4, 4, 7],
        'd' => [1, 7, 5, 5, 7],
        'e' => [0, 7, 7, 4, 7],
        'f' => [3, 4, 7, 4, 4],
        'h' => [4, 7, 5, 5, 5],
        'i' => [2, 0, 2, 2, 2],
        'l' => [6, 2, 2, 2, 7],
        'm' => [0, 7, 7, 5, 5],
        'n' => [0, 7, 5, 5, 5],
        'o' => [0, 7, 5, 5, 7],
        's' => [0, 7, 6, 3, 7],
        't' => [2, 7, 2, 2, 3],
        'v' => [0, 5, 5, 5, 2],
        'x' => [0, 5, 2, 2, 5],
        _ => [0; 5],
    }
}

/// Draws `text` in black at (x, y), each glyph pixel `s` × `s`.
fn draw_text(img: &mut Picture, x: u32, y: u32, text: &str, s: u32) {
    for (k, c) in text.chars().enumerate() {
        let g = glyph(c);
        for (row, bits) in g.iter().enumerate() {
            for col in 0..3 {
                if bits >> (2 - col) & 1 == 1 {
                    for dy in 0..s {
                        for dx in 0..s {
                            let px = x + (k as u32 * 4 + col) * s + dx;
                            let py = y + row as u32 * s + dy;
                            if px < img.width() && py < img.height() {
                                img.put_pixel(px, py, image::Rgb([0, 0, 0]));
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Two pictures of the same size side by side with an 8-pixel white gap, each under a
/// white strip naming it (`label_a`, `label_b`: lower-case model names).
pub fn side_by_side(a: &Picture, label_a: &str, b: &Picture, label_b: &str) -> Picture {
    let (gap, strip) = (8, 16);
    let mut img = Picture::from_pixel(
        a.width() + gap + b.width(),
        strip + a.height().max(b.height()),
        image::Rgb([255, 255, 255]),
    );
    image::imageops::replace(&mut img, a, 0, strip as i64);
    image::imageops::replace(&mut img, b, (a.width() + gap) as i64, strip as i64);
    draw_text(&mut img, 4, 3, label_a, 2);
    draw_text(&mut img, a.width() + gap + 4, 3, label_b, 2);
    img
}

/// Encodes `img` as PNG and writes it to `path`, atomically.
pub fn write_png(path: &Path, img: &Picture) -> Result<()> {
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(
            img.as_raw(),
            img.width(),
            img.height(),
            image::ExtendedColorType::Rgb8,
        )
        .map_err(|e| Error::io(path, std::io::Error::other(e)))?;
    write_atomic(path, &bytes)
}

use image::ImageEncoder as _;
