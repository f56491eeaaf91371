//! The baseline a practitioner would run instead of qpv (docs/baseline.md),
//! measured side by side with the qpv observer: a continuous-discrete EKF
//! (benches/ekf/filter.rs) on the models of the language, against the
//! observer of the file's first sound design (designed here with
//! `qpv::solve::design`).
//!
//! Per plant: N initial errors e(0) uniform in the region, one plant
//! trajectory (x(0) the region's first vertex, scaled into the state bound
//! F if needed; θ(t) of `Scenario::default_for`; u = 0), and three noise
//! conditions on the outputs: none, and Gaussian white noise (one sample per
//! step dt, held over the step by the continuous qpv observer, the EKF's
//! measurement) of standard deviation 1 % and 5 % of each output's range
//! over the region. Every filter sees the same plant trajectory, θ(t) and
//! noise samples. The EKF is tuned as a practitioner would: P0 = diag(h²),
//! R = diag(σ²) (the 1 % σ in the noise-free runs), Q_d = q·dt·diag(h²)
//! with q = 1e-4 and the "perfect model" q = 1e-6, h the region's
//! half-widths.
//!
//! Reported per filter: the median (and largest) time until the relative
//! error r(t) = ‖diag(h)⁻¹ e(t)‖/√nx first drops to 1 % (noise-free runs),
//! the runs with r(t_end) ≤ 1 % (noise-free), the RMS of r after the
//! transient (t ≥ the plant's `rms_from`) at 1 % and 5 % noise, and the
//! wall time per step of each filter in Rust (RK4 as simulated, and one
//! Euler step of the mean), μ(θ) given. For qpv, whether its certificate
//! V(t) ≤ V(0)·e^{−αt} (V = eᵀPe) held in every noise-free run.
//!
//! After each table, the `noise = rms` design at each noise level
//! (benches/ekf/rms.rs): its design time, certified RMS bound and simulated
//! RMS on the same runs.
//!
//! `cargo bench --bench ekf` (500 initial errors per plant;
//! `-- --runs N` for another count; `-- FILE.qpv ...` for other models).

use qpv::dsl::{Mode, PolytopicModel, StateBound};
use qpv::solve::simulate::Scenario;
use qpv::solve::{design, Settings};
use std::hint::black_box;
use std::time::Instant;

#[path = "ekf/filter.rs"]
mod filter;
use filter::{rk4, Ekf, Frozen, Mat, Qpv, Vector};
#[path = "ekf/rms.rs"]
mod rms;

