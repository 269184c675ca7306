//! Helpers shared by the integration tests: committed scenes and small built-in geometries.
#![allow(dead_code)]

use shellsim::scene::Scene;
use std::path::PathBuf;

/// The committed scene files, by file name.
pub const COMMITTED: [&str; 7] = [
    "scene1.json",
    "scene2.json",
    "cornell.json",
    "stress-edges.json",
    "stress-grazing.json",
    "stress-skewed.json",
    "stress-dense.json",
];

/// Path of a committed scene.
pub fn scene_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

/// Loads a committed scene.
pub fn load(name: &str) -> Scene {
    let p = scene_path(name);
    Scene::load_json(&p).unwrap_or_else(|e| panic!("{e}"))
}

/// The unit cube's six walls facing inward: 0 floor (z=0), 1 ceiling, 2 x=0, 3 x=1, 4 y=0, 5 y=1.
pub fn unit_cube() -> Scene {
    shellsim::scene::gen::unit_cube()
}
