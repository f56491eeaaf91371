//! `qpv design`: parse, derive, solve, certify, and report.

use super::input::{by_name, parse_alpha, parse_gamma};
use super::input::{
    check_json_target, emit_json, exit, fmt_matrix, load_model, print_text, CliError,
};
use super::schema::{DesignOutput, NotRun};
use qpv_dsl::{
    AlphaSpec, Clash, Conditions, DesignRequest, GammaSpec, Mode, Model, NoiseObjective,
    OutputFilter, OutputRoute, Split,
};
use qpv_solve::output_filter::OutputRouteInfo;
use qpv_solve::report::{Design, Note};
use qpv_solve::state_bound::StateBoundInfo;
use qpv_solve::vocab::{BoundSource, Phase};
use std::path::PathBuf;

/// The options of `qpv design`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// The model file (.qpv).
    pub file: PathBuf,
    /// Which model of the file (default: the only one, or the first).
    #[arg(long, value_name = "NAME")]
    pub model: Option<String>,
    /// Condition set: sound (default, certifies) or paper (reproduction only).
    #[arg(long, value_name = "sound|paper", value_parser = by_name(&Mode::ALL, Mode::name))]
    pub mode: Option<Mode>,
    /// Decay rate: a number or `max`.
    #[arg(long, value_name = "A|max", allow_hyphen_values = true, value_parser = parse_alpha)]
    pub alpha: Option<AlphaSpec>,
    /// Region scaling: a number in (0,1) or `search`.
    #[arg(long, value_name = "G|search", allow_hyphen_values = true, value_parser = parse_gamma)]
    pub gamma: Option<GammaSpec>,
    /// Representation of N_k, M_k: `as_written`, `symmetric` or
    /// `skew_slack` (symmetric plus a searched skew-symmetric slack;
    /// sound mode) (default: symmetric in sound mode, as_written in
    /// paper mode). Overrides the model's design blocks.
    #[arg(long, value_name = "as_written|symmetric|skew_slack", value_parser = by_name(&Split::ALL, Split::name))]
    pub split: Option<Split>,
    /// Rate conditions solved: `full` (all p² vertex pairs),
    /// `decoupled` (one slack per θ-vertex, 2p blocks; the certificate
    /// still checks all pairs), `cube` (box or zonotope regions: one
    /// pair of slacks per generator, certified on the slack
    /// inequalities) or `auto` (chosen by size; the default, the report
    /// says which). Overrides the model's design blocks.
    #[arg(long, value_name = "full|decoupled|cube|auto", value_parser = by_name(&Conditions::ALL, Conditions::name))]
    pub conditions: Option<Conditions>,
    /// How a θ-dependent output map is handled: `double_sum` (the
    /// double-sum relaxation) or `filter` (output post-filter
    /// augmentation). Overrides the model's design blocks.
    #[arg(long = "output-route", value_parser = ["double_sum", "filter"])]
    pub output_route: Option<String>,
    /// Pole a of the output filter x_y' = −a x_y + b y (implies
    /// `--output-route filter`; default 50).
    #[arg(value_name = "A", long = "filter-pole", allow_hyphen_values = true)]
    pub filter_pole: Option<f64>,
    /// Gain b of the output filter (implies `--output-route filter`;
    /// default: the pole, unit DC gain).
    #[arg(value_name = "B", long = "filter-gain", allow_hyphen_values = true)]
    pub filter_gain: Option<f64>,
    /// Design objective for sensor noise: `min` minimises the certified
    /// noise gain σ at the requested (fixed) alpha and gamma (sound
    /// mode); `rms` minimises the certified RMS error for white noise of
    /// --output-std (and --process-std) drawn every --noise-period
    /// seconds; `free` (default) is the ordinary design. Every certified
    /// sound design reports its noise bound either way.
    #[arg(long, value_name = "min|rms|free", value_parser = by_name(&NoiseObjective::ALL, NoiseObjective::name))]
    pub noise: Option<NoiseObjective>,
    /// With --noise rms: the standard deviation of the white noise on each
    /// noisy output, in its units (S,S,...: one per noisy output, or one
    /// value for all).
    #[arg(
        long = "output-std",
        value_name = "S[,S...]",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub output_std: Vec<f64>,
    /// With --noise rms: the standard deviation of white process noise on
    /// each state (one per state, or one value for all; default none).
    #[arg(
        long = "process-std",
        value_name = "Q[,Q...]",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub process_std: Vec<f64>,
    /// With --noise rms: the period (in the model's unit of time) at which
    /// the noise samples are drawn and held (the white-noise intensity is
    /// std^2 x DT).
    #[arg(long = "noise-period", value_name = "DT", allow_hyphen_values = true)]
    pub noise_period: Option<f64>,
    /// With alpha = max: return the smallest-gain design certified at
    /// alpha >= (1 - WITHIN) x the certified supremum (a fraction, 0 to
    /// 0.5; default 0.01; 0 returns the fastest point found).
    #[arg(long, value_name = "T", allow_hyphen_values = true)]
    pub within: Option<f64>,
    /// Bound every gain: ||L_l||_2 <= G at every vertex, imposed in the
    /// SDP and checked by the certificate from the reported gains.
    #[arg(value_name = "G", long = "max-gain", allow_hyphen_values = true)]
    pub max_gain: Option<f64>,
    /// Design at the sample period H seconds (e.g. 1e-4 for 10 kHz):
    /// the observer stepped by explicit Euler at H is certified by the
    /// discrete decrease V(e_k+1) <= (1 - H alpha) V(e_k) in place of
    /// the continuous rate condition (sound mode, full conditions).
    #[arg(long, value_name = "H", allow_hyphen_values = true)]
    pub sample: Option<f64>,
    /// The largest alpha the search tries (default 1e6): a design that
    /// reaches it says so.
    #[arg(value_name = "A", long = "alpha-cap", allow_hyphen_values = true)]
    pub alpha_cap: Option<f64>,
    /// For a QPV plant, also report the alpha its linear part alone (every
    /// N_k and M_k zero) certifies globally, unbounded and at the design's
    /// largest gain: what the region costs (two more alpha searches).
    #[arg(long = "region-cost")]
    pub region_cost: bool,
    /// Write the JSON report to this file (`-` for stdout).
    #[arg(long, value_name = "OUT")]
    pub json: Option<String>,
}

