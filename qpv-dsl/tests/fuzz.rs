//! Property test: at least 100 000 random and mutated inputs (mutations of
//! the example files: byte flips, deletions, duplications, token swaps,
//! insertions) must never panic, and every error must point inside the
//! input with a consistent line:column. A tiny inline PRNG keeps it
//! deterministic and dependency-free.
//!
//! The examples are mutated mostly with their comments stripped (shorter
//! inputs, and mutations then hit the language rather than prose); one seed
//! keeps its comments. `QPV_FUZZ_INPUTS=<n>` runs more inputs.
//!
//! A second property test writes random `region vertices` and `region
//! halfspaces` statements whose coordinates range over 1e-320..1e300 (each
//! coordinate with its own scale): each must parse into a verified polytope
//! (finite, every vertex inside every facet, at least n + 1 of each, the
//! input points inside) or fail with an error positioned on the region.

use qpv_dsl::{diagnostic::line_col, parse};
use std::panic::{catch_unwind, AssertUnwindSafe};

const SEEDS: &[&str] = &[
    include_str!("../../examples/paper.qpv"),
    include_str!("../../examples/paper_equations.qpv"),
    include_str!("../../examples/lotka_volterra.qpv"),
    include_str!("../../examples/lorenz.qpv"),
    include_str!("../../examples/van_de_vusse.qpv"),
    include_str!("../../examples/spacecraft.qpv"),
    include_str!("../../examples/manipulator.qpv"),
    include_str!("../../examples/arrhenius_reactor.qpv"),
    "model m { state x1, x2; input u; output y; param th in [-1, 2];
       A = [-1, th; 0, -2]; B = [1; th]; C = [1, 0]; N1 = 0; N2 = [0, 1; 1, 0]; M1 = 0;
       region halfspaces [1, 0; -1, 0; 0, 1; 0, -1; 1, 1];
       state_bound Q = [4, 0; 0, 4]; design { alpha = max; } }",
    "model v { state a, b, c; output y; region vertices [1,0,0; 0,1,0; 0,0,1; -1,-1,-1];
       der a = -a + b*c; der b = -b; der c = -c + a^2; out y = a + b*b; }",
    "model s { state p, q; output y; A = [-1, 0; 0, -2]; C = [1, 0];
       region halfspaces [1e-9, 0; -1e-9, 0; 0, 1e6; 0, -1e6; 1e-9, 1e6]; }",
    "model t { state p, q; output y; A = [-1, 0; 0, -2]; C = [1, 0];
       region vertices [1e-12, 0; -1e-12, 0; 0, 1e12; 0, -1e12]; }",
];

const VOCAB: &[&str] = &[
    "model",
    "state",
    "input",
    "output",
    "param",
    "in",
    "der",
    "out",
    "region",
    "box",
    "vertices",
    "halfspaces",
    "state_bound",
    "Q",
    "design",
    "noise",
    "disturbance",
    "B_w",
    "w1",
    "min",
    "free",
    "alpha",
    "gamma",
    "mode",
    "max",
    "search",
    "sound",
    "paper",
    "A",
    "B",
    "C",
    "N1",
    "N2",
    "N3",
    "N0",
    "M1",
    "M2",
    "x1",
    "x2",
    "x3",
    "y1",
    "th1",
    "th2",
    "u",
    "{",
    "}",
    "[",
    "]",
    "(",
    ")",
    ";",
    ",",
    "=",
    "+",
    "-",
    "*",
    "/",
    "^",
    "0",
    "1",
    "2.5",
    "1e999",
    "1e-300",
    "0.0",
    "-0",
    ".5",
    "3.",
    "//",
    "/*",
    "*/",
    "\n",
    " ",
    "θ",
    "\"",
    "#",
    "__",
    "99999999999999999999",
    "x1^64",
    "th1*th1",
    "(((",
    ")))",
    "[1, 2; 3, 4]",
    "box(0)",
    "box(-1)",
    "1e-12",
    "1e9",
    "1e300",
    "1e-300",
    "1e-320",
    "1e308*(1+th1)",
    "region halfspaces [1e-9, 0; -1e-9, 0; 0, 1e9; 0, -1e9];",
    "region vertices [1e12, 0; 0, 1e-12; -1e12, -1e-12];",
    "let",
    "const",
    "sin",
    "cos",
    "sqrt",
    "exp",
    "ln",
    "tan",
    "tanh",
    "atan",
    "abs",
    "sinn",
    "sin(th1)",
    "cos(th2)^2",
    "1/th1",
    "1/(2 + th1)",
    "th2/(th1 - th1)",
    "let s = cos(th1);",
    "let k = exp(-3/(1 + th2));",
    "const g = 9.81;",
    "sqrt(th1 - 5)",
    "ln(th1)",
    "tan(th1*10)",
    "exp(1000*th1)",
    "x1/(1 + x2)",
    "sin(x1)",
    "x1*x1*x1",
];

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
}

