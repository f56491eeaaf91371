//! The `noise = rms` rows of the EKF baseline: at each noise level, the
//! RMS-optimal design for white output noise of that level's standard
//! deviation (one sample per step dt), its certified RMS bound (as the
//! relative error r of the table) and its RMS simulated on the same runs,
//! plant trajectory and noise samples as the table's filters.

use super::filter::{Frozen, Qpv, Vector};
use super::{Case, Rng, Setup, LEVELS};
use qpv::dsl::{AlphaSpec, DesignRequest, GammaSpec, NoiseObjective};
use qpv::solve::simulate::Scenario;
use qpv::solve::{design, Settings};
use std::time::Instant;

/// One level's RMS design, simulated: the rows printed after the table.
pub(super) struct RmsRow {
    pub level: f64,
    pub alpha: f64,
    pub seconds: f64,
    pub bound_rel: f64,
    pub sim_rel: f64,
    pub max_gain: f64,
    /// The steady-state RMS (runs from e(0) = 0, the same noise samples):
    /// the RMS design, then the table's filters (file design, EKFs).
    pub steady: [f64; 1 + super::FILTERS],
}

impl<const NX: usize, const NY: usize> Setup<NX, NY> {
    /// The RMS design at `level` (output std = level × each output's range,
    /// noise_period = dt), its observer frozen on the run's grid, and its
    /// row after `runs` runs (the initial errors and noise seeds of the
    /// table's runs at that level).
    pub(super) fn rms_row(&self, case: &Case, level: f64, runs: usize) -> RmsRow {
        let text = std::fs::read_to_string(&case.file).expect("the model file");
        let parsed = qpv::dsl::parse(&text).expect("parses").remove(0);
        let plant = parsed.polytopic();
        let req = DesignRequest {
            alpha: AlphaSpec::Max,
            gamma: GammaSpec::Search,
            noise: NoiseObjective::Rms,
            output_std: self.range.iter().map(|r| r * level).collect(),
            noise_period: Some(self.dt),
            ..DesignRequest::default()
        };
        let t0 = Instant::now();
        let d = design(&plant, &req, &Settings::default()).expect("the RMS design runs");
        let seconds = t0.elapsed().as_secs_f64();
        assert!(d.certifies(), "the RMS design certifies nothing");
        let b = d
            .rms
            .clone()
            .expect("a certified RMS design carries its bound");
        let bound_rel = (b
            .per_state
            .iter()
            .zip(self.h.iter())
            .map(|(bk, hk)| (bk / hk).powi(2))
            .sum::<f64>()
            / NX as f64)
            .sqrt();
        let obs_model = d.observer_model(&plant).expect("the observer model");
        let oq = Qpv::<NX, NY>::new(&obs_model, &d.l_matrices());
        let scenario = Scenario::default_for(&plant);
        let obs: Vec<Frozen<NX, NY>> = (0..=2 * self.steps)
            .map(|i| {
                let t = 0.5 * self.dt * i as f64;
                let theta: Vec<f64> = scenario.theta.iter().map(|s| s.at(t)).collect();
                oq.at(&obs_model.mu(&theta))
            })
            .collect();
        let li = LEVELS.iter().position(|&l| l == level).unwrap_or(0);
        let mut rng = Rng(0x5EED);
        let (mut sum, mut count) = (0.0, 0usize);
        let mut steady = [(0.0, 0usize); 1 + super::FILTERS];
        for run in 0..runs {
            let e0 = self.draw_e(&mut rng);
            let seed = 1000 * run as u64 + li as u64;
            let (s, c) = self.run_rms(&obs, e0, level, seed);
            sum += s;
            count += c;
            let zero = Vector::<NX>::zeros();
            let (s, c) = self.run_rms(&obs, zero, level, seed);
            steady[0].0 += s;
            steady[0].1 += c;
            let (stats, _) = self.run(zero, level, seed);
            for (acc, st) in steady[1..].iter_mut().zip(&stats) {
                acc.0 += st.sum_sq;
                acc.1 += st.count;
            }
        }
        RmsRow {
            level,
            alpha: d.alpha,
            seconds,
            bound_rel,
            sim_rel: (sum / count as f64).sqrt(),
            max_gain: d.max_gain_norm(),
            steady: steady.map(|(s, c)| (s / c as f64).sqrt()),
        }
    }

    /// One run of the plant and the observer `obs` (frozen on the grid)
    /// from e(0) = `e0`, with the noise samples of the table's run `seed`:
    /// Σ r² and the count after the transient.
    fn run_rms(
        &self,
        obs: &[Frozen<NX, NY>],
        e0: Vector<NX>,
        level: f64,
        seed: u64,
    ) -> (f64, usize) {
        let sigma = self.range * level;
        let (mut x, mut xq) = (self.x0, self.x0 - e0);
        let mut rng = Rng(seed);
        let (mut sum, mut count) = (0.0, 0);
        for k in 0..=self.steps {
            let t = k as f64 * self.dt;
            let v = Vector::<NY>::from_fn(|i, _| sigma[i] * rng.gauss());
            if t >= self.rms_from {
                let r = self.rel(&(x - xq));
                sum += r * r;
                count += 1;
            }
            if k == self.steps {
                break;
            }
            let (pm, om) = (&self.plant[2 * k..2 * k + 3], &obs[2 * k..2 * k + 3]);
            (x, xq) = super::rk4_pair((pm, om), (&x, &xq), &v, self.dt);
        }
        (sum, count)
    }
}

/// Prints the RMS rows next to the table's EKF RMS at the same level
/// (`ekf[f][level]`: f = 0 for q = 1e-4, 1 for q = 1e-6).
pub(super) fn print_rms_rows(rows: &[RmsRow], ekf: &[[f64; 2]; 2]) {
    for (k, r) in rows.iter().enumerate() {
        println!(
            "  qpv noise = rms @{:.0}%: designed in {:.1} s, α = {:.4}, max ‖L‖ = {:.3}; certified RMS bound (r) {:.3e}, simulated RMS {:.3e}; ÷ EKF q=1e-4 {:.2}×, ÷ EKF q=1e-6 {:.2}×",
            r.level * 100.0,
            r.seconds,
            r.alpha,
            r.max_gain,
            r.bound_rel,
            r.sim_rel,
            r.sim_rel / ekf[0][k],
            r.sim_rel / ekf[1][k]
        );
        let st = &r.steady;
        println!(
            "    steady state (e(0) = 0, same noise): rms design {:.3e}, file design {:.3e}, EKF q=1e-4 {:.3e}, EKF q=1e-6 {:.3e}; rms ÷ EKF q=1e-4 {:.2}×, ÷ EKF q=1e-6 {:.2}×; bound ÷ simulated {:.2}",
            st[0], st[1], st[2], st[3], st[0] / st[2], st[0] / st[3], r.bound_rel / st[0]
        );
    }
}
