//! The global observer of an LPV plant (docs/method.md, "The global
//! observer"): no region or state bound, P ⪰ I and He{P A_l − Γ_l C_m} +
//! αP ≺ 0 at every rate combination, certified as family G5; and the
//! de-duplication of rate blocks whose nonlinear terms vanish.

use nalgebra::{DMatrix, DVector};
use qpv_dsl::{AlphaSpec, GammaSpec, Mode, PolytopicModel};
use qpv_solve::certificate::Gains;
use qpv_solve::certificate::{check, combo_lmi};
use qpv_solve::conditions::reference::paper_model;
use qpv_solve::conditions::{rate_combos, ConditionSet};
use qpv_solve::lmi::Problem;
use qpv_solve::model::StateScaling;
use qpv_solve::vocab::Candidate;
use qpv_solve::{design, Design, Settings};

fn three_tank() -> PolytopicModel {
    qpv_dsl::parse(include_str!("../../examples/three_tank.qpv")).expect("parses")[0].polytopic()
}

fn run(m: &PolytopicModel, alpha: AlphaSpec) -> Design {
    let r = qpv_solve::request(alpha, GammaSpec::Search, Mode::Sound);
    design(m, &r, &Settings::default()).expect("design runs")
}

/// A small deterministic generator of θ in the box (no dependency).
fn sample_thetas(m: &PolytopicModel, n: usize) -> Vec<Vec<f64>> {
    let mut state: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| {
            m.params
                .iter()
                .map(|p| p.lo + (p.hi - p.lo) * next())
                .collect()
        })
        .collect()
}

/// max over sampled θ of λ_max(He{P(A(θ) − L(θ)C(θ))} + αP), evaluated
/// after the exact congruence x = Dz that balances P (the sign of every
/// eigenvalue is that of the user's matrix; the balanced one is formed
/// without the cancellation huge gains cause in the user's units).
fn sampled_worst(m: &PolytopicModel, d: &Design, thetas: &[Vec<f64>]) -> f64 {
    let p = d.p_matrix();
    let ls = d.l_matrices();
    let dz = StateScaling::of_p(&p)
        .map(|s| s.d)
        .unwrap_or_else(|| vec![1.0; m.nx()]);
    let dm = DMatrix::from_diagonal(&DVector::from_vec(dz.clone()));
    let dinv = DMatrix::from_diagonal(&DVector::from_vec(dz.iter().map(|v| 1.0 / v).collect()));
    let pz = &dm * &p * &dm;
    let mut worst = f64::NEG_INFINITY;
    for th in thetas {
        let mu = m.mu(th);
        let mut l = DMatrix::zeros(m.nx(), m.ny());
        for (w, li) in mu.iter().zip(&ls) {
            l += li * *w;
        }
        let az = &dinv * m.a_at(th) * &dm;
        let lz = &dinv * l;
        let cz = m.c_at(th) * &dm;
        let f = &pz * (az - lz * cz);
        let mat = &f + f.transpose() + &pz * d.alpha;
        let lmax = mat.symmetric_eigenvalues().max();
        worst = worst.max(lmax / pz.norm());
    }
    worst
}

#[test]
fn lpv_plant_needs_no_region_and_is_global() {
    let m = three_tank();
    assert!(m.is_lpv());
    assert!(!m.has_region());
    assert_eq!(m.nv(), 32);
    let prob = Problem::new(&m, ConditionSet::Sound).expect("no region needed");
    assert!(prob.is_global());
    // One block per θ-vertex: the region-vertex pairs are gone.
    assert_eq!(prob.n_full_rate_blocks(), 32);
}

#[test]
fn three_tank_certifies_alpha_0_9_and_0_99_globally() {
    let m = three_tank();
    let thetas = sample_thetas(&m, 400);
    for alpha in [0.9, 0.99] {
        let d = run(&m, AlphaSpec::Fixed(alpha));
        assert!(d.certifies(), "α = {alpha}: {}", d.summary);
        assert!(d.global);
        assert_eq!(d.alpha, alpha);
        let families: Vec<&str> = d.margins.keys().map(|f| f.name()).collect();
        assert_eq!(families, ["G5", "S1"]);
        assert!(d.data_checks.is_empty(), "no S4 for a global design");
        assert!(d.summary.contains("GLOBAL"));
        // Re-checked from P and L alone, and by brute-force sampling of θ.
        let cert = check(
            &m,
            &Gains::new(&d.p_matrix(), &d.l_matrices()),
            &Candidate::new(alpha, d.gamma),
            Mode::Sound,
        );
        assert!(cert.passed);
        let worst = sampled_worst(&m, &d, &thetas);
        assert!(worst < 0.0, "α = {alpha}: sampled λ_max/‖P‖ = {worst:e}");
    }
}

