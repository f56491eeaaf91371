//! The simulator: reference right-hand sides against hand-computed values,
//! RK4 accuracy against closed-form solutions, and the paper's scenario.

use nalgebra::{DMatrix, DVector};
use qpv_dsl::{PolytopicModel, StateBound, Vertex};
use qpv_solve::conditions::reference::{box_region, names, paper_a, paper_model, paper_n, param};
use qpv_solve::simulate::{
    observer_derivative, plant_derivative, plant_output, simulate, simulate_each, MeasurementNoise,
    NoiseEnvelope, Scenario, Signal, SimError,
};

/// A scalar model x' = a(θ) x + b u, y = x, with θ ∈ [0, 1] and
/// a(0) = a0, a(1) = a1.
fn scalar_model(a0: f64, a1: f64, b: f64, nu: usize) -> PolytopicModel {
    let vertex = |t: f64, a: f64| Vertex {
        theta: vec![t],
        a: DMatrix::from_element(1, 1, a),
        n: vec![DMatrix::zeros(1, 1)],
        b: DMatrix::from_element(1, nu, b),
        c: DMatrix::from_element(1, 1, 1.0),
        m: vec![DMatrix::zeros(1, 1)],
    };
    PolytopicModel {
        name: "scalar".to_string(),
        states: names("x", 1),
        inputs: names("u", nu),
        input_rates: vec![],
        input_ranges: vec![],
        outputs: names("y", 1),
        params: vec![param("theta", 0.0, 1.0)],
        scheduling: vec![0],
        vertices: vec![vertex(0.0, a0), vertex(1.0, a1)],
        region: box_region(1, 1.0),
        state_bound: StateBound::None,
        designs: vec![],
        noise: Default::default(),
        derived: Vec::new(),
        cover: None,
        time_unit: Default::default(),
        jacobian: None,
    }
}

fn zero_gains(model: &PolytopicModel) -> Vec<DMatrix<f64>> {
    vec![DMatrix::zeros(model.nx(), model.ny()); model.nv()]
}

fn assert_close(got: &[f64], want: &[f64], tol: f64) {
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(want) {
        assert!((g - w).abs() <= tol, "got {got:?}, want {want:?}");
    }
}

#[test]
fn plant_derivative_matches_hand_computed_paper_values() {
    let model = paper_model();
    let x = [0.01, -0.02, 0.005];
    let theta = [0.3, 0.7];
    let dx = plant_derivative(&model, &x, &[], &theta).unwrap();
    // computed by hand (outside this code) from the paper's scenario formulas (docs/method.md §14)
    assert_close(&dx, &[-0.22631, 0.03416, -0.03498], 1e-14);

    // and against A(θ), N_k(θ) evaluated directly (no vertex interpolation)
    let (a, n) = (paper_a(0.3, 0.7), paper_n(0.3, 0.7));
    let xv = DVector::from_row_slice(&x);
    let direct: Vec<f64> = (0..3)
        .map(|k| (a.row(k) * &xv)[0] + xv.dot(&(&n[k] * &xv)))
        .collect();
    assert_close(&dx, &direct, 1e-15);
}

#[test]
fn plant_output_matches_hand_computed_paper_values() {
    let model = paper_model();
    let y = plant_output(&model, &[0.01, -0.02, 0.005], &[0.3, 0.7]).unwrap();
    // y1 = x1 + x2 x3, y2 = x2 + x1 x3
    assert_close(&y, &[0.0099, -0.01995], 1e-16);
}

