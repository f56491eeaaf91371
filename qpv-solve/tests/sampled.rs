//! `sample = h`: the discrete decrease family (docs/method.md §16) — the
//! sampled α against the continuous one, the continuous design's certified
//! Euler step against the discrete certificate, a brute-force check on the
//! true Euler error map, and the report's re-check.

use qpv_dsl::{AlphaSpec, GammaSpec, Mode, PolytopicModel, Split};
use qpv_solve::certificate::sampling::SampleInfo;
use qpv_solve::conditions::reference::paper_model;
use qpv_solve::falsify::falsify_design;
use qpv_solve::{design, Design, Settings};

/// γ_max of the paper example (docs/method.md §14).
const GAMMA: f64 = 0.18898;

fn req(alpha: AlphaSpec, gamma: f64, sample: Option<f64>) -> qpv_dsl::DesignRequest {
    let mut r = qpv_solve::request(alpha, GammaSpec::Fixed(gamma), Mode::Sound);
    r.split = Split::Symmetric;
    r.within = 0.0;
    r.sample = sample;
    r
}

fn example(name: &str, src: &str) -> PolytopicModel {
    qpv_dsl::parse(src)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .remove(0)
        .polytopic()
}

/// As h → 0 the sampled α_max approaches the continuous α_max from below;
/// it falls as h grows; every sampled design re-checks through its report
/// on S5d, and its gains also pass the continuous certificate at its α (the
/// discrete block implies He{PF} + αP ⪯ −h FᵀPF, docs/method.md §16).
#[test]
fn sampled_alpha_approaches_the_continuous_alpha_from_below() {
    let model = paper_model();
    let s = Settings::default();
    let tol = s.bisection_rel_tol;
    let cont = design(&model, &req(AlphaSpec::Max, GAMMA, None), &s).unwrap();
    assert!(cont.certifies(), "{}", cont.summary);
    let mut alphas = Vec::new();
    for h in [1e-4, 1e-3, 1e-2] {
        let d = design(&model, &req(AlphaSpec::Max, GAMMA, Some(h)), &s).unwrap();
        assert!(d.certifies(), "h = {h}: {}", d.summary);
        assert!(d.summary.starts_with("CERTIFIED at h = "), "{}", d.summary);
        let sample = d.sample.expect("a sampled design reports its period");
        assert_eq!(sample.h, h);
        assert!((sample.decrease - (1.0 - h * d.alpha)).abs() < 1e-15);
        let cert = d.recheck(&model);
        assert!(cert.passed, "h = {h}: {cert:?}");
        assert!(cert.family("S5d").is_some() && cert.family("S5").is_none());
        assert!(d.margins.contains_key("S5d"), "{:?}", d.margins);
        // The same gains, read as a continuous design, certify at α.
        let as_continuous = Design {
            sample: None,
            alpha: d.alpha * (1.0 - 1e-3),
            ..d.clone()
        };
        assert!(as_continuous.recheck(&model).passed, "h = {h}");
        assert!(
            d.alpha <= cont.alpha * (1.0 + tol),
            "h = {h}: sampled α {} above the continuous α {}",
            d.alpha,
            cont.alpha
        );
        alphas.push(d.alpha);
    }
    // h → 0: within 0.5 % of the continuous α at h = 1e-4.
    assert!(
        alphas[0] >= cont.alpha * (1.0 - 5e-3),
        "{alphas:?} vs {}",
        cont.alpha
    );
    // and falling with h (each to the bisection tolerance)
    for w in alphas.windows(2) {
        assert!(w[1] <= w[0] * (1.0 + tol), "{alphas:?}");
    }
    assert!(alphas[2] < alphas[0] * (1.0 - tol), "{alphas:?}");
}

