//! The RMS-optimal design (`noise = rms`) on the paper's example: it
//! certifies, its RMS bound is recomputed from P and L_l by the certificate
//! and is tight (0.9× of it fails), a forged bound is rejected, and a
//! Monte-Carlo Euler–Maruyama run with white output noise stays under it.

use nalgebra::DMatrix;
use qpv_dsl::{AlphaSpec, DesignRequest, GammaSpec, Mode, NoiseObjective};
use qpv_solve::certificate::rms::{rms_bound, RmsBound};
use qpv_solve::conditions::reference::paper_model;
use qpv_solve::simulate::Scenario;
use qpv_solve::{design, request, Design, Settings};
use std::sync::OnceLock;

const GAMMA: f64 = 0.18898;
/// 1 % of the paper's output range (about 0.04), per noise sample.
const STD: f64 = 4e-4;
/// The noise samples' period.
const DT: f64 = 1e-3;

fn rms_request(alpha: AlphaSpec) -> DesignRequest {
    DesignRequest {
        noise: NoiseObjective::Rms,
        output_std: vec![STD],
        noise_period: Some(DT),
        ..request(alpha, GammaSpec::Fixed(GAMMA), Mode::Sound)
    }
}

/// The RMS design at γ_max with no minimum rate, solved once.
fn rms_design() -> &'static Design {
    static D: OnceLock<Design> = OnceLock::new();
    D.get_or_init(|| {
        design(
            &paper_model(),
            &rms_request(AlphaSpec::Max),
            &Settings::default(),
        )
        .unwrap()
    })
}

#[test]
fn paper_rms_design_certifies_and_rechecks() {
    let d = rms_design();
    assert!(d.certifies(), "{}", d.summary);
    let b = d
        .rms
        .as_ref()
        .expect("a certified RMS design carries its bound");
    assert!(d.alpha > 0.0 && b.total > 0.0 && b.per_state.len() == 3);
    // Per-state bounds never exceed the total, and the total is at most
    // the root of the sum of the per-state squares.
    let sum_sq: f64 = b.per_state.iter().map(|v| v * v).sum();
    assert!(b.total <= sum_sq.sqrt() * (1.0 + 1e-12));
    assert!(b.per_state.iter().all(|&v| v <= b.total * (1.0 + 1e-12)));
    let cert = d.recheck(&paper_model());
    assert!(cert.passed, "{cert:?}");
    assert!(cert.data_checks["rms"].passed);
    // The report's bound is the certificate's own recomputation (on the
    // observer's model: the symmetric split applied).
    let obs = d.observer_model(&paper_model()).unwrap();
    let again = rms_bound(&obs, &b.noise, d.gamma, &d.p_matrix(), &d.l_matrices()).unwrap();
    assert!((again.total - b.total).abs() <= 1e-12 * b.total);
}

/// A report whose RMS claims are scaled by `f`.
fn scaled(d: &Design, f: f64, total: bool, state: Option<usize>) -> Design {
    let mut forged = d.clone();
    let b: &mut RmsBound = forged.rms.as_mut().unwrap();
    if total {
        b.total *= f;
    }
    if let Some(k) = state {
        b.per_state[k] *= f;
    }
    forged
}

#[test]
fn rms_bound_is_tight_and_forgeries_fail() {
    let d = rms_design();
    let model = paper_model();
    let obs = d.observer_model(&model).unwrap();
    // 0.9× the total, or 0.9× any one state's bound: not certified.
    assert!(!scaled(d, 0.9, true, None).recheck(&model).passed);
    for k in 0..3 {
        let c = scaled(d, 0.9, false, Some(k)).recheck(&model);
        assert!(!c.passed && !c.data_checks["rms"].passed, "state {k}");
    }
    // A looser claim is still certified (a bound, not an equality).
    assert!(scaled(d, 1.1, true, Some(0)).recheck(&model).passed);
    // Tightness of the vertex inequality itself: with κ scaled by 0.9 some
    // block of He{P F} + I/κ' is no longer negative semidefinite, so the
    // bound κ·c cannot be lowered by that factor from these gains.
    let b = d.rms.as_ref().unwrap();
    let (p, l) = (d.p_matrix(), d.l_matrices());
    let gammas: Vec<DMatrix<f64>> = l.iter().map(|li| &p * li).collect();
    let mut worst = f64::NEG_INFINITY;
    for c in qpv_solve::conditions::rate_combos(&obs) {
        let np = obs.region.vertices.len();
        for i in 0..np {
            for j in 0..np {
                let s = qpv_solve::certificate::combo_lmi(
                    &obs,
                    Mode::Sound,
                    qpv_solve::vocab::Candidate::new(0.0, d.gamma),
                    &p,
                    &gammas,
                    &c,
                    (i, j),
                );
                let m = s / d.gamma + DMatrix::identity(3, 3) / (0.9 * b.kappa);
                worst = worst.max(m.symmetric_eigenvalues().max());
            }
        }
    }
    assert!(worst > 0.0, "κ·0.9 still satisfies every block: {worst}");
}

