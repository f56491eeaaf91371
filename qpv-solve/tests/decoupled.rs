//! Decoupled vertex conditions. One slack Z_l per θ-vertex
//! replaces the N p² rate blocks of (S5) by N·2p blocks
//! (F0_l + G_l(x_i) + Z_l ≺ 0 for every e-vertex x_i, H_l(x_j) ⪯ Z_l for
//! every x-vertex x_j); the design is always certified on the full family.
//!
//! Measured (sound mode, paper's Q, γ = 0.1889, α = max, tolerance 1e-3):
//! paper example, N_k, M_k as written: full 10.605, decoupled 10.605;
//! symmetric split (N_k and M_k): 12.395 both; N_k symmetrised, M as
//! written: 11.272 both. Asymmetric regions (a shifted box, two simplices):
//! losses ≤ 0.15 %.

use nalgebra::{DMatrix, DVector};
use qpv_dsl::{
    AlphaSpec, Conditions, DesignRequest, GammaSpec, Mode, PolytopicModel, Region, Split,
};
use qpv_solve::certificate::rate_lmi;
use qpv_solve::certificate::Gains;
use qpv_solve::conditions::reference::{box_region, paper_model};
use qpv_solve::conditions::{gamma_max, ConditionSet};
use qpv_solve::lmi::{Objective, Problem};
use qpv_solve::vocab::Candidate;
use qpv_solve::{check, design, Design, Settings};

const TOL: f64 = 1e-3; // Settings::default().bisection_rel_tol

/// These tests compare the α searches of the condition families: the
/// fastest certified point (`within = 0`), not the practical design below it.
fn req(alpha: AlphaSpec, gamma: GammaSpec, split: Split, conditions: Conditions) -> DesignRequest {
    let mut r = qpv_solve::request(alpha, gamma, Mode::Sound);
    r.split = split;
    r.conditions = conditions;
    r.within = 0.0;
    r
}

fn run(model: &PolytopicModel, r: &DesignRequest) -> Design {
    design(model, r, &Settings::default()).expect("design runs")
}

/// The full-family certificate of a design, from its JSON alone.
fn recheck_full_family(model: &PolytopicModel, d: &Design) -> qpv_solve::Certificate {
    let back = Design::from_json(&d.to_json()).expect("JSON round trip");
    assert_eq!(&back, d);
    let c = back.recheck(model);
    let p = model.region.vertices.len();
    let rate = ConditionSet::from_mode(d.mode).families()[3];
    assert_eq!(
        c.family(rate).unwrap().count,
        model.nv() * p * p,
        "the full family is checked"
    );
    c
}

/// Full and decoupled designs of the same request; asserts both certify
/// (the decoupled one on the full family) and returns (α_full, α_dec).
fn compare(
    model: &PolytopicModel,
    alpha: AlphaSpec,
    gamma: GammaSpec,
    split: Split,
    what: &str,
) -> (f64, f64) {
    let full = run(model, &req(alpha, gamma, split, Conditions::Full));
    let dec = run(model, &req(alpha, gamma, split, Conditions::Decoupled));
    for d in [&full, &dec] {
        assert!(d.feasible() && d.certifies(), "{what}: {}", d.summary);
        assert!(recheck_full_family(model, d).passed, "{what}");
    }
    assert_eq!(full.conditions, Conditions::Full);
    assert_eq!(dec.conditions, Conditions::Decoupled);
    assert!(
        dec.notes
            .iter()
            .map(ToString::to_string)
            .any(|n| n.contains("conditions = decoupled")),
        "{:?}",
        dec.notes
    );
    println!(
        "{what}: α full = {:.5} (γ = {:.5}, {} solves, {:.3} s), decoupled = {:.5} (γ = {:.5}, {} solves, {:.3} s), loss {:.3} %",
        full.alpha,
        full.gamma,
        full.search.len(),
        full.seconds_total,
        dec.alpha,
        dec.gamma,
        dec.search.len(),
        dec.seconds_total,
        100.0 * (1.0 - dec.alpha / full.alpha)
    );
    (full.alpha, dec.alpha)
}

