//! `qpv tradeoff`: the rate–noise trade-off of a model. The fastest
//! certified design (α = max) fixes the range; noise-optimal designs at α
//! from 5 % to 99 % of it give, per α, the certified error bound per unit
//! noise amplitude and the largest gain; the knee is the fastest point
//! whose error bound is within twice the sweep's smallest.

use super::input::{
    check_json_target, emit_json, exit, load_model, prepare_plot_dir, print_text, CliError,
};
use super::schema::SCHEMA;
use qpv_dsl::{AlphaSpec, DesignRequest, GammaSpec};
use qpv_solve::model::noise::NoiseChannels;
use qpv_solve::report::Design;
use qpv_solve::search::noise::{tradeoff_with_progress, Sweep, SweepStep, Tradeoff, TradeoffPoint};
use serde::Serialize;
use std::path::PathBuf;

/// How many times the knee design's largest gain a design's gain may reach
/// before the report says its gains are far above what the knee needs.
const GAIN_EXCESS: f64 = 10.0;

/// The options of `qpv tradeoff`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// The model file (.qpv).
    pub file: PathBuf,
    /// Which model of the file.
    #[arg(long, value_name = "NAME")]
    pub model: Option<String>,
    /// Number of alpha values in the sweep (at least 2).
    #[arg(long, value_name = "N", default_value_t = 8)]
    pub points: usize,
    /// Region scaling: a number in (0,1) or `search` (default: search).
    #[arg(long, value_name = "G|search", allow_hyphen_values = true, value_parser = super::input::parse_gamma)]
    pub gamma: Option<GammaSpec>,
    /// Write the table as JSON to this file (`-` for stdout).
    #[arg(long, value_name = "OUT")]
    pub json: Option<String>,
    /// Directory for the SVG figure (tradeoff.svg).
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
}

/// One row of the JSON table.
#[derive(Serialize)]
struct PointView {
    alpha: f64,
    gamma: f64,
    certified: bool,
    sigma: Option<f64>,
    error_bound: Option<f64>,
    max_amplitude: Option<f64>,
    max_gain: Option<f64>,
    max_step_euler: Option<f64>,
    knee: bool,
    seconds: f64,
}

/// The fastest certified design, as the table reports it.
#[derive(Serialize)]
struct FastestView {
    alpha: f64,
    /// The certified supremum the sweep's range is measured against (the
    /// practical α = max stays within its tolerance of it).
    alpha_sup: f64,
    gamma: f64,
    max_gain: f64,
    sigma: Option<f64>,
    error_bound: Option<f64>,
    max_amplitude: Option<f64>,
    /// Its largest gain over the knee design's (None without a knee).
    gain_over_knee: Option<f64>,
}

/// `qpv tradeoff --json`.
#[derive(Serialize)]
struct TradeoffOutput<'a> {
    schema: &'static str,
    command: &'static str,
    model: &'a str,
    /// The γ request: a number or "search".
    gamma_request: String,
    /// The α = max design that fixed the sweep's range.
    alpha_max: FastestView,
    points: Vec<PointView>,
    /// Index into `points` of the knee (null if no point certified).
    knee: Option<usize>,
    seconds_total: f64,
}

fn opt(v: Option<f64>, prec: usize) -> String {
    v.map_or("-".to_string(), |x| format!("{x:.prec$e}"))
}

/// The table of a sweep, one line per point, the knee marked.
fn table(points: &[TradeoffPoint], knee: Option<usize>) -> String {
    let mut s = format!(
        "  {:>10} {:>9} {:>12} {:>12} {:>11} {:>11} {:>11}\n",
        "alpha", "gamma", "sigma", "error_bound", "nu_max", "max_gain", "euler_step"
    );
    for (k, p) in points.iter().enumerate() {
        s.push_str(&format!(
            "  {:>10.4} {:>9.5} {:>12} {:>12} {:>11} {:>11} {:>11}{}\n",
            p.alpha,
            p.gamma,
            opt(p.sigma, 4),
            p.error_bound.map_or("-".into(), |e| format!("{e:.4}")),
            opt(p.max_amplitude, 3),
            p.max_gain.map_or("-".into(), |g| format!("{g:.4}")),
            opt(p.max_step_euler, 3),
            if !p.certified {
                "  not certified"
            } else if Some(k) == knee {
                "  <- knee"
            } else {
                ""
            }
        ));
    }
    s
}

