//! What code generators take from a design (`qpv_solve::export`): baked
//! numbers certified on exactly the values generated code holds, their
//! figures, and the explanation of a design that is not certified (moved
//! here from qpv-macros' unit tests, which now only check that the macro
//! prints it).

use qpv_dsl::{DesignRequest, Float, GammaSpec, Mode, PolytopicModel, StateBound};
use qpv_solve::export::{self, BakeError, Baked, Best, SoundDesign};
use qpv_solve::{design, Settings};

/// The paper's example with its sound design (the nostd crate's model).
fn paper() -> PolytopicModel {
    let models = qpv_dsl::parse(include_str!("../../tests/nostd/paper_sound.qpv"))
        .expect("the paper model parses");
    models[0].polytopic()
}

/// Three significant digits, as the explanation prints them.
fn sig(v: f64) -> String {
    format!("{}", format!("{v:.2e}").parse::<f64>().unwrap_or(v))
}

#[test]
fn the_best_sound_design_hint_reports_the_full_search() {
    // From qpv-macros' unit tests (the hint of a paper-mode-only model).
    let poly = paper();
    let hint = export::best_sound_design(&poly, &Settings::default());
    let d = design(&poly, &DesignRequest::default(), &Settings::default())
        .expect("the paper model designs");
    assert!(d.feasible() && d.certifies(), "{}", d.summary);
    assert_eq!(
        hint.to_string(),
        format!(
            "the best certified sound design of this model is alpha = {}, gamma = {}",
            sig(d.alpha),
            sig(d.gamma)
        )
    );
    // The symmetric split's optimum lies beyond α = 12, at γ ≤ γ_max.
    let gmax = qpv_solve::conditions::gamma_max(&poly).expect("Q is given");
    assert!(d.alpha > 12.0 && d.gamma <= gmax, "{} {}", d.alpha, d.gamma);
    let mut no_q = poly.clone();
    no_q.state_bound = StateBound::None;
    let none = export::best_sound_design(&no_q, &Settings::default());
    assert!(matches!(none, SoundDesign::CannotAttempt(_)));
    assert!(none
        .to_string()
        .starts_with("a sound design of this model cannot be attempted: "));
}

#[test]
fn a_request_failing_on_the_data_names_the_limit_without_a_search() {
    // From qpv-macros' unit tests.
    let poly = paper();
    let mut req = poly.designs[0].clone();
    req.gamma = GammaSpec::Fixed(0.4);
    let d = design(&poly, &req, &Settings::default()).expect("design runs");
    assert!(!d.feasible() && !d.certifies());
    let why = export::explain(&poly, &req, &d, &Settings::default());
    let text = why.to_string();
    assert!(text.contains("margin -3.48"), "{text}");
    let gmax = qpv_solve::conditions::gamma_max(&poly).expect("Q is given");
    assert!(
        text.contains(&format!("(S4) admits gamma up to {} only", sig(gmax))),
        "{text}"
    );
    assert!(!text.contains("best certified"), "no search: {text}");
    assert_eq!(
        why.best,
        Best::Data {
            gamma_max: Some(gmax)
        }
    );
    assert_eq!(why.tradeoff, None);
}

