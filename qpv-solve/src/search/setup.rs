//! A request checked and its observer's model built, before any solve:
//! the one setup of every objective (decay, gain, noise), with the size
//! guard, the observer's kind, the unit balancing and the γ range computed
//! once ([`Setup::new`]), and the request as it is solved ([`prepare`]).

use crate::conditions::ConditionSet;
use crate::error::SolveError;
use crate::lmi::{Objective, Problem};
use crate::model::output_filter::OutputRouteInfo;
use crate::model::state_bound::StateBoundInfo;
use crate::model::{
    gamma_max, ObserverKind, ObserverModel, ObserverOptions, StateBoundClaim, StateScaling,
};
use crate::report::{Note, Notes};
use crate::settings::Settings;
use crate::vocab::BoundSource;
use qpv_dsl::{
    AlphaSpec, Conditions, DesignRequest, GammaSpec, Mode, PolytopicModel, Split, StateBound,
};

/// A request checked and its observer's model built, before any solve.
pub(super) struct Setup {
    /// The model the conditions are solved and certified on.
    pub model: PolytopicModel,
    /// The state bound used, for the report.
    pub bound_info: StateBoundInfo,
    /// The output route used, for the report.
    pub route_info: OutputRouteInfo,
    /// The size guard's "slow" warning, if any.
    pub size_note: Option<String>,
    /// γ_max from (S4), if the model has a state bound.
    pub gmax: Option<f64>,
    /// The top of the γ search's range.
    pub gamma_hi: f64,
    /// Which observer the request builds ([`ObserverKind::of`], decided
    /// here once).
    pub kind: ObserverKind,
    /// A badly scaled model in balanced coordinates x = D z, with D
    /// ([`StateScaling`]): the problem is solved there, its points mapped
    /// back, and certified on `model`.
    pub scaled: Option<(PolytopicModel, StateScaling)>,
}

impl Setup {
    /// Validates the model and the request, applies the size guard, and
    /// builds the observer's model: `state_bound auto` computed (then used
    /// as given), the output route (the model itself or its augmentation by
    /// the output post-filter), the requested representation of N_k, M_k.
    pub fn new(
        model: &PolytopicModel,
        request: &DesignRequest,
        settings: &Settings,
    ) -> Result<Setup, SolveError> {
        let set = ConditionSet::from_mode(request.mode);
        crate::model::validate(model)?;
        let kind = ObserverKind::of(model, request.mode);
        let global = kind.is_global();
        if request.mode == Mode::Paper && !model.has_region() {
            return Err(SolveError::PaperWithoutRegion(model.name.clone()));
        }
        let global_model = crate::model::global_model(model);
        let model: &PolytopicModel = if global { &global_model } else { model };
        // Refuse before anything is assembled or solved (with the vertices
        // a Jacobian box on the set S adds counted).
        let expanded = model
            .jacobian_needs_set()
            .then(|| crate::model::jacobian::expand(model.clone(), None).ok())
            .flatten();
        let size_note = match crate::model::size::guard(expanded.as_ref().unwrap_or(model), request)
        {
            crate::model::size::Verdict::TooLarge(m) => return Err(SolveError::TooLarge(m)),
            crate::model::size::Verdict::Slow(m) => Some(m),
            crate::model::size::Verdict::Fits => None,
        };
        let prepared = ObserverModel::prepare(
            model,
            &ObserverOptions::for_request(request),
            StateBoundClaim::Compute(settings),
        )?;
        let model = match request.gamma {
            GammaSpec::Fixed(g) if prepared.model.jacobian_needs_set() => {
                crate::model::jacobian::expand(prepared.model, Some(g))?
            }
            _ => prepared.model,
        };
        let has_q = matches!(model.state_bound, StateBound::Given(_));
        if set.requires_s4() && !has_q && !global {
            return Err(SolveError::MissingStateBound(model.name.clone()));
        }
        if let AlphaSpec::Fixed(a) = request.alpha {
            if !(a.is_finite() && a > 0.0) {
                return Err(SolveError::BadAlpha(a));
            }
            if let Some(h) = request.sample.filter(|h| h * a >= 1.0) {
                return Err(SolveError::StepTooLong { h, alpha: a });
            }
        }
        if let (GammaSpec::Fixed(g), false) = (request.gamma, global) {
            if !(g.is_finite() && g > 0.0 && g < 1.0) {
                return Err(SolveError::BadGamma(g));
            }
        }
        let gmax = gamma_max(&model);
        let gamma_hi = match set {
            ConditionSet::Sound if global => 1.0,
            ConditionSet::Sound => {
                let gm = gmax.unwrap_or(f64::NAN);
                let usable = gm.is_finite() && gm > 0.0;
                if !usable && matches!(request.gamma, GammaSpec::Search) {
                    return Err(SolveError::NoGammaRange(gm));
                }
                gm.min(1.0) * (1.0 - 1e-6)
            }
            ConditionSet::Paper => 1.0 - 1e-6,
        };
        let scaled = StateScaling::of(&model, request.mode)
            .and_then(|sc| sc.model(&model).map(|zm| (zm, sc)));
        Ok(Setup {
            scaled,
            kind,
            model,
            bound_info: prepared.state_bound,
            route_info: prepared.output_route,
            size_note,
            gmax,
            gamma_hi,
        })
    }