/// N_k symmetrised, M_k as written (the "11.27" reference split).
fn symmetric_n_only(model: &PolytopicModel) -> PolytopicModel {
    let mut m = model.clone();
    for v in &mut m.vertices {
        for n in &mut v.n {
            *n = (&*n + n.transpose()) * 0.5;
        }
    }
    m
}

#[test]
fn paper_example_no_loss_at_fixed_gamma() {
    let model = paper_model();
    let g = 0.1889;
    let fixed = GammaSpec::Fixed(g);
    // The decoupled set is sufficient for the full one: it can only lose
    // (up to the α tolerance of the search), and here it loses nothing.
    let (f, d) = compare(
        &model,
        AlphaSpec::Max,
        fixed,
        Split::AsWritten,
        "paper, as written",
    );
    assert!((10.5..10.7).contains(&f), "reference 10.60: {f}");
    assert!(d <= f * (1.0 + TOL) && d >= f * (1.0 - TOL), "{d} vs {f}");
    let (f, d) = compare(
        &model,
        AlphaSpec::Max,
        fixed,
        Split::Symmetric,
        "paper, symmetric N_k and M_k",
    );
    assert!(f > 12.0, "{f}");
    assert!(d <= f * (1.0 + TOL) && d >= f * (1.0 - TOL), "{d} vs {f}");
    let n_only = symmetric_n_only(&model);
    let (f, d) = compare(
        &n_only,
        AlphaSpec::Max,
        fixed,
        Split::AsWritten,
        "paper, symmetric N_k only",
    );
    assert!(d <= f * (1.0 + TOL) && d >= f * (1.0 - TOL), "{d} vs {f}");
}

#[test]
fn paper_example_gamma_search_decoupled() {
    // The default request (α = max, γ = search, symmetric split).
    let model = paper_model();
    let (f, d) = compare(
        &model,
        AlphaSpec::Max,
        GammaSpec::Search,
        Split::Symmetric,
        "paper, γ search",
    );
    // Both are searches over γ (not proofs of optimality): equal to 1 %.
    assert!((d / f - 1.0).abs() < 0.01, "{d} vs {f}");
}

/// The simplex with these vertices (0 inside): facets through each three.
fn simplex(v: [[f64; 3]; 4]) -> Region {
    let vertices: Vec<DVector<f64>> = v.iter().map(|x| DVector::from_row_slice(x)).collect();
    let mut facets = Vec::new();
    for (skip, opposite) in vertices.iter().enumerate() {
        let rows: Vec<usize> = (0..4).filter(|&k| k != skip).collect();
        let m = DMatrix::from_fn(3, 3, |r, c| v[rows[r]][c]);
        let a = m
            .lu()
            .solve(&DVector::from_element(3, 1.0))
            .expect("non-degenerate simplex");
        assert!(a.dot(opposite) < 1.0, "0 inside");
        facets.push(a);
    }
    Region {
        vertices,
        facets,
        generators: Vec::new(),
    }
}

/// The box lo ≤ x_i ≤ hi (lo < 0 < hi): facets e_i/hi and e_i/lo.
fn shifted_box(n: usize, lo: f64, hi: f64) -> Region {
    let mut r = box_region(n, 1.0);
    for v in &mut r.vertices {
        v.apply(|x| *x = if *x > 0.0 { hi } else { lo });
    }
    r.facets = (0..n)
        .flat_map(|i| {
            [hi, lo].map(|b| DVector::from_fn(n, |k, _| if k == i { 1.0 / b } else { 0.0 }))
        })
        .collect();
    r
}

