//! What the region costs the QPV examples (docs/method.md §18, "The cost
//! of the region"): each example's first sound design request, its
//! certified α, and the α its linear part alone (N_k = M_k = 0) certifies
//! with the global observer (`Design::linear_part_alpha`), with the time of
//! both. Run with `cargo bench --bench region_cost`; prints a table.

use qpv_dsl::Mode;
use qpv_solve::{design, Settings};
use std::time::Instant;

const EXAMPLES: [(&str, &str); 10] = [
    ("paper", include_str!("../../examples/paper.qpv")),
    (
        "lotka_volterra",
        include_str!("../../examples/lotka_volterra.qpv"),
    ),
    ("lorenz", include_str!("../../examples/lorenz.qpv")),
    (
        "van_de_vusse",
        include_str!("../../examples/van_de_vusse.qpv"),
    ),
    (
        "arrhenius_reactor",
        include_str!("../../examples/arrhenius_reactor.qpv"),
    ),
    ("sir", include_str!("../../examples/sir.qpv")),
    ("pmsm", include_str!("../../examples/pmsm.qpv")),
    ("spacecraft", include_str!("../../examples/spacecraft.qpv")),
    (
        "elastic_arm",
        include_str!("../../examples/elastic_arm.qpv"),
    ),
    (
        "varying_output",
        include_str!("../../examples/varying_output.qpv"),
    ),
];

fn main() {
    println!("| example | request | certified QPV α | linear part α (global) | QPV / linear | linear α at the QPV gain | QPV / that | time |");
    println!("| --- | --- | --- | --- | --- | --- | --- | --- |");
    for (name, text) in EXAMPLES {
        let model = &qpv_dsl::parse(text).expect("example parses")[0];
        let Some(req) = model.designs.iter().find(|d| d.mode == Mode::Sound) else {
            continue;
        };
        let m = model.polytopic();
        let t = Instant::now();
        let settings = Settings {
            region_cost: true,
            ..Settings::default()
        };
        let d = match design(&m, req, &settings) {
            Ok(d) => d,
            Err(e) => {
                println!("| {name} | - | error: {e} | | | | | |");
                continue;
            }
        };
        let secs = t.elapsed().as_secs_f64();
        let lin = d.linear_part_alpha;
        let at_gain = d.linear_part_alpha_at_gain;
        println!(
            "| {name} | {} | {} | {} | {} | {} | {} | {secs:.2} s |",
            match req.alpha {
                qpv_dsl::AlphaSpec::Max => "alpha = max".to_string(),
                qpv_dsl::AlphaSpec::Fixed(a) => format!("alpha = {a}"),
            },
            if d.certifies() {
                format!("{:.4}", d.alpha)
            } else {
                "not certified".into()
            },
            lin.map_or("-".into(), |a| format!("{a:.4}")),
            match (d.certifies(), lin) {
                (true, Some(a)) => format!("{:.1} %", 100.0 * d.alpha / a),
                _ => "-".into(),
            },
            at_gain.map_or("-".into(), |a| format!("{a:.4}")),
            match (d.certifies(), at_gain) {
                (true, Some(a)) => format!("{:.1} %", 100.0 * d.alpha / a),
                _ => "-".into(),
            },
        );
    }
}
