//! The paper's example, designed and certified at build time by `qpv!`, then
//! simulated with the generated observer and plant on the paper's scenario
//! (docs/method.md, "The paper's example").
//!
//!     cargo run --release --example paper [-- FIGURE_DIR]
//!
//! Prints both certificates, re-checks the baked gains at run time with the
//! independent checker, falsifies the convergence claim by sampling, runs
//! the paper's scenario with the generated observer, and writes the figures
//! (states and estimates, μ_l(θ(t)), the error against its guaranteed
//! envelope) as SVG into FIGURE_DIR (default `target/paper-figures`).
//!
//! `examples/paper.qpv` holds two designs: the published point in paper mode
//! (a reproduction: the generated `design1` only records that the printed
//! conditions hold; they certify nothing, so it has no observer) and a sound
//! α = max / γ = search design (`design2`, re-exported as
//! `paper_example::Observer`, `paper_example::CERTIFICATE`, ...).

use qpv::solve::certificate::Gains;
use qpv::solve::vocab::Candidate;
use std::f64::consts::PI;

qpv::qpv!(include "examples/paper.qpv");

use paper_example as model;

/// θ(t) of the paper's scenario.
fn theta(t: f64) -> [f64; model::NTHETA] {
    [
        0.5 + 0.5 * (4.0 * PI * t).sin(),
        0.5 + 0.5 * (PI * t / 5.0 + PI / 6.0).cos(),
    ]
}

