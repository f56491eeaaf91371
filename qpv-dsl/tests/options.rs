//! The design and state-bound options: `state_bound auto`,
//! `split = as_written | symmetric`, `conditions = full | decoupled`, their
//! mode-dependent defaults, and `PolytopicModel::with_split` (same plant).

use nalgebra::{DMatrix, DVector};
use qpv_dsl::{parse, Conditions, DesignRequest, Mode, Model, PolytopicModel, Split, StateBound};

const PAPER: &str = include_str!("../../examples/paper.qpv");

const BASE: &str = "model m {
    state x1, x2;
    output y;
    param th in [0, 1];
    A = [-1, th; 0, -2];
    N1 = [0, 1; 0, 0];
    N2 = [0, 0; 2*th, 0];
    C = [1, 0];
    M1 = [0, 3; 0, 0];
    region box([1, 2]);
    EXTRA
}
";

fn one(extra: &str) -> Model {
    let src = BASE.replace("EXTRA", extra);
    let mut models = parse(&src).unwrap_or_else(|e| panic!("{extra}: {e}"));
    models.remove(0)
}

#[test]
fn state_bound_auto_parses() {
    assert_eq!(
        one("state_bound auto;").state_bound,
        StateBound::Auto { h: None }
    );
    assert_eq!(
        one("state_bound auto(h = 2.5);").state_bound,
        StateBound::Auto { h: Some(2.5) }
    );
    // constant expressions and a trailing comma are accepted
    assert_eq!(
        one("state_bound auto(h = 5/2,);").state_bound,
        StateBound::Auto { h: Some(2.5) }
    );
    // `auto` stays usable as an ordinary name elsewhere
    let src = BASE
        .replace("param th", "param auto")
        .replace("th", "auto")
        .replace("EXTRA", "");
    assert!(parse(&src).is_ok(), "{src}");
}