#[test]
fn global_certificate_rejects_too_fast_a_claim() {
    // The gains of α = 0.9 do not certify a claim of α ten times larger:
    // the capacity bounds what the same (P, L) give.
    let m = three_tank();
    let d = run(&m, AlphaSpec::Fixed(0.9));
    let (p, l) = (d.p_matrix(), d.l_matrices());
    let gammas: Vec<DMatrix<f64>> = l.iter().map(|li| &p * li).collect();
    let cap = qpv_solve::certificate::alpha_capacity(&m, Mode::Sound, 1.0, &p, &gammas);
    assert!(cap >= 0.9, "capacity {cap}");
    let over = check(
        &m,
        &Gains::new(&p, &l),
        &Candidate::new(cap * 1.01, 1.0),
        Mode::Sound,
    );
    assert!(!over.passed);
    let worst = sampled_worst(
        &m,
        &Design {
            alpha: cap * 1.5,
            ..d.clone()
        },
        &sample_thetas(&m, 2000)
            .into_iter()
            .chain(m.vertices.iter().map(|v| v.theta.clone()))
            .collect::<Vec<_>>(),
    );
    assert!(worst > 0.0, "a claim at 1.5 × capacity must fail somewhere");
}

#[test]
fn three_tank_alpha_max_finds_a_high_supremum_and_returns_the_gain_knee() {
    let m = three_tank();
    let d = run(&m, AlphaSpec::Max);
    assert!(d.certifies(), "{}", d.summary);
    assert!(d.global);
    let pr = d.practical.as_ref().expect("practical info");
    // The supremum search certifies far beyond the classical 0.99 ...
    assert!(pr.alpha_sup > 0.99, "α_sup = {}", pr.alpha_sup);
    // ... with gains that grow like α³ on this cascade: high gain, and the
    // design returned is the knee, with far smaller gains.
    assert!(pr.high_gain, "{}", d.summary);
    let gain = d.gain_norms.iter().copied().fold(0.0, f64::max);
    assert!(
        d.alpha < pr.alpha_sup && d.alpha > pr.alpha_sup / 100.0,
        "α = {}",
        d.alpha
    );
    assert!(
        gain * 1e3 < pr.gain_sup,
        "knee gain {gain:e}, at α_sup {:e}",
        pr.gain_sup
    );
    let note = d
        .notes
        .iter()
        .map(|n| n.to_string())
        .find(|n| n.contains("knee"));
    assert!(
        note.is_some_and(|n| n.contains("max_gain")),
        "{:?}",
        d.notes
    );
    let worst = sampled_worst(&m, &d, &sample_thetas(&m, 400));
    assert!(worst < 0.0, "sampled λ_max/‖P‖ = {worst:e}");
    // within = 0 keeps the fastest point.
    let fastest = design(
        &m,
        &qpv_dsl::DesignRequest {
            within: 0.0,
            ..qpv_solve::request(AlphaSpec::Max, GammaSpec::Search, Mode::Sound)
        },
        &Settings::default(),
    )
    .expect("design runs");
    assert!(
        fastest.certifies() && fastest.alpha > 0.99,
        "{}",
        fastest.summary
    );
}

#[test]
fn a_given_region_and_state_bound_are_reported_unused() {
    let src = include_str!("../../examples/three_tank.qpv").replace(
        "design { alpha = 0.9; }",
        "region box(1); state_bound Q = [3,0,0;0,3,0;0,0,3]; design { alpha = 0.9; gamma = 0.3; }",
    );
    let model = &qpv_dsl::parse(&src).expect("parses")[0];
    assert!(model
        .warnings
        .iter()
        .any(|w| w.message.contains("region is not used")));
    assert!(model
        .warnings
        .iter()
        .any(|w| w.message.contains("state bound is not used")));
    let m = model.polytopic();
    let prob = Problem::new(&m, ConditionSet::Sound).unwrap();
    // 8 region vertices, but every pair has the same block: 32, not 32 · 64.
    assert_eq!(prob.n_pair_rate_blocks(), 32 * 64);
    assert_eq!(prob.n_full_rate_blocks(), 32);
    let d = design(&m, &m.designs[0], &Settings::default()).unwrap();
    assert!(d.certifies() && d.global, "{}", d.summary);
    assert!(d
        .notes
        .iter()
        .map(ToString::to_string)
        .any(|n| n.contains("region is not used")
            && n.contains("state bound is not used")
            && n.contains("γ = 0.3 is not used")));
}