/// splitmix64: uniform and Gaussian samples, the same on every platform.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn uniform(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal (Box–Muller).
    fn gauss(&mut self) -> f64 {
        let u = 1.0 - self.uniform();
        let v = self.uniform();
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// One plant of the table: its file, the step and the run's length, and
/// the time from which the RMS error is taken.
struct Case {
    file: String,
    dt: f64,
    t_end: f64,
    rms_from: f64,
}

/// The noise conditions: none, then σ = level × each output's range.
const LEVELS: [f64; 3] = [0.0, 0.01, 0.05];
/// The EKF's process-noise intensities q (Q_d = q·dt·diag(h²)).
const QS: [f64; 2] = [1e-4, 1e-6];
/// "Converged": the relative error reached this level.
const TOL: f64 = 0.01;

/// What one plant's measurement needs, shared by the runs.
struct Setup<const NX: usize, const NY: usize> {
    name: String,
    alpha: f64,
    p: Mat<NX, NX>,
    /// Region half-widths h and its bounding box's centre.
    h: Vector<NX>,
    centre: Vector<NX>,
    facets: Vec<Vector<NX>>,
    /// Each output's range over the region.
    range: Vector<NY>,
    x0: Vector<NX>,
    q_inv: Option<Mat<NX, NX>>,
    /// The plant's and the observer's model frozen at t_k and t_k + dt/2
    /// (index 2k and 2k + 1).
    plant: Vec<Frozen<NX, NY>>,
    obs: Vec<Frozen<NX, NY>>,
    /// The two models, and μ(θ) of each on the same grid (for the timing).
    pq: Qpv<NX, NY>,
    oq: Qpv<NX, NY>,
    mu_plant: Vec<Vec<f64>>,
    mu_obs: Vec<Vec<f64>>,
    steps: usize,
    dt: f64,
    rms_from: f64,
}

/// The file's model and the observer of its first sound design: the
/// design, the observer model and its gains.
fn designed(file: &str) -> (PolytopicModel, qpv::solve::Design, PolytopicModel) {
    let text = std::fs::read_to_string(file).unwrap_or_else(|e| panic!("{file}: {e}"));
    let parsed = qpv::dsl::parse(&text).expect("the model parses").remove(0);
    let plant = parsed.polytopic();
    let req = parsed
        .designs
        .iter()
        .find(|d| d.mode == Mode::Sound)
        .expect("the file has a sound design request");
    let t0 = Instant::now();
    let d = design(&plant, req, &Settings::default()).expect("the design runs");
    eprintln!(
        "{}: designed in {:.1} s: α = {:.4}, γ = {:.4}, certified: {}",
        plant.name,
        t0.elapsed().as_secs_f64(),
        d.alpha,
        d.gamma,
        d.certifies()
    );
    let obs = d.observer_model(&plant).expect("the observer model");
    (plant, d, obs)
}

impl<const NX: usize, const NY: usize> Setup<NX, NY> {
    fn new(case: &Case) -> Self {
        let (plant, d, obs_model) = designed(&case.file);
        assert!(d.certifies(), "the design certifies nothing");
        let gains = d.l_matrices();
        let (pq, oq) = (
            Qpv::<NX, NY>::new(&plant, &[]),
            Qpv::new(&obs_model, &gains),
        );
        let region = &plant.region;
        let lo = Vector::<NX>::from_fn(|i, _| {
            region
                .vertices
                .iter()
                .map(|v| v[i])
                .fold(f64::INFINITY, f64::min)
        });
        let hi = Vector::<NX>::from_fn(|i, _| {
            region
                .vertices
                .iter()
                .map(|v| v[i])
                .fold(f64::NEG_INFINITY, f64::max)
        });
        let facets: Vec<Vector<NX>> = region
            .facets
            .iter()
            .map(|a| Vector::from_fn(|i, _| a[i]))
            .collect();
        let q_inv = match &plant.state_bound {
            StateBound::Given(q) => q
                .clone()
                .try_inverse()
                .map(|qi| Mat::from_fn(|i, j| qi[(i, j)])),
            _ => None,
        };
        let v0 = &region.vertices[0];
        let mut x0 = Vector::<NX>::from_fn(|i, _| v0[i]);
        if let Some(qi) = &q_inv {
            let s: f64 = x0.dot(&(qi * x0));
            if s > 0.5 {
                x0 *= (0.5 / s).sqrt();
            }
        }
        let scenario = Scenario::default_for(&plant);
        let steps = (case.t_end / case.dt).round() as usize;
        let (mut mu_plant, mut mu_obs) = (Vec::new(), Vec::new());
        for i in 0..=2 * steps {
            let t = 0.5 * case.dt * i as f64;
            let theta: Vec<f64> = scenario.theta.iter().map(|s| s.at(t)).collect();
            mu_plant.push(plant.mu(&theta));
            mu_obs.push(obs_model.mu(&theta));
        }
        let mut setup = Setup {
            name: plant.name.clone(),
            alpha: d.alpha,
            p: Mat::from_fn(|i, j| d.p_matrix()[(i, j)]),
            h: (hi - lo) * 0.5,
            centre: (hi + lo) * 0.5,
            facets,
            range: Vector::zeros(),
            x0,
            q_inv,
            plant: mu_plant.iter().map(|m| pq.at(m)).collect(),
            obs: mu_obs.iter().map(|m| oq.at(m)).collect(),
            mu_plant,
            mu_obs,
            pq,
            oq,
            steps,
            dt: case.dt,
            rms_from: case.rms_from,
        };
        setup.range = setup.output_range(&plant);
        setup
    }

    /// A point uniform in the region (rejection in its bounding box).
    fn draw_e(&self, rng: &mut Rng) -> Vector<NX> {
        loop {
            let e = Vector::<NX>::from_fn(|i, _| {
                self.centre[i] + self.h[i] * (2.0 * rng.uniform() - 1.0)
            });
            if self.facets.iter().all(|a| a.dot(&e) <= 1.0) {
                return e;
            }
        }
    }

    /// Each output's range (max − min) over the region and the parameter
    /// box, sampled (the region's vertices and 20 000 random points).
    fn output_range(&self, plant: &PolytopicModel) -> Vector<NY> {
        let mut rng = Rng(7);
        let (mut lo, mut hi) = (
            Vector::<NY>::repeat(f64::INFINITY),
            Vector::<NY>::repeat(f64::NEG_INFINITY),
        );
        let verts: Vec<Vector<NX>> = plant
            .region
            .vertices
            .iter()
            .map(|v| Vector::from_fn(|i, _| v[i]))
            .collect();
        for i in 0..20_000 + verts.len() {
            let x = verts
                .get(i)
                .copied()
                .unwrap_or_else(|| self.draw_e(&mut rng));
            let theta: Vec<f64> = plant
                .params
                .iter()
                .map(|p| p.lo + (p.hi - p.lo) * rng.uniform())
                .collect();
            let y = self.pq.at(&plant.mu(&theta)).h(&x);
            lo = lo.inf(&y);
            hi = hi.sup(&y);
        }
        hi - lo
    }

    /// r = ‖diag(h)⁻¹ e‖/√nx.
    fn rel(&self, e: &Vector<NX>) -> f64 {
        (e.component_div(&self.h).norm_squared() / NX as f64).sqrt()
    }
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let mut runs = 500;
    let mut files = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if a == "--runs" {
            runs = it.next().and_then(|n| n.parse().ok()).expect("--runs N");
        } else {
            files.push(a.clone());
        }
    }
    let cases: Vec<Case> = if files.is_empty() {
        vec![
            Case {
                file: "examples/paper.qpv".into(),
                dt: 1e-3,
                t_end: 3.0,
                rms_from: 1.5,
            },
            Case {
                file: "examples/lorenz.qpv".into(),
                dt: 1e-3,
                t_end: 8.0,
                rms_from: 4.0,
            },
            Case {
                file: "examples/lotka_volterra.qpv".into(),
                dt: 1e-3,
                t_end: 16.0,
                rms_from: 8.0,
            },
        ]
    } else {
        files
            .into_iter()
            .map(|file| Case {
                file,
                dt: 1e-3,
                t_end: 8.0,
                rms_from: 4.0,
            })
            .collect()
    };
    println!("{runs} initial errors per plant; r = ‖diag(h)⁻¹e‖/√nx (h: the region's half-widths)");
    for case in &cases {
        measure(case, runs);
    }
}

