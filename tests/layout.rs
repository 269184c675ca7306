//! The dependency rule of ARCHITECTURE.md, checked on the source text: src/'s top-level
//! modules depend one way (no circle), nothing imports `cli`, every edge goes down the
//! layering cli → explore, rtl → experiment, size, radiosity, stability → machine → wave, fixed, partition → reference → scene (the leaves
//! error, output, limits, config, paper, progress and chart may be used from anywhere), scene's model
//! never imports its OBJ reader (which builds model's types), and hw/ never depends on the host.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Layer of each top-level module: an edge must go to a lower layer or to a leaf.
const LAYERS: &[(&str, u32)] = &[
    ("scene", 1),
    ("reference", 2),
    ("fixed", 3),
    ("partition", 3),
    ("wave", 3),
    ("machine", 4),
    ("experiment", 5),
    ("size", 5),
    ("radiosity", 5),
    ("stability", 5),
    ("explore", 6),
    ("rtl", 6),
    ("cli", 7),
];

/// Modules any other may use; they import no layered module.
const LEAVES: &[&str] = &[
    "error", "output", "limits", "config", "paper", "progress", "chart",
];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every `.rs` file below `dir`.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(rust_files(&p));
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
    out.sort();
    out
}

/// The top-level modules a text names through `crate::X` or `crate::{X, Y::…}`.
fn crate_paths(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut rest = text;
    while let Some(i) = rest.find("crate::") {
        let after = &rest[i + "crate::".len()..];
        // `shellsim_hw::…` or `mycrate::…` are not this crate.
        let before = rest[..i].chars().next_back();
        if !before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            if let Some(group) = after.strip_prefix('{') {
                let end = group.find('}').unwrap_or(group.len());
                for part in group[..end].split(',') {
                    let name: String = part
                        .trim()
                        .chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect();
                    if !name.is_empty() {
                        out.insert(name);
                    }
                }
            } else {
                let name: String = after
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                out.insert(name);
            }
        }
        rest = after;
    }
    out
}

/// Edges between src/'s top-level modules.
fn module_graph() -> BTreeMap<String, BTreeSet<String>> {
    let src = root().join("src");
    let mut files: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
    for e in std::fs::read_dir(&src).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if name == "lib.rs" || name == "main.rs" {
            continue;
        }
        if p.is_dir() {
            files.insert(name, rust_files(&p));
        } else if let Some(m) = name.strip_suffix(".rs") {
            files.insert(m.to_string(), vec![p]);
        }
    }
    let names: BTreeSet<String> = files.keys().cloned().collect();
    files
        .iter()
        .map(|(m, fs)| {
            let mut to = BTreeSet::new();
            for f in fs {
                let text = std::fs::read_to_string(f).unwrap();
                to.extend(
                    crate_paths(&text)
                        .into_iter()
                        .filter(|x| x != m && names.contains(x)),
                );
            }
            (m.clone(), to)
        })
        .collect()
}

#[test]
fn the_parser_finds_single_and_grouped_paths() {
    let found = crate_paths(
        "use crate::scene::Scene;\nuse crate::{config, output::write_json};\nshellsim_hw::crate_x",
    );
    let want: BTreeSet<String> = ["scene", "config", "output"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    assert_eq!(found, want);
}

#[test]
fn every_module_is_layered_or_a_leaf() {
    for m in module_graph().keys() {
        assert!(
            LAYERS.iter().any(|(n, _)| n == m) || LEAVES.contains(&m.as_str()),
            "src/{m} is neither in a layer nor a leaf: add it to ARCHITECTURE.md's rule and here"
        );
    }
}

#[test]
fn nothing_imports_cli() {
    for (m, to) in module_graph() {
        assert!(!to.contains("cli"), "src/{m} imports cli");
    }
}

#[test]
fn edges_go_down_the_layers() {
    let layer = |m: &str| LAYERS.iter().find(|(n, _)| *n == m).map(|(_, l)| *l);
    for (m, to) in module_graph() {
        for x in &to {
            if LEAVES.contains(&x.as_str()) {
                // A leaf uses only other leaves.
                assert!(
                    layer(&m).is_some() || LEAVES.contains(&m.as_str()),
                    "{m} -> {x}"
                );
                continue;
            }
            let (lm, lx) = (layer(&m), layer(x));
            assert!(
                lm.is_some() && lx.is_some() && lx < lm,
                "src/{m} imports {x}, which is not below it (layers {lm:?} -> {lx:?})"
            );
        }
    }
}

#[test]
fn the_module_graph_has_no_circle() {
    let g = module_graph();
    // Depth-first search; a module met again while on the stack closes a circle.
    fn visit<'a>(
        g: &'a BTreeMap<String, BTreeSet<String>>,
        m: &'a str,
        stack: &mut Vec<&'a str>,
        done: &mut BTreeSet<&'a str>,
    ) {
        if done.contains(m) {
            return;
        }
        if let Some(i) = stack.iter().position(|s| *s == m) {
            panic!("circle: {}", stack[i..].join(" -> ") + " -> " + m);
        }
        stack.push(m);
        for x in &g[m] {
            visit(g, x, stack, done);
        }
        stack.pop();
        done.insert(m);
    }
    let mut done = BTreeSet::new();
    for m in g.keys() {
        visit(&g, m, &mut Vec::new(), &mut done);
    }
}

#[test]
fn scene_model_and_obj_do_not_import_each_other() {
    // obj.rs builds model's types; model.rs never reaches back into the OBJ reader, and the
    // one polygon check depends on neither.
    let read = |f: &str| std::fs::read_to_string(root().join("src/scene").join(f)).unwrap();
    assert!(
        !read("model.rs").contains("obj::"),
        "scene/model.rs imports obj"
    );
    let polygon = read("polygon.rs");
    assert!(
        !polygon.contains("obj::") && !polygon.contains("model::"),
        "scene/polygon.rs imports obj or model"
    );
}

#[test]
fn hw_never_depends_on_the_host() {
    let manifest = std::fs::read_to_string(root().join("hw/Cargo.toml")).unwrap();
    assert!(
        !manifest.contains("shellsim ="),
        "hw/Cargo.toml depends on shellsim"
    );
    for f in rust_files(&root().join("hw/src")) {
        let text = std::fs::read_to_string(&f).unwrap();
        assert!(
            !text.contains("shellsim::"),
            "{} names the host crate",
            f.display()
        );
    }
}