#[test]
fn asymmetric_regions_lose_little() {
    let base = paper_model();
    let regions = [
        (
            "shifted box [-0.015, 0.025]³",
            shifted_box(3, -0.015, 0.025),
        ),
        (
            "skewed simplex",
            simplex([
                [0.04, 0.01, 0.0],
                [-0.01, 0.03, -0.01],
                [-0.015, -0.02, 0.03],
                [-0.01, -0.01, -0.025],
            ]),
        ),
        (
            "shifted regular simplex",
            simplex([
                [0.04, 0.025, 0.033],
                [0.04, -0.035, -0.027],
                [-0.02, 0.025, -0.027],
                [-0.02, -0.035, 0.033],
            ]),
        ),
    ];
    let mut worst: f64 = 0.0;
    for (name, region) in regions {
        let mut model = base.clone();
        model.region = region;
        let g = gamma_max(&model).unwrap() * 0.999;
        for split in [Split::AsWritten, Split::Symmetric] {
            let (f, d) = compare(
                &model,
                AlphaSpec::Max,
                GammaSpec::Fixed(g),
                split,
                &format!("{name}, {split:?}"),
            );
            assert!(d <= f * (1.0 + TOL), "{name}: decoupled {d} > full {f}");
            worst = worst.max(1.0 - d / f);
        }
    }
    println!("worst loss {:.3} %", 100.0 * worst);
    // Reference: about 0.3 % on an asymmetric region.
    assert!(worst < 0.01, "loss {:.3} %", 100.0 * worst);
}

/// A decoupled solve returns (P, Γ_l, Z_l) that satisfy its own 2p blocks
/// per θ-vertex, and hence every one of the p² full blocks: the
/// implication, checked with eigenvalues in model units.
#[test]
fn decoupled_solution_satisfies_the_full_family() {
    let model = paper_model();
    let (alpha, gamma) = (10.0, 0.1889);
    for mode in [Mode::Sound, Mode::Paper] {
        let set = ConditionSet::from_mode(mode);
        let gamma = if mode == Mode::Paper { 0.4 } else { gamma };
        let prob = Problem::new(&model, set)
            .unwrap()
            .with_conditions(Conditions::Decoupled)
            .unwrap();
        let settings = Settings::default();
        let asm = prob.assemble(alpha, gamma, &settings, Objective::Gains);
        qpv_solve::backend::ensure_lapack();
        let solver =
            qpv_clarabel::solve(asm, qpv_solve::backend::clarabel_settings(&settings)).unwrap();
        assert_eq!(
            solver.solution.status,
            qpv_clarabel::clarabel::solver::SolverStatus::Solved,
            "{mode:?}"
        );
        let x = &solver.solution.x;
        let (p, gammas) = prob.unpack(x);
        let z = prob.unpack_z(x);
        assert_eq!(z.len(), model.nv());
        let sigma = set.nonlinear_sign();
        let lmax = |m: &DMatrix<f64>| m.clone().symmetric_eigenvalues().max();
        let he = |m: DMatrix<f64>| &m + m.transpose();
        let rows = qpv_solve::conditions::rows;
        let rows_he = qpv_solve::conditions::rows_he;
        let scale = p.norm();
        for (l, v) in model.vertices.iter().enumerate() {
            let g = &gammas[l];
            let f0 = he((&p * &v.a - g * model.c0().0) * gamma) + &p * (gamma * alpha);
            let e_worst = model
                .region
                .vertices
                .iter()
                .map(|xi| {
                    lmax(
                        &(&f0
                            + he(&p * rows(&v.n, xi) * (-sigma) + g * rows(model.c0().1, xi))
                            + &z[l]),
                    )
                })
                .fold(f64::NEG_INFINITY, f64::max);
            let x_worst = model
                .region
                .vertices
                .iter()
                .map(|xj| {
                    lmax(
                        &(he(&p * rows_he(&v.n, xj) * sigma - g * rows_he(model.c0().1, xj))
                            - &z[l]),
                    )
                })
                .fold(f64::NEG_INFINITY, f64::max);
            assert!(e_worst < 0.0, "{mode:?} l={l}: e-blocks λ_max {e_worst}");
            assert!(
                x_worst < 1e-7 * scale,
                "{mode:?} l={l}: x-blocks λ_max {x_worst}"
            );
            assert!(e_worst + x_worst.max(0.0) < 0.0);
            // Every full block (l, i, j) is the sum of two of them.
            let p_cnt = model.region.vertices.len();
            for i in 0..p_cnt {
                for j in 0..p_cnt {
                    let m = rate_lmi(&model, mode, Candidate::new(alpha, gamma), &p, g, (l, i, j));
                    assert!(
                        lmax(&m) <= e_worst + x_worst.max(0.0) + 1e-9 * scale,
                        "l={l} i={i} j={j}"
                    );
                }
            }
        }
        let gains: Vec<DMatrix<f64>> = gammas
            .iter()
            .map(|g| p.clone().cholesky().unwrap().solve(g))
            .collect();
        let c = check(
            &model,
            &Gains::new(&p, &gains),
            &Candidate::new(alpha, gamma),
            mode,
        );
        assert!(c.families_passed(), "{mode:?}: {c:?}");
    }
}