/// Dispatches on the model's size (add a size here for other models).
fn measure(case: &Case, runs: usize) {
    let text = std::fs::read_to_string(&case.file).expect("the model file");
    let m = qpv::dsl::parse(&text)
        .expect("parses")
        .remove(0)
        .polytopic();
    match (m.nx(), m.ny()) {
        (1, 1) => measure_sized::<1, 1>(case, runs),
        (2, 1) => measure_sized::<2, 1>(case, runs),
        (2, 2) => measure_sized::<2, 2>(case, runs),
        (3, 1) => measure_sized::<3, 1>(case, runs),
        (3, 2) => measure_sized::<3, 2>(case, runs),
        (3, 3) => measure_sized::<3, 3>(case, runs),
        (4, 1) => measure_sized::<4, 1>(case, runs),
        (4, 2) => measure_sized::<4, 2>(case, runs),
        (nx, ny) => panic!("nx = {nx}, ny = {ny}: add the size to `measure` in benches/ekf.rs"),
    }
}

/// One filter's run: Σ r² and the count after the transient, the first
/// time r ≤ [`TOL`] (∞ if never) and r at the end.
#[derive(Debug, Clone, Copy)]
struct RunStats {
    sum_sq: f64,
    count: usize,
    t_tol: f64,
    r_end: f64,
}