    /// The problem of the request's conditions. Full: all N p² rate blocks;
    /// decoupled: N·2p blocks with a slack Z_l per θ-vertex (sufficient).
    /// The certificate checks the full family either way.
    pub fn problem(&self, request: &DesignRequest) -> Result<Problem<'_>, SolveError> {
        let (model, scaling) = match &self.scaled {
            Some((zm, sc)) => (zm, Some(sc.clone())),
            None => (&self.model, None),
        };
        Problem::new(model, ConditionSet::from_mode(request.mode))?
            .with_conditions(request.conditions)?
            .with_max_gain(request.max_gain)
            .with_poles(&request.poles)
            .with_scaling(scaling)
            .with_sample(request.sample)
    }

    /// The notes that follow from the setup alone: the size warning, the
    /// computed state bound, the output route, the split, the conditions.
    pub(super) fn notes(&self, request: &DesignRequest, prob: &Problem<'_>) -> Vec<String> {
        let (bound_info, route_info) = (&self.bound_info, &self.route_info);
        let mut notes: Vec<String> = Vec::new();
        notes.extend(self.size_note.clone());
        if let Some((_, sc)) = self.scaled.as_ref().filter(|_| !self.kind.is_global()) {
            let d: Vec<String> = sc.d.iter().map(|v| format!("{v:e}")).collect();
            notes.push(format!(
                "units: the region's extents per state are far from 1, so the conditions were solved in balanced coordinates x = D z, D = diag({}) (exact: powers of two), and P, L_l mapped back and certified in the model's own coordinates",
                d.join(", ")
            ));
        }
        if bound_info.source == BoundSource::Auto {
            notes.push(format!(
                "state bound computed (state_bound auto): h = {}, γ_max = {:.6}, in {} solver calls, {:.3} s",
                qpv_dsl::fmt_sig(bound_info.h.unwrap_or(f64::NAN), 6),
                bound_info.gamma_max.unwrap_or(f64::NAN),
                bound_info.solves,
                bound_info.seconds
            ));
            notes.extend(bound_info.notes.iter().cloned());
        }
        if let Some(f) = &route_info.filter {
            let bound: Vec<String> = f.bound.iter().map(|h| format!("{h:.4e}")).collect();
            notes.push(format!(
                "output post-filter x_y' = −{} x_y + {} y on every output: designed for the augmented plant ({} states: {}), measurement ỹ = x_y; region extended as (x_(i), 0) for the errors (the observer starts its filter estimate at the filter state) and P × R^ny for E and F, exact since no condition reads the filter coordinates; filter-state bound |x_y| ≤ [{}]",
                f.pole,
                f.gain,
                route_info.states.len(),
                route_info.states.join(", "),
                bound.join(", ")
            ));
        } else if route_info.output_varies {
            notes.push(format!(
                "C or M_k depend on θ: double-sum relaxation, {} rate combinations per vertex pair (Ξ_ll ≺ 0, (2/(r−1))Ξ_ll + Ξ_lm + Ξ_ml ≺ 0)",
                route_info.combinations
            ));
        }
        // An LPV plant has no N_k or M_k to symmetrise.
        if request.split == Split::Symmetric && !self.kind.is_global() {
            notes.push(
                "N_k and M_k symmetrised ((T + Tᵀ)/2, the same plant); re-check with this split"
                    .into(),
            );
        }
        notes.extend(jacobian_note(&self.model));
        if request.conditions == Conditions::Decoupled {
            notes.push(format!(
                "conditions = decoupled: solved with {} rate blocks (one slack Z per rate combination, sufficient) instead of {}; the certificate checks the full family of {} blocks",
                prob.n_rate_blocks(),
                prob.n_full_rate_blocks(),
                prob.n_full_rate_blocks()
            ));
        }
        if request.conditions == Conditions::Cube {
            let r = prob.n_generators();
            notes.push(format!(
                "conditions = cube: the region as a zonotope with {r} generators; certified with {} rate blocks (one pair of slacks Y, X per generator, sufficient) and D ⪰ GᵀPG, trace D ≤ 1 for the region's vertices, instead of {} vertex-pair blocks; solved with {} rate blocks{}; the report's `cube` key carries the slacks",
                prob.combos().len() * (4 * r + 1),
                prob.n_full_rate_blocks(),
                prob.n_rate_blocks(),
                if prob.cube_one_slack() {
                    " (N_k, M_k symmetric: H = −2G, one slack W = Y + X per generator)"
                } else {
                    ""
                }
            ));
        }
        notes
    }
}