#[test]
fn qpv_plant_without_region_is_still_refused() {
    let src =
        "model m { state x1; output y; der x1 = -x1 + x1*x1; out y = x1; state_bound Q = [1]; }";
    let err = qpv_dsl::parse(src).unwrap_err().to_string();
    assert!(err.contains("has no region"), "{err}");
}

/// The paper's plant with N_k and M_k zeroed at the first half of its
/// θ-vertices: a partly linear plant (as data; the de-duplication acts on
/// vertex data). Its output map then varies, so the rate family is the
/// double sum.
fn partly_linear() -> PolytopicModel {
    let mut m = paper_model();
    let half = m.nv() / 2;
    for v in &mut m.vertices[..half] {
        v.n.iter_mut().for_each(|n| n.fill(0.0));
        v.m.iter_mut().for_each(|x| x.fill(0.0));
    }
    m
}

#[test]
fn linear_vertices_are_written_once_and_certified_the_same() {
    let m = partly_linear();
    assert!(!m.is_lpv());
    let prob = Problem::new(&m, ConditionSet::Sound).unwrap();
    assert!(!prob.is_global());
    let p = m.region.vertices.len();
    let linear = (0..prob.combos().len())
        .filter(|&c| prob.combo_is_linear(c))
        .count();
    // The combinations whose every term (l, m) lies in the linear half.
    let half = m.nv() / 2;
    let expected = rate_combos(&m)
        .iter()
        .filter(|c| c.terms.iter().all(|&(l, k, _)| l < half && k < half))
        .count();
    assert!(expected > 0);
    assert_eq!(linear, expected);
    assert_eq!(
        prob.n_full_rate_blocks(),
        linear + (prob.combos().len() - linear) * p * p
    );
    assert!(prob.n_full_rate_blocks() < prob.n_pair_rate_blocks());
    let r = qpv_solve::request(AlphaSpec::Fixed(5.0), GammaSpec::Fixed(0.18), Mode::Sound);
    let d = design(&m, &r, &Settings::default()).unwrap();
    assert!(d.certifies(), "{}", d.summary);
    // The certificate's S5 margin is the minimum over every combination
    // and every pair, recomputed here block by block without de-duplication
    // (on the representation of N_k, M_k the design used).
    let m = m.with_split(d.split);
    let (pm, l) = (d.p_matrix(), d.l_matrices());
    let gammas: Vec<DMatrix<f64>> = l.iter().map(|li| &pm * li).collect();
    let mut worst = f64::INFINITY;
    for c in rate_combos(&m) {
        for i in 0..p {
            for j in 0..p {
                let b = combo_lmi(
                    &m,
                    Mode::Sound,
                    Candidate::new(d.alpha, d.gamma),
                    &pm,
                    &gammas,
                    &c,
                    (i, j),
                );
                worst = worst.min(-b.symmetric_eigenvalues().max());
            }
        }
    }
    let s5 = d.margins["S5"];
    assert!(
        (s5 - worst).abs() <= 1e-9 * worst.abs().max(1e-12),
        "{s5} vs {worst}"
    );
}

#[test]
fn skew_slack_is_refused_by_name_for_lpv_plants() {
    let m = three_tank();
    let skew = qpv_dsl::DesignRequest {
        split: qpv_dsl::Split::SkewSlack,
        ..qpv_solve::request(AlphaSpec::Fixed(0.9), GammaSpec::Search, Mode::Sound)
    };
    let err = design(&m, &skew, &Settings::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("skew_slack"), "{err}");
    assert!(err.contains("three_tank") && err.contains("LPV"), "{err}");
}

/// The noise-optimal global design of three-tank at α, on its one output.
fn noise_min(m: &PolytopicModel, alpha: f64, sample: Option<f64>) -> Design {
    let r = qpv_dsl::DesignRequest {
        noise: qpv_dsl::NoiseObjective::Min,
        sample,
        ..qpv_solve::request(AlphaSpec::Fixed(alpha), GammaSpec::Search, Mode::Sound)
    };
    design(m, &r, &Settings::default()).expect("design runs")
}