impl RunStats {
    const NEW: RunStats = RunStats {
        sum_sq: 0.0,
        count: 0,
        t_tol: f64::INFINITY,
        r_end: f64::NAN,
    };

    fn see(&mut self, t: f64, r: f64, after_transient: bool) {
        if after_transient {
            self.sum_sq += r * r;
            self.count += 1;
        }
        if r <= TOL && self.t_tol.is_infinite() {
            self.t_tol = t;
        }
        self.r_end = r;
    }
}

/// qpv's certificate along a run: the largest V(t)/(V(0)e^{−αt}), whether
/// it exceeded 1 (beyond rounding) and whether x left F (the premise).
#[derive(Debug, Clone, Copy)]
struct CertStats {
    worst: f64,
    violated: bool,
    left_f: bool,
}

/// The filters compared: qpv, then one EKF per q of [`QS`].
const FILTERS: usize = 1 + QS.len();

impl<const NX: usize, const NY: usize> Setup<NX, NY> {
    /// One run from e(0) = `e0` at the noise `level`: every filter's stats
    /// and qpv's certificate.
    fn run(&self, e0: Vector<NX>, level: f64, seed: u64) -> ([RunStats; FILTERS], CertStats) {
        self.run_traced(e0, level, seed, None)
    }

    /// [`Setup::run`], recording every filter's r(t) into `trace` if given.
    fn run_traced(
        &self,
        e0: Vector<NX>,
        level: f64,
        seed: u64,
        mut trace: Option<&mut Vec<(f64, [f64; FILTERS])>>,
    ) -> ([RunStats; FILTERS], CertStats) {
        let sigma = self.range * level;
        let rs = self.range * if level > 0.0 { level } else { 0.01 };
        let r = Mat::<NY, NY>::from_diagonal(&rs.component_mul(&rs));
        let h2 = Mat::<NX, NX>::from_diagonal(&self.h.component_mul(&self.h));
        let mut ekfs = QS.map(|q| Ekf {
            x: self.x0 - e0,
            p: h2,
            q: h2 * (q * self.dt),
            r,
        });
        let (mut x, mut xq) = (self.x0, self.x0 - e0);
        let v0 = e0.dot(&(self.p * e0));
        let mut stats = [RunStats::NEW; FILTERS];
        let mut cert = CertStats {
            worst: 0.0,
            violated: false,
            left_f: false,
        };
        let mut rng = Rng(seed);
        for k in 0..=self.steps {
            let t = k as f64 * self.dt;
            let v = Vector::<NY>::from_fn(|i, _| sigma[i] * rng.gauss());
            let now = &self.plant[2 * k];
            let y = now.h(&x) + v;
            for ekf in &mut ekfs {
                ekf.update(now, &y);
            }
            let eq = x - xq;
            let late = t >= self.rms_from;
            stats[0].see(t, self.rel(&eq), late);
            for (s, ekf) in stats[1..].iter_mut().zip(&ekfs) {
                s.see(t, self.rel(&(x - ekf.x)), late);
            }
            if let Some(tr) = trace.as_deref_mut() {
                let mut r = [self.rel(&eq); FILTERS];
                for (ri, ekf) in r[1..].iter_mut().zip(&ekfs) {
                    *ri = self.rel(&(x - ekf.x));
                }
                tr.push((t, r));
            }
            let bound = v0 * (-self.alpha * t).exp();
            let vt = eq.dot(&(self.p * eq));
            if k > 0 {
                cert.worst = cert.worst.max((vt - 1e-18 * v0) / bound);
            }
            // NaN counts as a violation
            cert.violated |= vt.is_nan() || vt > bound * (1.0 + 1e-6) + 1e-18 * v0;
            if let Some(qi) = &self.q_inv {
                cert.left_f |= x.dot(&(qi * x)) > 1.0;
            }
            if k == self.steps {
                break;
            }
            let (pm, om) = (&self.plant[2 * k..2 * k + 3], &self.obs[2 * k..2 * k + 3]);
            for ekf in &mut ekfs {
                ekf.predict([&pm[0], &pm[1], &pm[2]], self.dt);
            }
            (x, xq) = rk4_pair((pm, om), (&x, &xq), &v, self.dt);
        }
        (stats, cert)
    }

