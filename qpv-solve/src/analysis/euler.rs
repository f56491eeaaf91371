//! The explicit Euler simulation of plant and observer at one step: what
//! the sampling figures of a design ([`crate::certificate::sampling`]) claim about, run
//! on a scenario.

use crate::analysis::simulate::{check_gains, check_model, Frozen, Scenario, SimError, Trajectory};
use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;

/// Simulates plant and observer both discretised by the same explicit Euler
/// step `scenario.dt` (the setting [`crate::certificate::sampling::max_step_euler`] covers):
/// x_{k+1} = x_k + h f(x_k, θ_k, u_k),
/// x̂_{k+1} = x̂_k + h (f(x̂_k, θ_k, u_k) + L(θ_k)(y_k − ŷ_k)).
/// Input checks and the [`Trajectory`] are as for
/// [`crate::analysis::simulate::simulate`].
pub fn simulate_euler(
    model: &PolytopicModel,
    gains: &[DMatrix<f64>],
    scenario: &Scenario,
) -> Result<Trajectory, SimError> {
    check_model(model)?;
    check_gains(model, gains)?;
    let nx = model.nx();
    for (what, v) in [("x0", &scenario.x0), ("xhat0", &scenario.xhat0)] {
        if v.len() != nx {
            return Err(SimError::Length {
                what: what.into(),
                expected: nx,
                got: v.len(),
            });
        }
    }
    if scenario.theta.len() != model.ntheta() || scenario.u.len() != model.nu() {
        return Err(SimError::Length {
            what: "scenario theta / u".into(),
            expected: model.ntheta() + model.nu(),
            got: scenario.theta.len() + scenario.u.len(),
        });
    }
    // The time grid as the RK4 simulator checks it, every step recorded.
    let steps = crate::analysis::simulate::recorded(scenario.steps()?)?;
    let h = scenario.dt;
    let mut frozen = Frozen::new(model);
    let mut traj = Trajectory::with_capacity(steps + 1);
    let mut x = scenario.x0.clone();
    let mut xh = scenario.xhat0.clone();
    let (mut dx, mut dxh) = (vec![0.0; nx], vec![0.0; nx]);
    let (mut y, mut yh) = (vec![0.0; model.ny()], vec![0.0; model.ny()]);
    for k in 0..=steps {
        let t = k as f64 * h;
        let theta: Vec<f64> = scenario.theta.iter().map(|s| s.at(t)).collect();
        let u: Vec<f64> = scenario.u.iter().map(|s| s.at(t)).collect();
        if theta
            .iter()
            .chain(&u)
            .chain(&x)
            .chain(&xh)
            .any(|v| !v.is_finite())
        {
            traj.diverged_at = Some(t);
            break;
        }
        let err = x
            .iter()
            .zip(&xh)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt();
        traj.t.push(t);
        traj.x.push(x.clone());
        traj.xhat.push(xh.clone());
        traj.mu.push(model.mu(&theta));
        traj.theta.push(theta.clone());
        traj.error_norm.push(err);
        if k == steps {
            break;
        }
        frozen.set(model, gains, &theta);
        frozen.drift(&x, &mut dx);
        frozen.add_input(&u, &mut dx);
        frozen.output(&x, &mut y);
        frozen.output(&xh, &mut yh);
        for (a, b) in y.iter_mut().zip(&yh) {
            *a -= b;
        }
        frozen.drift(&xh, &mut dxh);
        frozen.add_input(&u, &mut dxh);
        frozen.add_gain(&y, &mut dxh);
        for i in 0..nx {
            x[i] += h * dx[i];
            xh[i] += h * dxh[i];
        }
    }
    Ok(traj)
}
