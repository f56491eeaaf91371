//! Measurement: how much does the cover of the parameter box (`cover θ into
//! n;`) pay against the one box of (θ, φ)? For a plant with one parameter θ
//! and derived scheduling variables φ(θ), Θ is cut into `n` equal pieces and
//! the polytopic model takes the corners of the box of (θ, φ) over each
//! piece (ranges recomputed on the piece with the same proof): n·2^d
//! vertices instead of 2^d, each box much thinner. The design is solved
//! with the largest certified α at the example's γ (the certificate checks
//! every vertex), for the manipulator with its velocity region widened and
//! the spacecraft. Prints a table: plant, region, pieces, vertices,
//! certified α, solve time.
//!
//!     cargo bench --bench hull --profile dev [-- manipulator|spacecraft] [--pieces 1,2,4,8]

use qpv::dsl::{AlphaSpec, GammaSpec, Model};
use std::time::Instant;

/// The model text with the single parameter's range cut into `n` pieces
/// (the example's own `cover` statement, if any, replaced).
fn with_cover(text: &str, n: usize) -> Model {
    let plain: String = text
        .lines()
        .filter(|l| !l.trim_start().starts_with("cover "))
        .collect::<Vec<_>>()
        .join("\n");
    let models = qpv::dsl::parse(&plain).expect("the example parses");
    assert_eq!(models[0].params.len(), 1, "one parameter");
    let name = models[0].params[0].name.clone();
    let covered = plain.replacen(
        "design {",
        &format!("cover {name} into {n};\n    design {{"),
        1,
    );
    qpv::dsl::parse(&covered)
        .expect("the covered example parses")
        .remove(0)
}

fn manipulator(v: f64) -> String {
    let src = include_str!("../examples/manipulator.qpv");
    let q = 4.0 * v * v;
    src.replace(
        "region box([0.5, 0.5, 0.07, 0.07]);",
        &format!("region box([0.5, 0.5, {v}, {v}]);"),
    )
    .replace(
        "0, 0, 0.0196, 0 ; 0, 0, 0, 0.0196 ]",
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
            let poly = with_cover(text, n).polytopic();
            let start = Instant::now();
            let d = qpv::solve::design(&poly, &req, &Default::default());
            let secs = start.elapsed().as_secs_f64();
            let alpha = match d {
                Ok(d) if d.certifies() => format!("{:.5}", d.alpha),
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
