//! The explicit Euler simulation of plant and observer at one step: what
//! the sampling figures of a design ([`crate::certificate::sampling`]) claim about, run
//! on a scenario.

use crate::analysis::integrate::euler;
use crate::analysis::scenario::check_run;
use crate::analysis::simulate::{Closed, Scenario, SimError, Trajectory};
use crate::analysis::trajectory::recorded;
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
    check_run(model, gains, scenario)?;
    // The time grid as the RK4 simulator checks it, every step recorded.
    let steps = recorded(scenario.steps()?)?;
    let h = scenario.dt;
    let mut sys = Closed::new(model, gains, scenario);
    let mut traj = Trajectory::with_capacity(steps + 1);
    let mut z: Vec<f64> = scenario.x0.iter().chain(&scenario.xhat0).copied().collect();
    let mut dz = vec![0.0; z.len()];
    for k in 0..=steps {
        let t = k as f64 * h;
        // f(t_k, z_k), and whether θ(t_k), u(t_k) and z_k are finite.
        if !sys.rhs(t, &z, &mut dz) || z.iter().any(|v| !v.is_finite()) {
            traj.diverged_at = Some(t);
            break;
        }
        sys.emit(t, &z, &mut |r| {
            traj.push(r);
            true
        });
        if k == steps {
            break;
        }
        euler(&mut z, h, &dz);
    }
    Ok(traj)
}