/// The continuous design's certified Euler step (`sampling.max_step_euler`,
/// computed by the sampling module's own bisection with β = α/2) is where
/// the independent discrete certificate's S5d at α/2 changes sign: the
/// continuous gains pass it at h* and fail it 1 % above.
#[test]
fn continuous_gains_pass_the_discrete_certificate_at_their_euler_step() {
    let model = paper_model();
    let s = Settings::default();
    let cont = design(&model, &req(AlphaSpec::Fixed(10.0), GAMMA, None), &s).unwrap();
    assert!(cont.certifies(), "{}", cont.summary);
    let sm = cont
        .sampling
        .clone()
        .expect("a certified design has sampling figures");
    assert_eq!(sm.beta, 5.0);
    let at = |h: f64| Design {
        alpha: sm.beta,
        sample: Some(SampleInfo::new(h, sm.beta)),
        ..cont.clone()
    };
    let pass = at(sm.max_step_euler).recheck(&model);
    assert!(pass.passed, "{pass:?}");
    let fail = at(sm.max_step_euler * 1.01).recheck(&model);
    assert!(!fail.passed, "{fail:?}");
    assert!(!fail.family("S5d").unwrap().passed);
    // (S1)-(S4) do not depend on h
    for f in ["S1", "S2", "S3"] {
        assert!(fail.family(f).unwrap().passed, "{f}");
    }
}

/// The discrete certificate against the true Euler error map, sampled:
/// (θ, e, x) ∈ Θ × E × F, e⁺ = e + h·e'(e, x, θ), V(e⁺)/V(e) never above
/// 1 − hα (20 000 samples per plant; three plants, one with a θ-dependent
/// output map on the double sum).
#[test]
fn the_true_euler_error_map_never_exceeds_the_certified_decrease() {
    let s = Settings::default();
    let cases: Vec<(&str, PolytopicModel, f64, f64, f64)> = vec![
        ("paper", paper_model(), 8.0, GAMMA, 0.02),
        (
            "lotka_volterra",
            example("lotka", include_str!("../../examples/lotka_volterra.qpv")),
            1.0,
            0.3,
            0.05,
        ),
        (
            "varying_output",
            example("varying", include_str!("../../examples/varying_output.qpv")),
            0.3,
            0.33,
            0.1,
        ),
    ];
    for (name, model, alpha, gamma, h) in cases {
        let d = design(&model, &req(AlphaSpec::Fixed(alpha), gamma, Some(h)), &s).unwrap();
        assert!(d.certifies(), "{name}: {}", d.summary);
        let f = falsify_design(&model, &d, 20_000, 11).unwrap();
        assert_eq!(f.samples + f.skipped, 20_000, "{name}");
        assert!(f.samples > 19_000, "{name}");
        assert!(f.passed(), "{name}: {:?}", f.worst);
        assert!(f.worst_ratio < 0.0 && f.worst_ratio.is_finite(), "{name}");
        // A claim no Lyapunov function can meet is caught (hα > 1: the
        // decrease factor is negative), so the ratio is live.
        let impossible = Design {
            alpha: 1.5 / h,
            ..d.clone()
        };
        assert!(!falsify_design(&model, &impossible, 2_000, 11)
            .unwrap()
            .passed());
    }
}

/// The report round-trips through JSON with its `sample` key, and the
/// re-check reads h from it: a tampered h fails.
#[test]
fn the_report_carries_the_sample_and_the_recheck_uses_it() {
    let model = paper_model();
    let s = Settings::default();
    let d = design(&model, &req(AlphaSpec::Fixed(10.0), GAMMA, Some(1e-2)), &s).unwrap();
    assert!(d.certifies(), "{}", d.summary);
    assert!(d.noise.is_none() && d.sampling.is_none());
    let json = d.to_json();
    assert!(json.contains("\"sample\""), "{json}");
    let back = Design::from_json(&json).unwrap();
    assert_eq!(back.sample, d.sample);
    assert!(back.recheck(&model).passed);
    let mut tampered = back.clone();
    tampered.sample = Some(SampleInfo::new(0.05, 10.0));
    let cert = tampered.recheck(&model);
    assert!(!cert.passed, "{cert:?}");
    assert!(cert.input_errors.is_empty(), "{cert:?}");
    assert!(!cert.family("S5d").unwrap().passed, "{cert:?}");
}

