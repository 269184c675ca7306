//! ARCHITECTURE.md stays true where a test can tell: every repository path it names exists,
//! its dependency rule names the layers and leaves tests/it/layout.rs checks, and it is at most
//! 300 lines (issue 35).
//!
//! A path is a token that starts a word with a top-level folder of the repository (`src/`,
//! `hw/`, `tests/`, `docs/`, …) or is a root file (`BENCHMARKS.md`), in prose, code spans and
//! the diagram alike; `{a,b}` groups are expanded and `*` matches within one name. Under a
//! heading that names paths (a code-map section), a code span holding a relative name that
//! ends in `.rs` or `/` (`model.rs`, `cli/mod.rs`, `gen/`) must exist below one of the
//! heading's folders or their parents; elsewhere such names are not checked.

use std::path::{Path, PathBuf};

/// The longest ARCHITECTURE.md may be.
const MAX_LINES: usize = 300;

/// Top-level folders a path may start with.
const ROOTS: &[&str] = &[
    "src/",
    "hw/",
    "tests/",
    "ci/",
    ".ci/",
    "docs/",
    "benches/",
    "scenes/",
    "examples/",
    "vendor/",
    "waves/",
];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A path the text names, on its line, with the places it may be (any one will do).
#[derive(Debug, Clone, PartialEq, Eq)]
struct Named {
    line: usize,
    token: String,
    candidates: Vec<String>,
}

fn is_path_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.' | '/' | '{' | '}' | '*')
}

/// `a{b,c}d{e,f}` as every combination (`abde`, `abdf`, `acde`, `acdf`).
fn expand(s: &str) -> Vec<String> {
    let Some(open) = s.find('{') else {
        return vec![s.to_string()];
    };
    let Some(len) = s[open..].find('}') else {
        return vec![s.to_string()];
    };
    let close = open + len;
    let (head, tail) = (&s[..open], &s[close + 1..]);
    s[open + 1..close]
        .split(',')
        .flat_map(|alt| expand(&format!("{head}{}{tail}", alt.trim())))
        .collect()
}

/// The tokens of `line` that start a word with one of [`ROOTS`] or are a root file
/// (`NAME.md` in capitals), trailing sentence punctuation dropped.
fn rooted_tokens(line: &str) -> Vec<String> {
    let chars: Vec<(usize, char)> = line.char_indices().collect();
    let mut out = Vec::new();
    let mut k = 0;
    while k < chars.len() {
        let (i, c) = chars[k];
        let starts_word = k == 0 || !is_path_char(chars[k - 1].1);
        if !starts_word || !is_path_char(c) {
            k += 1;
            continue;
        }
        // The token: path characters, and commas and spaces inside a `{…}` group.
        let mut depth = 0;
        let mut end = k;
        while end < chars.len() {
            let ch = chars[end].1;
            match ch {
                '{' => depth += 1,
                '}' if depth > 0 => depth -= 1,
                ',' | ' ' if depth > 0 => {}
                _ if is_path_char(ch) => {}
                _ => break,
            }
            end += 1;
        }
        let stop = chars.get(end).map_or(line.len(), |&(j, _)| j);
        let token = line[i..stop].trim_end_matches(['.', ',']);
        let root_file = token.ends_with(".md")
            && token.starts_with(|c: char| c.is_ascii_uppercase())
            && token[..token.len() - 3]
                .chars()
                .all(|c| c.is_ascii_uppercase() || c == '_');
        if ROOTS.iter().any(|r| token.starts_with(r)) || root_file {
            out.push(token.to_string());
        }
        k = end.max(k + 1);
    }
    out
}

/// The code spans of `line` (between single backticks).
fn code_spans(line: &str) -> Vec<&str> {
    line.split('`').skip(1).step_by(2).collect()
}

/// A relative name a code-map section may hold: lowercase names joined by `/`, ending in
/// `.rs` or `/`.
fn is_relative_name(s: &str) -> bool {
    let body = match (s.strip_suffix(".rs"), s.strip_suffix('/')) {
        (Some(b), _) | (None, Some(b)) => b,
        _ => return false,
    };
    !body.is_empty()
        && !ROOTS.iter().any(|r| s.starts_with(r))
        && body.split('/').all(|p| {
            !p.is_empty()
                && p.chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
        })
}