/// The global model, P and Γ_l of a design, exactly balanced by P (x = Dz).
fn balanced(m: &PolytopicModel, d: &Design) -> (PolytopicModel, DMatrix<f64>, Vec<DMatrix<f64>>) {
    let g = qpv_solve::model::global_model(m).into_owned();
    let p = d.p_matrix();
    let s = StateScaling::of_p(&p).expect("P balances");
    let gammas = d.l_matrices().iter().map(|l| &p * l).collect::<Vec<_>>();
    (
        s.model(&g).expect("exact"),
        s.p_to_z(&p).expect("exact"),
        gammas
            .iter()
            .map(|x| s.gamma_to_z(x).expect("exact"))
            .collect(),
    )
}

#[test]
fn noise_min_is_global_and_its_sigma_is_the_smallest_that_checks() {
    use qpv_solve::certificate::noise::check_noise;
    use qpv_solve::model::noise::NoiseChannels;
    let m = three_tank();
    let d = noise_min(&m, 0.5, None);
    assert!(d.certifies() && d.global, "{}", d.summary);
    assert!(d.summary.contains("GLOBAL"), "{}", d.summary);
    let nb = d.noise.as_ref().expect("a noise bound");
    assert!(nb.max_amplitude.is_infinite(), "{}", nb.max_amplitude);
    assert!(nb.check.passed && nb.error_bound.is_finite());
    // The block LMI at σ holds, at 0.9σ it fails: σ is the certified one
    // and not loose by more than 10 %.
    let (zm, pz, gz) = balanced(&m, &d);
    let ch = NoiseChannels::all_outputs();
    assert!(check_noise(&zm, &ch, d.alpha, 1.0, &pz, &gz, nb.sigma).passed);
    assert!(!check_noise(&zm, &ch, d.alpha, 1.0, &pz, &gz, 0.9 * nb.sigma).passed);
    // A report round trip keeps "unlimited" (null in JSON).
    let json = serde_json::to_string(nb).expect("serialises");
    assert!(json.contains("\"max_amplitude\":null"), "{json}");
    let back: qpv_solve::certificate::noise::NoiseBound =
        serde_json::from_str(&json).expect("reads back");
    assert!(back.max_amplitude.is_infinite());
}

/// The noise claim by brute force over θ: with the worst noise v for each
/// e (v = −LᵀPe/σ), V' + αV − σ|v|² = eᵀ(He{P(A − LC)} + αP + PLLᵀP/σ)e,
/// so that matrix must be negative semidefinite at every sampled θ
/// (evaluated balanced, like [`sampled_worst`]).
#[test]
fn global_noise_claim_holds_at_sampled_parameters() {
    let m = three_tank();
    let d = noise_min(&m, 0.9, None);
    assert!(d.certifies(), "{}", d.summary);
    let sigma = d.noise.as_ref().expect("bound").sigma;
    let p = d.p_matrix();
    let ls = d.l_matrices();
    let dz = StateScaling::of_p(&p).expect("balances").d;
    let dm = DMatrix::from_diagonal(&DVector::from_vec(dz.clone()));
    let pz = &dm * &p * &dm;
    let mut worst = f64::NEG_INFINITY;
    for th in sample_thetas(&m, 4000) {
        let mut l = DMatrix::zeros(m.nx(), m.ny());
        for (w, li) in m.mu(&th).iter().zip(&ls) {
            l += li * *w;
        }
        let f = &p * (m.a_at(&th) - &l * m.c_at(&th));
        let pl = &p * &l;
        let mat = &f + f.transpose() + &p * d.alpha + &pl * pl.transpose() / sigma;
        let mz = &dm * mat * &dm;
        worst = worst.max(mz.symmetric_eigenvalues().max() / pz.norm());
    }
    assert!(worst <= 1e-9, "worst normalised eigenvalue {worst:e}");
}

#[test]
fn sampled_global_noise_min_certifies_the_discrete_claim() {
    let m = three_tank();
    let d = noise_min(&m, 0.1, Some(0.01));
    assert!(d.certifies() && d.global, "{}", d.summary);
    let nb = d.noise.as_ref().expect("a noise bound");
    assert!(nb.max_amplitude.is_infinite() && nb.check.passed);
    assert!(d.summary.contains("GLOBAL at"), "{}", d.summary);
}

fn run_sampled(m: &PolytopicModel, alpha: AlphaSpec, h: f64) -> Design {
    let r = qpv_dsl::DesignRequest {
        sample: Some(h),
        ..qpv_solve::request(alpha, GammaSpec::Search, Mode::Sound)
    };
    design(m, &r, &Settings::default()).expect("design runs")
}

