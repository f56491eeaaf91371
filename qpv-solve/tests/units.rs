//! Results do not depend on the units a model is written in
//! (docs/method.md §5, "Units"): the same plant with its states rescaled (x_new = s_i x_i)
//! certifies the same α.

use nalgebra::{DMatrix, DVector};
use qpv_dsl::{PolytopicModel, Region, StateBound};
use qpv_solve::certificate::Gains;
use qpv_solve::vocab::Candidate;
use qpv_solve::{check, design, Design, Settings};

/// The plant in new units x_new,i = s_i x_i, written out independently of
/// the library: with x = S⁻¹ x_new, A → S A S⁻¹, row k of the quadratic
/// term xᵀN_k x → s_k (S⁻¹N_kS⁻¹), B → S B, C → C S⁻¹, M_k → S⁻¹M_kS⁻¹,
/// the region's vertices → S x, its facets → S⁻¹ a, Q → S Q S.
fn rescale(model: &PolytopicModel, s: &[f64]) -> PolytopicModel {
    let n = model.nx();
    assert_eq!(s.len(), n);
    let sm = DMatrix::from_diagonal(&DVector::from_column_slice(s));
    let si = DMatrix::from_diagonal(&DVector::from_iterator(n, s.iter().map(|v| 1.0 / v)));
    let mut out = model.clone();
    for v in &mut out.vertices {
        v.a = &sm * &v.a * &si;
        v.n =
            v.n.iter()
                .enumerate()
                .map(|(k, nk)| &si * nk * &si * s[k])
                .collect();
        v.b = &sm * &v.b;
        v.c = &v.c * &si;
        v.m = v.m.iter().map(|mk| &si * mk * &si).collect();
    }
    out.region = Region {
        vertices: model.region.vertices.iter().map(|x| &sm * x).collect(),
        facets: model.region.facets.iter().map(|a| &si * a).collect(),
        generators: model.region.generators.iter().map(|g| &sm * g).collect(),
    };
    if let StateBound::Given(q) = &model.state_bound {
        out.state_bound = StateBound::Given(&sm * q * &sm);
    }
    out.noise.b_w = model.noise.b_w.iter().map(|b| &sm * b).collect();
    out
}

fn example(src: &str) -> PolytopicModel {
    qpv_dsl::parse(src).expect("example parses")[0].polytopic()
}

fn run(model: &PolytopicModel, i: usize) -> Design {
    design(model, &model.designs[i], &Settings::default()).expect("design runs")
}

/// The gains of the rescaled plant in the original units: P = S P_new S,
/// L_l = S⁻¹ L_new,l (x_new = S x).
fn gains_back(d: &Design, s: &[f64]) -> (DMatrix<f64>, Vec<DMatrix<f64>>) {
    let sm = DMatrix::from_diagonal(&DVector::from_column_slice(s));
    let si = DMatrix::from_diagonal(&DVector::from_iterator(s.len(), s.iter().map(|v| 1.0 / v)));
    let p = &sm * d.p_matrix() * &sm;
    let l = d.l_matrices().iter().map(|l| &si * l).collect();
    (p, l)
}

/// The acceptance test of the units section: the paper's example and two
/// others, rescaled by 10^±6 (uniformly, and per state for the paper),
/// certify the same α within 0.1 %; the gains designed in the new units,
/// taken back to the original units, pass the certificate there (where
/// no scaling is involved).
#[test]
fn rescaled_models_certify_the_same_alpha() {
    let mut arrh = example(include_str!("../../examples/arrhenius_reactor.qpv"));
    arrh.designs[0].alpha = qpv_dsl::AlphaSpec::Max;
    let cases = [
        (example(include_str!("../../examples/paper.qpv")), 1),
        (
            example(include_str!("../../examples/lotka_volterra.qpv")),
            0,
        ),
        (arrh, 0),
    ];
    for (m, i) in &cases {
        let base = run(m, *i);
        assert!(base.certifies(), "{}: {}", m.name, base.summary);
        assert!(
            !base
                .notes
                .iter()
                .map(ToString::to_string)
                .any(|n| n.contains("balanced coordinates")),
            "{}: a well-scaled model is solved as written",
            m.name
        );
        let n = m.nx();
        let mut scales: Vec<Vec<f64>> = vec![vec![1e-6; n], vec![1e6; n]];
        if n == 3 {
            scales.push(vec![1e-6, 1.0, 1e6]);
        }
        for s in scales {
            let scaled = rescale(m, &s);
            let d = run(&scaled, *i);
            assert!(d.certifies(), "{} at {s:?}: {}", m.name, d.summary);
            let rel = (d.alpha / base.alpha - 1.0).abs();
            assert!(
                rel < 1e-3,
                "{} at {s:?}: α = {} against {} unscaled",
                m.name,
                d.alpha,
                base.alpha
            );
            assert!(
                d.notes
                    .iter()
                    .map(ToString::to_string)
                    .any(|n| n.contains("balanced coordinates")),
                "{} at {s:?}: {:?}",
                m.name,
                d.notes
            );
            // Re-checked through the report, in the new units ...
            assert!(d.recheck(&scaled).passed, "{} at {s:?}", m.name);
            // ... and in the original units.
            let (p, l) = gains_back(&d, &s);
            let c = check(
                &m.with_split(d.split),
                &Gains::new(&p, &l),
                &Candidate::new(d.alpha, d.gamma),
                d.mode,
            );
            assert!(c.passed, "{} at {s:?}: {:?}", m.name, c.margins());
        }
    }
}