    /// The measurements of one run at 1 % noise (for the timing).
    fn measurements(&self) -> Vec<Vector<NY>> {
        let mut rng = Rng(99);
        let mut x = self.x0;
        let mut ys = Vec::with_capacity(self.steps);
        for k in 0..self.steps {
            let v = Vector::<NY>::from_fn(|i, _| 0.01 * self.range[i] * rng.gauss());
            ys.push(self.plant[2 * k].h(&x) + v);
            let pm = &self.plant[2 * k..2 * k + 3];
            x = rk4(&x, self.dt, |s, x| pm[s].f(x));
        }
        ys
    }
}

/// ns per step of a pass over n steps (best of 20 passes: the machine may
/// be shared).
fn ns_per_step(n: usize, mut pass: impl FnMut() -> f64) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..20 {
        let t0 = Instant::now();
        black_box(pass());
        best = best.min(t0.elapsed().as_nanos() as f64 / n as f64);
    }
    best
}

impl<const NX: usize, const NY: usize> Setup<NX, NY> {
    /// Wall ns per step of each filter on one run's measurements, μ(θ)
    /// given: `[qpv, EKF]` × `[RK4, Euler]` (the EKF with q = 1e-4; its
    /// cost does not depend on q).
    fn timing(&self) -> [[f64; 2]; 2] {
        let ys = self.measurements();
        let (n, dt) = (ys.len(), self.dt);
        let x0 = self.x0 - self.h * 0.5;
        let (mp, mo) = (&self.mu_plant, &self.mu_obs);
        let qpv_rk4 = ns_per_step(n, || {
            let mut x = x0;
            for (k, y) in ys.iter().enumerate() {
                let o = [
                    self.oq.at(&mo[2 * k]),
                    self.oq.at(&mo[2 * k + 1]),
                    self.oq.at(&mo[2 * k + 2]),
                ];
                x = rk4(&x, dt, |s, x| o[s].observer(x, black_box(y)));
            }
            x[0]
        });
        let qpv_euler = ns_per_step(n, || {
            let mut x = x0;
            for (k, y) in ys.iter().enumerate() {
                x += self.oq.at(&mo[2 * k]).observer(&x, black_box(y)) * dt;
            }
            x[0]
        });
        let h2 = Mat::<NX, NX>::from_diagonal(&self.h.component_mul(&self.h));
        let rs = self.range * 0.01;
        let fresh = || Ekf {
            x: x0,
            p: h2,
            q: h2 * (QS[0] * dt),
            r: Mat::from_diagonal(&rs.component_mul(&rs)),
        };
        let ekf_rk4 = ns_per_step(n, || {
            let mut ekf = fresh();
            for (k, y) in ys.iter().enumerate() {
                let p = [
                    self.pq.at(&mp[2 * k]),
                    self.pq.at(&mp[2 * k + 1]),
                    self.pq.at(&mp[2 * k + 2]),
                ];
                ekf.update(&p[0], black_box(y));
                ekf.predict([&p[0], &p[1], &p[2]], dt);
            }
            ekf.x[0]
        });
        let ekf_euler = ns_per_step(n, || {
            let mut ekf = fresh();
            for (k, y) in ys.iter().enumerate() {
                let p = self.pq.at(&mp[2 * k]);
                ekf.update(&p, black_box(y));
                ekf.predict_euler(&p, dt);
            }
            ekf.x[0]
        });
        [[qpv_rk4, qpv_euler], [ekf_rk4, ekf_euler]]
    }
}