#[test]
fn observer_derivative_matches_hand_computed_paper_values() {
    let model = paper_model();
    let base = DMatrix::from_row_slice(3, 2, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    let gains: Vec<DMatrix<f64>> = (1..=4).map(|l| &base * l as f64).collect();
    let y = [0.0099, -0.01995];
    let xhat = [0.002, 0.001, -0.003];
    let d = observer_derivative(&model, &gains, &xhat, &y, &[], &[0.3, 0.7]).unwrap();
    assert_close(&d, &[-0.0869639, -0.1481782, -0.1804356], 1e-14);
}

#[test]
fn derivatives_reject_wrong_sizes_and_nan() {
    let model = paper_model();
    let theta = [0.3, 0.7];
    assert!(matches!(
        plant_derivative(&model, &[0.0; 2], &[], &theta),
        Err(SimError::Length {
            expected: 3,
            got: 2,
            ..
        })
    ));
    assert!(matches!(
        plant_derivative(&model, &[f64::NAN, 0.0, 0.0], &[], &theta),
        Err(SimError::NotFinite { .. })
    ));
    assert!(matches!(
        plant_output(&model, &[0.0; 3], &[0.5]),
        Err(SimError::Length { .. })
    ));
    let gains = vec![DMatrix::zeros(3, 2); 3];
    assert!(matches!(
        observer_derivative(&model, &gains, &[0.0; 3], &[0.0; 2], &[], &theta),
        Err(SimError::Length {
            expected: 4,
            got: 3,
            ..
        })
    ));
    let gains = vec![DMatrix::zeros(2, 3); 4];
    assert!(matches!(
        observer_derivative(&model, &gains, &[0.0; 3], &[0.0; 2], &[], &theta),
        Err(SimError::Shape { .. })
    ));
    let mut broken = model.clone();
    broken.vertices.pop();
    assert!(matches!(
        plant_derivative(&broken, &[0.0; 3], &[], &theta),
        Err(SimError::Model(_))
    ));
}

#[test]
fn rk4_matches_exponential_decay_with_fourth_order_accuracy() {
    // x' = -x: θ fixed at 0 picks a(0) = -1
    let model = scalar_model(-1.0, -1.0, 0.0, 0);
    let run = |dt: f64| {
        let scenario = Scenario {
            theta: vec![Signal::Constant(0.0)],
            u: vec![],
            x0: vec![1.0],
            xhat0: vec![1.0],
            t_end: 1.0,
            dt,
        };
        let traj = simulate(&model, &zero_gains(&model), &scenario).unwrap();
        assert_eq!(traj.t.len(), (1.0 / dt).round() as usize + 1);
        assert_eq!(*traj.t.last().unwrap(), 1.0);
        (traj.x.last().unwrap()[0] - (-1.0f64).exp()).abs()
    };
    let (coarse, fine) = (run(0.1), run(0.05));
    assert!(coarse < 1e-6, "error {coarse}");
    let order = (coarse / fine).log2();
    assert!((order - 4.0).abs() < 0.2, "observed order {order}");
    assert!(run(1e-3) < 1e-13);
}

#[test]
fn rk4_samples_theta_at_stage_times() {
    // x' = -θ(t) x with θ(t) = t: x(t) = exp(-t²/2). Sampling θ only at the
    // start of each step would make the method first order.
    let model = scalar_model(0.0, -1.0, 0.0, 0);
    let scenario = Scenario {
        theta: vec![Signal::custom(|t| t)],
        u: vec![],
        x0: vec![1.0],
        xhat0: vec![0.0],
        t_end: 1.0,
        dt: 0.01,
    };
    let traj = simulate(&model, &zero_gains(&model), &scenario).unwrap();
    let err = (traj.x.last().unwrap()[0] - (-0.5f64).exp()).abs();
    assert!(err < 1e-10, "error {err}");
    assert_close(traj.theta.last().unwrap(), &[1.0], 1e-15);
    assert_close(traj.mu.last().unwrap(), &[0.0, 1.0], 1e-15);
}

#[test]
fn rk4_samples_input_at_stage_times() {
    // x' = -x + cos t, x(0) = 0: x(t) = (cos t + sin t − e^{−t}) / 2
    let model = scalar_model(-1.0, -1.0, 1.0, 1);
    let scenario = Scenario {
        theta: vec![Signal::Constant(0.5)],
        u: vec![Signal::Cos {
            offset: 0.0,
            amplitude: 1.0,
            omega: 1.0,
            phase: 0.0,
        }],
        x0: vec![0.0],
        xhat0: vec![0.0],
        t_end: 2.0,
        dt: 0.01,
    };
    let traj = simulate(&model, &zero_gains(&model), &scenario).unwrap();
    let t: f64 = 2.0;
    let exact = 0.5 * (t.cos() + t.sin() - (-t).exp());
    let err = (traj.x.last().unwrap()[0] - exact).abs();
    assert!(err < 1e-10, "error {err}");
}

#[test]
fn observer_without_gain_started_on_the_state_stays_on_it() {
    let model = paper_model();
    let mut scenario = Scenario::paper(&model);
    scenario.xhat0 = scenario.x0.clone();
    let traj = simulate(&model, &zero_gains(&model), &scenario).unwrap();
    assert_eq!(traj.diverged_at, None);
    assert_eq!(traj.len(), 2001);
    assert!(traj.error_norm.iter().all(|&e| e == 0.0));
    // the state itself moves
    assert!(traj.x.last().unwrap() != &scenario.x0);
    assert_eq!(traj.error_below(1e-12), Some(0.0));
}

#[test]
fn paper_scenario_follows_spec_section_7() {
    let model = paper_model();
    let s = Scenario::paper(&model);
    assert_eq!(s.x0, vec![-0.02; 3]);
    assert_eq!(s.xhat0, vec![0.0; 3]);
    assert_eq!((s.t_end, s.dt), (2.0, 1e-3));
    let t: f64 = 0.37;
    let pi = std::f64::consts::PI;
    assert_close(
        &[s.theta[0].at(t), s.theta[1].at(t)],
        &[
            0.5 + 0.5 * (4.0 * pi * t).sin(),
            0.5 + 0.5 * (pi * t / 5.0 + pi / 6.0).cos(),
        ],
        1e-15,
    );
}

#[test]
fn default_scenario_sweeps_the_box_from_a_region_vertex() {
    let model = paper_model();
    let s = Scenario::default_for(&model);
    assert_eq!(
        s.x0,
        model.region.vertices[0].iter().copied().collect::<Vec<_>>()
    );
    let samples: Vec<f64> = (0..2000).map(|k| s.theta[1].at(k as f64 * 1e-3)).collect();
    let (lo, hi) = samples
        .iter()
        .fold((f64::MAX, f64::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    assert!(lo < 0.01 && hi > 0.99 && lo >= 0.0 && hi <= 1.0);
    let traj = simulate(&model, &zero_gains(&model), &s).unwrap();
    assert_eq!(traj.len(), 2001);
}

#[test]
fn divergence_is_reported_not_panicked() {
    // x' = x² (N = 1) from x(0) = 1 blows up at t = 1
    let mut model = scalar_model(0.0, 0.0, 0.0, 0);
    for v in &mut model.vertices {
        v.n[0][(0, 0)] = 1.0;
    }
    let scenario = Scenario {
        theta: vec![Signal::Constant(0.0)],
        u: vec![],
        x0: vec![1.0],
        xhat0: vec![0.0],
        t_end: 3.0,
        dt: 0.01,
    };
    let traj = simulate(&model, &zero_gains(&model), &scenario).unwrap();
    let at = traj.diverged_at.expect("x' = x² must blow up");
    assert!(at > 0.9 && at < 1.2, "diverged at {at}");
    assert!(traj.x.iter().flatten().all(|v| v.is_finite()));
    assert_eq!(traj.error_below(1e-6), None);

    // a NaN parameter signal stops the run as well
    let mut nan = scenario.clone();
    nan.theta = vec![Signal::custom(|t| if t > 0.5 { f64::NAN } else { 0.0 })];
    let traj = simulate(
        &scalar_model(-1.0, -1.0, 0.0, 0),
        &vec![DMatrix::zeros(1, 1); 2],
        &nan,
    )
    .unwrap();
    let at = traj.diverged_at.unwrap();
    assert!((0.49..=0.51).contains(&at), "stopped at {at}");
}

#[test]
fn invalid_time_grids_are_errors() {
    let model = scalar_model(-1.0, -1.0, 0.0, 0);
    let gains = zero_gains(&model);
    let mut s = Scenario::default_for(&model);
    for (t_end, dt) in [
        (1.0, 0.0),
        (1.0, f64::NAN),
        (f64::INFINITY, 0.1),
        (-1.0, 0.1),
        (1e9, 1e-9),
    ] {
        s.t_end = t_end;
        s.dt = dt;
        assert!(matches!(
            simulate(&model, &gains, &s),
            Err(SimError::TimeGrid(_))
        ));
    }
    s.t_end = 0.0;
    s.dt = 0.1;
    let traj = simulate(&model, &gains, &s).unwrap();
    assert_eq!(traj.t, vec![0.0]);
}

#[test]
fn error_below_finds_the_last_crossing() {
    let model = scalar_model(-1.0, -1.0, 0.0, 0);
    let scenario = Scenario {
        theta: vec![Signal::Constant(0.0)],
        u: vec![],
        x0: vec![1.0],
        xhat0: vec![0.0],
        t_end: 5.0,
        dt: 0.01,
    };
    // L = 0: the error is e^{-t}, below 0.1 from t = ln 10 on
    let traj = simulate(&model, &zero_gains(&model), &scenario).unwrap();
    let t = traj.error_below(0.1).unwrap();
    assert!((t - 10f64.ln()).abs() <= 0.01, "t = {t}");
    assert_eq!(traj.error_below(1e-9), None);
    assert_eq!(traj.error_below(f64::NAN), None);
    assert_eq!(traj.error_below(2.0), Some(0.0));
}

#[test]
fn csv_has_a_header_and_one_row_per_step() {
    let model = paper_model();
    let mut scenario = Scenario::paper(&model);
    scenario.t_end = 0.01;
    let traj = simulate(&model, &zero_gains(&model), &scenario).unwrap();
    let mut buf = Vec::new();
    // The one trajectory writer, `qpv simulate --plot`'s: the model's names
    // and the outputs y between the inputs and the weights.
    traj.write_csv(&model, &mut buf).unwrap();
    let text = String::from_utf8(buf).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0],
        "t,x1,x2,x3,xhat1,xhat2,xhat3,theta1,theta2,y1,y2,mu1,mu2,mu3,mu4,error_norm"
    );
    assert_eq!(lines.len(), traj.len() + 1);
    let first: Vec<f64> = lines[1].split(',').map(|c| c.parse().unwrap()).collect();
    assert_eq!(first.len(), 16);
    assert_eq!(&first[1..4], &[-0.02; 3]);
    assert!((first[15] - 0.02 * 3f64.sqrt()).abs() < 1e-15);
    let json = serde_json::to_string(&traj).unwrap();
    assert!(json.contains("\"error_norm\""));
}

#[test]
fn lyapunov_values_follow_the_error() {
    // x' = −x, L = 0: e(t) = e(0) e^{−t}, so V = 3 e(0)² e^{−2t} for P = 3
    let model = scalar_model(-1.0, -1.0, 0.0, 0);
    let scenario = Scenario {
        theta: vec![Signal::Constant(0.0)],
        u: vec![],
        x0: vec![0.5],
        xhat0: vec![0.0],
        t_end: 1.0,
        dt: 0.01,
    };
    let traj = simulate(&model, &zero_gains(&model), &scenario).unwrap();
    let v = traj.lyapunov(&DMatrix::from_element(1, 1, 3.0)).unwrap();
    assert_eq!(v.len(), traj.len());
    for (t, v) in traj.t.iter().zip(&v) {
        let want = 0.75 * (-2.0 * t).exp();
        assert!((v - want).abs() < 1e-9, "t = {t}: {v} vs {want}");
    }
    assert_eq!(traj.lyapunov(&DMatrix::identity(2, 2)), None);
}

fn parse_one(src: &str) -> PolytopicModel {
    let models = qpv_dsl::parse(src).unwrap();
    assert_eq!(models.len(), 1);
    models[0].polytopic()
}

#[test]
fn parsed_paper_example_simulates_like_the_hand_built_model() {
    let parsed = parse_one(include_str!("../../examples/paper.qpv"));
    let model = paper_model();
    assert_eq!(parsed.vertices.len(), 4);
    for (p, m) in parsed.vertices.iter().zip(&model.vertices) {
        assert_eq!((&p.theta, &p.a, &p.n), (&m.theta, &m.a, &m.n));
        assert_eq!((&p.c, &p.m), (&m.c, &m.m));
    }
    assert_eq!(parsed.state_bound, model.state_bound);

    let base = DMatrix::from_row_slice(3, 2, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    let gains: Vec<DMatrix<f64>> = (1..=4).map(|l| &base * l as f64).collect();
    let a = simulate(&parsed, &gains, &Scenario::paper(&parsed)).unwrap();
    let b = simulate(&model, &gains, &Scenario::paper(&model)).unwrap();
    assert_eq!(a, b);
}

#[test]
fn every_example_model_runs_its_default_scenario() {
    for src in [
        include_str!("../../examples/paper.qpv"),
        include_str!("../../examples/paper_equations.qpv"),
        include_str!("../../examples/lorenz.qpv"),
        include_str!("../../examples/lotka_volterra.qpv"),
        include_str!("../../examples/van_de_vusse.qpv"),
    ] {
        for model in qpv_dsl::parse(src).unwrap() {
            let p = model.polytopic();
            let traj = simulate(&p, &zero_gains(&p), &Scenario::default_for(&p)).unwrap();
            assert!(!traj.is_empty(), "{}", p.name);
            assert_eq!(traj.x[0], Scenario::default_for(&p).x0, "{}", p.name);
            if traj.diverged_at.is_none() {
                assert_eq!(traj.len(), 2001, "{}", p.name);
            }
        }
    }
}

/// The streamed run hands out exactly the rows `simulate` records, and a
/// callback that says stop ends the run there.
#[test]
fn the_streamed_run_is_the_recorded_one() {
    let model = paper_model();
    let gains = vec![DMatrix::from_element(3, 2, 0.5); model.nv()];
    let mut sc = Scenario::paper(&model);
    sc.t_end = 0.3;
    let traj = simulate(&model, &gains, &sc).unwrap();
    let mut rows = Vec::new();
    let diverged = simulate_each(&model, &gains, &sc, None, &mut |r| {
        rows.push((
            r.t,
            r.x.to_vec(),
            r.xhat.to_vec(),
            r.mu.to_vec(),
            r.error_norm,
        ));
        true
    })
    .unwrap();
    assert_eq!(diverged, traj.diverged_at);
    assert_eq!(rows.len(), traj.len());
    for (i, (t, x, xhat, mu, e)) in rows.iter().enumerate() {
        assert_eq!(*t, traj.t[i]);
        assert_eq!(x, &traj.x[i]);
        assert_eq!(xhat, &traj.xhat[i]);
        assert_eq!(mu, &traj.mu[i]);
        assert_eq!(*e, traj.error_norm[i]);
    }
    let mut seen = 0;
    simulate_each(&model, &gains, &sc, None, &mut |_| {
        seen += 1;
        seen < 5
    })
    .unwrap();
    assert_eq!(seen, 5);
}

/// Measurement noise has norm ν on its outputs and is zero elsewhere; the
/// same seed gives the same noise, and the observer feels it.
#[test]
fn measurement_noise_has_its_amplitude_on_its_outputs() {
    let mut a = MeasurementNoise::new(7, 0.3, vec![1, 2]);
    let mut b = MeasurementNoise::new(7, 0.3, vec![1, 2]);
    for _ in 0..100 {
        let v = a.sample(4);
        assert_eq!(v, b.sample(4));
        assert!(v[0] == 0.0 && v[3] == 0.0, "{v:?}");
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!((norm - 0.3).abs() < 1e-12, "{norm}");
    }
    let model = paper_model();
    let gains = vec![DMatrix::from_element(3, 2, 0.5); model.nv()];
    let mut sc = Scenario::paper(&model);
    sc.t_end = 0.1;
    let clean = simulate(&model, &gains, &sc).unwrap();
    let mut last = 0.0;
    let mut noise = MeasurementNoise::new(1, 1e-2, vec![0, 1]);
    simulate_each(&model, &gains, &sc, Some(&mut noise), &mut |r| {
        last = r.error_norm;
        true
    })
    .unwrap();
    let clean_last = *clean.error_norm.last().unwrap();
    assert!(last != clean_last, "{last} vs {clean_last}");
}

/// The certified bound under noise starts at √(V(0)/λ_min(P)) and tends to
/// ν times the bound's error bound per unit amplitude.
#[test]
fn the_noise_envelope_runs_from_v0_to_the_ultimate_bound() {
    let p = DMatrix::from_diagonal(&DVector::from_vec(vec![2.0, 4.0]));
    let bound = qpv_solve::certificate::noise::NoiseBound {
        sigma: 1.0,
        max_amplitude: 1.0,
        error_bound: 0.5,
        per_state: vec![0.5, 0.25],
        noisy_outputs: vec!["y".into()],
        disturbances: 0,
        check: qpv_solve::certificate::noise::NoiseCheck {
            margin: 1.0,
            guard: 0.0,
            passed: true,
            worst_at: String::new(),
            count: 1,
        },
    };
    let env = NoiseEnvelope::new(&p, &[0.0, 1.0], 3.0, &bound, 0.2).unwrap();
    // V(0) = 4, λ_min = 2: √2 at t = 0; ν · 0.5 = 0.1 at the end.
    assert!((env.at(0.0) - 2f64.sqrt()).abs() < 1e-15);
    assert!((env.ultimate() - 0.1).abs() < 1e-15);
    assert!((env.at(50.0) - 0.1).abs() < 1e-12);
    assert!(env.at(0.1) < env.at(0.0) && env.at(0.1) > env.at(1.0));
    assert!(NoiseEnvelope::new(&(-p), &[0.0, 1.0], 3.0, &bound, 0.2).is_none());
}