/// The certificate does not depend on the units either: a design of the
/// paper's example, written in units 10^±10 times smaller or larger, passes
/// at its α and fails at twice its capacity, as in the original units.
#[test]
fn certificate_is_unit_independent() {
    let written = example(include_str!("../../examples/paper.qpv"));
    let d = run(&written, 1);
    assert!(d.certifies());
    // The representation of N_k the design was certified with.
    let m = written.with_split(d.split);
    let cap = qpv_solve::certificate::alpha_capacity(
        &m,
        d.mode,
        d.gamma,
        &d.p_matrix(),
        &d.l_matrices()
            .iter()
            .map(|l| d.p_matrix() * l)
            .collect::<Vec<_>>(),
    );
    assert!(
        cap >= d.alpha * (1.0 - 1e-6),
        "capacity {cap} < α {}",
        d.alpha
    );
    for e in [-10, 10] {
        let s = vec![10f64.powi(e); 3];
        let scaled = rescale(&m, &s);
        // x_new = S x: P_new = S⁻¹ P S⁻¹, L_new = S L.
        let inv: Vec<f64> = s.iter().map(|v| 1.0 / v).collect();
        let (p, _) = gains_back(&d, &inv);
        let l: Vec<DMatrix<f64>> = d.l_matrices().iter().map(|l| l * s[0]).collect();
        let ok = check(
            &scaled,
            &Gains::new(&p, &l),
            &Candidate::new(d.alpha, d.gamma),
            d.mode,
        );
        assert!(ok.passed, "1e{e}: {:?}", ok.margins());
        let bad = check(
            &scaled,
            &Gains::new(&p, &l),
            &Candidate::new(2.0 * cap, d.gamma),
            d.mode,
        );
        assert!(!bad.passed, "1e{e}: twice the capacity passes");
        assert!(bad.family("S5").is_some_and(|f| !f.passed));
    }
}

/// The change of coordinates is exact and only applied where needed.
#[test]
fn state_scaling_is_exact_and_only_for_badly_scaled_regions() {
    use qpv_solve::model::StateScaling;
    let m = example(include_str!("../../examples/paper.qpv"));
    assert_eq!(StateScaling::of(&m, qpv_dsl::Mode::Sound), None);
    let scaled = rescale(&m, &[1e-6, 1.0, 1e6]);
    assert_eq!(StateScaling::of(&scaled, qpv_dsl::Mode::Paper), None);
    let sc = StateScaling::of(&scaled, qpv_dsl::Mode::Sound).expect("scaled");
    for d in &sc.d {
        assert_eq!(d.log2().fract(), 0.0, "a power of two: {d}");
    }
    let z = sc.model(&scaled).expect("exact");
    // Every state's extent is now within a factor √2 of 1.
    for w in StateScaling::half_widths(&z.region, 3) {
        assert!((0.7..=1.42).contains(&w), "half-width {w}");
    }
    // P ↦ DPD ↦ P is exact.
    let p = DMatrix::from_fn(3, 3, |r, c| 1.0 / (1.0 + r as f64 + c as f64));
    let pz = sc.p_to_z(&p).expect("exact");
    assert_eq!(sc.p_from_z(&pz), p);
    // An entry that would overflow refuses the transformation.
    let huge = DMatrix::from_element(3, 3, f64::MAX);
    assert!(sc.p_to_z(&huge).is_none());
}