#[test]
fn design_defaults_follow_the_mode() {
    let m = one("design { }
         design { mode = paper; }
         design { split = as_written; }
         design { mode = paper; split = symmetric; conditions = decoupled; }
         design { split = symmetric; mode = paper; }
         design { conditions = full; }
         design { split = skew_slack; conditions = decoupled; }");
    let got: Vec<(Mode, Split, Conditions)> = m
        .designs
        .iter()
        .map(|d| (d.mode, d.split, d.conditions))
        .collect();
    assert_eq!(
        got,
        vec![
            (Mode::Sound, Split::Symmetric, Conditions::Auto),
            (Mode::Paper, Split::AsWritten, Conditions::Auto),
            (Mode::Sound, Split::AsWritten, Conditions::Auto),
            (Mode::Paper, Split::Symmetric, Conditions::Decoupled),
            (Mode::Paper, Split::Symmetric, Conditions::Auto),
            (Mode::Sound, Split::Symmetric, Conditions::Full),
            (Mode::Sound, Split::SkewSlack, Conditions::Decoupled),
        ]
    );
    let d = DesignRequest::default();
    assert_eq!(
        (d.mode, d.split, d.conditions),
        (Mode::Sound, Split::Symmetric, Conditions::Auto)
    );
    assert_eq!(Split::default_for(Mode::Paper), Split::AsWritten);
}

/// f(x, θ) = A(θ)x + (xᵀ N_k(θ) x)_k and h(x) = C(θ)x + (xᵀ M_k(θ) x)_k from the
/// polytopic data.
fn plant(p: &PolytopicModel, x: &DVector<f64>, theta: &[f64]) -> (DVector<f64>, DVector<f64>) {
    let mut f = p.a_at(theta) * x;
    for (k, nk) in p.n_at(theta).iter().enumerate() {
        f[k] += x.dot(&(nk * x));
    }
    (f, p.output(x, theta))
}

fn is_symmetric(m: &DMatrix<f64>) -> bool {
    (m - m.transpose()).abs().max() == 0.0
}

#[test]
fn symmetric_split_keeps_the_plant() {
    for src in [PAPER.to_string(), BASE.replace("EXTRA", "")] {
        let model = parse(&src).unwrap().remove(0);
        let written = model.polytopic();
        let sym = written.with_split(Split::Symmetric);
        assert_eq!(written.with_split(Split::AsWritten), written);
        // the representation does change (N_k as written are not symmetric)...
        assert_ne!(sym, written);
        for v in &sym.vertices {
            assert!(v.n.iter().all(is_symmetric));
        }
        assert!(sym.vertices.iter().all(|v| v.m.iter().all(is_symmetric)));
        // ...but A, B, C and the vertex order do not
        for (a, b) in sym.vertices.iter().zip(&written.vertices) {
            assert_eq!((&a.a, &a.b, &a.theta), (&b.a, &b.b, &b.theta));
        }
        // and the plant right-hand side and output are the same everywhere
        let nx = model.nx();
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..200 {
            let x = DVector::from_fn(nx, |_, _| 4.0 * rnd() - 2.0);
            let theta: Vec<f64> = model
                .params
                .iter()
                .map(|p| p.lo + (p.hi - p.lo) * rnd())
                .collect();
            let (f0, y0) = plant(&written, &x, &theta);
            let (f1, y1) = plant(&sym, &x, &theta);
            let (fm, ym) = (
                model.rhs(&x, &DVector::zeros(model.nu()), &theta),
                model.output(&x, &theta),
            );
            let scale = 1.0 + f0.amax() + y0.amax();
            assert!((&f0 - &f1).amax() <= 1e-12 * scale, "{f0} vs {f1}");
            assert!((&y0 - &y1).amax() <= 1e-12 * scale, "{y0} vs {y1}");
            assert!((&f1 - &fm).amax() <= 1e-12 * scale, "{f1} vs {fm}");
            assert!((&y1 - &ym).amax() <= 1e-12 * scale, "{y1} vs {ym}");
        }
    }
}

#[test]
fn paper_auto_example_parses() {
    let src = include_str!("../../examples/paper_auto.qpv");
    let m = parse(src).unwrap().remove(0);
    assert_eq!(m.state_bound, StateBound::Auto { h: None });
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    let d = &m.designs[0];
    assert_eq!(
        (d.mode, d.split, d.conditions),
        (Mode::Sound, Split::Symmetric, Conditions::Auto)
    );
    // the same plant as the paper's example
    let paper = parse(PAPER).unwrap().remove(0).polytopic();
    let auto = m.polytopic();
    assert_eq!(auto.vertices, paper.vertices);
    assert_eq!(&auto.region, &paper.region);
}

/// `conditions = cube` and `region zonotope [...]`: a box and a
/// parallelotope given by halfspaces are recognised as zonotopes (their
/// generators recovered), a zonotope keeps its generators, and its
/// vertices and facets are those of the polytope.
#[test]
fn cube_conditions_and_zonotope_regions() {
    let with = |region: &str| {
        let src = format!(
            "model m {{ state x1, x2; output y; param th in [0, 1];
             A = [-1, th; 0, -2]; C = [1, 0]; {region} design {{ conditions = cube; }} }}"
        );
        parse(&src).map(|mut v| v.remove(0))
    };
    let m = with("region box([0.5, 2]);").unwrap();
    assert_eq!(m.designs[0].conditions, Conditions::Cube);
    let g = m.region.zonotope_generators().unwrap();
    assert_eq!(g.len(), 2);
    assert_eq!((g[0][0], g[0][1], g[1][0], g[1][1]), (0.5, 0.0, 0.0, 2.0));
    // |x1 + x2| ≤ 1, |x2| ≤ 1: a parallelotope with generators (1, 0), (−1, 1).
    let m = with("region halfspaces [1, 1; -1, -1; 0, 1; 0, -1];").unwrap();
    let g = m.region.zonotope_generators().unwrap();
    let has = |x: f64, y: f64| {
        g.iter().any(|v| {
            ((v[0] - x).abs() + (v[1] - y).abs() < 1e-12)
                || ((v[0] + x).abs() + (v[1] + y).abs() < 1e-12)
        })
    };
    assert!(has(1.0, 0.0) && has(-1.0, 1.0), "{g:?}");
    // A hexagon: three generators in the plane.
    let m = with("region zonotope [1, 0; 0, 1; 0.5, 0.5];").unwrap();
    assert_eq!(m.region.generators.len(), 3);
    assert_eq!(m.region.vertices.len(), 6);
    assert_eq!(m.region.facets.len(), 6);
    assert!(m.region.contains(&DVector::from_vec(vec![1.5, 1.5])));
    assert!(!m.region.contains(&DVector::from_vec(vec![1.5, -1.5])));
    // A triangle is no zonotope: a positioned error at the setting.
    let e = with("region vertices [1, 0; 0, 1; -1, -1];").unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("`conditions = cube` needs a region that is a box"),
        "{text}"
    );
    // Too few generators.
    let e = with("region zonotope [1, 1];").unwrap_err().to_string();
    assert!(e.contains("at least 2 generators"), "{e}");
}