/// Infeasible at the rate: a fixed α beyond what the discrete decrease
/// certifies at h is a failure whose note names the largest α certified at
/// that h; that α certifies as a fixed request at the same h.
#[test]
fn a_rate_beyond_the_sample_period_says_what_certifies_there() {
    let model = paper_model();
    let s = Settings::default();
    let h = 0.03;
    let d = design(&model, &req(AlphaSpec::Fixed(12.3), GAMMA, Some(h)), &s).unwrap();
    assert!(!d.certifies(), "{}", d.summary);
    assert!(
        d.summary.starts_with("NOT CERTIFIED at h = 3e-2 s"),
        "{}",
        d.summary
    );
    let note = d
        .notes
        .iter()
        .map(ToString::to_string)
        .find(|n| n.starts_with("not certified at h = 3e-2 s"))
        .unwrap_or_else(|| panic!("{:?}", d.notes));
    let key = "the largest α certified at this h and γ = 0.188980 is ";
    let at = note.find(key).unwrap_or_else(|| panic!("{note}")) + key.len();
    let alpha: f64 = note[at..]
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(alpha > 0.0 && alpha < 12.3, "{note}");
    let ok = design(&model, &req(AlphaSpec::Fixed(alpha), GAMMA, Some(h)), &s).unwrap();
    assert!(ok.certifies(), "{}", ok.summary);
    // The period at which the asked α certifies, and the failed one just
    // above it: a design at the first certifies, at the second does not.
    let key = "α = 12.3 certifies at the shorter period h = ";
    let at = note.find(key).unwrap_or_else(|| panic!("{note}")) + key.len();
    let h_ok: f64 = note[at..]
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let key = " and fails at ";
    let at = note.find(key).unwrap_or_else(|| panic!("{note}")) + key.len();
    let h_fail: f64 = note[at..]
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        h_ok < h_fail && h_fail <= h && h_fail / h_ok <= 1.1 * (1.0 + 1e-3),
        "{note}"
    );
    let ok = design(&model, &req(AlphaSpec::Fixed(12.3), GAMMA, Some(h_ok)), &s).unwrap();
    assert!(ok.certifies(), "at h = {h_ok}: {}", ok.summary);
}