#[test]
fn f64_numbers_are_baked_as_solved_and_f32_numbers_rounded_and_rechecked() {
    let poly = paper();
    let req = qpv_solve::request(
        qpv_dsl::AlphaSpec::Fixed(10.0),
        GammaSpec::Fixed(0.1889),
        Mode::Sound,
    );
    let d = design(&poly, &req, &Settings::default()).expect("design runs");
    assert!(d.certifies(), "{}", d.summary);

    let f64_baked = Baked::solved(&poly, d.clone(), Float::F64).expect("certified");
    assert_eq!(f64_baked.design().p, d.p);
    assert_eq!(f64_baked.design().margins, d.margins);
    // the figures are those the design reports, recomputed on the numbers
    let f = f64_baked.figures();
    let noise = d.noise.as_ref().expect("a noise bound");
    assert_eq!(f.sigma, Some(noise.sigma));
    assert_eq!(f.error_bound, Some(noise.error_bound));
    let sampling = d.sampling.as_ref().expect("sampling figures");
    assert_eq!(f.euler, Some((sampling.max_step_euler, sampling.beta)));

    let f32_baked = Baked::solved(&poly, d.clone(), Float::F32).expect("certified");
    let b = f32_baked.design();
    assert!(b
        .p
        .iter()
        .chain(b.l.iter().flatten())
        .flatten()
        .all(|v| f64::from(*v as f32) == *v));
    assert_ne!(b.p, d.p, "rounded");
    assert!(b.recheck(&poly).passed);
    // its margins are those of the rounded numbers' certificate
    assert_eq!(b.margins, b.recheck(&poly).margins());
    assert!(f32_baked.figures().sigma.is_some());

    // A claim is re-checked: negated gains do not bake.
    let mut bad = d.clone();
    for l in &mut bad.l {
        for row in l {
            row.iter_mut().for_each(|v| *v = -*v);
        }
    }
    assert!(matches!(
        Baked::claimed(&poly, bad, Float::F64),
        Err(BakeError::Failed(_))
    ));
    // A design that is not certified is not baked, whatever its numbers.
    let mut uncertified = d;
    uncertified.verdict = qpv_solve::vocab::Verdict::NotCertified;
    assert!(matches!(
        Baked::solved(&poly, uncertified, Float::F64),
        Err(BakeError::NotCertified)
    ));
}

/// An n-state chain (ẋ_k = −x_k + x_{k+1}, x_n' = −x_n + 0.05 x_1²) on the
/// box of half-width 1, with the state bound Q = 8 I (γ_max = 1/√8),
/// designed with cube conditions at fixed (α, γ).
fn chain(n: usize) -> String {
    let states: Vec<String> = (1..=n).map(|k| format!("x{k}")).collect();
    let rows: Vec<String> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| match j as isize - i as isize {
                    0 => "-1",
                    1 => "1",
                    _ => "0",
                })
                .collect::<Vec<_>>()
                .join(", ")
        })
        .collect();
    let zero_row = vec!["0"; n].join(", ");
    let n1: Vec<String> = (0..n)
        .map(|i| {
            if i == n - 1 {
                format!("0.05{}", ", 0".repeat(n - 1))
            } else {
                zero_row.clone()
            }
        })
        .collect();
    let q: Vec<String> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| if i == j { "8" } else { "0" })
                .collect::<Vec<_>>()
                .join(", ")
        })
        .collect();
    let ns: String = (2..=n).map(|k| format!(" N{k} = 0;")).collect();
    format!(
        "model chain {{ state {}; output y; A = [{}]; N1 = [{}];{ns} C = [1{}]; M1 = 0; \
         region box(1); state_bound Q = [{}]; \
         design {{ alpha = 0.1; gamma = 0.3; conditions = cube; }} }}",
        states.join(", "),
        rows.join("; "),
        n1.join("; "),
        ", 0".repeat(n - 1),
        q.join("; ")
    )
}

#[test]
fn the_figures_keep_the_size_guard_of_a_cube_design() {
    // 7 states: 128 region vertices, 16 384 vertex pairs, above the size
    // the automatic choice solves exactly (`size::AUTO_FULL_BLOCKS`): the
    // noise bound and the sampling figures, which check every pair, are
    // not computed for the baked numbers either.
    let poly = qpv_dsl::parse(&chain(7)).expect("the chain parses")[0].polytopic();
    let req = poly.designs[0].clone();
    let d = design(&poly, &req, &Settings::default()).expect("design runs");
    assert!(d.certifies(), "{}", d.summary);
    assert!(d.cube.is_some());
    let pairs = poly.nv() * poly.region.vertices.len().pow(2);
    assert!(pairs > qpv_solve::model::size::AUTO_FULL_BLOCKS, "{pairs}");
    let baked = Baked::solved(&poly, d.clone(), Float::F64).expect("certified");
    assert_eq!(baked.figures(), qpv_codegen::Figures::default());
    let claimed = Baked::claimed(&poly, d, Float::F64).expect("re-checks by its slacks");
    assert_eq!(claimed.figures(), qpv_codegen::Figures::default());
}
