//! The structure checks of every crate in the workspace: each module
//! imports only from its own layer or the layers below it, named pairs of
//! modules never import each other, and no module imports itself through
//! a circle.
//!
//! qpv-solve's layers are listed once, in the README ("Inside each crate
//! the modules are layers"), and [`the_readme_lists_every_layer_of_the_table`]
//! checks that list against the table below (lib.rs, the facade,
//! re-exports from all of them and is not checked; `mod.rs` re-exports of
//! a folder's own files are part of that folder's facade).
//!
//! qpv-dsl follows text → AST → model → polytopic model:
//!
//! ```text
//! 0 vocabulary   diagnostic (spans, messages), expr (θ-polynomials),
//!                func (the callable functions), region (polytope geometry),
//!                time_unit (the model's unit of time)
//! 1 text → AST   ast, syntax (the pest grammar's tree walk)
//! 2 expressions  poly (AST → polynomials), sched (scheduling functions and
//!                their ranges), equations (`der`/`out` → matrices), cover
//! 3 model        the validated model (model/)
//! 4 polytope     vertices (the polytopic model and μ_l(θ))
//! ```
//!
//! qpv-codegen: the IR and the certified numbers (0), the builders of
//! the observer's bodies (1), the C printer and the f32 rounding bound of
//! the built bodies (2).
//! qpv-macros: the macro's input, the cache, the fallback and the slow-solve
//! note (0), code emission (1), the expansion that drives them (2). The
//! root package: plot (0); in the command line, file input (1), the JSON
//! schema and the signal files (2), the commands (3), the commands that
//! reuse another command's pieces (4), and the dispatcher `cli` (5).
//! qpv-lapack and qpv-clarabel have no layers, only the circle check.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// One crate's structure: where its sources are, the layer of each module
/// (by the longest table entry that is a prefix of its path; modules not in
/// the table fail the check, unless the table is empty), the pairs of
/// modules that must not import each other, and modules left out.
struct Crate {
    src: &'static str,
    layers: &'static [(&'static str, usize)],
    apart: &'static [(&'static str, &'static str)],
    skip: &'static [&'static str],
}

/// qpv-solve: module → layer.
const SOLVE: Crate = Crate {
    src: "qpv-solve/src",
    layers: &[
        ("error", 0),
        ("settings", 0),
        ("vocab", 0),
        ("backend", 0),
        ("linalg", 0),
        ("line_search", 0),
        ("fixtures", 0),
        ("lapack", 0),
        ("model", 1),
        ("conditions", 2),
        ("lmi", 3),
        ("certificate", 3),
        ("report", 4),
        ("search", 5),
        ("analysis", 6),
        ("export", 6),
    ],
    apart: &[("certificate", "lmi"), ("lmi", "certificate")],
    skip: &["lapack"],
};

/// The other crates of the workspace.
const OTHERS: &[Crate] = &[
    Crate {
        src: "qpv-dsl/src",
        layers: &[
            ("diagnostic", 0),
            ("expr", 0),
            ("func", 0),
            ("region", 0),
            ("time_unit", 0),
            ("ast", 1),
            ("syntax", 1),
            ("poly", 2),
            ("sched", 2),
            ("measured", 2),
            ("jacobian", 2),
            ("equations", 2),
            ("cover", 2),
            ("model", 3),
            ("vertices", 4),
        ],
        apart: &[],
        skip: &[],
    },
    Crate {
        src: "qpv-macros/src",
        layers: &[
            ("input", 0),
            ("cache", 0),
            ("fallback", 0),
            ("slow_solve", 0),
            ("emit", 1),
            ("expand", 2),
        ],
        apart: &[],
        skip: &[],
    },
    Crate {
        src: "qpv-codegen/src",
        layers: &[
            ("ir", 0),
            ("design", 0),
            ("measured", 0),
            ("build", 1),
            ("rounding", 2),
            ("c", 2),
        ],
        apart: &[],
        skip: &[],
    },
    Crate {
        src: "src",
        layers: &[
            ("plot", 0),
            ("main", 0),
            ("cli::input", 1),
            ("cli::schema", 2),
            ("cli::signal", 2),
            ("cli::vertices", 3),
            ("cli::design", 3),
            ("cli::simulate", 3),
            ("cli::gains", 3),
            ("cli::check", 4),
            ("cli::simulate_sampled", 4),
            ("cli::tradeoff", 4),
            ("cli::codegen", 4),
            ("cli", 5),
        ],
        apart: &[],
        skip: &[],
    },
    Crate {
        src: "qpv-lapack/src",
        layers: &[],
        apart: &[],
        skip: &[],
    },
    Crate {
        src: "qpv-clarabel/src",
        layers: &[],
        apart: &[],
        skip: &[],
    },
];