/// `noise = min` at the sample period (docs/method.md §16, "Noise at the
/// sample period"): the design minimises σ of the discrete claim
/// V(e⁺) − (1 − hα)V(e) ≤ hσ(|w|² + |v|²); the independent check of the
/// block LMI passes at the reported σ and fails at 0.9σ (σ is the least for
/// these gains), and brute-force sampling of the true Euler error map with
/// noise (20 000 draws: (θ, e, x) ∈ Θ × E × F, the noise the worst case or
/// anywhere in a ball of twice ν_max) never exceeds it; a claim of σ/100 is
/// caught, so the sampler is live.
#[test]
fn the_sampled_noise_bound_holds_on_the_euler_error_map() {
    use qpv_solve::analysis::noise::falsify_noise;
    use qpv_solve::certificate::noise_sampled::SampledNoise;
    use qpv_solve::model::noise::NoiseChannels;
    let s = Settings::default();
    let cases: Vec<(&str, PolytopicModel, f64, f64, f64)> = vec![
        ("paper", paper_model(), 5.0, GAMMA, 1e-2),
        (
            "lotka_volterra",
            example("lotka", include_str!("../../examples/lotka_volterra.qpv")),
            1.0,
            0.3,
            0.05,
        ),
    ];
    for (name, model, alpha, gamma, h) in cases {
        let mut r = req(AlphaSpec::Fixed(alpha), gamma, Some(h));
        r.noise = qpv_dsl::NoiseObjective::Min;
        let d = design(&model, &r, &s).unwrap();
        assert!(d.certifies(), "{name}: {}", d.summary);
        assert!(
            d.summary.starts_with("CERTIFIED at h = "),
            "{name}: {}",
            d.summary
        );
        assert!(d.margins.contains_key("S5d"), "{name}: {:?}", d.margins);
        let nb = d.noise.clone().expect("a noise bound");
        assert!(nb.check.passed && nb.sigma > 0.0, "{name}: {nb:?}");
        let ch = NoiseChannels::from_model(&model);
        let obs = d.observer_model(&model).unwrap();
        let (p, l) = (d.p_matrix(), d.l_matrices());
        let gammas: Vec<_> = l.iter().map(|li| &p * li).collect();
        let claim = SampledNoise {
            model: &obs,
            channels: &ch,
            alpha,
            gamma: d.gamma,
            h,
        };
        assert!(claim.check(&p, &gammas, nb.sigma).passed, "{name}");
        assert!(!claim.check(&p, &gammas, 0.9 * nb.sigma).passed, "{name}");
        let f = falsify_noise(&model, &d, &ch, 20_000, 7).unwrap();
        assert!(f.samples > 19_000, "{name}: {}", f.samples);
        assert!(f.passed(), "{name}: {:?}", f.worst);
        let mut tampered = d.clone();
        if let Some(n) = tampered.noise.as_mut() {
            n.sigma /= 100.0;
        }
        let f = falsify_noise(&model, &tampered, &ch, 20_000, 7).unwrap();
        assert!(!f.passed(), "{name}: σ/100 not caught ({})", f.worst_ratio);
    }
}

/// The continuous-plant bound with noise (docs/method.md §16): on the
/// paper's noise-optimal design at h = 1e-3, the report carries ν_c and the
/// noise term, and the worst-case recursion b⁺ = √(ρ²b² + hσν²) + δ from
/// b = 1 (the certified set's edge) stays in {b ≤ 1} at ν_c and settles
/// below δ/(1 − ρ) + ν√(σ/α); above ν_c it leaves the set.
#[test]
fn the_continuous_bound_with_noise_adds_the_two_bounds() {
    let (alpha, h) = (5.0, 1e-3);
    let mut r = req(AlphaSpec::Fixed(alpha), GAMMA, Some(h));
    r.noise = qpv_dsl::NoiseObjective::Min;
    let d = design(&paper_model(), &r, &Settings::default()).unwrap();
    assert!(d.certifies(), "{}", d.summary);
    let nb = d.noise.clone().expect("a noise bound");
    let b = d
        .sample
        .and_then(|s| s.continuous_bound)
        .expect("a continuous-plant bound");
    assert!(b.invariant, "{b:?}");
    let nu_c = b.noise_amplitude_max.expect("ν_c");
    assert!(nu_c > 0.0 && nu_c < nb.max_amplitude, "ν_c = {nu_c}");
    assert_eq!(b.noise_per_unit, Some(nb.error_bound));
    let rho2 = 1.0 - h * alpha;
    let run = |nu: f64| -> (f64, f64) {
        let (mut v, mut top) = (1.0f64, 1.0f64);
        for _ in 0..200_000 {
            v = (rho2 * v * v + h * nb.sigma * nu * nu).sqrt() + b.delta;
            top = top.max(v);
        }
        (v, top)
    };
    for nu in [nu_c, 0.5 * nu_c] {
        let (end, top) = run(nu);
        assert!(top <= 1.0 + 1e-12, "ν = {nu}: left the set ({top})");
        let bound = b.ultimate_v_sqrt + nu * (nb.sigma / alpha).sqrt();
        assert!(end <= bound * (1.0 + 1e-9), "ν = {nu}: {end} > {bound}");
    }
    let (_, top) = run(1.1 * nu_c);
    assert!(
        top > 1.0,
        "ν = 1.1 ν_c stays inside: ν_c is not the largest"
    );
}
