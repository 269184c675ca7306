//! The Cornell box from the published measurements, scaled to the unit cube and turned z-up.

use super::*;

/// The Cornell box's size in millimetres along its depth: the scale factor to the unit cube.
pub(super) const CORNELL_MM: f64 = 559.2;

/// The published light's height is the ceiling's (548.8 mm); it is put 0.1 mm lower so it
/// is not coplanar with the ceiling.
const CORNELL_LIGHT_Y: f64 = 548.7;

/// A published point (mm, y up, open front at z = 0) in scene coordinates: scaled by
/// 1/559.2 and turned z-up by a proper rotation (x, y, z) → (x, 559.2 − z, y), so the red
/// wall stays on the left seen from the front. The back wall lands on y = 0, the added front
/// wall on y = 1, the floor on z = 0.
pub(super) fn cornell_point([x, y, z]: [f64; 3]) -> DVec3 {
    v3(
        x / CORNELL_MM,
        (CORNELL_MM - z) / CORNELL_MM,
        y / CORNELL_MM,
    )
}

/// The Cornell box's 8 corners (mm), from which every shell face is built.
pub(super) const CB: [[f64; 3]; 8] = [
    [552.8, 0.0, 0.0],     // 0: floor, front, x high
    [0.0, 0.0, 0.0],       // 1: floor, front, x = 0
    [0.0, 0.0, 559.2],     // 2: floor, back, x = 0
    [549.6, 0.0, 559.2],   // 3: floor, back, x high
    [556.0, 548.8, 0.0],   // 4: ceiling, front, x high
    [556.0, 548.8, 559.2], // 5: ceiling, back, x high
    [0.0, 548.8, 559.2],   // 6: ceiling, back, x = 0
    [0.0, 548.8, 0.0],     // 7: ceiling, front, x = 0
];

pub(super) const CORNELL_WHITE: Spectrum = Spectrum::Grey(0.75);
pub(super) const CORNELL_RED: Spectrum = Spectrum::Rgb([0.63, 0.065, 0.05]);
pub(super) const CORNELL_GREEN: Spectrum = Spectrum::Rgb([0.14, 0.45, 0.091]);

/// The Cornell box's shell (floor, ceiling, back, right, left and the added front wall) as
/// published (corner indices into [`CB`]) with their colours; each face is oriented into
/// the box and split into two triangles if it is not planar.
fn cornell_shell() -> Vec<Patch> {
    let faces: [([usize; 4], Spectrum); 6] = [
        ([0, 1, 2, 3], CORNELL_WHITE), // floor
        ([4, 5, 6, 7], CORNELL_WHITE), // ceiling
        ([3, 2, 6, 5], CORNELL_WHITE), // back wall
        ([2, 1, 7, 6], CORNELL_GREEN), // right wall (x = 0)
        ([0, 3, 5, 4], CORNELL_RED),   // left wall (x ≈ 550–556; not planar)
        ([0, 1, 7, 4], CORNELL_WHITE), // front wall: not in the data, closes the box
    ];
    let inside = CB.iter().map(|&c| cornell_point(c)).sum::<DVec3>() / 8.0;
    let mut patches = Vec::new();
    for (corners, colour) in faces {
        let v: Vec<DVec3> = corners.iter().map(|&k| cornell_point(CB[k])).collect();
        let p = Patch {
            vertices: v,
            emission: Spectrum::Grey(0.0),
            reflectance: colour,
            name: None,
            material: None,
        };
        // Face into the box.
        let p = if p.area_vector().dot(inside - p.centroid()) < 0.0 {
            Patch {
                vertices: flipped(p.vertices),
                ..p
            }
        } else {
            p
        };
        patches.extend(split_if_bad(p));
    }
    patches
}

/// A quad that fails [`Patch::check`] (the published left wall bends by about 3 mm) as two
/// triangles split along its 0–2 diagonal; any other patch as it is.
fn split_if_bad(p: Patch) -> Vec<Patch> {
    if p.vertices.len() == 4 && p.check().is_err() {
        let v = &p.vertices;
        vec![
            Patch {
                vertices: vec![v[0], v[1], v[2]],
                ..p.clone()
            },
            Patch {
                vertices: vec![v[0], v[2], v[3]],
                ..p.clone()
            },
        ]
    } else {
        vec![p]
    }
}

/// The Cornell box (Cornell University Program of Computer Graphics, "Cornell Box Data"):
/// floor (patch 0), light (patch 1, emitting [17, 12, 4]), then the rest of the shell and
/// the two blocks. Walls face into the box, the blocks' faces outward (into the room); the
/// blocks have no bottom. The published box is open at the front (z = 0 mm); a white front
/// wall through the four front corners closes it so that every ray from inside hits a patch.
pub(super) fn cornell() -> Vec<Patch> {
    let mut shell = cornell_shell();
    let floor = shell.remove(0);

    // The light, 0.1 mm below the ceiling, facing down.
    let light: Vec<DVec3> = [
        [343.0, CORNELL_LIGHT_Y, 227.0],
        [343.0, CORNELL_LIGHT_Y, 332.0],
        [213.0, CORNELL_LIGHT_Y, 332.0],
        [213.0, CORNELL_LIGHT_Y, 227.0],
    ]
    .iter()
    .map(|&c| cornell_point(c))
    .collect();
    let mut light = Patch {
        vertices: light,
        emission: Spectrum::Rgb([17.0, 12.0, 4.0]),
        reflectance: Spectrum::Grey(0.78),
        name: None,
        material: None,
    };
    if light.area_vector().z > 0.0 {
        light.vertices = flipped(light.vertices);
    }

    let mut patches = vec![floor, light];
    patches.extend(shell);

    // The blocks: the top's 4 corners (x, z in mm) and the height; 5 faces each.
    let short: [[f64; 2]; 4] = [[130.0, 65.0], [82.0, 225.0], [240.0, 272.0], [290.0, 114.0]];
    let tall: [[f64; 2]; 4] = [
        [423.0, 247.0],
        [265.0, 296.0],
        [314.0, 456.0],
        [472.0, 406.0],
    ];
    for (top, h) in [(short, 165.0), (tall, 330.0)] {
        let up = |k: usize| cornell_point([top[k][0], h, top[k][1]]);
        let down = |k: usize| cornell_point([top[k][0], 0.0, top[k][1]]);
        let mut centre = (0..4).map(up).sum::<DVec3>() / 4.0;
        centre.z /= 2.0;
        let mut faces = vec![(0..4).map(up).collect::<Vec<_>>()];
        for k in 0..4 {
            let l = (k + 1) % 4;
            faces.push(vec![down(k), up(k), up(l), down(l)]);
        }
        for v in faces {
            let p = Patch {
                vertices: v,
                emission: Spectrum::Grey(0.0),
                reflectance: CORNELL_WHITE,
                name: None,
                material: None,
            };
            // Face out of the block.
            let p = if p.area_vector().dot(p.centroid() - centre) < 0.0 {
                Patch {
                    vertices: flipped(p.vertices),
                    ..p
                }
            } else {
                p
            };
            patches.extend(split_if_bad(p));
        }
    }
    patches
}