/// One RK4 step of the plant with θ(t) evaluated at the stages.
fn plant_step(x: &[f64; model::NX], t: f64, dt: f64) -> [f64; model::NX] {
    let f = |x: &[f64; model::NX], t: f64| model::plant::derivative(x, &[], &theta(t));
    let k1 = f(x, t);
    let k2 = f(
        &std::array::from_fn(|i| x[i] + 0.5 * dt * k1[i]),
        t + 0.5 * dt,
    );
    let k3 = f(
        &std::array::from_fn(|i| x[i] + 0.5 * dt * k2[i]),
        t + 0.5 * dt,
    );
    let k4 = f(&std::array::from_fn(|i| x[i] + dt * k3[i]), t + dt);
    std::array::from_fn(|i| x[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
}

/// A progress line on stderr: the time since the start and what runs now.
fn step(start: std::time::Instant, what: &str) {
    eprintln!("[{:6.2} s] {what}", start.elapsed().as_secs_f64());
}

fn main() {
    let start = std::time::Instant::now();
    step(
        start,
        "the two designs were solved and certified when qpv! expanded (build time); their certificates:",
    );
    println!("{}", model::design1::CERTIFICATE);
    println!();
    println!("{}", model::CERTIFICATE);
    println!();
    println!(
        "generated observer: NX = {}, NY = {}, NV = {} vertices, alpha = {}, gamma = {}",
        model::NX,
        model::NY,
        model::NV,
        model::ALPHA,
        model::GAMMA
    );

    // The baked gains, re-checked at run time by the independent checker and
    // put to a Monte-Carlo falsification on the true error dynamics.
    let src = include_str!("paper.qpv");
    let parsed = &qpv::dsl::parse(src).expect("paper.qpv parses")[0];
    let request = &parsed.designs[1];
    let poly = parsed.polytopic().with_split(request.split);
    let p = nalgebra::DMatrix::from_fn(model::NX, model::NX, |i, j| model::P[i][j]);
    let gains: Vec<_> = model::L
        .iter()
        .map(|l| nalgebra::DMatrix::from_fn(model::NX, model::NY, |i, j| l[i][j]))
        .collect();
    step(
        start,
        "re-checking the baked P, L_l with the independent certificate ...",
    );
    let cert = qpv::solve::check(
        &poly,
        &Gains::new(&p, &gains),
        &Candidate::new(model::ALPHA, model::GAMMA),
        request.mode,
    );
    println!(
        "run-time re-check of the baked P, L_l: {}",
        if cert.passed {
            "all condition families hold"
        } else {
            "FAILED"
        }
    );
    for f in &cert.families {
        println!(
            "  {:<4} worst margin {:>11.4e} over {} conditions",
            f.name, f.margin, f.count
        );
    }
    step(
        start,
        "falsifying the decay claim on 100 000 random samples of (e, x, theta) ...",
    );
    match qpv::solve::falsify::falsify(&poly, &p, &gains, model::ALPHA, model::GAMMA, 100_000, 7) {
        Ok(f) => println!(
            "falsification: {} samples of (e, x, theta), {} counterexamples, worst (V' + alpha V)/V = {:.4}",
            f.samples, f.counterexamples, f.worst_ratio
        ),
        Err(e) => println!("falsification could not run: {e}"),
    }

    step(
        start,
        "simulating the paper's scenario (2 s, RK4 at dt = 1e-4) ...",
    );
    let dt = 1e-4;
    let record_every = 10; // one figure sample per millisecond
    let steps = (2.0 / dt) as usize;
    let mut x = [-0.02; model::NX];
    let mut obs = model::Observer::new();
    let mut rec = Record::default();
    for n in 0..=steps {
        let t = n as f64 * dt;
        let th = theta(t);
        if n % record_every == 0 {
            rec.push(t, &x, &obs.estimate(), &model::mu(&th));
        }
        if n == steps {
            break;
        }
        let y = model::plant::output(&x, &th);
        obs.step_rk4(dt, &y, &[], &th);
        x = plant_step(&x, t, dt);
    }
    println!();
    println!("{:>6}  {:>12}", "t", "||x - xhat||");
    for target in [0.0, 0.25, 0.5, 1.0, 1.5, 2.0] {
        if let Some(i) = rec.t.iter().position(|&t| t >= target - 1e-9) {
            println!("{:>6.2}  {:>12.3e}", rec.t[i], rec.err[i]);
        }
    }
    if let Some(i) = rec.err.iter().rposition(|&e| e >= 1e-6) {
        if let Some(t) = rec.t.get(i + 1) {
            println!("error below 1e-6 from t = {t:.3} s on");
        }
    }
    println!("steps with θ clamped into Θ: {}", obs.clamped());

    let dir = std::env::args()
        .nth(1)
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::path::PathBuf::from("target/paper-figures"));
    step(
        start,
        &format!("writing the figures to {} ...", dir.display()),
    );
    match rec.write_figures(&dir, &p) {
        Ok(()) => {
            println!("figures written to {}", dir.display());
            step(start, "done");
        }
        Err(e) => {
            eprintln!("could not write figures: {e}");
            std::process::exit(1);
        }
    }
}

/// The recorded trajectory for the figures.
#[derive(Default)]
struct Record {
    t: Vec<f64>,
    x: Vec<[f64; model::NX]>,
    xhat: Vec<[f64; model::NX]>,
    mu: Vec<[f64; model::NV]>,
    err: Vec<f64>,
}

impl Record {
    fn push(
        &mut self,
        t: f64,
        x: &[f64; model::NX],
        xhat: &[f64; model::NX],
        mu: &[f64; model::NV],
    ) {
        self.t.push(t);
        self.x.push(*x);
        self.xhat.push(*xhat);
        self.mu.push(*mu);
        self.err.push(
            (0..model::NX)
                .map(|i| (x[i] - xhat[i]).powi(2))
                .sum::<f64>()
                .sqrt(),
        );
    }

    fn series(&self, f: impl Fn(usize) -> f64) -> Vec<(f64, f64)> {
        self.t.iter().enumerate().map(|(k, &t)| (t, f(k))).collect()
    }

    /// The paper's Figs. 1-4 and the error against e^{-αt/2}.
    fn write_figures(
        &self,
        dir: &std::path::Path,
        p: &nalgebra::DMatrix<f64>,
    ) -> Result<(), String> {
        use qpv::plot::{line_chart, Series, PALETTE};
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        for i in 0..model::NX {
            let name = format!("x{}", i + 1);
            let s = [
                Series::new(
                    name.clone(),
                    self.series(|k| self.x[k][i]),
                    PALETTE[0],
                    false,
                ),
                Series::new(
                    format!("{name} estimate"),
                    self.series(|k| self.xhat[k][i]),
                    PALETTE[1],
                    true,
                ),
            ];
            let title = format!("Fig. {}: {name} and its estimate", i + 1);
            line_chart(
                &dir.join(format!("x{}.svg", i + 1)),
                &title,
                &name,
                &s,
                false,
            )?;
        }
        let mu: Vec<Series> = (0..model::NV)
            .map(|l| {
                Series::new(
                    format!("mu{}", l + 1),
                    self.series(|k| self.mu[k][l]),
                    PALETTE[l],
                    false,
                )
            })
            .collect();
        line_chart(
            &dir.join("mu.svg"),
            "Fig. 4: vertex weights mu_l(theta(t))",
            "mu",
            &mu,
            false,
        )?;
        // V(t) <= V(0) e^{-αt} gives ||e(t)|| <= sqrt(cond P) ||e(0)|| e^{-αt/2}.
        let factor = qpv::solve::simulate::envelope_factor(p)
            .ok_or("the baked P is not positive definite")?;
        let e0 = self.err[0];
        let s = [
            Series::new(
                "||x - xhat||",
                self.series(|k| self.err[k]),
                PALETTE[0],
                false,
            ),
            Series::new(
                format!(
                    "certified envelope sqrt(cond P) ||e(0)|| e^(-{:.2} t/2)",
                    model::ALPHA
                ),
                self.series(|k| factor * e0 * (-model::ALPHA * self.t[k] / 2.0).exp()),
                PALETTE[1],
                true,
            ),
        ];
        line_chart(
            &dir.join("error.svg"),
            "estimation error (log scale)",
            "||e||",
            &s,
            true,
        )
    }
}