/// Rough tokens: runs of word characters, or single other characters.
fn tokens(s: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut start = 0;
    let mut in_word = false;
    for (i, c) in s.char_indices() {
        let w = c.is_alphanumeric() || c == '_' || c == '.';
        if (in_word && !w) || (!in_word && i > start) {
            out.push(&s[start..i]);
            start = i;
        }
        in_word = w;
        if !w {
            out.push(&s[start..i + c.len_utf8()]);
            start = i + c.len_utf8();
        }
    }
    if start < s.len() {
        out.push(&s[start..]);
    }
    out
}

/// The seeds: the first example as written, all of them without comments.
fn seeds() -> Vec<String> {
    let strip = |s: &str| -> String {
        s.lines()
            .map(|l| l.split("//").next().unwrap_or("").trim_end())
            .filter(|l| !l.is_empty())
            .collect::<Vec<_>>()
            .join("\n")
    };
    let mut out = vec![SEEDS[0].to_string()];
    out.extend(SEEDS.iter().map(|s| strip(s)));
    out
}

fn mutate(rng: &mut Rng, src: &str) -> String {
    let mut b = src.as_bytes().to_vec();
    for _ in 0..1 + rng.below(4) {
        let len = b.len();
        match rng.below(7) {
            0 if len > 0 => {
                // byte flip (may break UTF-8; repaired below)
                let i = rng.below(len);
                b[i] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                // deletion of a short range
                let i = rng.below(len);
                let n = 1 + rng.below(12.min(len - i));
                b.drain(i..i + n);
            }
            2 if len > 0 => {
                // duplication of a range
                let i = rng.below(len);
                let n = 1 + rng.below(40.min(len - i));
                let chunk: Vec<u8> = b[i..i + n].to_vec();
                let at = rng.below(len);
                b.splice(at..at, chunk);
            }
            3 => {
                // token swap
                let s = String::from_utf8_lossy(&b).into_owned();
                let mut t = tokens(&s);
                if t.len() > 2 {
                    let (i, j) = (rng.below(t.len()), rng.below(t.len()));
                    t.swap(i, j);
                }
                b = t.concat().into_bytes();
            }
            4 => {
                // insertion of a vocabulary token
                let at = rng.below(len + 1);
                let tok = VOCAB[rng.below(VOCAB.len())];
                b.splice(at..at, tok.bytes());
            }
            5 if len > 0 => {
                // truncation
                b.truncate(rng.below(len));
            }
            _ => {
                // token replacement
                let s = String::from_utf8_lossy(&b).into_owned();
                let mut t = tokens(&s);
                if !t.is_empty() {
                    let i = rng.below(t.len());
                    t[i] = VOCAB[rng.below(VOCAB.len())];
                }
                b = t.concat().into_bytes();
            }
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

fn random_input(rng: &mut Rng) -> String {
    if rng.below(4) == 0 {
        // random bytes, mostly printable
        (0..rng.below(200))
            .map(|_| {
                if rng.below(8) == 0 {
                    char::from_u32(rng.below(0x3000) as u32).unwrap_or('?')
                } else {
                    (b' ' + rng.below(95) as u8) as char
                }
            })
            .collect()
    } else {
        // token soup, often inside a model block
        let body: Vec<&str> = (0..rng.below(80))
            .map(|_| VOCAB[rng.below(VOCAB.len())])
            .collect();
        let body = body.join(if rng.below(2) == 0 { " " } else { "" });
        if rng.below(2) == 0 {
            format!("model f {{ {body} }}")
        } else {
            body
        }
    }
}

/// Parses one input; returns a description of any property violation.
fn check(src: &str) -> Option<String> {
    let result = catch_unwind(AssertUnwindSafe(|| match parse(src) {
        Ok(models) => {
            for m in &models {
                let p = m.polytopic();
                let theta: Vec<f64> = m.params.iter().map(|q| 0.3 * q.lo + 0.7 * q.hi).collect();
                let mu = p.mu(&theta);
                if (mu.iter().sum::<f64>() - 1.0).abs() > 1e-9 {
                    return Some("weights do not sum to 1".to_string());
                }
                let a = p.a_at(&theta);
                let a_model = m.eval_a(&theta);
                let scale = p.vertices.iter().map(|v| v.a.amax()).fold(1.0, f64::max);
                if (&a - &a_model).amax() > 1e-9 * scale {
                    return Some(format!(
                        "vertex decomposition differs from the model: {a} vs {a_model}"
                    ));
                }
                for w in &m.warnings {
                    if w.span.end > src.len() || w.span.start > w.span.end {
                        return Some(format!("warning span out of range: {w:?}"));
                    }
                }
            }
            None
        }
        Err(e) => {
            if e.span.start > e.span.end || e.span.end > src.len() {
                return Some(format!("span out of range: {:?}", e.span));
            }
            if !src.is_char_boundary(e.span.start) || !src.is_char_boundary(e.span.end) {
                return Some(format!("span not on char boundaries: {:?}", e.span));
            }
            if line_col(src, e.span.start) != (e.line, e.column) {
                return Some("line/column inconsistent with the span".to_string());
            }
            if e.message.is_empty()
                || e.message.contains("Rule")
                || e.message.contains("internal error")
            {
                return Some(format!("bad message: {}", e.message));
            }
            let _ = e.to_string();
            None
        }
    }));
    match result {
        Ok(problem) => problem,
        Err(_) => Some("panicked".to_string()),
    }
}

#[test]
fn no_input_panics() {
    let total: usize = std::env::var("QPV_FUZZ_INPUTS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100_000)
        .max(100_000);
    let seeds = seeds();
    let seeds = &seeds;
    let threads = std::thread::available_parallelism()
        .map_or(4, |n| n.get())
        .clamp(1, 16);
    let per = total.div_ceil(threads);
    let start = std::time::Instant::now();
    let failures: Vec<(String, String)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                s.spawn(move || {
                    let mut rng =
                        Rng(0x1234_5678_9ABC_DEF1
                            ^ (t as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
                    let mut bad = Vec::new();
                    for _ in 0..per {
                        let src = if rng.below(5) == 0 {
                            random_input(&mut rng)
                        } else {
                            let seed = &seeds[rng.below(seeds.len())];
                            mutate(&mut rng, seed)
                        };
                        if let Some(problem) = check(&src) {
                            bad.push((problem, src));
                            if bad.len() >= 5 {
                                break;
                            }
                        }
                    }
                    bad
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_default())
            .collect()
    });
    eprintln!(
        "{} inputs on {threads} threads in {:?}",
        per * threads,
        start.elapsed()
    );
    assert!(
        failures.is_empty(),
        "{} failing inputs, e.g.:\n{}",
        failures.len(),
        failures
            .iter()
            .take(3)
            .map(|(p, s)| format!("--- {p}\n{s}\n"))
            .collect::<String>()
    );
}

#[test]
fn seeds_parse() {
    for s in seeds() {
        parse(&s).unwrap_or_else(|e| panic!("{e}\n{s}"));
    }
}

/// A random region statement in `n` dimensions: rows with small integer
/// mantissas and one decimal scale per coordinate, sometimes extreme.
fn region_statement(rng: &mut Rng, n: usize) -> (String, bool) {
    let halfspaces = rng.below(2) == 0;
    let scales: Vec<i32> = (0..n)
        .map(|_| match rng.below(6) {
            0 => rng.below(40) as i32 - 320, // subnormal to tiny
            1 => 260 + rng.below(49) as i32, // huge
            _ => rng.below(25) as i32 - 12,  // 1e-12 .. 1e12
        })
        .collect();
    let count = n + 1 + rng.below(2 * n + 4);
    let mut rows: Vec<String> = (0..count)
        .map(|_| {
            (0..n)
                .map(|j| format!("{}e{}", rng.below(19) as i64 - 9, scales[j]))
                .collect::<Vec<_>>()
                .join(", ")
        })
        .collect();
    if rng.below(4) != 0 {
        // usually close the region around the origin
        for (j, k) in scales.iter().enumerate() {
            for s in [1, -1] {
                let row: Vec<String> = (0..n)
                    .map(|i| {
                        if i == j {
                            format!("{s}e{k}")
                        } else {
                            "0".into()
                        }
                    })
                    .collect();
                rows.push(row.join(", "));
            }
        }
    }
    let kw = if halfspaces { "halfspaces" } else { "vertices" };
    (format!("region {kw} [{}];", rows.join("; ")), halfspaces)
}

/// Checks one parsed region (in the scaled, scale-free sense): finite,
/// at least n + 1 vertices and facets, every vertex inside every facet.
fn verify_region(r: &qpv_dsl::Region, n: usize) -> Option<String> {
    if r.vertices.len() <= n || r.facets.len() <= n {
        return Some(format!(
            "{} vertices and {} facets in {n} dimensions",
            r.vertices.len(),
            r.facets.len()
        ));
    }
    for v in r.vertices.iter().chain(&r.facets) {
        if v.iter().any(|x| !x.is_finite()) {
            return Some(format!("non-finite entry in {v}"));
        }
    }
    for a in &r.facets {
        for v in &r.vertices {
            let terms: f64 = a.iter().zip(v.iter()).map(|(p, q)| (p * q).abs()).sum();
            if a.dot(v) > 1.0 + 1e-7 * (1.0 + terms) {
                return Some(format!("vertex {v} outside facet {a}"));
            }
        }
    }
    None
}

#[test]
fn region_statements_at_extreme_scales() {
    let mut rng = Rng(0x0E5C_A1E5_0F00_0001);
    let mut failures: Vec<(String, String)> = Vec::new();
    let mut converted = 0;
    for _ in 0..3000 {
        let n = 1 + rng.below(4);
        let (region, _) = region_statement(&mut rng, n);
        let states: Vec<String> = (1..=n).map(|i| format!("x{i}")).collect();
        let a: Vec<String> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| if i == j { "-1" } else { "0" })
                    .collect::<Vec<_>>()
                    .join(", ")
            })
            .collect();
        let c: Vec<&str> = (0..n).map(|j| if j == 0 { "1" } else { "0" }).collect();
        let src = format!(
            "model r {{ state {}; output y; A = [{}]; C = [{}];\n  {region}\n}}",
            states.join(", "),
            a.join("; "),
            c.join(", ")
        );
        if let Some(problem) = check(&src) {
            failures.push((problem, src));
            continue;
        }
        match parse(&src) {
            Ok(models) => {
                converted += 1;
                if let Some(problem) = verify_region(&models[0].region, n) {
                    failures.push((problem, src));
                }
            }
            Err(e) => {
                // errors about the region point into the region statement
                if e.line != 2 && !e.message.contains("overflows") {
                    failures.push((format!("error off the region: {}", e.message), src));
                }
            }
        }
        if failures.len() >= 5 {
            break;
        }
    }
    eprintln!("{converted} of 3000 extreme-scale regions converted, the rest refused");
    assert!(converted > 300, "only {converted} regions converted");
    assert!(
        failures.is_empty(),
        "{} failing inputs, e.g.:\n{}",
        failures.len(),
        failures
            .iter()
            .take(3)
            .map(|(p, s)| format!("--- {p}\n{s}\n"))
            .collect::<String>()
    );
}
