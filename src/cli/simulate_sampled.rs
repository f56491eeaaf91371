//! `qpv simulate --sample H`: the continuous plant (RK4 at min(--dt, H/20))
//! against the observer stepped at H on sampled y, u, θ (zero-order hold),
//! compared with the certified continuous-plant bound (docs/method.md §16),
//! recomputed from the model as it is now and the gains as given.
//!
//! Exit codes: 0 the run stayed inside the bound (or no bound is certified,
//! said so, and nothing is compared); 1 the run left the bound although its
//! premises held (e(0) in {V ≤ 1}, x in F, θ and u in their ranges and
//! rates), or it diverged; 2 bad input.

use super::gains::read_claim;
use super::input::{load_model_for, CliError};
use super::simulate::{
    check_grid_flags, claimed_design, default_t_end, noisy_outputs, scenario, Grid, Options,
    DEFAULT_DT,
};
use qpv_dsl::diagnostic::fmt_num;
use qpv_dsl::TimeUnit;
use qpv_solve::analysis::sampled::{check_sampled_run, SampledCheck, SampledRun, MIN_SUBSTEPS};
use qpv_solve::simulate::MeasurementNoise;

/// Runs `qpv simulate --sample H`.
pub fn run(o: &Options) -> Result<i32, CliError> {
    let h = o.sample.unwrap_or(f64::NAN);
    if !(h.is_finite() && h > 0.0) {
        return Err(CliError::Input(format!(
            "--sample {}: expected a positive sample period in seconds (e.g. 1e-3 for 1 kHz)",
            fmt_num(h)
        )));
    }
    if o.plot.is_some() {
        return Err(CliError::Input(
            "--sample runs the sampled-data check only: --plot is not available with it (run without --sample for figures)"
                .into(),
        ));
    }
    if let Some(nu) = o.noise.filter(|nu| !(nu.is_finite() && *nu >= 0.0)) {
        return Err(CliError::Input(format!(
            "--noise {}: expected a noise amplitude >= 0",
            fmt_num(nu)
        )));
    }
    check_grid_flags(o)?;
    let claim = read_claim(&o.design, "report")?;
    let (_, model) = load_model_for(&o.file, o.model.as_deref(), &o.design, claim.model())?;
    let withdrawn = claim.certifies == Some(false);
    let design = claimed_design(claim, &o.design)?;
    if design.l.is_empty() {
        return Err(CliError::Input(format!(
            "{}: the design has no gains (it was not solved)",
            o.design.display()
        )));
    }
    let poly = model.polytopic();
    // The plant's RK4 step is h/substeps, at most --dt (default 1e-3); the
    // default horizon is the continuous run's, from the design's rate.
    let dt = o.dt.unwrap_or(DEFAULT_DT);
    let substeps = ((h / dt - 1e-9).ceil() as usize).max(MIN_SUBSTEPS);
    let t_end = o.t_end.unwrap_or_else(|| {
        let (t, why) = default_t_end(design.alpha, h / substeps as f64);
        println!("default time grid: {why}");
        t.max(h)
    });
    let mut sc = scenario(o, &poly, Grid { dt, t_end })?;
    let obs = design
        .observer_model(&poly)
        .map_err(|e| CliError::Input(format!("{}: {e}", o.design.display())))?;
    sc.x0.resize(obs.nx(), 0.0);
    sc.xhat0.resize(obs.nx(), 0.0);
    if h > sc.t_end.max(f64::MIN_POSITIVE) {
        return Err(CliError::Input(format!(
            "--sample {}: longer than the run (--t-end {})",
            fmt_num(h),
            fmt_num(sc.t_end)
        )));
    }
    let mut run = SampledRun::for_model(&obs, h);
    run.substeps = substeps;
    run.noise = o.noise.map(|nu| {
        let outputs = noisy_outputs(&design, &obs);
        let names: Vec<&str> = outputs.iter().map(|&i| obs.outputs[i].as_str()).collect();
        println!(
            "measurement noise: |v_k| = {} on {} (random direction at each sample, seed {})",
            fmt_num(nu),
            names.join(", "),
            o.seed
        );
        MeasurementNoise::new(o.seed, nu, outputs)
    });
    let held: Vec<&str> = obs
        .params
        .iter()
        .map(|p| p.name.as_str())
        .zip(&run.hold_params)
        .chain(obs.inputs.iter().map(|s| s.as_str()).zip(&run.hold_inputs))
        .filter(|(_, &held)| held)
        .map(|(n, _)| n)
        .collect();
    println!(
        "sampled run: the observer stepped at {} (explicit Euler on y, u, theta sampled at t_k), \
         the continuous plant by RK4 at h/{}",
        poly.time_unit.describe_period(h),
        run.substeps
    );
    if !held.is_empty() {
        println!(
            "held over each step in the plant too (no declared rate, the bound's assumption): {}",
            held.join(", ")
        );
    }
    let mut check = check_sampled_run(&poly, &design, &sc, &run)
        .map_err(|e| CliError::Input(format!("simulation: {e}")))?;
    if withdrawn {
        // The report's own verdict may only withdraw a claim: nothing it
        // did not claim is compared, whatever the gains achieve.
        check.withdraw("the report does not certify (its verdict is not `certified`)");
    }
    println!("{}", describe(&check, poly.time_unit));
    Ok(if check.violated() { 1 } else { 0 })
}