/// Parses `--output-route`, `--filter-pole` and `--filter-gain` (either
/// filter option implies the filter route).
fn parse_route(
    route: Option<&str>,
    pole: Option<f64>,
    gain: Option<f64>,
) -> Result<Option<OutputRoute>, CliError> {
    let filter = pole.is_some() || gain.is_some();
    match route {
        Some("double_sum") if filter => Err(CliError::Input(
            "--filter-pole/--filter-gain need --output-route filter (not double_sum)".into(),
        )),
        Some("double_sum") => Ok(Some(OutputRoute::DoubleSum)),
        None if !filter => Ok(None),
        _ => {
            let pole = pole.unwrap_or(OutputFilter::DEFAULT_POLE);
            let gain = gain.unwrap_or(pole);
            if !(pole.is_finite() && pole > 0.0) {
                return Err(CliError::Input(format!(
                    "--filter-pole {pole}: expected a positive number"
                )));
            }
            if !(gain.is_finite() && gain != 0.0) {
                return Err(CliError::Input(format!(
                    "--filter-gain {gain}: expected a nonzero number"
                )));
            }
            Ok(Some(OutputRoute::Filter(OutputFilter { pole, gain })))
        }
    }
}

/// A request of `qpv design`, or why it is not run: `skip` says so when an
/// override of the flags does not apply to it.
struct Planned {
    request: DesignRequest,
    skip: Option<String>,
    /// What the flags changed of the model's design block(s), in words.
    overridden: Option<String>,
}

/// The values of the flags that are numbers in a range, checked, and the
/// two flags that exclude each other whatever the request.
fn check_flags(o: &Options) -> Result<(), CliError> {
    let noise_min = o.noise == Some(NoiseObjective::Min);
    if let Some(w) = o.within {
        if !(0.0..=DesignRequest::MAX_WITHIN).contains(&w) {
            return Err(CliError::Input(format!(
                "--within {w}: expected a fraction from 0 (the fastest point found) to {} (e.g. 0.01 for 1 %)",
                DesignRequest::MAX_WITHIN
            )));
        }
    }
    if let Some(g) = o.max_gain {
        if !(g.is_finite() && g > 0.0) {
            return Err(CliError::Input(format!(
                "--max-gain {g}: expected a positive number (the bound on every ||L_l||_2)"
            )));
        }
        if noise_min {
            return Err(CliError::Input(
                "--max-gain with --noise min: the noise SDP has no gain bound".into(),
            ));
        }
    }
    let good = |v: &[f64]| v.iter().all(|s| s.is_finite() && *s > 0.0);
    if !good(&o.output_std) || !good(&o.process_std) {
        return Err(CliError::Input(
            "--output-std/--process-std: expected positive standard deviations, separated by \
             commas (e.g. --output-std 0.01 or --output-std 0.01,0.02)"
                .into(),
        ));
    }
    if let Some(dt) = o.noise_period {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(CliError::Input(format!(
                "--noise-period {dt}: expected a positive period in seconds (e.g. 1e-3)"
            )));
        }
    }
    if let Some(h) = o.sample {
        if !(h.is_finite() && h > 0.0) {
            return Err(CliError::Input(format!(
                "--sample {h}: expected a positive sample period in seconds (e.g. 1e-4 for 10 kHz)"
            )));
        }
    }
    if let Some(cap) = o.alpha_cap {
        let floor = qpv_solve::Settings::default().alpha_floor;
        if !(cap.is_finite() && cap >= floor) {
            return Err(CliError::Input(format!(
                "--alpha-cap {cap}: expected a number of at least {floor} (the largest alpha the \
                 search tries; the search starts at alpha = {floor})"
            )));
        }
    }
    Ok(())
}