/// Writes DIR/tradeoff.svg (error bound and gain against α, the knee
/// marked) and returns the report line that says so.
fn write_figure(
    dir: &std::path::Path,
    name: &str,
    points: &[TradeoffPoint],
    knee: Option<usize>,
) -> Result<String, CliError> {
    std::fs::create_dir_all(dir).map_err(|e| CliError::Io(format!("{}: {e}", dir.display())))?;
    let path = dir.join("tradeoff.svg");
    let pts: Vec<(f64, f64, f64)> = points
        .iter()
        .filter_map(|p| Some((p.alpha, p.error_bound?, p.max_gain?)))
        .collect();
    let kp = knee.and_then(|k| {
        let p = &points[k];
        Some((p.alpha, p.error_bound?, p.max_gain?))
    });
    if pts.is_empty() {
        Ok("  no certified point: no figure written\n".into())
    } else {
        qpv::plot::tradeoff_chart(
            &path,
            &format!(
                "{}: certified noise bound and gain against the decay rate",
                name
            ),
            &pts,
            kp,
        )
        .map_err(CliError::Io)?;
        Ok(format!("  figure: {}\n", path.display()))
    }
}

/// The `--json` document of a sweep.
fn json_view<'a>(
    name: &'a str,
    gamma: GammaSpec,
    fastest: &Design,
    over: Option<f64>,
    points: &[TradeoffPoint],
    knee: Option<usize>,
    seconds_total: f64,
) -> TradeoffOutput<'a> {
    TradeoffOutput {
        schema: SCHEMA,
        command: "tradeoff",
        model: name,
        gamma_request: match gamma {
            GammaSpec::Fixed(g) => g.to_string(),
            GammaSpec::Search => "search".into(),
        },
        alpha_max: FastestView {
            alpha: fastest.alpha,
            alpha_sup: fastest
                .practical
                .as_ref()
                .map_or(fastest.alpha, |p| p.alpha_sup),
            gamma: fastest.gamma,
            max_gain: fastest.max_gain_norm(),
            sigma: fastest.noise.as_ref().map(|n| n.sigma),
            error_bound: fastest.noise.as_ref().map(|n| n.error_bound),
            max_amplitude: fastest.noise.as_ref().map(|n| n.max_amplitude),
            gain_over_knee: over,
        },
        points: points
            .iter()
            .enumerate()
            .map(|(k, p)| PointView {
                alpha: p.alpha,
                gamma: p.gamma,
                certified: p.certified,
                sigma: p.sigma,
                error_bound: p.error_bound,
                max_amplitude: p.max_amplitude,
                max_gain: p.max_gain,
                max_step_euler: p.max_step_euler,
                knee: Some(k) == knee,
                seconds: p.seconds,
            })
            .collect(),
        knee,
        seconds_total,
    }
}

/// The text report's summary: the fastest design, the table and the knee.
fn summary(
    name: &str,
    gamma: GammaSpec,
    fastest: &Design,
    top: f64,
    over: Option<f64>,
    sweep: &Tradeoff,
) -> String {
    let fast_gain = fastest.max_gain_norm();
    let mut s = format!(
        "model {}: rate-noise trade-off ({} noise-optimal designs, gamma {}; noise on every output)\n",
        name,
        sweep.points.len(),
        match gamma {
            // The global observer of an LPV plant has no γ (docs/method.md §17).
            _ if fastest.global => "unused (global observer)".into(),
            GammaSpec::Fixed(g) => format!("= {g}"),
            GammaSpec::Search => "searched per point".into(),
        }
    );
    let sup = fastest.practical.as_ref().map_or(top, |p| p.alpha_sup);
    let high = fastest.practical.as_ref().is_some_and(|p| p.high_gain);
    s.push_str(&format!(
        "  alpha = max design: alpha = {:.6} (certified supremum {sup:.6}{}), gamma = {:.6}, max ||L_l||_2 = {:.4}{}\n",
        fastest.alpha,
        if high {
            ", high gain: the sweep stays below the knee returned"
        } else {
            ""
        },
        fastest.gamma,
        fast_gain,
        fastest.noise.as_ref().map_or(String::new(), |n| format!(
            ", ||e(inf)|| per unit noise <= {:.4}",
            n.error_bound
        ))
    ));
    if let Some(r) = over.filter(|r| *r > GAIN_EXCESS) {
        s.push_str(&format!(
            "  the alpha = max design's gains are far above what the knee needs: ||L|| is {r:.0}x the knee design's\n"
        ));
    }
    s.push_str(&table(&sweep.points, sweep.knee));
    match sweep.knee {
        Some(k) => s.push_str(&format!(
            "  knee: alpha = {:.4} (the fastest point whose certified error bound is within 2x the smallest of the sweep)\n",
            sweep.points[k].alpha
        )),
        None => s.push_str("  no point of the sweep certified: no knee\n"),
    }
    s
}