/// The median and the largest of `v` (∞ entries count as large).
fn median_max(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[v.len() / 2], v[v.len() - 1])
}

/// Per noise level and filter: (Σ r², count, first times to 1 %, runs
/// converged), and qpv's certificate over the noise-free runs.
type Tally = Vec<[(f64, usize, Vec<f64>, usize); FILTERS]>;

fn measure_sized<const NX: usize, const NY: usize>(case: &Case, runs: usize) {
    let s = Setup::<NX, NY>::new(case);
    let mut tally: Tally = LEVELS
        .iter()
        .map(|_| std::array::from_fn(|_| (0.0, 0, Vec::new(), 0)))
        .collect();
    let (mut held, mut worst, mut left_f) = (0, 0.0f64, 0);
    let mut rng = Rng(0x5EED);
    let t0 = Instant::now();
    for run in 0..runs {
        let e0 = s.draw_e(&mut rng);
        for (li, &level) in LEVELS.iter().enumerate() {
            let (stats, cert) = s.run(e0, level, 1000 * run as u64 + li as u64);
            for (t, st) in tally[li].iter_mut().zip(&stats) {
                t.0 += st.sum_sq;
                t.1 += st.count;
                t.2.push(st.t_tol);
                t.3 += usize::from(st.r_end <= TOL);
            }
            if level == 0.0 {
                held += usize::from(!cert.violated);
                worst = worst.max(cert.worst);
                left_f += usize::from(cert.left_f);
            }
        }
    }
    let sim_s = t0.elapsed().as_secs_f64();
    figure(&s, &mut Rng(0x5EED));
    let cost = s.timing();
    print_table(&s, case, &tally, runs, (held, worst, left_f), cost);
    let rms_of = |li: usize, f: usize| (tally[li][f].0 / tally[li][f].1 as f64).sqrt();
    let rows: Vec<rms::RmsRow> = LEVELS[1..]
        .iter()
        .map(|&level| s.rms_row(case, level, runs))
        .collect();
    let ekf = [[rms_of(1, 1), rms_of(2, 1)], [rms_of(1, 2), rms_of(2, 2)]];
    rms::print_rms_rows(&rows, &ekf);
    eprintln!(
        "{}: {runs} × {} runs simulated in {sim_s:.1} s",
        s.name,
        LEVELS.len()
    );
}

/// One RK4 step of the plant and the qpv observer as one ODE, y(t) =
/// h(x(t)) + v held over the step: `pm`, `om` are the plant and the
/// observer frozen at the step's start, middle and end.
fn rk4_pair<const NX: usize, const NY: usize>(
    (pm, om): (&[Frozen<NX, NY>], &[Frozen<NX, NY>]),
    (x, xq): (&Vector<NX>, &Vector<NX>),
    v: &Vector<NY>,
    dt: f64,
) -> (Vector<NX>, Vector<NX>) {
    let g = |s: usize, x: &Vector<NX>, xq: &Vector<NX>| {
        (pm[s].f(x), om[s].observer(xq, &(pm[s].h(x) + v)))
    };
    let (a1, b1) = g(0, x, xq);
    let (a2, b2) = g(1, &(x + a1 * (0.5 * dt)), &(xq + b1 * (0.5 * dt)));
    let (a3, b3) = g(1, &(x + a2 * (0.5 * dt)), &(xq + b2 * (0.5 * dt)));
    let (a4, b4) = g(2, &(x + a3 * dt), &(xq + b3 * dt));
    (
        x + (a1 + a2 * 2.0 + a3 * 2.0 + a4) * (dt / 6.0),
        xq + (b1 + b2 * 2.0 + b3 * 2.0 + b4) * (dt / 6.0),
    )
}