/// The flag of `o` that made a request clash ([`DesignRequest::validate`]):
/// the clash's first setting if a flag set it, else its second.
fn culprit(clash: Clash, o: &Options) -> &'static str {
    let noise = ("--noise min", o.noise == Some(NoiseObjective::Min));
    let skew = ("--split skew_slack", o.split == Some(Split::SkewSlack));
    let paper = ("--mode paper", o.mode == Some(Mode::Paper));
    let (first, second) = match clash {
        Clash::SkewSlackPaper => (skew, paper),
        Clash::NoiseMinAlphaMax => (noise, ("--alpha max", o.alpha == Some(AlphaSpec::Max))),
        Clash::NoiseMinPaper => (noise, paper),
        Clash::NoiseMinSkewSlack => (noise, skew),
        Clash::MaxGainNoiseMin => (("--max-gain", o.max_gain.is_some()), noise),
        Clash::MaxGainSkewSlack => (("--max-gain", o.max_gain.is_some()), skew),
        Clash::MaxGainPaper => (("--max-gain", o.max_gain.is_some()), paper),
        Clash::SamplePaper | Clash::SampleCube | Clash::SampleSkewSlack => {
            (("--sample", o.sample.is_some()), noise)
        }
        // `poles` has no flag: the model's design block set it.
        Clash::PolesPaper => (("`poles`", false), paper),
        Clash::PolesNoiseMin => (("`poles`", false), noise),
        Clash::PolesSkewSlack => (("`poles`", false), skew),
        Clash::PolesSample => (("`poles`", false), ("--sample", o.sample.is_some())),
        Clash::RmsKeysWithoutRms
        | Clash::RmsNoOutputStd
        | Clash::RmsNoPeriod
        | Clash::RmsPaper
        | Clash::RmsSkewSlack
        | Clash::RmsMaxGain
        | Clash::RmsPoles
        | Clash::RmsSample => (
            ("--noise rms", o.noise == Some(NoiseObjective::Rms)),
            ("the design block's noise settings", true),
        ),
    };
    if first.1 || !second.1 {
        first.0
    } else {
        second.0
    }
}

/// One request with the overrides of the flags applied: to run, or to
/// skip (an override that does not apply to it), or an error (`--noise
/// min` on a request it cannot answer).
fn plan(
    mut r: DesignRequest,
    o: &Options,
    route: Option<OutputRoute>,
) -> Result<Planned, CliError> {
    let skip = |r: DesignRequest, why: String| {
        Ok(Planned {
            request: r,
            skip: Some(why),
            overridden: None,
        })
    };
    if let Some(w) = o.within {
        if r.alpha != AlphaSpec::Max {
            return skip(
                r,
                "--within applies to alpha = max requests only (this one has a fixed alpha)".into(),
            );
        }
        r.within = w;
    }
    if let Some(s) = o.split {
        r.split = s;
    }
    if let Some(c) = o.conditions {
        r.conditions = c;
    }
    if let Some(x) = route {
        r.output_route = x;
    }
    if let Some(n) = o.noise {
        r.noise = n;
    }
    if !o.output_std.is_empty() {
        r.output_std = o.output_std.clone();
    }
    if !o.process_std.is_empty() {
        r.process_std = o.process_std.clone();
    }
    if let Some(dt) = o.noise_period {
        r.noise_period = Some(dt);
    }
    if let Some(g) = o.max_gain {
        r.max_gain = Some(g);
    }
    if let Some(h) = o.sample {
        r.sample = Some(h);
    }
    match r.validate() {
        Ok(()) => Ok(Planned {
            request: r,
            skip: None,
            overridden: None,
        }),
        Err(Clash::NoiseMinAlphaMax) => Err(CliError::Input(format!(
            "--noise min needs a fixed alpha ({r}): alpha = max is the fastest design, not a \
             noise trade-off; give --alpha below the maximum, or sweep with `qpv tradeoff`"
        ))),
        Err(Clash::NoiseMinSkewSlack) => Err(CliError::Input(format!(
            "--noise min with split = skew_slack ({r}): use --split symmetric or as_written"
        ))),
        Err(c @ (Clash::RmsNoOutputStd | Clash::RmsNoPeriod | Clash::RmsKeysWithoutRms)) => Err(
            CliError::Input(format!("{c} (flags: --output-std, --noise-period)")),
        ),
        Err(clash) => {
            let why = format!("{} does not apply here: {clash}", culprit(clash, o));
            skip(r, why)
        }
    }
}

