//! Measurement: does a tighter cover of the curve {(θ, φ(θ))} than the box
//! of (θ, φ) pay? For a plant with one parameter θ and derived scheduling
//! variables φ(θ), Θ is split into `n` equal pieces and the polytopic model
//! takes the corners of the box of (θ, φ) over each piece (ranges recomputed
//! on the piece with the same proof, `Model::restricted`): n·2^d vertices
//! instead of 2^d, each box much thinner. The design is solved with the
//! largest certified α at the example's γ (the certificate checks every
//! vertex), for the manipulator with its velocity region widened and the
//! spacecraft. Prints a table: plant, region, pieces, vertices, certified α,
//! solve time.
//!
//!     cargo bench --bench hull --profile dev [-- manipulator|spacecraft] [--pieces 1,2,4,8]

use qpv::dsl::{AlphaSpec, GammaSpec, Model, PolytopicModel};
use std::time::Instant;

/// The polytopic model over `n` equal pieces of the single parameter's range.
fn pieces(model: &Model, n: usize) -> PolytopicModel {
    assert_eq!(model.params.len(), 1, "one parameter");
    let (lo, hi) = (model.params[0].lo, model.params[0].hi);
    let cut = |k: usize| {
        if k == n {
            hi
        } else {
            lo + (hi - lo) * k as f64 / n as f64
        }
    };
    let mut poly = model.polytopic();
    poly.vertices.clear();
    for k in 0..n {
        let piece = model
            .restricted(&[(cut(k), cut(k + 1))])
            .expect("the piece is inside Θ");
        poly.vertices.extend(piece.polytopic().vertices);
    }
    poly
}

fn manipulator(v: f64) -> String {
    let src = include_str!("../examples/manipulator.qpv");
    let q = 4.0 * v * v;
    src.replace(
        "region box([0.5, 0.5, 0.02, 0.02]);",
        &format!("region box([0.5, 0.5, {v}, {v}]);"),
    )
    .replace(
        "0, 0, 0.0016, 0 ; 0, 0, 0, 0.0016 ]",
        &format!("0, 0, {q}, 0 ; 0, 0, 0, {q} ]"),
    )
}

fn spacecraft(r: f64) -> String {
    let src = include_str!("../examples/spacecraft.qpv");
    let q = 4.0 * r * r;
    src.replace("region box(0.05);", &format!("region box({r});"))
        .replace(
            "Q = [ 0.01, 0, 0 ; 0, 0.01, 0 ; 0, 0, 0.01 ]",
            &format!("Q = [ {q}, 0, 0 ; 0, {q}, 0 ; 0, 0, {q} ]"),
        )
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    // `--pieces 1,2,4,8` chooses the partitions (default 1, 2, 4)
    let ns: Vec<usize> = args
        .iter()
        .position(|a| a == "--pieces")
        .and_then(|i| args.get(i + 1))
        .map(|list| {
            list.split(',')
                .map(|n| n.parse().expect("--pieces takes numbers"))
                .collect()
        })
        .unwrap_or_else(|| vec![1, 2, 4]);
    // (plant, model text, γ): the manipulator at its example's γ (a smaller
    // one for the widest region), the spacecraft at γ = 0.25 (its example's
    // 0.5 is the edge γ_max of the state bound, where no rate certifies)
    let cases: Vec<(&str, String, f64)> = vec![
        ("manipulator", manipulator(0.02), 0.45),
        ("manipulator", manipulator(0.05), 0.45),
        ("manipulator", manipulator(0.1), 0.45),
        ("manipulator", manipulator(0.1), 0.2),
        ("manipulator", manipulator(0.07), 0.45),
        ("spacecraft", spacecraft(0.05), 0.25),
        ("spacecraft", spacecraft(0.1), 0.25),
    ];
    let only: Option<&str> = args
        .get(1)
        .map(|s| s.as_str())
        .filter(|s| !s.starts_with('-'));
    println!(
        "{:<12} {:<28} {:>5} {:>6} {:>8} {:>12} {:>9}",
        "plant", "region", "gamma", "pieces", "vertices", "alpha", "time"
    );
    for (name, text, gamma) in &cases {
        if only.is_some_and(|o| o != *name) {
            continue;
        }
        let models = qpv::dsl::parse(text).expect("the example parses");
        let model = &models[0];
        let region = text
            .lines()
            .find(|l| l.trim_start().starts_with("region"))
            .unwrap_or("")
            .split(';')
            .next()
            .unwrap_or("")
            .trim()
            .to_string();
        let mut req = model.designs[0].clone();
        req.alpha = AlphaSpec::Max;
        req.gamma = GammaSpec::Fixed(*gamma);
        for &n in &ns {
            let poly = pieces(model, n);
            let start = Instant::now();
            let d = qpv::solve::design(&poly, &req, &Default::default());
            let secs = start.elapsed().as_secs_f64();
            let alpha = match d {
                Ok(d) if d.certifies => format!("{:.5}", d.alpha),
                Ok(_) => "none".to_string(),
                Err(e) => format!("error: {e}"),
            };
            println!(
                "{:<12} {:<28} {:>5} {:>6} {:>8} {:>12} {:>8.1}s",
                name,
                region,
                gamma,
                n,
                poly.nv(),
                alpha,
                secs
            );
        }
    }
}