/// The worst per-step ratio V(e⁺)/V(e) of the Euler error map
/// e⁺ = (I + h(A(θ) − L(θ)C(θ)))e, in the balanced coordinates of P (an
/// exact congruence): at every θ of `thetas`, over `n_e` random e and the
/// exact maximiser over e (the largest generalised eigenvalue of
/// (Mᵀ P M, P), M the step matrix).
fn worst_step_ratio(
    m: &PolytopicModel,
    d: &Design,
    h: f64,
    thetas: &[Vec<f64>],
    n_e: usize,
) -> (f64, f64) {
    let p = d.p_matrix();
    let ls = d.l_matrices();
    let dz = StateScaling::of_p(&p)
        .map(|s| s.d)
        .unwrap_or_else(|| vec![1.0; m.nx()]);
    let dm = DMatrix::from_diagonal(&DVector::from_vec(dz.clone()));
    let dinv = DMatrix::from_diagonal(&DVector::from_vec(dz.iter().map(|v| 1.0 / v).collect()));
    let pz = &dm * &p * &dm;
    let chol = pz.clone().cholesky().expect("P ≻ 0");
    let linv = chol.l().try_inverse().expect("invertible");
    let mut state: u64 = 0x2545_f491_4f6c_dd1d;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let (mut random, mut exact) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    for th in thetas {
        let mu = m.mu(th);
        let mut l = DMatrix::zeros(m.nx(), m.ny());
        for (w, li) in mu.iter().zip(&ls) {
            l += li * *w;
        }
        let fz = &dinv * (m.a_at(th) - l * m.c_at(th)) * &dm;
        let step = DMatrix::identity(m.nx(), m.nx()) + fz * h;
        for _ in 0..n_e {
            let e = DVector::from_fn(m.nx(), |_, _| next());
            let ep = &step * &e;
            random = random.max(ep.dot(&(&pz * &ep)) / e.dot(&(&pz * &e)));
        }
        // max_e V(Me)/V(e) = σ_max(Lᵀ M L⁻ᵀ)² for P = LLᵀ.
        let n = chol.l().transpose() * &step * linv.transpose();
        exact = exact.max(n.singular_values().max().powi(2));
    }
    (random, exact)
}

#[test]
fn three_tank_sampled_certifies_globally_and_the_euler_map_decreases() {
    let m = three_tank();
    let h = 0.01;
    let mut thetas = sample_thetas(&m, 300);
    thetas.extend(m.vertices.iter().map(|v| v.theta.clone()));
    for alpha in [AlphaSpec::Fixed(0.15), AlphaSpec::Max] {
        let d = run_sampled(&m, alpha, h);
        assert!(d.certifies(), "{alpha:?}: {}", d.summary);
        assert!(d.global);
        assert!(d.summary.contains("GLOBAL") && d.summary.contains("S5d"));
        let families: Vec<&str> = d.margins.keys().map(|f| f.name()).collect();
        assert_eq!(families, ["S1", "S5d"]);
        assert!(d.data_checks.is_empty(), "no S4 for a global design");
        if alpha == AlphaSpec::Fixed(0.15) {
            assert_eq!(d.alpha, 0.15);
        } else {
            assert!(d.alpha > 0.15, "α = {}", d.alpha);
            assert!(h * d.alpha < 1.0);
        }
        let (p, l) = (d.p_matrix(), d.l_matrices());
        let at = Candidate {
            sample: Some(h),
            ..Candidate::new(d.alpha, 1.0)
        };
        let cert = check(&m, &Gains::new(&p, &l), &at, Mode::Sound);
        assert!(cert.passed, "{alpha:?}: independent S5d check");
        // The discrete decrease implies the continuous one for the same
        // (P, L): He{PF} + αP ⪯ −h FᵀPF ⪯ 0.
        let cont = check(
            &m,
            &Gains::new(&p, &l),
            &Candidate::new(d.alpha, 1.0),
            Mode::Sound,
        );
        assert!(cont.passed, "{alpha:?}: the continuous G5 at the same α");
        // Brute force on the Euler error map at random θ and e.
        let bound = 1.0 - h * d.alpha;
        let (random, exact) = worst_step_ratio(&m, &d, h, &thetas, 20);
        assert!(
            random <= bound * (1.0 + 1e-9),
            "{alpha:?}: random e: {random} > {bound}"
        );
        assert!(
            exact <= bound * (1.0 + 1e-9),
            "{alpha:?}: worst e: {exact} > {bound}"
        );
        // The worst θ is a vertex (the step is affine in θ's weights), where
        // the exact ratio is the one the capacity computes.
        let gammas: Vec<DMatrix<f64>> = l.iter().map(|li| &p * li).collect();
        let cap = qpv_solve::certificate::alpha_capacity_sampled(
            &qpv_solve::model::global_model(&m),
            1.0,
            h,
            &p,
            &gammas,
        );
        eprintln!(
            "{alpha:?}: α = {}, 1 − hα = {bound}, brute force random {random}, worst {exact}, capacity {cap}, max ‖L‖ = {:e}",
            d.alpha,
            d.gain_norms.iter().copied().fold(0.0, f64::max)
        );
        assert!(
            cap >= d.alpha * (1.0 - 1e-9),
            "capacity {cap} < α {}",
            d.alpha
        );
        assert!(
            (exact - (1.0 - h * cap)).abs() <= 1e-7,
            "{alpha:?}: brute-force worst {exact} vs capacity 1 − hα_c = {}",
            1.0 - h * cap
        );
        // A claim beyond the capacity is rejected.
        let over = Candidate {
            sample: Some(h),
            ..Candidate::new(cap + 0.05, 1.0)
        };
        assert!(!check(&m, &Gains::new(&p, &l), &over, Mode::Sound).passed);
    }
}