/// The requests to run: without `--mode`, `--alpha`, `--gamma`, the model's
/// own `design` blocks (or α = max, γ = search, sound if it has none); with
/// any of them, one request built from the flags alone, the unspecified
/// ones taking those same defaults. The other flags then override their
/// setting in every request; a request one does not apply to (the rules of
/// [`DesignRequest::validate`]: `--split skew_slack` on a paper-mode
/// request) is skipped, and it is an error if that leaves nothing to run.
fn requests(model: &Model, o: &Options) -> Result<Vec<Planned>, CliError> {
    check_flags(o)?;
    let default = DesignRequest::default();
    let reqs = if o.mode.is_none() && o.alpha.is_none() && o.gamma.is_none() {
        if model.designs.is_empty() {
            vec![default]
        } else {
            model.designs.clone()
        }
    } else {
        let mut r = default;
        if let Some(m) = o.mode {
            r.mode = m;
            r.split = Split::default_for(m);
        }
        if let Some(a) = o.alpha {
            r.alpha = a;
        }
        if let Some(g) = o.gamma {
            r.gamma = g;
        }
        vec![r]
    };
    let route = parse_route(o.output_route.as_deref(), o.filter_pole, o.filter_gain)?;
    let blocks = reqs.clone();
    let mut plan: Vec<Planned> = reqs
        .into_iter()
        .map(|r| plan(r, o, route))
        .collect::<Result<_, _>>()?;
    if o.mode.is_some() || o.alpha.is_some() || o.gamma.is_some() {
        // one request from the flags in place of the model's blocks
        let changes: Vec<String> = (1..)
            .zip(&model.designs)
            .map(|(k, b)| (k, overridden(b, &plan[0].request)))
            .filter(|(_, c)| !c.is_empty())
            .map(|(k, c)| format!("design block {k}: {}", c.join(", ")))
            .collect();
        if !changes.is_empty() {
            plan[0].overridden = Some(format!(
                "--mode/--alpha/--gamma replace the model's design blocks, so their settings are not used unless a flag gives them: {}",
                changes.join("; ")
            ));
        }
    } else if !model.designs.is_empty() {
        for (k, (p, b)) in (1..).zip(plan.iter_mut().zip(&blocks)) {
            let c = overridden(b, &p.request);
            if !c.is_empty() {
                p.overridden = Some(format!(
                    "command-line flags override design block {k}: {}",
                    c.join(", ")
                ));
            }
        }
    }
    if plan.iter().all(|p| p.skip.is_some()) {
        let reason = plan.iter().find_map(|p| p.skip.as_deref()).unwrap_or("");
        return Err(CliError::Input(format!("nothing to run: {reason}")));
    }
    Ok(plan)
}

/// The settings of a request as `key = value` items, keyed, from its
/// `design`-block form (`alpha = max(within = 0); gamma = search; ...`).
fn setting_items(r: &DesignRequest) -> Vec<(String, String)> {
    r.to_string()
        .split("; ")
        .map(|item| {
            let key = item.split(" = ").next().unwrap_or(item).to_string();
            (key, item.to_string())
        })
        .collect()
}

/// What the request run changed of a model's design block: every setting
/// of the block the run does not keep, as "max_gain = 50 dropped" or
/// "split = as_written -> split = symmetric".
fn overridden(block: &DesignRequest, run: &DesignRequest) -> Vec<String> {
    let now = setting_items(run);
    setting_items(block)
        .into_iter()
        .filter_map(|(key, item)| match now.iter().find(|(k, _)| *k == key) {
            None => Some(format!("{item} dropped")),
            Some((_, other)) if *other != item => Some(format!("{item} -> {other}")),
            Some(_) => None,
        })
        .collect()
}

/// Whether a design error is an outcome about the plant rather than bad
/// input: a `state_bound auto` that found no usable state bound (exit 1,
/// like any design that is not certified). `SolveError::StateBound` is
/// exactly that class; refused inputs are `StateBoundInput`.
fn is_outcome(e: &qpv_solve::SolveError) -> bool {
    matches!(e, qpv_solve::SolveError::StateBound(_))
}

/// The output-route line of a design report (nothing for a constant
/// output map designed by the single sum).
fn describe_route(r: &OutputRouteInfo) -> String {
    match &r.filter {
        Some(f) => {
            let h: Vec<String> = f.bound.iter().map(|h| format!("{h:.4e}")).collect();
            format!(
                "  output route: filter x_y' = -{} x_y + {} y; observer states: {}; filter-state bound [{}]\n",
                f.pole,
                f.gain,
                r.states.join(", "),
                h.join(", ")
            )
        }
        None if r.output_varies => format!(
            "  output route: double sum (C or M_k depend on theta; {} rate combinations per vertex pair)\n",
            r.combinations
        ),
        None => String::new(),
    }
}

/// The state bound lines of a design report.
fn describe_state_bound(sb: &StateBoundInfo) -> String {
    let gmax = sb.gamma_max.map_or("-".to_string(), |g| format!("{g:.6}"));
    let mut s = match sb.source {
        BoundSource::Auto => format!(
            "  state bound: computed (state_bound auto): h = {}{}, gamma_max = {gmax} \
             (solver estimate for any ellipsoid around the region: {:.6}), invariance with N_k {}, \
             {} solver calls, {:.3} s\n",
            qpv_dsl::fmt_sig(sb.h.unwrap_or(f64::NAN), 6),
            if sb.h_fixed {
                " (fixed)"
            } else {
                " (searched)"
            },
            sb.gamma_upper.unwrap_or(f64::NAN),
            sb.split.unwrap_or(Split::AsWritten).name(),
            sb.solves,
            sb.seconds
        ),
        BoundSource::Given => format!("  state bound: given, gamma_max = {gmax}\n"),
        BoundSource::None => "  state bound: none\n".to_string(),
    };
    if let (Some(q), BoundSource::Auto) = (&sb.q, sb.source) {
        s.push_str(&format!(
            "  Q:\n{}",
            fmt_matrix(&qpv_solve::report::rows_to_matrix(q), "    ")
        ));
    }
    s
}