impl Crate {
    /// The layer of a module path: its longest prefix in the table.
    fn layer(&self, path: &[String]) -> Option<usize> {
        (1..=path.len()).rev().find_map(|n| {
            let key = path[..n].join("::");
            self.layers.iter().find(|(m, _)| *m == key).map(|(_, l)| *l)
        })
    }
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
/// messages are not imports), up to its unit tests (`#[cfg(test)]`: an
/// inline test module's `super` is the file's own module).
fn code(text: &str) -> String {
    let mut out = String::new();
    for line in text.lines() {
        if line.trim() == "#[cfg(test)]" {
            break;
        }
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

/// The leading identifiers of a path's text (`a::b::c…` → [a, b, c]); the
/// rest of the text after them.
fn leading_idents(text: &str) -> (Vec<String>, &str) {
    let mut idents = Vec::new();
    let mut rest = text.trim_start();
    loop {
        let ident: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if ident.is_empty() {
            return (idents, rest);
        }
        rest = &rest[ident.len()..];
        let stop = ident == "super" || ident == "self";
        if !stop {
            idents.push(ident);
        }
        match rest.strip_prefix("::") {
            Some(r) if !stop => rest = r.trim_start(),
            _ => return (idents, rest),
        }
    }
}

/// The items of a `{a::b, c::{d, e}}` group at the start of `text` (without
/// the braces), split at its top-level commas.
fn group_items(text: &str) -> Vec<&str> {
    let mut depth = 0usize;
    let mut items = Vec::new();
    let mut start = 1;
    for (i, ch) in text.char_indices() {
        match ch {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    items.push(&text[start..i]);
                    break;
                }
            }
            ',' if depth == 1 => {
                items.push(&text[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    items
}

/// The module paths a path text names: one for `a::b::C`, one per item for
/// `a::{b, c::D}` (nested groups too), each prefixed by `base`.
fn expand(base: &[String], text: &str, out: &mut Vec<Vec<String>>) {
    let (idents, rest) = leading_idents(text);
    let mut path = base.to_vec();
    path.extend(idents);
    if rest.starts_with('{') {
        for item in group_items(rest) {
            expand(&path, item, out);
        }
    } else if !path.is_empty() {
        out.push(path);
    }
}

/// Every `crate::a::b…` and `super::…` path of a file, as absolute module
/// paths (the leading identifiers only), with `crate::{a, b::c}` groups
/// expanded into one path per item.
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
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '$') {
                continue;
            }
            expand(&base, rest, &mut out);
        }
    }
    out
}

/// The import circles of a module graph, each as `a -> b -> ... -> a`
/// (depth-first search; every circle has at least one of its edges found).
fn circles(edges: &BTreeMap<String, BTreeSet<String>>) -> Vec<String> {
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
    let mut found = Vec::new();
    for n in edges.keys() {
        visit(n, edges, &mut state, &mut Vec::new(), &mut found);
    }
    found
}

/// The violations of one crate's structure, and its module graph (module →
/// the modules it imports).
fn check(krate: &Crate) -> (Vec<String>, BTreeMap<String, BTreeSet<String>>) {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join(krate.src);
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
        if krate.skip.contains(&top.as_str()) {
            continue;
        }
        let own = krate.layer(&module);
        if own.is_none() && !krate.layers.is_empty() {
            violations.push(format!(
                "{}: module `{}` has no layer in the table",
                file.display(),
                module.join("::")
            ));
            continue;
        }
        let text = std::fs::read_to_string(file).unwrap();
        for path in imports(&module, &text) {
            let target_top = &path[0];
            let resolved = krate.layer(&path).is_some()
                || krate.skip.contains(&target_top.as_str())
                || krate.layers.is_empty();
            if !resolved {
                violations.push(format!(
                    "{} imports crate::{}, which names no module of the layer table \
                     (a root re-export or an unknown path: import from the module itself)",
                    file.display(),
                    path.join("::")
                ));
            }
            if let (Some(own), Some(theirs)) = (own, krate.layer(&path)) {
                if theirs > own {
                    violations.push(format!(
                        "{} (layer {own}) imports crate::{} (layer {theirs})",
                        file.display(),
                        path.join("::")
                    ));
                }
            }
            if krate.apart.contains(&(top.as_str(), target_top.as_str())) {
                violations.push(format!(
                    "{} imports crate::{}: these two modules stay apart",
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
    for c in circles(&edges) {
        violations.push(format!("import circle: {c}"));
    }
    (violations, edges)
}

#[test]
fn no_import_against_the_layers_and_no_circle() {
    let (violations, edges) = check(&SOLVE);
    assert!(
        violations.is_empty(),
        "layer violations:\n{}",
        violations.join("\n")
    );
    // The check sees the crate: every layer's module is there and has imports.
    assert!(edges.contains_key("search") && edges.contains_key("certificate"));
}

#[test]
fn no_crate_has_an_import_circle_or_an_import_against_its_layers() {
    let mut all = Vec::new();
    for krate in OTHERS {
        let (violations, edges) = check(krate);
        all.extend(
            violations
                .into_iter()
                .map(|v| format!("{}: {v}", krate.src)),
        );
        // Crates with modules that import each other are seen doing so.
        if matches!(krate.src, "qpv-dsl/src" | "qpv-macros/src" | "src") {
            assert!(!edges.is_empty(), "{}: no imports seen", krate.src);
        }
    }
    assert!(all.is_empty(), "structure violations:\n{}", all.join("\n"));
}

/// The README's list of qpv-solve's layers: the fenced block after the
/// line that introduces it, one line per layer starting with its number.
fn readme_layers() -> BTreeMap<usize, String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md");
    let text = std::fs::read_to_string(path).unwrap();
    let start = text
        .find("qpv-solve's layers, bottom to top")
        .expect("the README introduces qpv-solve's layers");
    let block = &text[start..];
    let open = block.find("```text\n").expect("a text block") + 8;
    let close = open + block[open..].find("```").expect("its end");
    let mut layers: BTreeMap<usize, String> = BTreeMap::new();
    let mut current = None;
    for line in block[open..close].lines() {
        let first = line.split_whitespace().next().unwrap_or("");
        if let Ok(n) = first.parse::<usize>() {
            current = Some(n);
        }
        if let Some(n) = current {
            let entry = layers.entry(n).or_default();
            entry.push(' ');
            entry.push_str(line);
        }
    }
    layers
}

#[test]
fn the_readme_lists_every_layer_of_the_table() {
    let readme = readme_layers();
    let mut missing = Vec::new();
    for (module, layer) in SOLVE.layers {
        if SOLVE.skip.contains(module) {
            continue;
        }
        let words: Vec<String> = readme
            .get(layer)
            .map(|l| {
                l.split(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .map(str::to_string)
                    .collect()
            })
            .unwrap_or_default();
        if !words.iter().any(|w| w == module) {
            missing.push(format!("layer {layer}: `{module}`"));
        }
    }
    let table: BTreeSet<usize> = SOLVE.layers.iter().map(|(_, l)| *l).collect();
    let listed: BTreeSet<usize> = readme.keys().copied().collect();
    assert_eq!(
        table, listed,
        "the README lists other layers than the table"
    );
    assert!(
        missing.is_empty(),
        "the README's layer list does not name these modules of the table:\n{}",
        missing.join("\n")
    );
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

#[test]
fn the_checker_expands_groups_and_flags_unresolved_paths() {
    let m = vec!["search".to_string()];
    let found = imports(
        &m,
        "use crate::{model::noise::N, report::{Design, figures}, Settings};",
    );
    let want: Vec<Vec<String>> = [
        &["model", "noise", "N"][..],
        &["report", "Design"],
        &["report", "figures"],
        &["Settings"],
    ]
    .iter()
    .map(|p| p.iter().map(|s| s.to_string()).collect())
    .collect();
    assert_eq!(found, want);
    // A root re-export is not a module of the table: the check names it.
    assert!(SOLVE.layer(&["Settings".to_string()]).is_none());
    assert!(SOLVE.layer(&["model".to_string(), "noise".to_string()]) == Some(1));
}

#[test]
fn the_checker_finds_a_circle_and_only_circles() {
    let graph = |pairs: &[(&str, &str)]| {
        let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (a, b) in pairs {
            g.entry(a.to_string()).or_default().insert(b.to_string());
        }
        g
    };
    // The circle qpv-dsl had: ast -> sched -> poly -> ast.
    let found = circles(&graph(&[
        ("ast", "sched"),
        ("sched", "poly"),
        ("poly", "ast"),
        ("model", "poly"),
    ]));
    assert_eq!(found, vec!["ast -> sched -> poly -> ast".to_string()]);
    // A diamond is no circle.
    assert!(circles(&graph(&[("a", "b"), ("a", "c"), ("b", "d"), ("c", "d")])).is_empty());
}

/// The README's table of qpv-solve's files, built from the code: every
/// file under qpv-solve/src with its layer (the table above) and the first
/// clause of its module documentation.
fn file_table() -> String {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join(SOLVE.src);
    let mut rows: Vec<(usize, String, String)> = Vec::new();
    let mut stack = vec![src.clone()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
                continue;
            }
            let rel = path
                .strip_prefix(&src)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            if !rel.ends_with(".rs") || rel == "lib.rs" {
                continue;
            }
            let top = rel.split(['/', '.']).next().unwrap_or("").to_string();
            let Some(layer) = SOLVE.layer(&[top]) else {
                continue;
            };
            let text = std::fs::read_to_string(&path).unwrap();
            let doc: Vec<&str> = text
                .lines()
                .take_while(|l| l.starts_with("//!") && l.trim() != "//!")
                .map(|l| l.trim_start_matches("//!").trim())
                .collect();
            let doc = doc.join(" ");
            // The first clause: up to a `:`, `.` or `;` that ends a word
            // (not the `::` of a path or the `.` of a file name).
            let b = doc.as_bytes();
            let end = (0..b.len())
                .find(|&i| {
                    matches!(b[i], b':' | b'.' | b';')
                        && b.get(i + 1).map_or(true, |c| c.is_ascii_whitespace())
                })
                .unwrap_or(doc.len());
            rows.push((layer, rel, doc[..end].replace('|', "\\|")));
        }
    }
    rows.sort();
    let mut out = String::from("| layer | file | holds |\n| --- | --- | --- |\n");
    for (layer, file, what) in rows {
        out.push_str(&format!("| {layer} | `{file}` | {what} |\n"));
    }
    out
}

/// The markers of the README's generated file table.
const FILES_BEGIN: &str =
    "<!-- qpv-solve files: generated by qpv-solve/tests/layers.rs (QPV_BLESS=1 rewrites it) -->\n";
const FILES_END: &str = "<!-- end of qpv-solve files -->";

#[test]
fn the_readme_file_table_is_the_code_s() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md");
    let text = std::fs::read_to_string(&path).unwrap();
    let start = text.find(FILES_BEGIN).expect("the README's file table") + FILES_BEGIN.len();
    let end = start + text[start..].find(FILES_END).expect("its end marker");
    let table = file_table();
    if std::env::var_os("QPV_BLESS").is_some() {
        let new = format!("{}{table}{}", &text[..start], &text[end..]);
        std::fs::write(&path, new).unwrap();
        return;
    }
    assert_eq!(
        text[start..end],
        table,
        "the README's file table differs from the code (QPV_BLESS=1 cargo test --test solve layers rewrites it)"
    );
}
