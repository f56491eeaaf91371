//! The structure check of qpv-solve: every module imports only from its own
//! layer or the layers below it, the certificate and the LMI assembly never
//! import each other, and no module imports itself through a circle.
//!
//! The layers (bottom to top; lib.rs, the facade, re-exports from all of
//! them and is not checked; `mod.rs` re-exports of a folder's own files are
//! part of that folder's facade):
//!
//! ```text
//! 0 vocabulary   error, settings, vocab, backend, linalg, fixtures, lapack
//! 1 model        the observer's model: state bound, output route, split, skew;
//!                size (the size guard) and diagnosis (why a model fails)
//! 2 conditions   the condition families as data
//! 3 lmi | certificate   assembly into the SDP | independent re-check;
//!                sampling (the Euler step certificate beside it)
//! 4 report       Design and its parts (serde), filled in by the search
//! 5 search       α bisection, γ search, retry rules, skew alternation;
//!                noise (its bound, check and noise-optimal search)
//! 6 analysis     simulate, falsify
//! ```

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Top-level module → layer.
const LAYERS: &[(&str, usize)] = &[
    ("error", 0),
    ("settings", 0),
    ("vocab", 0),
    ("backend", 0),
    ("linalg", 0),
    ("fixtures", 0),
    ("lapack", 0),
    ("model", 1),
    ("size", 1),
    ("diagnosis", 1),
    ("conditions", 2),
    ("lmi", 3),
    ("certificate", 3),
    ("sampling", 3),
    ("report", 4),
    ("search", 5),
    ("noise", 5),
    ("analysis", 6),
];

/// Pairs of modules of one layer that must not import each other.
const APART: &[(&str, &str)] = &[("certificate", "lmi"), ("lmi", "certificate")];

fn layer(top: &str) -> Option<usize> {
    LAYERS.iter().find(|(m, _)| *m == top).map(|(_, l)| *l)
}

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module path of a source file: `a/b.rs` → ["a", "b"], `a/mod.rs` → ["a"].
fn module_of(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap();
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if parts.last().is_some_and(|p| p == "mod" || p == "lib") {
        parts.pop();
    }
    parts
}

/// The code of a file without comments and string literals (doc links and
/// messages are not imports).
fn code(text: &str) -> String {
    let mut out = String::new();
    for line in text.lines() {
        let mut in_str = false;
        let mut prev = ' ';
        let mut kept = String::new();
        for (i, ch) in line.char_indices() {
            if !in_str && line[i..].starts_with("//") {
                break;
            }
            if ch == '"' && prev != '\\' {
                in_str = !in_str;
            } else if !in_str {
                kept.push(ch);
            }
            prev = ch;
        }
        out.push_str(&kept);
        out.push('\n');
    }
    out
}

/// Every `crate::a::b…` and `super::…` path of a file, as absolute module
/// paths (the leading identifiers only).
fn imports(module: &[String], text: &str) -> Vec<Vec<String>> {
    let code = code(text);
    let mut out = Vec::new();
    // `super` of module a::b is a (of a file `a/b.rs`; of `a/mod.rs`, module a, it is the root).
    let parent = module[..module.len().saturating_sub(1)].to_vec();
    for (kw, base) in [("crate::", Vec::new()), ("super::", parent)] {
        let mut rest = code.as_str();
        while let Some(i) = rest.find(kw) {
            let before = rest[..i].chars().last();
            rest = &rest[i + kw.len()..];
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                continue;
            }
            let mut path = base.clone();
            for seg in rest.split("::") {
                let ident: String = seg
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if ident.is_empty() || ident == "super" || ident == "self" {
                    break;
                }
                let whole = ident.len() == seg.len();
                path.push(ident);
                if !whole {
                    break;
                }
            }
            if !path.is_empty() {
                out.push(path);
            }
        }
    }
    out
}

#[test]
fn no_import_against_the_layers_and_no_circle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("qpv-solve/src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    files.sort();
    let modules: BTreeSet<Vec<String>> = files.iter().map(|f| module_of(&src, f)).collect();
    let mut violations = Vec::new();
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for file in &files {
        let module = module_of(&src, file);
        let Some(top) = module.first() else {
            continue; // lib.rs: the facade
        };
        if top == "lapack" {
            continue;
        }
        let Some(own) = layer(top) else {
            violations.push(format!(
                "{}: module `{top}` has no layer in LAYERS",
                file.display()
            ));
            continue;
        };
        let text = std::fs::read_to_string(file).unwrap();
        for path in imports(&module, &text) {
            let target_top = &path[0];
            let Some(theirs) = layer(target_top) else {
                continue; // not a module (e.g. a macro or an item of lib.rs)
            };
            if theirs > own {
                violations.push(format!(
                    "{} (layer {own}) imports crate::{} (layer {theirs})",
                    file.display(),
                    path.join("::")
                ));
            }
            if APART.contains(&(top.as_str(), target_top.as_str())) {
                violations.push(format!(
                    "{} imports crate::{}: the certificate and the assembly stay apart",
                    file.display(),
                    path.join("::")
                ));
            }
            // The module the path names: its longest prefix that is a module file.
            let target = (1..=path.len())
                .rev()
                .map(|n| path[..n].to_vec())
                .find(|p| modules.contains(p));
            if let Some(t) = target.filter(|t| *t != module) {
                edges
                    .entry(module.join("::"))
                    .or_default()
                    .insert(t.join("::"));
            }
        }
    }
    // Circles: depth-first search over the module graph.
    fn visit(
        n: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
        found: &mut Vec<String>,
    ) {
        match state.get(n) {
            Some(2) => return,
            Some(1) => {
                let at = stack.iter().position(|s| s == n).unwrap_or(0);
                found.push(format!("{} -> {n}", stack[at..].join(" -> ")));
                return;
            }
            _ => {}
        }
        state.insert(n.to_string(), 1);
        stack.push(n.to_string());
        for m in edges.get(n).into_iter().flatten() {
            visit(m, edges, state, stack, found);
        }
        stack.pop();
        state.insert(n.to_string(), 2);
    }
    let mut state = BTreeMap::new();
    let mut circles = Vec::new();
    for n in edges.keys() {
        visit(n, &edges, &mut state, &mut Vec::new(), &mut circles);
    }
    for c in circles {
        violations.push(format!("import circle: {c}"));
    }
    assert!(
        violations.is_empty(),
        "layer violations:\n{}",
        violations.join("\n")
    );
    // The check sees the crate: every layer's module is there and has imports.
    assert!(edges.contains_key("search") && edges.contains_key("certificate"));
}

#[test]
fn the_checker_sees_paths_and_ignores_comments() {
    let m = vec!["search".to_string(), "skew".to_string()];
    let found = imports(
        &m,
        "use crate::lmi::skew::max;\n// crate::report::X\nlet s = \"crate::analysis\";\nuse super::design;",
    );
    assert_eq!(
        found,
        vec![
            vec!["lmi".to_string(), "skew".to_string(), "max".to_string()],
            vec!["search".to_string(), "design".to_string()],
        ]
    );
}