/// The claim recomputed, the premises and the verdict, in words.
fn describe(c: &SampledCheck, unit: TimeUnit) -> String {
    let cl = &c.claim;
    let mut s = String::new();
    if let Some(why) = &c.withdrawn {
        s.push_str(&format!(
            "NOT certified at {}: {why}; no bound is claimed and nothing is compared\n",
            unit.describe_period(cl.h)
        ));
    } else if cl.certificate.passed {
        s.push_str(&format!(
            "certified at {} (independent certificate, family S5d) with alpha = {} (the gains reach alpha = {:.6} at this h): V(e_k+1) <= {} V(e_k) for the Euler plant\n",
            unit.describe_period(cl.h),
            fmt_num(cl.alpha),
            cl.capacity,
            fmt_num(1.0 - cl.h * cl.alpha)
        ));
    } else {
        s.push_str(&format!(
            "NOT certified at {}: the gains reach alpha = {:.6} there (capacity of the discrete family); no bound is certified and nothing is compared\n",
            unit.describe_period(cl.h),
            cl.capacity
        ));
    }
    match &cl.bound {
        _ if c.withdrawn.is_some() => {}
        Ok(b) => s.push_str(&format!(
            "continuous-plant bound (recomputed): |x''| <= {:.4e}, |r_k| <= {:.4e} per step, delta = {:.4e}, rho = {:.6}; sqrt V(e_k) <= rho^k sqrt V(e_0) + delta (1 - rho^k)/(1 - rho); ultimate sqrt V <= {:.4e}, ||e|| <= {:.4e}{}\n  assumes: {}\n",
            b.accel,
            b.truncation,
            b.delta,
            (1.0 - cl.h * cl.alpha).sqrt(),
            b.ultimate_v_sqrt,
            b.ultimate_error,
            if b.holds() { "" } else { "; delta > 1 - rho: the certified set is NOT shown invariant, no bound holds" },
            b.assumption()
        )),
        Err(why) if cl.certificate.passed => s.push_str(&format!(
            "no continuous-plant bound: {why}; nothing is compared\n"
        )),
        Err(_) => {}
    }
    let mut compared = c.withdrawn.is_none();
    if let Some(n) = c.noise.as_ref().filter(|_| compared) {
        let line = match n.sigma {
            Some(sigma) if n.amplitude <= n.amplitude_max => format!(
                "with noise (recomputed: sigma = {sigma:.4e} for V(e_k+1) - (1 - h alpha) V(e_k) <= h sigma |v_k|^2): sqrt V(e_k+1) <= sqrt(rho^2 b_k^2 + h sigma nu^2) + delta, nu = {} <= nu_c = {}\n",
                fmt_num(n.amplitude),
                if n.amplitude_max.is_finite() { format!("{:.4e}", n.amplitude_max) } else { "unlimited".into() }
            ),
            Some(_) => {
                compared = false;
                format!(
                    "noise amplitude {} is above nu_c = {:.4e}, the largest that keeps the certified set invariant against the truncation error: no bound, nothing is compared\n",
                    fmt_num(n.amplitude),
                    n.amplitude_max
                )
            }
            None => {
                compared = false;
                "no discrete noise bound is certified for these gains at this h (design with noise = min and sample): nothing is compared\n".to_string()
            }
        };
        s.push_str(&line);
    }
    s.push_str(&format!(
        "{} samples: sqrt V(e_0) = {:.4e}{}, ||e|| at the end = {:.4e}\n",
        c.samples,
        c.v0_sqrt,
        if c.v0_sqrt > 1.0 && !cl.bound.as_ref().is_ok_and(|b| b.global) {
            " (> 1: e(0) outside the certified set, the bound is not a guarantee for this run)"
        } else {
            ""
        },
        c.last_error
    ));
    if let Some((t, v)) = c.left_f {
        s.push_str(&format!(
            "warning: the plant leaves the state bound F at t = {t:.4} (x^T Q^-1 x up to {v:.4} > 1); the bound assumes x stays in F\n"
        ));
    }
    if let Some(t) = c.left_theta {
        s.push_str(&format!(
            "warning: a parameter or input leaves its declared range at t = {t:.4}; the bound assumes it does not\n"
        ));
    }
    if let Some((name, t, slope)) = &c.rate_exceeded {
        s.push_str(&format!(
            "warning: {name} moves faster than its declared rate at t = {t:.4} (slope {slope:.4e}); the bound assumes it does not\n"
        ));
    }
    if compared && cl.bound.as_ref().is_ok_and(|b| b.holds()) {
        match c.exceeded {
            Some((t, r)) => s.push_str(&format!(
                "the error LEAVES the certified bound at t = {t:.4} (up to {r:.4} times the bound)\n"
            )),
            None => s.push_str(&format!(
                "the error stays inside the certified bound (largest sqrt V(e_k) / bound_k = {:.4}){}\n",
                c.worst_ratio,
                match c.entered_at {
                    Some(t) => format!("; inside the ultimate bound from t = {t:.4} on"),
                    None => "; not yet inside the ultimate bound at the end".into(),
                }
            )),
        }
    }
    if let Some(t) = c.diverged_at {
        s.push_str(&format!("simulation diverged at t = {t}\n"));
    }
    s.trim_end().to_string()
}