/// The Euler-step figure of a global design (§15 on the global model,
/// checked in the coordinates that balance P): present for three-tank at
/// α = 0.9, and at that step the Euler map contracts V by (1 − hβ) at
/// sampled θ, while at 4× the step it fails somewhere.
#[test]
fn the_euler_step_of_a_global_design_is_certified_and_tight() {
    let m = three_tank();
    let d = run(&m, AlphaSpec::Fixed(0.9));
    assert!(d.certifies(), "{}", d.summary);
    let s = d.sampling.clone().expect("the Euler-step figures");
    assert!(s.max_step_euler > 0.0 && s.beta == 0.45, "{s:?}");
    let p = d.p_matrix();
    let ls = d.l_matrices();
    let dz = StateScaling::of_p(&p).expect("balances").d;
    let dm = DMatrix::from_diagonal(&DVector::from_vec(dz.clone()));
    let dinv = DMatrix::from_diagonal(&DVector::from_vec(dz.iter().map(|v| 1.0 / v).collect()));
    let pz = &dm * &p * &dm;
    let worst_at = |h: f64| -> f64 {
        let mut worst = f64::NEG_INFINITY;
        let mut thetas = sample_thetas(&m, 2000);
        thetas.extend(m.vertices.iter().map(|v| v.theta.clone()));
        for th in thetas {
            let mut l = DMatrix::zeros(m.nx(), m.ny());
            for (w, li) in m.mu(&th).iter().zip(&ls) {
                l += li * *w;
            }
            let fz = &dinv * (m.a_at(&th) - &l * m.c_at(&th)) * &dm;
            let step = DMatrix::identity(m.nx(), m.nx()) + fz * h;
            let mat = step.transpose() * &pz * &step - &pz * (1.0 - h * s.beta);
            worst = worst.max(mat.symmetric_eigenvalues().max() / pz.norm());
        }
        worst
    };
    assert!(
        worst_at(s.max_step_euler) <= 1e-12,
        "{}",
        worst_at(s.max_step_euler)
    );
    assert!(
        worst_at(4.0 * s.max_step_euler) > 0.0,
        "the step is not tight"
    );
}

/// Near the plant's own decay (α = 0.1 on three-tank: the x2 and x3 modes
/// decay at 0.03, V at twice that) the gain-objective pilot's P is
/// degenerate and the units it balances by certify nothing; the design is
/// solved again in the model's own units and certifies, with a note.
#[test]
fn a_fixed_alpha_the_pilot_units_miss_certifies_in_the_model_units() {
    let m = three_tank();
    let d = run(&m, AlphaSpec::Fixed(0.1));
    assert!(d.certifies() && d.global, "{}", d.summary);
    assert_eq!(d.alpha, 0.1);
    assert!(
        d.notes
            .iter()
            .any(|n| n.to_string().contains("model's own units")),
        "{:?}",
        d.notes
    );
    let worst = sampled_worst(&m, &d, &sample_thetas(&m, 400));
    assert!(worst < 0.0, "sampled λ_max/‖P‖ = {worst:e}");
}