/// The line on the continuous plant sampled at h (docs/method.md §16):
/// the truncation error per step, the ultimate error bound and the
/// assumptions; or nothing if it was not computed (the design's notes say
/// why).
pub(crate) fn continuous_line(
    h: f64,
    b: Option<&qpv_solve::report::continuous::ContinuousBound>,
) -> String {
    let Some(b) = b else {
        return String::new();
    };
    let verdict = if b.global {
        format!(
            "the global observer's recursion holds for every e, and lim sup |e_k| <= {:.4e} (sqrt V <= {:.4e}; {:.4e} per unit h)",
            b.ultimate_error,
            b.ultimate_v_sqrt,
            b.ultimate_error / h
        )
    } else if b.invariant {
        format!(
            "the certified set stays invariant and lim sup |e_k| <= {:.4e} (sqrt V <= {:.4e}; {:.4e} per unit h)",
            b.ultimate_error,
            b.ultimate_v_sqrt,
            b.ultimate_error / h
        )
    } else {
        format!(
            "NOT bounded: the truncation error per step in sqrt V ({:.4e}) exceeds the contraction 1 - sqrt(1 - h alpha); a shorter h is needed",
            b.delta
        )
    };
    let noise = match (b.noise_amplitude_max, b.noise_per_unit) {
        (Some(nu), Some(per)) if b.holds() && nu > 0.0 => format!(
            "  with noise of amplitude nu <= {}: lim sup |e_k| <= {:.4e} + {:.4e} nu (the two bounds add)\n",
            if nu.is_finite() { format!("{nu:.4e}") } else { "any".into() },
            b.ultimate_error,
            per
        ),
        (Some(_), Some(_)) => "  with noise: no amplitude keeps the certified set invariant against the truncation error\n".into(),
        _ => String::new(),
    };
    format!(
        "  continuous plant sampled at h: Euler truncation error |r_k| <= {:.4e} per step (|x''| <= {:.4e} over F x Theta): {verdict}\n{noise}  assumes: {}\n",
        b.truncation,
        b.accel,
        b.assumption()
    )
}

/// The verdict line(s) of a design: what is certified and how, once.
fn describe_verdict(d: &Design) -> String {
    let searched = search_counts(d);
    let families: Vec<&str> = d.margins.keys().map(|f| f.name()).collect();
    match (d.feasible(), d.mode) {
        (true, Mode::Sound) if d.sample.is_some() => {
            let s = d.sample.unwrap_or(qpv_solve::certificate::sampling::SampleInfo::new(f64::NAN, d.alpha));
            // The global observer has no γ and no data check S4.
            let (head, at, data) = if d.global {
                (
                    "CERTIFIED, GLOBAL",
                    " for every initial error (LPV plant: no region, state bound or gamma)".to_string(),
                    "",
                )
            } else {
                ("CERTIFIED", format!(" at gamma = {:.6}", d.gamma), " and the data check S4")
            };
            format!(
                "  {head} at {}: alpha = {:.6} per {}{at}, V(e_k+1) <= {:.6} V(e_k) per step for the observer stepped by explicit Euler at h (the discrete decrease S5d in place of S5): every condition family holds ({}){data}, by the independent eigenvalue check of the reported P and L_l; {searched}\n{}",
                s.describe(d.time_unit),
                d.alpha,
                d.time_unit.singular(),
                s.decrease,
                families.join(", "),
                practical_line(d)
            ) + &continuous_line(s.h, s.continuous_bound.as_ref())
        }
        (true, Mode::Sound) if d.global => format!(
            "  CERTIFIED, GLOBAL: alpha = {:.6} for every initial error (LPV plant: no region, state bound or gamma): \
             P > 0 and the rate family hold ({}), by the independent eigenvalue check of the reported P and L_l; \
             {searched}\n{}",
            d.alpha,
            families.join(", "),
            practical_line(d)
        ),
        (true, Mode::Sound) => format!(
            "  CERTIFIED: alpha = {:.6} at gamma = {:.6}: every sound condition family holds ({}) and the data check S4, \
             by the independent eigenvalue check of the reported P and L_l; {searched}\n{}",
            d.alpha,
            d.gamma,
            families.join(", "),
            practical_line(d)
        ),
        (true, Mode::Paper) => format!(
            "  the paper's printed conditions hold at alpha = {:.6}, gamma = {:.6} (reproduction: no convergence claim)\n",
            d.alpha, d.gamma
        ),
        (false, _) => {
            let tested = d.search.iter().any(|s| s.phase == Phase::Final);
            if tested && d.global {
                format!(
                    "  no certified global observer at the requested alpha = {} (LPV plant)\n",
                    d.alpha
                )
            } else if tested {
                format!(
                    "  no certified observer at the requested alpha = {}, gamma = {:.6}\n",
                    d.alpha, d.gamma
                )
            } else {
                "  no certified observer: no alpha > 0 could be certified\n".to_string()
            }
        }
    }
}

/// The counts of a design's search log, each with one meaning: solver
/// calls (every SDP solved, whatever its status), the points they returned
/// (status solved), and of those the ones the independent certificate
/// rejected.
fn counts(d: &Design) -> (usize, usize, usize) {
    let returned = |s: &&qpv_solve::SearchStep| s.status == qpv_solve::Status::Solved;
    let calls = d.search.len();
    let solved = d.search.iter().filter(returned).count();
    let rejected = d
        .search
        .iter()
        .filter(returned)
        .filter(|s| !s.certified)
        .count();
    (calls, solved, rejected)
}

