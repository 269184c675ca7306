//! The dependency rule of ARCHITECTURE.md, checked on the source text: src/'s top-level
//! modules depend one way (no circle), nothing imports `cli`, every edge goes down the
//! layering cli → explore, rtl → experiment, size, radiosity, stability → machine → wave, fixed, partition → reference → scene (the leaves
//! error, output, limits, config, paper, progress and chart may be used from anywhere), scene's model
//! never imports its OBJ reader (which builds model's types), hw/ never depends on the host,
//! and no file of src/ or hw/src/ imports a file that imports it (a file-level circle).

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

/// The module path of a source file below `root` (src/ or hw/src/): `wave/vcd.rs` is
/// `["wave", "vcd"]`, `wave/mod.rs` is `["wave"]`, `lib.rs` is `[]`.
fn module_of(root: &Path, f: &Path) -> Vec<String> {
    let rel = f.strip_prefix(root).unwrap();
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().unwrap();
    let stem = last.strip_suffix(".rs").unwrap();
    if stem != "mod" && stem != "lib" && stem != "main" {
        parts.push(stem.to_string());
    }
    parts
}

/// The paths of a use tree at the front of `s` (`a::b::{c, d::e}` gives `a::b::c` and
/// `a::b::d::e`), each as its leading identifiers.
fn use_tree(s: &str) -> Vec<Vec<String>> {
    fn ident(s: &str) -> (&str, &str) {
        let n = s
            .find(|c: char| !(c.is_alphanumeric() || c == '_'))
            .unwrap_or(s.len());
        (&s[..n], &s[n..])
    }
    fn tree(s: &str, out: &mut Vec<Vec<String>>, prefix: Vec<String>) -> usize {
        let t = s.trim_start();
        let skipped = s.len() - t.len();
        if let Some(group) = t.strip_prefix('{') {
            let mut at = 1;
            loop {
                let rest = &group[at - 1..];
                let rest_t = rest.trim_start_matches([',', ' ', '\n', '\t', '\r']);
                at += rest.len() - rest_t.len();
                if rest_t.is_empty() || rest_t.starts_with('}') {
                    return skipped + at + 1;
                }
                let used = tree(rest_t, out, prefix.clone());
                if used == 0 {
                    return skipped + at;
                }
                at += used;
            }
        }
        let (id, rest) = ident(t);
        if id.is_empty() {
            out.push(prefix);
            return skipped;
        }
        let mut p = prefix;
        p.push(id.to_string());
        if let Some(more) = rest.strip_prefix("::") {
            skipped + id.len() + 2 + tree(more, out, p)
        } else {
            out.push(p);
            skipped + id.len()
        }
    }
    let mut out = Vec::new();
    tree(s, &mut out, Vec::new());
    out
}

/// The module files a file names, resolved to the deepest module of each path that is a
/// file of the crate: `crate::a::b` (also in doc comments), `super::…`, `self::…`. A
/// `mod.rs`'s relative paths into its own submodules (`pub use vcd::VcdBody`) are its
/// folder's face, not an edge; a child naming `super::X` defined in the `mod.rs` is one.
fn file_edges(
    root: &Path,
    f: &Path,
    modules: &BTreeMap<Vec<String>, PathBuf>,
) -> BTreeSet<PathBuf> {
    let text = std::fs::read_to_string(f).unwrap();
    // A file's own unit tests (`#[cfg(test)] mod tests`, last in the file) name their file
    // as `super`: not an edge.
    let text = match text.find("#[cfg(test)]\nmod tests") {
        Some(i) => &text[..i],
        None => &text[..],
    };
    let me = module_of(root, f);
    let is_mod = matches!(
        f.file_name().unwrap().to_str().unwrap(),
        "mod.rs" | "lib.rs" | "main.rs"
    );
    // The module `super::` names, and `self::`.
    let here = me.clone();
    let parent = if is_mod {
        me[..me.len().saturating_sub(1)].to_vec()
    } else {
        me[..me.len() - 1].to_vec()
    };
    let mut paths: Vec<Vec<String>> = Vec::new();
    let bytes = text.as_bytes();
    let mut i = 0;
    while i < text.len() {
        let prev_ok = i == 0
            || !(bytes[i - 1].is_ascii_alphanumeric()
                || bytes[i - 1] == b'_'
                || bytes[i - 1] == b':');
        let rest = &text[i..];
        if prev_ok {
            if let Some(r) = rest.strip_prefix("crate::") {
                paths.extend(use_tree(r));
            } else if rest.starts_with("super::") {
                let mut base = parent.clone();
                let mut r = rest;
                let mut first = true;
                while let Some(x) = r.strip_prefix("super::") {
                    if !first {
                        base.pop();
                    }
                    first = false;
                    r = x;
                }
                // `super` of a file `a/b.rs` is `a`; of `a/b/mod.rs` also `a`.
                for p in use_tree(r) {
                    let mut full = base.clone();
                    full.extend(p);
                    paths.push(full);
                }
            } else if let Some(r) = rest.strip_prefix("self::") {
                for p in use_tree(r) {
                    let mut full = if is_mod { here.clone() } else { parent.clone() };
                    full.extend(p);
                    paths.push(full);
                }
            }
        }
        i += rest.chars().next().map_or(1, char::len_utf8);
    }
    let mut out = BTreeSet::new();
    for p in paths {
        // The deepest prefix that is a module file.
        for n in (0..=p.len()).rev() {
            if let Some(g) = modules.get(&p[..n]) {
                if g != f {
                    out.insert(g.clone());
                }
                break;
            }
        }
    }
    out
}