/// Runs `qpv tradeoff`.
pub fn run(o: &Options) -> Result<i32, CliError> {
    if o.points < 2 {
        return Err(CliError::Input(format!(
            "--points {}: expected at least 2",
            o.points
        )));
    }
    if o.points > 200 {
        return Err(CliError::Input(format!(
            "--points {}: at most 200 (each point is a full design)",
            o.points
        )));
    }
    let gamma = o.gamma.unwrap_or(GammaSpec::Search);
    // Every output is checked before the sweep (which can take minutes).
    let json = o.json.as_deref();
    check_json_target(json, &[&o.file])?;
    if let Some(dir) = &o.plot {
        prepare_plot_dir(dir, &["tradeoff.svg".to_string()], &[&o.file])?;
    }
    let (_, model) = load_model(&o.file, o.model.as_deref())?;
    let poly = model.polytopic();
    let settings = qpv_solve::Settings::default();
    let t0 = std::time::Instant::now();
    let base = DesignRequest {
        gamma,
        ..DesignRequest::default()
    };
    let bad = |e: qpv_solve::SolveError| CliError::Input(format!("{}: {e}", o.file.display()));
    let bar = super::design::spinner(format!(
        "{}: the fastest certified design (alpha = max)",
        model.name
    ));
    let fast_request = DesignRequest {
        alpha: AlphaSpec::Max,
        ..base.clone()
    };
    let fastest =
        qpv_solve::backend::with_iteration_progress(super::design::iteration_message(&bar), || {
            qpv_solve::design(&poly, &fast_request, &settings)
        })
        .map_err(bad)?;
    if !fastest.certifies() {
        bar.finish_and_clear();
        print_text(
            json,
            &format!(
                "model {}: NOT CERTIFIED: no certified alpha > 0 (alpha = max), so there is no trade-off to sweep\n",
                model.name
            ),
        );
        return Ok(exit::NOT_CERTIFIED);
    }
    // The certified supremum (the practical α = max reports it); for a
    // high-gain design, whose supremum is reached only as ‖L‖ → ∞, the knee
    // it returned (docs/method.md §11a, §17).
    let top = match fastest.practical.as_ref() {
        Some(p) if p.high_gain => fastest.alpha,
        Some(p) => p.alpha_sup,
        None => fastest.alpha,
    };
    // The range: up to 99 % of the certified supremum, extended below
    // 5 % while the gain still falls steeply ([`Sweep::under`]).
    let channels = NoiseChannels::from_model(&poly);
    let sweep =
        qpv_solve::backend::with_iteration_progress(super::design::iteration_message(&bar), || {
            tradeoff_with_progress(
                &poly,
                &base,
                &channels,
                &Sweep::under(top, o.points),
                &settings,
                &mut |step| {
                    let (what, a) = match *step {
                        SweepStep::Point { index, of, alpha } => {
                            (format!("{}/{of}", index + 1), alpha)
                        }
                        SweepStep::Below { alpha } => ("below the range".into(), alpha),
                    };
                    bar.set_message(format!(
                        "{}: noise-optimal design {what} at alpha = {a:.4}",
                        model.name
                    ));
                    bar.tick();
                },
            )
        })
        .map_err(bad)?;
    bar.finish_and_clear();
    let (points, knee) = (&sweep.points, sweep.knee);
    let knee_gain = knee.and_then(|k| points[k].max_gain);
    let fast_gain = fastest.max_gain_norm();
    let over = knee_gain.filter(|g| *g > 0.0).map(|g| fast_gain / g);
    let mut s = summary(&model.name, gamma, &fastest, top, over, &sweep);
    if let Some(dir) = &o.plot {
        s.push_str(&write_figure(dir, &model.name, points, knee)?);
    }
    let seconds_total = t0.elapsed().as_secs_f64();
    s.push_str(&format!(
        "  {} designs in {seconds_total:.2} s\n",
        points.len() + 1
    ));
    print_text(json, &s);
    let out = json_view(
        &model.name,
        gamma,
        &fastest,
        over,
        points,
        knee,
        seconds_total,
    );
    emit_json(json, &out)?;
    Ok(if knee.is_some() {
        exit::CERTIFIED
    } else {
        exit::NOT_CERTIFIED
    })
}