#[test]
fn rms_request_errors_are_reported() {
    let model = paper_model();
    let mut r = rms_request(AlphaSpec::Max);
    r.output_std = vec![STD, STD, STD];
    let e = design(&model, &r, &Settings::default()).unwrap_err();
    assert!(e.to_string().contains("3 values of output_std"), "{e}");
    let mut r = rms_request(AlphaSpec::Max);
    r.noise_period = None;
    let e = design(&model, &r, &Settings::default()).unwrap_err();
    assert!(e.to_string().contains("noise_period"), "{e}");
    let mut r = rms_request(AlphaSpec::Max);
    r.sample = Some(1e-3);
    let e = design(&model, &r, &Settings::default()).unwrap_err();
    assert!(e.to_string().contains("sample"), "{e}");
}

/// A Gaussian sample (Box–Muller on splitmix64), the same on every platform.
struct Rng(u64);

impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn gauss(&mut self) -> f64 {
        let u = self.uniform().max(1e-300);
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * self.uniform()).cos()
    }
}

/// Euler–Maruyama: plant and observer stepped at the noise period with one
/// Gaussian sample of std [`STD`] per output and step (held over it:
/// intensity STD²·DT), x̂(0) = x(0) (the steady state from the start), θ(t)
/// of the paper's scenario; the time-averaged E[e_k²] over t ∈ [2, T],
/// averaged over `runs` seeds.
fn simulated_ms(d: &Design, runs: u64, t_end: f64) -> Vec<f64> {
    use qpv_solve::simulate::{observer_derivative, plant_derivative, plant_output};
    let model = paper_model();
    let obs = d.observer_model(&model).unwrap();
    let l = d.l_matrices();
    let scenario = Scenario::paper(&model);
    let steps = (t_end / DT).round() as usize;
    let mut ms = [0.0; 3];
    let mut count = 0usize;
    for seed in 0..runs {
        let mut rng = Rng(seed + 1);
        let mut x = vec![0.01, -0.005, 0.008];
        let mut xh = x.clone();
        for k in 0..steps {
            let t = k as f64 * DT;
            let theta: Vec<f64> = scenario.theta.iter().map(|s| s.at(t)).collect();
            let mut y = plant_output(&model, &x, &theta).unwrap();
            y.iter_mut().for_each(|v| *v += STD * rng.gauss());
            let dx = plant_derivative(&model, &x, &[], &theta).unwrap();
            let dxh = observer_derivative(&obs, &l, &xh, &y, &[], &theta).unwrap();
            for i in 0..3 {
                x[i] += DT * dx[i];
                xh[i] += DT * dxh[i];
            }
            if t >= 2.0 {
                for i in 0..3 {
                    ms[i] += (x[i] - xh[i]).powi(2);
                }
                count += 1;
            }
        }
    }
    ms.iter().map(|v| v / count as f64).collect()
}

#[test]
fn monte_carlo_stays_under_the_rms_bound() {
    let d = rms_design();
    let b = d.rms.as_ref().unwrap();
    let ms = simulated_ms(d, 4, 12.0);
    let total: f64 = ms.iter().sum();
    assert!(
        total.sqrt() <= b.total,
        "simulated RMS {} above the certified {}",
        total.sqrt(),
        b.total
    );
    for (k, (m, bk)) in ms.iter().zip(&b.per_state).enumerate() {
        assert!(m.sqrt() <= *bk, "state {k}: simulated {} > {bk}", m.sqrt());
    }
    // The noise does get through: the run measures something.
    assert!(total.sqrt() > 1e-3 * b.total, "{total}");
}