#[test]
fn sample_parses_as_a_period_in_seconds() {
    let m = one("design { }
         design { sample = 1e-4; }
         design { alpha = 5; gamma = 0.5; sample = 1/100; conditions = full; }");
    let samples: Vec<Option<f64>> = m.designs.iter().map(|d| d.sample).collect();
    assert_eq!(samples, vec![None, Some(1e-4), Some(0.01)]);
    assert_eq!(m.designs[2].conditions, Conditions::Full);
}

/// `DesignRequest::validate` is the table the language checks: a request
/// built in code meets the same refusals (with the language's words), and
/// its `Display` reads back as the block's settings.
#[test]
fn requests_are_validated_and_written_as_their_settings() {
    use qpv_dsl::{AlphaSpec, Clash, GammaSpec, NoiseObjective};
    let base = DesignRequest {
        alpha: AlphaSpec::Fixed(5.0),
        gamma: GammaSpec::Fixed(0.25),
        ..DesignRequest::default()
    };
    assert_eq!(base.validate(), Ok(()));
    assert_eq!(
        base.to_string(),
        "alpha = 5; gamma = 0.25; mode = sound; split = symmetric; conditions = auto"
    );
    let noise_max = DesignRequest {
        alpha: AlphaSpec::Max,
        noise: NoiseObjective::Min,
        ..base.clone()
    };
    assert_eq!(noise_max.validate(), Err(Clash::NoiseMinAlphaMax));
    assert_eq!(Clash::NoiseMinAlphaMax.key(), "noise");
    // The language refuses the same block at the same key, in the same words.
    let src = BASE.replace("EXTRA", "design { alpha = max; noise = min; }");
    let err = parse(&src).unwrap_err().to_string();
    assert!(err.contains(&Clash::NoiseMinAlphaMax.to_string()), "{err}");
    let sampled = DesignRequest {
        sample: Some(1e-3),
        conditions: Conditions::Cube,
        ..base.clone()
    };
    assert_eq!(sampled.validate(), Err(Clash::SampleCube));
    let paper_skew = DesignRequest {
        mode: Mode::Paper,
        split: Split::SkewSlack,
        noise: NoiseObjective::Min,
        ..base.clone()
    };
    assert_eq!(paper_skew.validate(), Err(Clash::SkewSlackPaper));
    let gained = DesignRequest {
        max_gain: Some(20.0),
        sample: Some(1e-4),
        within: 0.05,
        alpha: AlphaSpec::Max,
        ..base
    };
    assert_eq!(gained.validate(), Ok(()));
    assert_eq!(
        gained.to_string(),
        "alpha = max(within = 0.05); gamma = 0.25; mode = sound; split = symmetric; \
         conditions = auto; max_gain = 20; sample = 0.0001"
    );
}
