//! Falsification of a design's noise claim on the true nonlinear error
//! dynamics.

use crate::model::noise::NoiseChannels;
use crate::report::figures::channels_on_observer;
use crate::report::Design;
use nalgebra::{DMatrix, DVector};
use qpv_dsl::PolytopicModel;
use serde::Serialize;

/// The outcome of [`falsify_noise`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoiseFalsification {
    /// σ that was checked.
    pub sigma: f64,
    /// α that was checked.
    pub alpha: f64,
    /// The sampler's seed (same seed, same samples).
    pub seed: u64,
    /// Points evaluated (e = 0 excluded).
    pub samples: usize,
    /// Points with r ≥ 0 (or a non-finite r).
    pub counterexamples: usize,
    /// The largest r = (V' + αV − σ(|w|² + |v|²))/V found (its discrete
    /// form for a sampled design, see [`falsify_noise`]).
    pub worst_ratio: f64,
    /// The point with the largest ratio.
    pub worst: Option<NoiseSample>,
}

/// One evaluated point of [`falsify_noise`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoiseSample {
    /// The estimation error e (eᵀPe ≤ 1).
    pub e: Vec<f64>,
    /// The plant state x.
    pub x: Vec<f64>,
    /// The parameter vector θ.
    pub theta: Vec<f64>,
    /// The noise on the noisy outputs, then the disturbance w.
    pub noise: Vec<f64>,
    /// r at this point.
    pub ratio: f64,
}

impl NoiseFalsification {
    /// True if points were evaluated and none was a counterexample.
    pub fn passed(&self) -> bool {
        self.samples > 0 && self.counterexamples == 0
    }

    /// Counts one evaluated point of ratio `r` (a counterexample if r ≥ 0
    /// or NaN) and keeps it (built by `point`) if it is the worst so far.
    fn record(&mut self, r: f64, point: impl FnOnce() -> NoiseSample) {
        self.samples += 1;
        let key = if r.is_nan() { f64::INFINITY } else { r };
        if r.is_nan() || r >= 0.0 {
            self.counterexamples += 1;
        }
        if key > self.worst_ratio {
            self.worst_ratio = key;
            self.worst = Some(point());
        }
    }
}