/// The relative error r(t) of every filter on the first run at 1 % noise
/// (the first initial error the table's runs draw), as an SVG under
/// target/ekf-baseline/ (docs/baseline.md shows the paper plant's).
fn figure<const NX: usize, const NY: usize>(s: &Setup<NX, NY>, rng: &mut Rng) {
    let e0 = s.draw_e(rng);
    let mut trace = Vec::new();
    s.run_traced(e0, 0.01, 1, Some(&mut trace));
    let names = ["qpv".to_string()]
        .into_iter()
        .chain(QS.iter().map(|q| format!("EKF q={q:.0e}")));
    let series: Vec<qpv::plot::Series> = names
        .enumerate()
        .map(|(f, name)| {
            let every = (trace.len() / 600).max(1);
            let points = trace
                .iter()
                .step_by(every)
                .map(|(t, r)| (*t, r[f]))
                .collect();
            qpv::plot::Series::new(name, points, qpv::plot::PALETTE[f], f > 0)
        })
        .collect();
    let dir = std::path::Path::new("target/ekf-baseline");
    let path = dir.join(format!("{}.svg", s.name));
    let drawn = std::fs::create_dir_all(dir)
        .map_err(|e| e.to_string())
        .and_then(|_| {
            qpv::plot::line_chart(
                &path,
                &format!("{}: relative error at 1 % output noise, one run", s.name),
                "‖diag(h)⁻¹e‖/√nx",
                &series,
                true,
            )
        });
    match drawn {
        Ok(()) => eprintln!("figure: {}", path.display()),
        Err(e) => eprintln!("figure not drawn: {e}"),
    }
}

fn print_table<const NX: usize, const NY: usize>(
    s: &Setup<NX, NY>,
    case: &Case,
    tally: &Tally,
    runs: usize,
    (held, worst, left_f): (usize, f64, usize),
    cost: [[f64; 2]; 2],
) {
    let fmt_v = |v: &Vector<NY>| {
        v.iter()
            .map(|x| format!("{x:.3e}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    println!();
    println!(
        "{} (nx = {NX}, ny = {NY}): x(0) = [{}], dt = {}, t_end = {} s, RMS over t ≥ {} s; region half-widths h = [{}]; output range [{}]; qpv α = {:.4}",
        s.name,
        s.x0.iter().map(|x| format!("{x:.4}")).collect::<Vec<_>>().join(", "),
        case.dt,
        case.t_end,
        case.rms_from,
        s.h.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(", "),
        fmt_v(&s.range),
        s.alpha,
    );
    println!(
        "  {:<14} {:>11} {:>9} {:>9} {:>10} {:>10} {:>9} {:>9}",
        "filter", "t→1% med.", "max", "conv.", "RMS @1%", "RMS @5%", "ns RK4", "ns Euler"
    );
    let names = ["qpv".to_string()]
        .into_iter()
        .chain(QS.iter().map(|q| format!("EKF q={q:.0e}")));
    let rms = |li: usize, f: usize| (tally[li][f].0 / tally[li][f].1 as f64).sqrt();
    for (f, name) in names.enumerate() {
        let (med, max) = median_max(tally[0][f].2.clone());
        let c = cost[f.min(1)];
        println!(
            "  {name:<14} {:>9.3} s {:>7.3} s {:>5}/{runs} {:>10.3e} {:>10.3e} {:>9.0} {:>9.0}",
            med,
            max,
            tally[0][f].3,
            rms(1, f),
            rms(2, f),
            c[0],
            c[1]
        );
    }
    let ratios: Vec<String> = QS
        .iter()
        .enumerate()
        .map(|(i, q)| {
            let r = |li| rms(li, 0) / rms(li, 1 + i);
            format!("{:.2}× / {:.2}× (EKF q={q:.0e})", r(1), r(2))
        })
        .collect();
    println!(
        "  qpv's RMS ÷ the EKF's at 1 % / 5 %: {}",
        ratios.join(", ")
    );
    println!(
        "  qpv certificate V ≤ V0·e^(−αt), noise-free: held in {held}/{runs} runs (largest V/(V0·e^(−αt)) over t > 0: {worst:.6}); x left F in {left_f} runs"
    );
}