/// The counts of [`counts`] in words.
fn search_counts(d: &Design) -> String {
    let (calls, returned, rejected) = counts(d);
    format!(
        "the search made {calls} solver call(s), {returned} returned a point, {rejected} of those rejected by that check and not used"
    )
}

/// The one line a user steps an observer by: α (and, for the practical
/// α = max, its share of the certified supremum), the largest gain, the
/// certified Euler step.
fn practical_line(d: &Design) -> String {
    let gain = d.max_gain_norm();
    let alpha = match &d.practical {
        Some(p) => format!(
            "alpha = {} ({:.1} % of {} {}{})",
            sig(d.alpha),
            100.0 * d.alpha / p.alpha_sup,
            if p.capped {
                "the search's cap"
            } else {
                "the certified supremum"
            },
            sig(p.alpha_sup),
            if p.high_gain {
                "; high gain near it: the knee is returned"
            } else {
                ""
            }
        ),
        None => format!("alpha = {}", sig(d.alpha)),
    };
    let step = match &d.sampling {
        Some(sp) if sp.max_step_euler > 0.0 => {
            format!(
                ", Euler step <= {}",
                d.time_unit.duration(sp.max_step_euler)
            )
        }
        _ => String::new(),
    };
    let bound = d
        .max_gain
        .map(|g| format!(" (bound {})", sig(g)))
        .unwrap_or_default();
    format!("  {alpha}, ||L|| <= {}{bound}{step}\n", sig(gain))
}

/// Three significant digits ([`qpv_dsl::fmt_sig`]).
fn sig(v: f64) -> String {
    qpv_dsl::fmt_sig(v, 3)
}

/// The margins of a design that failed: per family, of its best attempt.
fn describe_failure_margins(d: &Design) -> String {
    let mut s = String::new();
    if d.margins.is_empty() {
        let (calls, returned, _) = counts(d);
        s.push_str(&if returned > 0 {
            format!(
                "  {returned} of the {calls} solver call(s) returned a point, and none passed the independent certificate: no certified margins to show\n"
            )
        } else {
            format!("  none of the {calls} solver call(s) returned a point, so there are no margins to show\n")
        });
        return s;
    }
    let at = d
        .search
        .iter()
        .rev()
        .find(|st| st.phase == Phase::Diagnose || st.phase == Phase::Final)
        .map(|st| format!(" (tried at alpha {}, gamma {:.6})", st.alpha, st.gamma))
        .unwrap_or_default();
    s.push_str(&format!(
        "  margins of the best attempt{at}, per condition family (positive = satisfied):\n"
    ));
    for (k, v) in &d.margins {
        s.push_str(&format!(
            "    {k:<12} {v:>13.4e}  {}\n",
            if *v > 0.0 { "pass" } else { "FAIL" }
        ));
    }
    s
}

/// The noise and sampling lines of a certified sound design (nothing for
/// any other design: an uncertified design carries no bound).
pub(super) fn describe_noise(d: &Design) -> String {
    let mut s = String::new();
    if !(d.certifies() && d.mode == Mode::Sound) {
        return s;
    }
    if let Some(nb) = &d.noise {
        let claim = if d.sample.is_some() {
            "V(e_k+1) - (1 - h alpha) V(e_k) <= h sigma (|v_k|^2 + |w_k|^2), noise held over each step"
        } else {
            "V' + alpha V <= sigma (|v|^2 + |w|^2)"
        };
        s.push_str(&format!(
            "  noise (certified, {claim} {}; noisy outputs: {}{}):\n",
            if d.global {
                "for every e (global)"
            } else {
                "on the region"
            },
            if nb.noisy_outputs.is_empty() {
                "none".to_string()
            } else {
                nb.noisy_outputs.join(", ")
            },
            if nb.disturbances > 0 {
                format!("; {} disturbance input(s)", nb.disturbances)
            } else {
                String::new()
            }
        ));
        s.push_str(&format!("    sigma                 {:.6e}\n", nb.sigma));
        s.push_str(&format!(
            "    ||e(inf)|| per unit noise amplitude <= {:.4}\n",
            nb.error_bound
        ));
        s.push_str(&match nb.max_amplitude.is_finite() {
            true => format!(
                "    nu_max (largest noise amplitude keeping the region invariant) = {:.4e}\n",
                nb.max_amplitude
            ),
            false => {
                "    nu_max: unlimited (the global observer's claim holds for every e)\n".into()
            }
        });
        let per: Vec<String> = nb.per_state.iter().map(|v| format!("{v:.4}")).collect();
        s.push_str(&format!(
            "    per-state |e_k(inf)| per unit noise <= [{}]\n",
            per.join(", ")
        ));
    }
    if let Some(b) = &d.rms {
        let std: Vec<String> = b
            .noise
            .output_std
            .iter()
            .map(|v| format!("{v:.4e}"))
            .collect();
        s.push_str(&format!(
            "  RMS error (certified, time-averaged, white noise std [{}] on output(s) {} every {} {}{}; while x in F and e in the region/gamma):\n",
            std.join(", "),
            b.noise.outputs.iter().map(|o| (o + 1).to_string()).collect::<Vec<_>>().join(", "),
            b.noise.period,
            d.time_unit.symbol(),
            if b.noise.process_std.is_empty() { String::new() } else { ", with process noise".to_string() }
        ));
        s.push_str(&format!("    total RMS <= {:.4e}\n", b.total));
        let per: Vec<String> = b.per_state.iter().map(|v| format!("{v:.4e}")).collect();
        s.push_str(&format!("    per-state RMS <= [{}]\n", per.join(", ")));
    }
    if let Some(why) = qpv_solve::report::figures::no_noise_bound(d) {
        s.push_str(&format!(
            "  noise: none certified: {why}; {}\n",
            qpv_solve::report::NOISE_MIN_ADVICE
        ));
    }
    if let Some(sp) = &d.sampling {
        s.push_str(&format!(
            "  sampling: largest Euler step h = {:.4e} (certified: V contracts by (1 - h beta) per step, beta = {:.4}, \
             plant and observer discretised by the same Euler step); RK4 step estimate {:.4e} (an estimate, \
             frozen vertex dynamics, not a proof)\n",
            sp.max_step_euler, sp.beta, sp.step_estimate_rk4
        ));
    }
    s
}

