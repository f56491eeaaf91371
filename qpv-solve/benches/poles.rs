//! Pole regions on the three-tank LPV plant (docs/method.md §18): α, the
//! largest gain, the bound a disk implies and the wall time of each design,
//! with and without regions. Run with `cargo bench --bench poles`; prints
//! numbers (a table for the docs).

use qpv_dsl::{AlphaSpec, DesignRequest, GammaSpec, Mode, PoleRegion, PolytopicModel};
use qpv_solve::{design, Settings};
use std::time::Instant;

fn three_tank() -> PolytopicModel {
    qpv_dsl::parse(include_str!("../../examples/three_tank.qpv")).expect("parses")[0].polytopic()
}

fn row(m: &PolytopicModel, alpha: AlphaSpec, poles: &[PoleRegion]) {
    let r = DesignRequest {
        poles: poles.to_vec(),
        ..qpv_solve::request(alpha, GammaSpec::Search, Mode::Sound)
    };
    let t = Instant::now();
    let d = design(m, &r, &Settings::default()).expect("design runs");
    let secs = t.elapsed().as_secs_f64();
    let gain = d.gain_norms.iter().copied().fold(0.0, f64::max);
    let regions: Vec<String> = poles.iter().map(|p| p.to_string()).collect();
    let alpha = match alpha {
        AlphaSpec::Max => "max".to_string(),
        AlphaSpec::Fixed(a) => a.to_string(),
    };
    println!(
        "| alpha = {alpha} | {} | {} | {} | {:.3e} | {} | {} | {secs:.2} s |",
        if regions.is_empty() {
            "none".into()
        } else {
            regions.join(", ")
        },
        if d.certifies() { "yes" } else { "no" },
        if d.certifies() {
            format!("{:.4}", d.alpha)
        } else {
            "-".into()
        },
        gain,
        d.pole_gain_bound.map_or("-".into(), |b| format!("{b:.3e}")),
        d.search.len(),
    );
}

fn main() {
    let m = three_tank();
    println!("| request | poles | certified | α | max ‖L_l‖₂ | disk bound | solves | time |");
    println!("| --- | --- | --- | --- | --- | --- | --- | --- |");
    let disk = |r: f64| PoleRegion::Disk {
        centre: -r,
        radius: r,
    };
    for alpha in [
        AlphaSpec::Fixed(0.09),
        AlphaSpec::Fixed(0.9),
        AlphaSpec::Max,
    ] {
        row(&m, alpha, &[]);
    }
    for r in [3.0, 30.0, 100.0, 300.0, 1000.0] {
        row(&m, AlphaSpec::Fixed(0.09), &[disk(r)]);
        row(&m, AlphaSpec::Max, &[disk(r)]);
    }
    row(&m, AlphaSpec::Fixed(0.9), &[disk(1000.0)]);
    row(&m, AlphaSpec::Max, &[PoleRegion::Sector { angle: 45.0 }]);
    row(
        &m,
        AlphaSpec::Max,
        &[PoleRegion::Strip {
            lo: -50.0,
            hi: -0.01,
        }],
    );
    row(
        &m,
        AlphaSpec::Max,
        &[disk(100.0), PoleRegion::Sector { angle: 45.0 }],
    );
}
