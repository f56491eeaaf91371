//! Measurement: how the Jacobian of a nonlinear term of unmeasured states
//! is bounded, and what it costs. For each plant, the design of its own
//! design block (and a variant without the gain bound and the sample
//! period) with the Jacobian box bounded globally (where the function
//! allows it: sin, tanh) and on the set S = box hull of F ⊕ (−P/γ) at the
//! top of the γ range (the regional observer; the plants get a region and a
//! state bound for it). Prints a table: plant, request, bound, the
//! interval, vertices, certified α, max ‖L_l‖₂, time. Every α is certified
//! by the independent certificate (which recomputes the box).
//!
//!     cargo bench --bench jacobian

use qpv::dsl::{AlphaSpec, PolytopicModel};
use std::time::Instant;

/// The example's text with a region and a state bound (F = 2× the region
/// box in every direction: Q = diag(4 r²)) inserted before its design block.
fn with_region(text: &str, r: &[f64]) -> String {
    let rs: Vec<String> = r.iter().map(|v| v.to_string()).collect();
    let n = r.len();
    let q: Vec<String> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    if i == j {
                        (4.0 * r[i] * r[i]).to_string()
                    } else {
                        "0".into()
                    }
                })
                .collect::<Vec<_>>()
                .join(", ")
        })
        .collect();
    text.replacen(
        "    design {",
        &format!(
            "    region box([{}]);\n    state_bound Q = [ {} ];\n    design {{",
            rs.join(", "),
            q.join(" ; ")
        ),
        1,
    )
}

fn row(plant: &str, what: &str, poly: &PolytopicModel, req: &qpv::dsl::DesignRequest) {
    let start = Instant::now();
    let d = qpv::solve::design(poly, req, &Default::default());
    let secs = start.elapsed().as_secs_f64();
    let (alpha, gain, bound, nv) = match &d {
        Ok(d) if d.certifies() => {
            let bound = d
                .notes
                .iter()
                .map(|n| n.to_string())
                .find(|n| n.contains("nonlinear terms"))
                .and_then(|n| {
                    n.split(": d(")
                        .nth(1)
                        .map(|s| format!("d({}", s.split(';').next().unwrap_or("")))
                })
                .unwrap_or_default();
            (
                format!("{:.4}", d.alpha),
                format!("{:.1}", d.gain_norms.iter().copied().fold(0.0, f64::max)),
                bound,
                d.l.len(),
            )
        }
        Ok(_) => ("none".into(), "-".into(), String::new(), 0),
        Err(e) => (format!("error: {e}"), "-".into(), String::new(), 0),
    };
    println!("{plant:<16} {what:<34} {nv:>3} {alpha:>10} {gain:>9} {secs:>7.2}s  {bound}");
}

fn main() {
    let arm = include_str!("../examples/flexible_joint.qpv");
    let friction = include_str!("../examples/friction_joint.qpv");
    let duffing = include_str!("../examples/duffing_position.qpv");
    let cases: Vec<(&str, String)> = vec![
        ("flexible_joint", arm.to_string()),
        ("flexible_joint", with_region(arm, &[0.3, 1.0, 0.3, 1.0])),
        ("flexible_joint", with_region(arm, &[1.0, 3.0, 1.0, 3.0])),
        ("friction_joint", friction.to_string()),
        ("friction_joint", with_region(friction, &[0.5, 0.02])),
        ("friction_joint", with_region(friction, &[0.5, 0.5])),
        ("duffing_position", duffing.to_string()),
    ];
    println!(
        "{:<16} {:<34} {:>3} {:>10} {:>9} {:>8}  bound",
        "plant", "request, bounding", "nv", "alpha", "max|L|", "time"
    );
    for (name, text) in &cases {
        let model = qpv::dsl::parse(text).expect("parses").remove(0);
        let region = if model.region.vertices.is_empty() {
            "no region".to_string()
        } else {
            let r: Vec<String> = (0..model.nx())
                .map(|k| {
                    let w = model
                        .region
                        .vertices
                        .iter()
                        .map(|v| v[k])
                        .fold(0.0, f64::max);
                    format!("{w}")
                })
                .collect();
            format!("box([{}])", r.join(", "))
        };
        let own = model.designs[0].clone();
        let free = qpv::dsl::DesignRequest {
            max_gain: None,
            sample: None,
            alpha: AlphaSpec::Max,
            ..own.clone()
        };
        let poly = model.polytopic();
        for (req, label) in [(&own, "own block"), (&free, "alpha = max only")] {
            if poly.jacobian.as_ref().is_some_and(|j| j.global.is_some()) {
                row(name, &format!("{label}, global, {region}"), &poly, req);
            }
            if model.region.vertices.is_empty() {
                continue;
            }
            let on_set = poly.with_jacobian_on_set();
            row(name, &format!("{label}, on S, {region}"), &on_set, req);
        }
    }
}