/// Samples the noise claim V' + αV ≤ σ(|w|² + |v|²) of a design with a
/// `noise` bound on the true nonlinear error dynamics
/// e' = f(x) − f(x̂) − L(θ)(h(x) − h(x̂)) + B_w(θ) w − L(θ) E v:
/// e in E, x in F and θ in the box drawn like [`crate::falsify::falsify`]
/// does; (v, w) the worst case for that (e, x, θ) (v = −EᵀLᵀPe/σ,
/// w = B_wᵀPe/σ, the maximiser of the right-hand side) in a quarter of the
/// draws, otherwise uniform in the ball of radius 2ν_max. Any r ≥ 0 is a
/// counterexample. A `sample = h` design's claim is the discrete one
/// (docs/method.md §16): on the Euler error map e⁺ = e + h·e',
/// r = (V(e⁺) − (1 − hα)V(e) − hσ(|w|² + |v|²))/(hV(e)).
pub fn falsify_noise(
    plant: &PolytopicModel,
    design: &Design,
    channels: &NoiseChannels,
    samples: usize,
    seed: u64,
) -> Result<NoiseFalsification, crate::analysis::simulate::SimError> {
    use crate::analysis::checks::{check_gains, check_model, SimError};
    use crate::analysis::falsify::{draw_e, draw_theta, draw_x, factor, Rng};
    use crate::analysis::rhs::Frozen;
    let nb = design
        .noise
        .as_ref()
        .ok_or_else(|| SimError::Argument("the design carries no noise bound".into()))?;
    let model = design
        .observer_model(plant)
        .map_err(|e| SimError::Model(e.to_string()))?;
    channels
        .validate(plant)
        .map_err(|e| SimError::Argument(e.to_string()))?;
    let ch = channels_on_observer(plant, design, channels);
    ch.validate(&model)
        .map_err(|e| SimError::Argument(e.to_string()))?;
    check_model(&model)?;
    let (p, gains) = (design.p_matrix(), design.l_matrices());
    check_gains(&model, &gains)?;
    let (nx, ny) = (model.nx(), model.ny());
    let (alpha, sigma) = (design.alpha, nb.sigma);
    let sample = design.sample.map(|s| s.h);
    let rp = factor("P", &p, nx)?;
    let rp_t = rp.transpose();
    let to_e = |z: &DVector<f64>| rp_t.solve_upper_triangular(z);
    let e_vertices = region_in_e(&model, &p);
    let qpv_dsl::StateBound::Given(q) = &model.state_bound else {
        return Err(SimError::Model(
            "the design's model has no state bound Q".into(),
        ));
    };
    let rq = factor("state bound Q", q, nx)?;
    let x_vertices = region_in_f(&model, &rq);
    let outs = ch.noisy_outputs(ny);
    let nw = ch.n_w();
    let nvw = outs.len() + nw;
    let radius = 2.0 * nb.max_amplitude;
    let mut frozen = Frozen::new(&model);
    let mut rng = Rng(seed);
    let mut z = DVector::zeros(nx);
    let mut zv = vec![0.0; nvw];
    let mut theta = vec![0.0; model.ntheta()];
    let (mut fx, mut fxh, mut hx, mut hxh) =
        (vec![0.0; nx], vec![0.0; nx], vec![0.0; ny], vec![0.0; ny]);
    let mut out = NoiseFalsification {
        sigma,
        alpha,
        seed,
        samples: 0,
        counterexamples: 0,
        worst_ratio: f64::NEG_INFINITY,
        worst: None,
    };
    for _ in 0..samples {
        let e = draw_e(&mut rng, &mut z, &e_vertices, &to_e);
        let x = draw_x(&mut rng, &mut z, Some(&rq), &x_vertices);
        draw_theta(&mut rng, &model, &mut theta);
        frozen.set(&model, &gains, &theta);
        let xh = &x - &e;
        frozen.drift(x.as_slice(), &mut fx);
        frozen.drift(xh.as_slice(), &mut fxh);
        frozen.output(x.as_slice(), &mut hx);
        frozen.output(xh.as_slice(), &mut hxh);
        let (lt, bw) = gain_and_bw_at(&frozen.mu, &gains, &ch, (nx, ny, nw));
        let pe = &p * &e;
        // (v, w): the maximiser, or random in the ball.
        let vw: Vec<f64> = if rng.uniform() < 0.25 {
            let ltpe = lt.transpose() * &pe;
            let bwpe = bw.transpose() * &pe;
            outs.iter()
                .map(|&k| -ltpe[k] / sigma)
                .chain(bwpe.iter().map(|b| b / sigma))
                .collect()
        } else {
            rng.ball(&mut zv, false);
            zv.iter().map(|c| c * radius).collect()
        };
        // e' = f(x) − f(x̂) − L (h(x) − h(x̂) + E v) + B_w w
        let mut innov = DVector::from_fn(ny, |k, _| hx[k] - hxh[k]);
        for (c, &k) in outs.iter().enumerate() {
            innov[k] += vw[c];
        }
        let w = DVector::from_fn(nw, |c, _| vw[outs.len() + c]);
        let de = DVector::from_fn(nx, |k, _| fx[k] - fxh[k]) - &lt * innov + &bw * w;
        let v = e.dot(&pe);
        if v <= 0.0 {
            continue;
        }
        let n2: f64 = vw.iter().map(|c| c * c).sum();
        let r = match sample {
            // The discrete claim on the Euler error map e⁺ = e + h·e'.
            Some(h) => {
                let ep = &e + &de * h;
                (ep.dot(&(&p * &ep)) - (1.0 - h * alpha) * v - h * sigma * n2) / (h * v)
            }
            None => (2.0 * pe.dot(&de) + alpha * v - sigma * n2) / v,
        };
        out.record(r, || NoiseSample {
            e: e.iter().copied().collect(),
            x: x.iter().copied().collect(),
            theta: theta.clone(),
            noise: vw.clone(),
            ratio: r,
        });
    }
    Ok(out)
}

/// The region's vertices scaled into E = {eᵀPe ≤ 1} (those with vᵀPv > 0).
fn region_in_e(model: &PolytopicModel, p: &DMatrix<f64>) -> Vec<DVector<f64>> {
    model
        .region
        .vertices
        .iter()
        .filter_map(|v| {
            let vpv = v.dot(&(p * v));
            (vpv > 0.0).then(|| v * (1.0 / vpv.sqrt()).min(1.0))
        })
        .collect()
}

/// The region's vertices scaled onto the boundary of F = {xᵀQ⁻¹x ≤ 1}
/// (`rq` the Cholesky factor of Q).
fn region_in_f(model: &PolytopicModel, rq: &DMatrix<f64>) -> Vec<DVector<f64>> {
    model
        .region
        .vertices
        .iter()
        .filter_map(|v| {
            let r = rq.solve_lower_triangular(v)?.norm();
            (r > 0.0).then(|| v / r)
        })
        .collect()
}

/// L(θ) and B_w(θ) at the scheduling weights `mu`.
fn gain_and_bw_at(
    mu: &[f64],
    gains: &[DMatrix<f64>],
    ch: &NoiseChannels,
    (nx, ny, nw): (usize, usize, usize),
) -> (DMatrix<f64>, DMatrix<f64>) {
    let mut lt = DMatrix::zeros(nx, ny);
    let mut bw = DMatrix::zeros(nx, nw);
    for (l, &mu) in mu.iter().enumerate() {
        lt += &gains[l] * mu;
        if let Some(b) = &ch.b_w {
            bw += &b[l] * mu;
        }
    }
    (lt, bw)
}