/// The request as it is solved, its setup and the notes so far:
/// `conditions = auto` chosen by size (crate::model::size::choose; a
/// sampled design has the full vertex family only), the global observer's
/// request ([`global_request`]) and its units ([`global_balance`]).
pub(super) fn prepare(
    model: &PolytopicModel,
    request: &DesignRequest,
    settings: &Settings,
    hint: Option<&nalgebra::DMatrix<f64>>,
) -> Result<(DesignRequest, Setup, Notes), SolveError> {
    let (chosen_conditions, auto_note) = match request.sample {
        Some(h) if request.conditions == Conditions::Auto => {
            let (c, why) = crate::model::size::choose_sampled(model, request);
            let text = match c {
                Conditions::Full => format!(
                    "sample = {h:e}: the discrete decrease is solved and certified on the full vertex family (conditions = full)"
                ),
                _ => format!(
                    "sample = {h:e}: the discrete decrease is solved on its decoupled form (conditions = decoupled: {why}) and certified on the full vertex family"
                ),
            };
            (c, Some(Note::Text(text)))
        }
        _ => {
            let (c, why) = crate::model::size::choose(model, request);
            (c, (!why.is_empty()).then_some(Note::ConditionsChosen(why)))
        }
    };
    let resolved = DesignRequest {
        conditions: chosen_conditions,
        ..request.clone()
    };
    let mut notes = Notes::default();
    if ObserverKind::of(model, request.mode) == ObserverKind::Regional {
        notes.extend(auto_note);
        let resolved = jacobian_request(model, resolved, &mut notes)?;
        let setup = Setup::new(model, &resolved, settings)?;
        return Ok((resolved, setup, notes));
    }
    let resolved = global_request(model, resolved, &mut notes)?;
    let mut setup = Setup::new(model, &resolved, settings)?;
    let pilots = global_balance(&mut setup, &resolved, settings, hint)?;
    if let Some((_, sc)) = &setup.scaled {
        notes.push(Note::BalancedUnits {
            d: sc.d.clone(),
            from: if hint.is_some() && pilots == 0 {
                "the first search's P".to_string()
            } else {
                format!("{pilots} pilot solver call(s), not in the search log")
            },
        });
    }
    Ok((resolved, setup, notes))
}

/// How the nonlinear terms of `model` were bounded, for the notes.
fn jacobian_note(model: &PolytopicModel) -> Option<String> {
    let b = model.jacobian.as_ref()?.bound.as_ref()?;
    let entries: Vec<String> = b
        .entries
        .iter()
        .map(|e| format!("{} ∈ [{:.6e}, {:.6e}]", e.name, e.lo, e.hi))
        .collect();
    let q = b.dims.len();
    Some(format!(
        "nonlinear terms of unmeasured states: Jacobian bounded on {} (interval gradients, outward rounding): {}; {q} non-constant entr{} = {q} robust vertex dimension{} (×{} vertices, {} in all; one gain per θ-vertex, shared by its {} corners)",
        b.set,
        entries.join(", "),
        if q == 1 { "y" } else { "ies" },
        if q == 1 { "" } else { "s" },
        1usize << q,
        model.nv(),
        1usize << q
    ))
}

/// The request of a model whose nonlinear terms need the set S (a
/// Jacobian entry without a global bound): S depends on γ, so a searched γ
/// is fixed at the top of its range ([`crate::model::jacobian::gamma_for_set`],
/// where S is smallest), with a note; the skew slack is refused.
fn jacobian_request(
    model: &PolytopicModel,
    request: DesignRequest,
    notes: &mut Notes,
) -> Result<DesignRequest, SolveError> {
    if model.jacobian.is_some() && request.split == Split::SkewSlack {
        return Err(SolveError::Unsupported(format!(
            "model `{}` has nonlinear terms of unmeasured states; the skew slack (`split = skew_slack`) is not supported with them",
            model.name
        )));
    }
    if !model.jacobian_needs_set() || request.gamma != GammaSpec::Search {
        return Ok(request);
    }
    let Some(g) = crate::model::jacobian::gamma_for_set(model) else {
        return Ok(request);
    };
    notes.push(Note::Text(format!(
        "γ fixed at {g:.6} (the top of its range): the Jacobian bound of the nonlinear terms holds on S = F ⊕ (−P/γ), which depends on γ"
    )));
    Ok(DesignRequest {
        gamma: GammaSpec::Fixed(g),
        ..request
    })
}