/// The data checks and the diagnosis of a design, one line each.
fn describe_checks(d: &Design) -> String {
    let mut s = String::new();
    if !d.data_checks.is_empty() {
        s.push_str("  data checks:\n");
        for (k, c) in &d.data_checks {
            s.push_str(&format!(
                "    {k:<12} value {:>10.4} <= {:<6} {}{}  ({})\n",
                c.value,
                c.bound,
                if c.passed { "pass" } else { "FAIL" },
                if c.required { "" } else { " (not required)" },
                c.description
            ));
        }
    }
    if let Some(found) = d.diagnosis.as_ref().filter(|f| !f.is_empty()) {
        s.push_str("  diagnosis:\n");
        for f in found {
            s.push_str(&format!(
                "    {}{}\n",
                if f.blocking { "BLOCKING: " } else { "" },
                f.message
            ));
        }
    }
    s
}

/// A human-readable report of one design.
pub fn describe_design(d: &Design) -> String {
    let mut s = String::new();
    let verdict = match (d.feasible(), d.mode) {
        (true, Mode::Sound) => "CERTIFIED".to_string(),
        (true, Mode::Paper) => {
            "satisfies the paper's printed conditions (reproduction mode: certifies nothing)".into()
        }
        (false, _) => "NOT CERTIFIED".to_string(),
    };
    s.push_str(&format!(
        "model {} ({} mode): {verdict}\n",
        d.model,
        d.mode.name()
    ));
    s.push_str(&describe_verdict(d));
    s.push_str(&format!(
        "  split = {}, conditions = {}\n",
        d.split.name(),
        match d.conditions {
            Conditions::Full | Conditions::Auto => "full (all vertex pairs)",
            Conditions::Decoupled => "decoupled (certified on all vertex pairs)",
            Conditions::Cube => "cube (zonotope slacks; certified on the slack inequalities)",
        }
    ));
    if let Some(why) = d
        .notes
        .iter()
        .find(|n| matches!(n, Note::ConditionsChosen(_)))
    {
        s.push_str(&format!("  {why}\n"));
    }
    if let Some(r) = &d.output_route {
        s.push_str(&describe_route(r));
    }
    if d.global {
        s.push_str(
            "  global observer (LPV plant): no region, state bound or gamma; \
             the decay holds for every initial error\n",
        );
    } else if let Some(sb) = &d.state_bound {
        s.push_str(&describe_state_bound(sb));
    }
    if d.feasible() && !d.p.is_empty() {
        s.push_str(&format!("  P:\n{}", fmt_matrix(&d.p_matrix(), "    ")));
        for (l, m) in d.l_matrices().iter().enumerate() {
            let norm = d.gain_norms.get(l).copied().unwrap_or(f64::NAN);
            s.push_str(&format!(
                "  L_{} (||L||_2 = {norm:.4}):\n{}",
                l + 1,
                fmt_matrix(m, "    ")
            ));
        }
    }
    if d.feasible() && !d.margins.is_empty() {
        s.push_str("  condition families (worst margin, positive = satisfied):\n");
        for (k, v) in &d.margins {
            s.push_str(&format!(
                "    {k:<12} {v:>13.4e}  {}\n",
                if *v > 0.0 { "pass" } else { "FAIL" }
            ));
        }
    }
    if !d.feasible() {
        s.push_str(&describe_failure_margins(d));
    }
    s.push_str(&describe_noise(d));
    s.push_str(&describe_checks(d));
    if d.feasible() {
        s.push_str(&format!(
            "  solver calls: {} in {:.3} s; the reported point: {} iterations, {:.3} s (the search log is in the JSON report)\n",
            d.search.len(),
            d.seconds_total,
            d.solver.iterations,
            d.solver.seconds
        ));
    } else {
        s.push_str(&format!(
            "  solver calls: {} in {:.3} s; the last one ended {} (Clarabel: {}); a solver status says whether a point \
             was returned, not whether it certifies\n",
            d.search.len(),
            d.seconds_total,
            d.solver.status,
            d.solver.detail
        ));
    }
    if let Some(g) = &d.gamma_search {
        s.push_str(&format!("  {}\n", g.statement()));
    }
    for n in d
        .notes
        .iter()
        // the γ search's statement has its own line above
        // and so has a missing noise bound's reason (with the noise figures)
        .filter(|n| {
            !(matches!(n, Note::GammaSearch(_) | Note::NoNoiseBound(_))
                || (d.feasible() && n.is_search_log()))
        })
    {
        s.push_str(&format!("  note: {n}\n"));
    }
    s
}