#[test]
fn paper_mode_decoupled_reproduces_the_published_point() {
    // The printed conditions (26) with σ = −1, decoupled: still satisfied at
    // the paper's (α, γ) = (10, 0.4), and re-checked on all 256 blocks.
    let model = paper_model();
    let mut r = qpv_solve::request(AlphaSpec::Fixed(10.0), GammaSpec::Fixed(0.4), Mode::Paper);
    r.conditions = Conditions::Decoupled;
    let d = run(&model, &r);
    assert!(d.feasible() && !d.certifies(), "{}", d.summary);
    let c = recheck_full_family(&model, &d);
    assert!(c.families_passed());
    assert_eq!(c.family("26").unwrap().count, 256);
}

#[test]
fn json_reports_the_condition_set() {
    let model = paper_model();
    let d = run(
        &model,
        &req(
            AlphaSpec::Fixed(10.0),
            GammaSpec::Fixed(0.1889),
            Split::AsWritten,
            Conditions::Decoupled,
        ),
    );
    assert!(d.feasible(), "{}", d.summary);
    let v: serde_json::Value = serde_json::from_str(&d.to_json()).unwrap();
    assert_eq!(v["conditions"], "decoupled");
    assert_eq!(
        Design::from_json(&d.to_json()).unwrap().conditions,
        Conditions::Decoupled
    );
    // An unknown value is rejected; a report without the key reads as full.
    let mut bad = v.clone();
    bad["conditions"] = "partial".into();
    let err = Design::from_json(&bad.to_string()).unwrap_err().to_string();
    assert!(
        err.contains("unknown conditions") && err.contains("partial"),
        "{err}"
    );
    let mut old = v;
    old.as_object_mut().unwrap().remove("conditions");
    assert_eq!(
        Design::from_json(&old.to_string()).unwrap().conditions,
        Conditions::Full
    );
}

/// The full family's feasible set contains the decoupled one's at every γ,
/// so a γ search that ends below the decoupled search's α on the same
/// model has missed the optimum (up to the bisection tolerance). Van de
/// Vusse has a sharp peak of α_max(γ) near γ ≈ 0.003 that a refinement
/// with fewer α searches (fewer P to seed its neighbours) missed, ending
/// below the decoupled search.
#[test]
fn full_gamma_search_is_never_below_decoupled() {
    for src in [
        include_str!("../../examples/lotka_volterra.qpv"),
        include_str!("../../examples/van_de_vusse.qpv"),
    ] {
        let model = qpv_dsl::parse(src).expect("parses")[0].polytopic();
        let search = |c| {
            let d = run(
                &model,
                &req(AlphaSpec::Max, GammaSpec::Search, Split::Symmetric, c),
            );
            assert!(d.certifies(), "{}", d.summary);
            d.alpha
        };
        let (full, dec) = (search(Conditions::Full), search(Conditions::Decoupled));
        assert!(
            full >= dec * (1.0 - TOL),
            "{}: full {full} < decoupled {dec}",
            model.name
        );
    }
}