/// Every path `text` names (see the file's header).
fn named_paths(text: &str) -> Vec<Named> {
    let mut out = Vec::new();
    let mut bases: Vec<String> = Vec::new();
    let mut fenced = false;
    for (n, line) in text.lines().enumerate() {
        let line_no = n + 1;
        if line.starts_with("```") {
            fenced = !fenced;
        }
        let rooted: Vec<String> = rooted_tokens(line).iter().flat_map(|t| expand(t)).collect();
        if !fenced && line.starts_with('#') {
            // A heading sets the folders relative names resolve against: each folder it
            // names and its parent, a file's folder.
            bases.clear();
            for t in &rooted {
                let p = Path::new(t.trim_end_matches('/'));
                if t.ends_with('/') {
                    bases.push(format!("{}/", p.display()));
                }
                if let Some(parent) = p.parent().filter(|q| !q.as_os_str().is_empty()) {
                    bases.push(format!("{}/", parent.display()));
                }
            }
        }
        for t in rooted {
            out.push(Named {
                line: line_no,
                token: t.clone(),
                candidates: vec![t],
            });
        }
        if fenced || bases.is_empty() {
            continue;
        }
        for span in code_spans(line) {
            for t in expand(span) {
                if is_relative_name(&t) {
                    out.push(Named {
                        line: line_no,
                        candidates: bases.iter().map(|b| format!("{b}{t}")).collect(),
                        token: t,
                    });
                }
            }
        }
    }
    out
}

/// True when `name` matches `pattern`, whose `*` matches any run of characters.
fn glob_match(pattern: &str, name: &str) -> bool {
    match pattern.split_once('*') {
        None => pattern == name,
        Some((head, rest)) => {
            name.starts_with(head)
                && (0..=name.len() - head.len()).any(|k| {
                    name.is_char_boundary(head.len() + k)
                        && glob_match(rest, &name[head.len() + k..])
                })
        }
    }
}

/// True when the repository path `p` (relative, `*` allowed within a name) exists below `dir`.
fn exists(dir: &Path, p: &str) -> bool {
    let mut here = vec![dir.to_path_buf()];
    for part in p.trim_end_matches('/').split('/') {
        let mut next = Vec::new();
        for d in &here {
            if part.contains('*') {
                if let Ok(rd) = std::fs::read_dir(d) {
                    for e in rd.flatten() {
                        if glob_match(part, &e.file_name().to_string_lossy()) {
                            next.push(e.path());
                        }
                    }
                }
            } else if d.join(part).exists() {
                next.push(d.join(part));
            }
        }
        here = next;
    }
    !here.is_empty() && (!p.ends_with('/') || here.iter().any(|h| h.is_dir()))
}

/// The paths `text` names that exist nowhere below `dir`, as `line N: token`.
fn missing(dir: &Path, text: &str) -> Vec<String> {
    named_paths(text)
        .into_iter()
        .filter(|n| !n.candidates.iter().any(|c| exists(dir, c)))
        .map(|n| format!("line {}: {}", n.line, n.token))
        .collect()
}

fn architecture() -> String {
    std::fs::read_to_string(root().join("ARCHITECTURE.md")).unwrap()
}

#[test]
fn every_path_architecture_names_exists() {
    let text = architecture();
    let named = named_paths(&text);
    // The extractor found the map's paths at all (a broken one would pass vacuously).
    assert!(named.len() > 100, "only {} paths found", named.len());
    let gone = missing(&root(), &text);
    assert!(
        gone.is_empty(),
        "ARCHITECTURE.md names paths that do not exist:\n  {}",
        gone.join("\n  ")
    );
}

#[test]
fn architecture_is_at_most_300_lines() {
    let n = architecture().lines().count();
    assert!(
        n <= MAX_LINES,
        "ARCHITECTURE.md has {n} lines, more than {MAX_LINES}: mechanics belong in the code's comments"
    );
}

#[test]
fn the_extractor_finds_rooted_braced_and_relative_paths() {
    let text = "See src/lib.rs, `hw/src/{link,msg}.rs` and BENCHMARKS.md.\n\
                hw/src/machine/'s walks; not a/src/x.rs nor shellsim-hw/\n\
                ### `src/scene/`, `src/main.rs`\n\
                `model.rs`, `gen/`, `Scene::twins`, `cli/mod.rs`\n\
                ## Invariants\n\
                `model.rs` unchecked here\n";
    let got: Vec<(usize, String, Vec<String>)> = named_paths(text)
        .into_iter()
        .map(|n| (n.line, n.token, n.candidates))
        .collect();
    let one = |l: usize, t: &str| (l, t.to_string(), vec![t.to_string()]);
    let rel = |l: usize, t: &str| {
        let c = ["src/scene/", "src/", "src/"].map(|b| format!("{b}{t}"));
        (l, t.to_string(), c.to_vec())
    };
    assert_eq!(
        got,
        vec![
            one(1, "src/lib.rs"),
            one(1, "hw/src/link.rs"),
            one(1, "hw/src/msg.rs"),
            one(1, "BENCHMARKS.md"),
            one(2, "hw/src/machine/"),
            one(3, "src/scene/"),
            one(3, "src/main.rs"),
            rel(4, "model.rs"),
            rel(4, "gen/"),
            rel(4, "cli/mod.rs"),
        ]
    );
}