/// Above this estimated time per solve (seconds) a command says so
/// before the first solve.
const SLOW_NOTICE_SECONDS: f64 = 20.0;

/// The notice a request predicted to be slow prints (on stderr) before
/// its first solve, from the size estimate; None for a request that is
/// not (`qpv design`, `qpv codegen`).
pub(super) fn slow_notice(
    poly: &qpv_dsl::PolytopicModel,
    request: &qpv_dsl::DesignRequest,
    number: usize,
) -> Option<String> {
    let size = qpv_solve::model::size::estimate(poly, request);
    (size.seconds_per_solve > SLOW_NOTICE_SECONDS).then(|| {
        format!(
            "note: design request {number} is large ({:.3e} PSD blocks, {:.3e} constraint \
             nonzeros): about {:.0} s per solve on this estimate, and a search runs several \
             solves",
            size.psd_blocks + size.psd_blocks_plus,
            size.nonzeros,
            size.seconds_per_solve
        )
    })
}

/// A spinner on stderr (drawn only on a terminal) with the elapsed time
/// and `message`, ticking on its own between updates.
pub(super) fn spinner(message: String) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} {elapsed} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    bar.set_message(message);
    bar.enable_steady_tick(std::time::Duration::from_millis(250));
    bar
}

/// The spinner's message after each iteration of a long solve: the
/// message the last solve left, then the running solve's iteration and
/// relative duality gap (a search reports between solves only, and one
/// solve of a large design takes minutes).
pub(super) fn iteration_message(
    bar: &indicatif::ProgressBar,
) -> impl FnMut(&qpv_solve::backend::Iteration) + 'static {
    let bar = bar.clone();
    let started = std::time::Instant::now();
    move |it| {
        // Quiet for solves that are quick anyway.
        if started.elapsed().as_secs_f64() < 2.0 {
            return;
        }
        let base = bar.message();
        let base = base.split(" | solving:").next().unwrap_or("");
        bar.set_message(format!(
            "{base} | solving: iteration {}, relative gap {:.1e}",
            it.number, it.gap_rel
        ));
    }
}

/// Runs `qpv design`.
pub fn run(o: &Options) -> Result<i32, CliError> {
    let json = o.json.as_deref();
    check_json_target(json, &[&o.file])?;
    let (_, model) = load_model(&o.file, o.model.as_deref())?;
    let plan = requests(&model, o)?;
    let poly = model.polytopic();
    let mut settings = qpv_solve::Settings::default();
    if let Some(cap) = o.alpha_cap {
        settings.alpha_cap = cap;
    }
    settings.region_cost = o.region_cost;
    let mut designs = Vec::new();
    let mut skipped = Vec::new();
    let mut failures = Vec::new();
    for (
        number,
        Planned {
            request: r,
            skip,
            overridden,
        },
    ) in (1..).zip(&plan)
    {
        let not_run = |reason: String| NotRun {
            request: number,
            settings: r.to_string(),
            reason,
        };
        if let Some(reason) = skip {
            print_text(
                json,
                &format!("skipping design request {number} ({r}): {reason}\n"),
            );
            skipped.push(not_run(reason.clone()));
            continue;
        }
        // The solver's clock runs between solves too; a request predicted
        // to be slow says so before its first solve (on stderr, so that
        // `--json -` stays one document).
        let bar = spinner(format!("designing {} ({r})", model.name));
        if let Some(notice) = slow_notice(&poly, r, number) {
            bar.suspend(|| eprintln!("{notice}; progress follows"));
        }
        let mut n = 0usize;
        let mut progress = |step: &qpv_solve::SearchStep| {
            n += 1;
            bar.set_message(format!(
                "solve {n}: {} gamma = {:.4}, alpha = {:.4}: {}{}",
                step.phase,
                step.gamma,
                step.alpha,
                step.status,
                if step.certified { ", certified" } else { "" }
            ));
            bar.tick();
        };
        let result = qpv_solve::backend::with_iteration_progress(iteration_message(&bar), || {
            qpv_solve::design_with_progress(&poly, r, &settings, &mut progress)
        });
        bar.finish_and_clear();
        match result {
            Ok(mut d) => {
                if let Some(note) = overridden {
                    d.notes.push(note.clone());
                }
                print_text(json, &describe_design(&d));
                designs.push(d);
            }
            Err(e) if is_outcome(&e) => {
                print_text(
                    json,
                    &format!(
                        "model {} (design request {number}): NOT CERTIFIED: {e}\n",
                        model.name
                    ),
                );
                failures.push(not_run(e.to_string()));
            }
            Err(e) => return Err(CliError::Input(format!("{}: {e}", o.file.display()))),
        }
    }
    emit_json(
        json,
        &DesignOutput::new(&model.name, &designs, &skipped, &failures),
    )?;
    Ok(
        if failures.is_empty() && designs.iter().all(|d| d.feasible()) {
            exit::CERTIFIED
        } else {
            exit::NOT_CERTIFIED
        },
    )
}