/// The request of a global design ([`crate::model::ObserverKind::Global`]): γ is fixed at 1 (unused: the conditions are
/// homogeneous), the conditions are the full family (one block per rate
/// combination: decoupled and cube conditions have nothing to split), and
/// what the plant's own statements asked for that the global observer does
/// not use is noted. At `sample = h` the rate family is the discrete
/// decrease without region terms (docs/method.md, "The global observer").
/// Refused elsewhere: the skew slack (not built for the global observer).
fn global_request(
    model: &PolytopicModel,
    request: DesignRequest,
    notes: &mut Notes,
) -> Result<DesignRequest, SolveError> {
    let family = match request.sample {
        None => "He{P A_l − Γ_l C_m} + αP ≺ 0 at every rate combination (certificate family G5)"
            .to_string(),
        Some(h) => format!(
            "at sample = {h:e} the discrete decrease [(1 − hα)P, (P + hΦ)ᵀ; P + hΦ, P] ⪰ 0, Φ = P A_l − Γ_l C_m, at every rate combination (certificate family S5d without region terms)"
        ),
    };
    let mut used = vec![format!(
        "the plant is LPV (every N_k and M_k is zero): the global observer, P ⪰ I and {family}, with no region, state bound or γ"
    )];
    if model.has_region() {
        used.push("the model's region is not used".into());
    }
    if !matches!(model.state_bound, StateBound::None) {
        used.push(if request.sample.is_some() {
            "its state bound is not used by the certificate (only as the operating envelope of the continuous-plant bound)".into()
        } else {
            "its state bound is not used".into()
        });
    }
    if let GammaSpec::Fixed(g) = request.gamma {
        used.push(format!("γ = {g} is not used"));
    }
    if !matches!(request.conditions, Conditions::Full | Conditions::Auto) {
        used.push(format!(
            "conditions = {:?} is replaced by the full family (one block per rate combination)",
            request.conditions
        ));
    }
    notes.push(used.join("; "));
    Ok(DesignRequest {
        gamma: GammaSpec::Fixed(1.0),
        conditions: Conditions::Full,
        ..request
    })
}

/// The balancing of a global design's units ([`StateScaling::of_p`]): the
/// problem is posed in coordinates where P's diagonal is near 1, from the
/// P of `hint` or of pilot solves at the requested α (a feasibility solve, then the gain objective in its units) (for
/// α = max at 0.1·max_l ‖A_l‖_F), up to two rounds. Returns the number
/// of pilot solves.
fn global_balance(
    setup: &mut Setup,
    request: &DesignRequest,
    settings: &Settings,
    hint: Option<&nalgebra::DMatrix<f64>>,
) -> Result<usize, SolveError> {
    let alpha = match request.alpha {
        AlphaSpec::Fixed(a) => a,
        AlphaSpec::Max => {
            0.1 * setup
                .model
                .vertices
                .iter()
                .map(|v| v.a.norm())
                .fold(settings.alpha_floor, f64::max)
        }
    };
    let mut p = hint.cloned();
    let mut pilots = 0;
    for _ in 0..2 {
        let p_now = match p.take() {
            Some(p) => p,
            None => {
                pilots += 1;
                // The first pilot only needs some feasible P; the next one
                // the smallest-gain point in the units it gave.
                let objective = if pilots == 1 {
                    Objective::Feasibility
                } else {
                    Objective::Gains
                };
                // A pilot without a point is retried at smaller α (the
                // units that suit a smaller α are a better start than none),
                // and with pole regions, that give none in unbalanced units
                // when the region cuts α far down, without them.
                let mut found = None;
                let free = DesignRequest {
                    poles: Vec::new(),
                    ..request.clone()
                };
                let mut tries = vec![request];
                if !request.poles.is_empty() {
                    tries.push(&free);
                }
                'pilot: for req in tries {
                    let prob = setup.problem(req)?;
                    for k in 0..4 {
                        let a = alpha * 0.5f64.powi(k);
                        if let Some(p) = prob.solve(a, 1.0, settings, objective)?.p {
                            found = Some(p);
                            break 'pilot;
                        }
                    }
                }
                match found {
                    Some(p) => p,
                    None => break,
                }
            }
        };
        // The unit: the state the output map weighs most (C D keeps its size).
        let c = &setup.model.vertices[0].c;
        let unit = (0..c.ncols()).max_by(|&a, &b| {
            let w = |i: usize| c.column(i).abs().sum();
            w(a).total_cmp(&w(b))
        });
        let Some(sc) = StateScaling::of_p_relative(&p_now, unit) else {
            break;
        };
        if setup.scaled.as_ref().is_some_and(|(_, s)| *s == sc) {
            break;
        }
        match sc.model(&setup.model) {
            Some(zm) => setup.scaled = Some((zm, sc)),
            None => break,
        }
    }
    Ok(pilots)
}