#[test]
fn a_path_that_does_not_exist_is_reported() {
    let text = "Real: src/lib.rs and `tests/it/layout.rs`; not: src/no_such_file.rs, \
                `hw/src/{link,nope}.rs`, docs/nowhere/, tests/*.nothing, NOPE.md.\n\
                ### `src/scene/`\n\
                `model.rs` and `gone.rs`\n";
    let gone = missing(&root(), text);
    assert_eq!(
        gone,
        [
            "line 1: src/no_such_file.rs",
            "line 1: hw/src/nope.rs",
            "line 1: docs/nowhere/",
            "line 1: tests/*.nothing",
            "line 1: NOPE.md",
            "line 3: gone.rs",
        ]
    );
    // A file named as a folder is not one.
    assert!(!exists(&root(), "src/lib.rs/"));
    assert!(exists(&root(), "tests/it/*.rs") && exists(&root(), "src/scene/"));
}

/// The layers and leaves ARCHITECTURE.md's dependency rule states: `(N) `a`, `b`; …` after
/// "From the top:", and the code spans between "The leaves —" and the next "—".
fn stated_rule(text: &str) -> (Vec<(String, u32)>, Vec<String>) {
    let text = &text.split_whitespace().collect::<Vec<_>>().join(" ");
    let spans = |s: &str| -> Vec<String> { code_spans(s).iter().map(|x| x.to_string()).collect() };
    let from = text.find("From the top:").expect("the rule's layers");
    let layers_text = &text[from..from + text[from..].find("The leaves").expect("the leaves")];
    let mut layers = Vec::new();
    for part in layers_text.split('(').skip(1) {
        let (n, names) = part.split_once(')').expect("(N) names");
        let n: u32 = n.trim().parse().expect("a layer number");
        for name in spans(names) {
            layers.push((name, n));
        }
    }
    let at = text.find("The leaves —").expect("the leaves") + "The leaves —".len();
    let leaves = spans(&text[at..at + text[at..].find('—').expect("the leaves' end")]);
    (layers, leaves)
}

/// The `LAYERS` and `LEAVES` tests/it/layout.rs checks, read from its source text.
fn checked_rule(source: &str) -> (Vec<(String, u32)>, Vec<String>) {
    let block = |name: &str| -> &str {
        let at = source
            .find(name)
            .unwrap_or_else(|| panic!("{name} in tests/it/layout.rs"));
        let rest = &source[at..];
        let open = rest.find("= &[").expect("a list") + 4;
        &rest[open..open + rest[open..].find("];").expect("the list's end")]
    };
    let quoted =
        |s: &str| -> Vec<String> { s.split('"').skip(1).step_by(2).map(String::from).collect() };
    let layers = block("const LAYERS")
        .split('(')
        .skip(1)
        .map(|t| {
            let name = quoted(t).remove(0);
            let n = t
                .split(',')
                .nth(1)
                .and_then(|x| x.trim().trim_end_matches(')').trim().parse().ok());
            (name, n.expect("a layer number"))
        })
        .collect();
    (layers, quoted(block("const LEAVES")))
}

#[test]
fn the_stated_dependency_rule_is_the_one_tests_layout_checks() {
    let sorted = |(mut l, mut v): (Vec<(String, u32)>, Vec<String>)| {
        l.sort();
        v.sort();
        (l, v)
    };
    let stated = sorted(stated_rule(&architecture()));
    let layout = std::fs::read_to_string(root().join("tests/it/layout.rs")).unwrap();
    let checked = sorted(checked_rule(&layout));
    assert!(stated.0.len() > 5 && stated.1.len() > 3, "{stated:?}");
    assert_eq!(
        stated, checked,
        "ARCHITECTURE.md's layers and leaves (left) differ from tests/it/layout.rs's (right)"
    );
}

#[test]
fn the_rule_readers_read_layers_and_leaves() {
    let doc = "From the top: (2) `cli`, `x`; (1) `scene`. The leaves — `error`, `chart` — may";
    let src = "const LAYERS: &[(&str, u32)] = &[\n    (\"scene\", 1),\n    (\"cli\", 2),\n    (\"x\", 2),\n];\n\
               const LEAVES: &[&str] = &[\n    \"error\", \"chart\",\n];";
    let s = stated_rule(doc);
    assert_eq!(
        s.0,
        [
            ("cli".to_string(), 2),
            ("x".to_string(), 2),
            ("scene".to_string(), 1)
        ]
    );
    assert_eq!(s.1, ["error", "chart"]);
    let c = checked_rule(src);
    assert_eq!(
        c.0,
        [
            ("scene".to_string(), 1),
            ("cli".to_string(), 2),
            ("x".to_string(), 2)
        ]
    );
    assert_eq!(c.1, ["error", "chart"]);
}