/// `conditions = cube` on the paper example at the reference γ: α ≥ 12.3
/// (docs/method.md, the cube's measured loss), certified by the slack
/// inequalities; the same P, L_l also pass the full vertex family (a
/// cross-check that is affordable for nx ≤ 8), and the report re-checks
/// from its JSON alone.
#[test]
fn paper_example_cube_certifies_and_passes_the_full_family() {
    let model = paper_model();
    let d = run(
        &model,
        &req(
            AlphaSpec::Max,
            GammaSpec::Fixed(0.18898),
            Split::Symmetric,
            Conditions::Cube,
        ),
    );
    assert!(d.feasible() && d.certifies(), "{}", d.summary);
    assert_eq!(d.conditions, Conditions::Cube);
    assert!(d.alpha >= 12.3, "cube α = {}", d.alpha);
    let cube = d.cube.as_ref().expect("the report carries the slacks");
    assert_eq!(cube.d.len(), 3);
    assert_eq!(cube.y.len(), model.nv());
    let sym = model.with_split(Split::Symmetric);
    let full = check(
        &sym,
        &Gains::new(&d.p_matrix(), &d.l_matrices()),
        &Candidate::new(d.alpha, d.gamma),
        Mode::Sound,
    );
    assert!(full.passed, "{:?}", full.families);
    assert_eq!(full.families[3].count, 4 * 8 * 8);
    let back = Design::from_json(&d.to_json()).expect("JSON round trip");
    let c = back.recheck(&model);
    assert!(c.passed, "{:?}", c.families);
    // The cube certificate checks 4r + 1 = 13 inequalities per θ-vertex.
    assert_eq!(c.families[3].count, 4 * 13);
}

/// The cube certificate fails when a slack is lowered or a gain moved.
#[test]
fn cube_certificate_fails_for_perturbed_slacks_and_gains() {
    use qpv_solve::certificate::check;
    use qpv_solve::conditions::cube::CubeSlacks;
    let model = paper_model().with_split(Split::Symmetric);
    let d = run(
        &model,
        &req(
            AlphaSpec::Fixed(10.0),
            GammaSpec::Fixed(0.18898),
            Split::AsWritten,
            Conditions::Cube,
        ),
    );
    assert!(d.certifies(), "{}", d.summary);
    let slacks = CubeSlacks::from_report(d.cube.as_ref().unwrap());
    let (p, l) = (d.p_matrix(), d.l_matrices());
    let ok = check(
        &model,
        &Gains::new(&p, &l).with_cube(Some(&slacks)),
        &Candidate::new(d.alpha, d.gamma),
        Mode::Sound,
    );
    assert!(ok.passed, "{:?}", ok.families);
    // Y_{1,1} lowered by its own size: Y ⪰ ±G(g_1) fails.
    let mut low = slacks.clone();
    let y = &low.y[0][0];
    let shift = y.norm() + 1.0;
    low.y[0][0] = y - DMatrix::identity(3, 3) * shift;
    let c = check(
        &model,
        &Gains::new(&p, &l).with_cube(Some(&low)),
        &Candidate::new(d.alpha, d.gamma),
        Mode::Sound,
    );
    assert!(!c.passed && !c.families[3].passed);
    assert!(
        c.families[3].worst_at.contains("Y k=1"),
        "{}",
        c.families[3].worst_at
    );
    // X_{2,3} raised: the sum F0 + ΣY + ΣX ≺ 0 fails.
    let mut high = slacks.clone();
    high.x[1][2] += DMatrix::identity(3, 3) * (p.norm() * 1e3);
    let c = check(
        &model,
        &Gains::new(&p, &l).with_cube(Some(&high)),
        &Candidate::new(d.alpha, d.gamma),
        Mode::Sound,
    );
    assert!(!c.passed && c.families[3].worst_at.contains("F0"));
    // D with a trace above 1.
    let mut dd = slacks.clone();
    dd.d[0] += 1.0;
    let c = check(
        &model,
        &Gains::new(&p, &l).with_cube(Some(&dd)),
        &Candidate::new(d.alpha, d.gamma),
        Mode::Sound,
    );
    assert!(!c.passed && !c.families[1].passed);
    // A gain moved: some slack inequality no longer holds.
    let mut l2 = l.clone();
    l2[0] *= 3.0;
    let c = check(
        &model,
        &Gains::new(&p, &l2).with_cube(Some(&slacks)),
        &Candidate::new(d.alpha, d.gamma),
        Mode::Sound,
    );
    assert!(!c.passed && !c.families[3].passed);
}