/// The first file-level import circle in a crate below `root`, if any (the crate root,
/// lib.rs, left out: it only declares and re-exports).
fn file_circle(root: &Path) -> Option<String> {
    let files = rust_files(root);
    let modules: BTreeMap<Vec<String>, PathBuf> = files
        .iter()
        // The crate root only gathers the modules (as for the top-level check above).
        .filter(|f| {
            f.parent() != Some(root)
                || !matches!(f.file_name().unwrap().to_str(), Some("main.rs" | "lib.rs"))
        })
        .map(|f| (module_of(root, f), f.clone()))
        .collect();
    let graph: BTreeMap<PathBuf, BTreeSet<PathBuf>> = modules
        .values()
        .map(|f| (f.clone(), file_edges(root, f, &modules)))
        .collect();
    fn visit(
        g: &BTreeMap<PathBuf, BTreeSet<PathBuf>>,
        f: &PathBuf,
        stack: &mut Vec<PathBuf>,
        done: &mut BTreeSet<PathBuf>,
    ) -> Option<Vec<PathBuf>> {
        if done.contains(f) {
            return None;
        }
        if let Some(i) = stack.iter().position(|s| s == f) {
            let mut c = stack[i..].to_vec();
            c.push(f.clone());
            return Some(c);
        }
        stack.push(f.clone());
        for x in &g[f] {
            if let Some(c) = visit(g, x, stack, done) {
                return Some(c);
            }
        }
        stack.pop();
        done.insert(f.clone());
        None
    }
    let mut done = BTreeSet::new();
    for f in graph.keys() {
        if let Some(c) = visit(&graph, f, &mut Vec::new(), &mut done) {
            let names: Vec<String> = c
                .iter()
                .map(|p| p.strip_prefix(root).unwrap().display().to_string())
                .collect();
            return Some(names.join(" -> "));
        }
    }
    None
}

#[test]
fn the_use_tree_parser_finds_nested_groups() {
    let got = use_tree("wave::{fst::X, options::{A, B}}, other");
    let want: Vec<Vec<String>> = [
        vec!["wave", "fst", "X"],
        vec!["wave", "options", "A"],
        vec!["wave", "options", "B"],
    ]
    .iter()
    .map(|v| v.iter().map(|s| s.to_string()).collect())
    .collect();
    assert_eq!(got, want);
}

/// A made-up crate with a circle through a parent's re-export is found; without it, none.
#[test]
fn a_file_circle_is_found() {
    let d = tempfile::tempdir().unwrap();
    let w = |p: &str, t: &str| {
        let p = d.path().join(p);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, t).unwrap();
    };
    w("lib.rs", "mod a;\nmod b;\n");
    w("a/mod.rs", "mod x;\npub use x::X;\n");
    w("a/x.rs", "pub struct X;\n");
    w("b.rs", "use crate::a::X;\n");
    assert_eq!(file_circle(d.path()), None);
    // Siblings in two folders, one named in a doc comment.
    w("a/x.rs", "/// Makes [`crate::b::Y`].\npub struct X;\n");
    w("b.rs", "use crate::a::{x::X};\npub struct Y;\n");
    let c = file_circle(d.path()).expect("a circle");
    assert!(c.contains("b.rs") && c.contains("a/x.rs"), "{c}");
    // A child naming its parent's item, the parent the child's.
    w("b.rs", "pub struct Y;\n");
    w("a/x.rs", "use super::Z;\npub struct X;\n");
    w(
        "a/mod.rs",
        "mod x;\npub struct Z;\nfn f(_: self::x::X) {}\n",
    );
    let c = file_circle(d.path()).expect("a circle");
    assert!(c.contains("a/mod.rs") && c.contains("a/x.rs"), "{c}");
}

#[test]
fn no_file_imports_a_file_that_imports_it() {
    for root in [root().join("src"), root().join("hw/src")] {
        if let Some(c) = file_circle(&root) {
            panic!("{}: import circle {c}", root.display());
        }
    }
}
