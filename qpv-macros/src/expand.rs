//! The expansion pipeline: input → `qpv_dsl::parse` → polytopic model →
//! for each design request: cache or solve → independent certificate → emit.
//!
//! The first error stops everything and becomes one `compile_error!` on the
//! offending tokens (see [`crate::fallback`]). An expansion that took long
//! in a macro built without optimisation also carries one warning (see
//! [`crate::slow_solve`]).

use crate::cache;
use crate::emit::{self, CertifiedDesign, EmitModel, Figures};
use crate::fallback::{self, Failure};
use crate::input::{Input, Source};
use crate::slow_solve;
use nalgebra::DMatrix;
use proc_macro2::TokenStream;
use qpv_dsl::{
    AlphaSpec, Conditions, DesignRequest, GammaSpec, Mode, Model, NoiseObjective, OutputFilter,
    OutputRoute, PolytopicModel, Split, StateBound,
};
use qpv_solve::conditions::cube::CubeSlacks;
use qpv_solve::model::{ClaimedBound, ObserverModel, ObserverOptions, StateBoundClaim};
use qpv_solve::noise::NoiseChannels;
use qpv_solve::report::{matrix_to_rows, rows_to_matrix};
use qpv_solve::{Design, Settings};
use quote::quote;

/// Expands one `qpv!` invocation; the generated code calls the math
/// functions of a model's scheduling functions through `libm` (the path of
/// the `libm` crate: `::libm`, or the facade's re-export).
pub fn expand(tokens: TokenStream, libm: TokenStream) -> TokenStream {
    let input = match Input::from_tokens(tokens) {
        Ok(i) => i,
        Err(e) => return fallback::emit(&Failure::at(e.span, e.message), TokenStream::new()),
    };
    let mut input = input;
    input.libm = libm;
    let start = std::time::Instant::now();
    let mut out = TokenStream::new();
    if let Source::File { absolute, .. } = &input.source {
        // Makes cargo rebuild the calling crate when the model file changes.
        let path = absolute.to_string_lossy().into_owned();
        out.extend(quote!(
            const _: &str = ::core::include_str!(#path);
        ));
    }
    match models(&input) {
        Ok(tokens) => out.extend(tokens),
        Err((failure, stub)) => out.extend(fallback::emit(&failure, stub)),
    }
    // Parsing and emitting take milliseconds: a long expansion is solving.
    out.extend(slow_solve::warning_if_slow(start.elapsed()));
    out
}

/// A failure at the text range `start..end` of the input.
fn failure_at(input: &Input, start: usize, end: usize, message: &str) -> Failure {
    let (first, last) = input.spans(start, end);
    Failure {
        first,
        last,
        message: input.locate(start, message),
    }
}

/// Parses the text and expands every model; the first error wins.
fn models(input: &Input) -> Result<TokenStream, (Failure, TokenStream)> {
    let models = qpv_dsl::parse(&input.text).map_err(|e| {
        (
            failure_at(input, e.span.start, e.span.end, &e.message),
            TokenStream::new(),
        )
    })?;
    if models.is_empty() {
        return Err((
            failure_at(input, 0, 0, "no model found: expected `model NAME { ... }`"),
            TokenStream::new(),
        ));
    }
    let mut out = TokenStream::new();
    for model in &models {
        let tokens = one_model(input, model)?;
        dump(&model.name, &tokens);
        out.extend(tokens);
    }
    Ok(out)
}

/// With `QPV_DUMP_DIR` set, writes the generated module of each model to
/// `<dir>/<model>.rs` (one line of tokens; run rustfmt on it) for review.
fn dump(name: &str, tokens: &TokenStream) {
    if let Some(dir) = std::env::var_os("QPV_DUMP_DIR") {
        let dir = std::path::PathBuf::from(dir);
        if std::fs::create_dir_all(&dir).is_ok() {
            let _ = std::fs::write(dir.join(format!("{name}.rs")), tokens.to_string());
        }
    }
}

/// The request as the user wrote it, in words.
pub fn describe(req: &DesignRequest) -> String {
    let alpha = match req.alpha {
        AlphaSpec::Fixed(a) => format!("{a}"),
        AlphaSpec::Max => "max".into(),
    };
    let gamma = match req.gamma {
        GammaSpec::Fixed(g) => format!("{g}"),
        GammaSpec::Search => "search".into(),
    };
    let mode = mode_name(req.mode);
    let mut text = format!("alpha = {alpha}; gamma = {gamma}; mode = {mode}");
    if req.split != Split::default_for(req.mode) {
        text.push_str("; split = ");
        text.push_str(req.split.name());
    }
    // `auto` (the default) and `full` (the former default, and what auto
    // is for every model small enough to bake) read as before: no mention.
    if !matches!(req.conditions, Conditions::Auto | Conditions::Full) {
        text.push_str("; conditions = ");
        text.push_str(req.conditions.name());
    }
    if let OutputRoute::Filter(f) = req.output_route {
        text.push_str(&format!(
            "; output_route = filter(pole = {}, gain = {})",
            f.pole, f.gain
        ));
    }
    if req.noise == NoiseObjective::Min {
        text.push_str("; noise = min");
    }
    if let Some(h) = req.sample {
        text.push_str(&format!("; sample = {h}"));
    }
    text
}

/// The noise bound and sampling figures of the numbers about to be baked,
/// computed on the model the certificate checked (`checked`: the observer's
/// model, augmented by the output filter for the filter route) with the
/// plant's declared noise channels. Each figure is present only if its own
/// check passed.
fn figures(
    plant: &PolytopicModel,
    checked: &PolytopicModel,
    filter: Option<OutputFilter>,
    alpha: f64,
    gamma: f64,
    p: &nalgebra::DMatrix<f64>,
    ls: &[nalgebra::DMatrix<f64>],
) -> Figures {
    let channels = NoiseChannels::from_model(plant);
    let channels = match filter {
        Some(f) => channels.through_filter(plant.nx(), plant.ny(), plant.nv(), f.gain),
        None => channels,
    };
    let noise = qpv_solve::noise::noise_bound(checked, &channels, alpha, gamma, p, ls)
        .filter(|b| b.check.passed);
    let sampling = qpv_solve::sampling::sampling(checked, alpha, gamma, p, ls);
    Figures {
        sigma: noise.as_ref().map(|b| b.sigma),
        error_bound: noise.as_ref().map(|b| b.error_bound),
        max_amplitude: noise.as_ref().map(|b| b.max_amplitude),
        euler: sampling
            .as_ref()
            .filter(|s| s.max_step_euler > 0.0)
            .map(|s| (s.max_step_euler, s.beta)),
        rk4: sampling
            .as_ref()
            .map(|s| s.step_estimate_rk4)
            .filter(|h| *h > 0.0),
        f32_floor: None,
    }
}

/// For a `noise = min` request that was not certified: the best certified
/// point of the rate–noise trade-off found at lower rates (the same γ
/// request, α halved up to three times), or why there is none.
fn best_tradeoff_point(poly: &PolytopicModel, req: &DesignRequest) -> String {
    let AlphaSpec::Fixed(alpha) = req.alpha else {
        return String::new();
    };
    let channels = NoiseChannels::from_model(poly);
    let mut last_err = None;
    for k in 1..=3 {
        let a = alpha / f64::from(1u32 << k);
        let r = DesignRequest {
            alpha: AlphaSpec::Fixed(a),
            ..req.clone()
        };
        match qpv_solve::noise::design_noise(poly, &r, &channels, &settings()) {
            Ok(d) if d.feasible && d.certifies => {
                if let Some(nb) = d.noise.as_ref() {
                    return format!(
                        "; the best certified trade-off point found is alpha = {}, gamma = {} \
                         (sigma = {}, error bound {} per unit noise)",
                        sig(d.alpha),
                        sig(d.gamma),
                        sig(nb.sigma),
                        sig(nb.error_bound)
                    );
                }
            }
            Ok(_) => {}
            Err(e) => last_err = Some(e.to_string()),
        }
    }
    match last_err {
        Some(e) => format!("; no noise-optimal design could be attempted at lower rates: {e}"),
        None => format!(
            "; no noise-optimal design was certified down to alpha = {} either",
            sig(alpha / 8.0)
        ),
    }
}

fn mode_name(m: Mode) -> &'static str {
    match m {
        Mode::Sound => "sound",
        Mode::Paper => "paper",
    }
}

/// Three significant digits for messages (stable across solver versions).
fn sig(v: f64) -> String {
    format!("{}", format!("{v:.2e}").parse::<f64>().unwrap_or(v))
}

/// Solver settings used by the macro (the library defaults).
fn settings() -> Settings {
    Settings::default()
}

/// Expands one model: its designs, then the module.
fn one_model(input: &Input, model: &Model) -> Result<TokenStream, (Failure, TokenStream)> {
    let no_stub = TokenStream::new;
    let at_name = |msg: &str| {
        failure_at(
            input,
            model.span.start,
            model.span.end,
            &format!("model `{}`: {msg}", model.name),
        )
    };
    if syn::parse_str::<syn::Ident>(&model.name).is_err() || model.name.starts_with("r#") {
        return Err((
            at_name(
                "the model name must be a Rust identifier that is not a keyword: \
                 it becomes the name of the generated module",
            ),
            no_stub(),
        ));
    }
    if model.designs.is_empty() {
        return Err((
            at_name(
                "no `design { ... }` block: qpv! synthesises an observer, add e.g. \
                 `design { alpha = max; gamma = search; }`",
            ),
            no_stub(),
        ));
    }
    let poly = model.polytopic();

    if model.designs.iter().all(|d| d.mode == Mode::Paper) {
        let first = &model.designs[0];
        return Err((
            failure_at(
                input,
                first.span.start,
                first.span.end,
                &format!(
                    "model `{}` has only paper-mode designs: they reproduce the published \
                     conditions, which certify nothing, and qpv! only generates observers \
                     from certified gains; add a sound design such as \
                     `design {{ alpha = max; gamma = search; }}` ({})",
                    model.name,
                    best_sound_design(&poly)
                ),
            ),
            no_stub(),
        ));
    }

    // The stub used if a design fails: the real API with zero data.
    let stub = || {
        let zero = |req: &DesignRequest| {
            let filter = filter_of(req);
            let nz = model.nx() + if filter.is_some() { model.ny() } else { 0 };
            CertifiedDesign {
                request: String::new(),
                mode: String::new(),
                certifies: true,
                alpha: 0.0,
                gamma: 0.0,
                p: vec![0.0; nz * nz],
                l: vec![vec![0.0; nz * model.ny()]; poly.nv()],
                margins: Vec::new(),
                status: String::new(),
                iterations: 0,
                filter,
                figures: Figures::default(),
                float: req.float,
                sample: req.sample,
            }
        };
        emit::emit(&EmitModel {
            model,
            libm: input.libm.clone(),
            scheduling: poly.scheduling.clone(),
            designs: model.designs.iter().map(zero).collect(),
        })
    };

    let cache_dir = cache::dir();
    let mut designs = Vec::with_capacity(model.designs.len());
    for req in &model.designs {
        let fail = |msg: String| {
            (
                failure_at(input, req.span.start, req.span.end, &msg),
                stub(),
            )
        };
        let start = std::time::Instant::now();
        let design = one_design(model, &poly, req, cache_dir.as_deref()).map_err(fail)?;
        timing(&model.name, &design.numbers.request, design.origin, start);
        designs.push(design.numbers);
    }
    Ok(emit::emit(&EmitModel {
        model,
        libm: input.libm.clone(),
        scheduling: poly.scheduling.clone(),
        designs,
    }))
}

/// The output post-filter of a filter-route request.
fn filter_of(req: &DesignRequest) -> Option<OutputFilter> {
    match req.output_route {
        OutputRoute::Filter(f) => Some(f),
        OutputRoute::DoubleSum => None,
    }
}

/// A row-major slice as rows of `cols` entries.
fn rows(data: &[f64], cols: usize) -> Vec<Vec<f64>> {
    data.chunks(cols.max(1)).map(<[f64]>::to_vec).collect()
}

/// The cached or freshly solved design for one request, independently
/// certified; or the message of the compile error.
fn one_design(
    model: &Model,
    poly: &PolytopicModel,
    req: &DesignRequest,
    cache: Option<&std::path::Path>,
) -> Result<Outcome, String> {
    let settings = settings();
    // The key is the model as written (`state_bound auto` included), so an
    // auto bound is cached with the design.
    let key = cache::key(poly, req, &format!("{settings:?}"));
    let cached = cache.and_then(|dir| cache::load(dir, &key));
    let (observer, bound) = observer_model(poly, req, &settings, cached.as_ref())?;
    let ctx = DesignCtx {
        model,
        request: describe(req),
        req,
        filter: filter_of(req),
        // The design's state: the plant's, plus one filter state per output
        // for the filter route (P is nz × nz, each L_l nz × ny).
        nz: model.nx()
            + if filter_of(req).is_some() {
                model.ny()
            } else {
                0
            },
        ny: model.ny(),
        observer: &observer,
    };
    // A cache hit is re-certified, never trusted blindly.
    if let Some(e) = cached {
        if let Some(hit) = ctx.recertified(&e) {
            if e.bound != bound {
                // the state bound was recomputed: keep the fresh one
                if let Some(dir) = cache {
                    let fresh = cache::Entry { bound, ..e };
                    cache::store(dir, &key, &fresh);
                }
            }
            return Ok(hit);
        }
    }
    let (outcome, entry) = ctx.solved(&settings, bound)?;
    if let Some(dir) = cache {
        cache::store(dir, &key, &entry);
    }
    Ok(outcome)
}

/// The observer's model (the one builder): the state bound, then the output
/// route (the plant, or the plant augmented by the output filter), then the
/// representation of N_k, M_k the design uses (the plant, hence the
/// generated code, is the same). `state_bound auto`: Q from the cache if it
/// passes the independent state-bound check again, else computed (then
/// returned for the cache); the design and the macro's own certificate use
/// it as given.
fn observer_model(
    poly: &PolytopicModel,
    req: &DesignRequest,
    settings: &Settings,
    cached: Option<&cache::Entry>,
) -> Result<(ObserverModel, Option<cache::Bound>), String> {
    let options = ObserverOptions::for_request(req);
    let reused = cached
        .and_then(|e| e.bound.as_ref())
        .and_then(|b| recheck_bound(poly, &options, b));
    if let Some(found) = reused {
        return Ok(found);
    }
    let observer = ObserverModel::prepare(poly, &options, StateBoundClaim::Compute(settings))
        .map_err(|e| format!("design `{}` cannot be attempted: {e}", describe(req)))?;
    let bound = match (
        &poly.state_bound,
        &observer.plant.state_bound,
        observer.state_bound.h,
    ) {
        (StateBound::Auto { .. }, StateBound::Given(q), Some(h)) => Some(cache::Bound {
            h,
            symmetric: observer.state_bound.split == Some(qpv_dsl::Split::Symmetric),
            q: matrix_to_rows(q).concat(),
        }),
        _ => None,
    };
    Ok((observer, bound))
}

/// What one request's design needs beside the numbers: the request, its
/// output route and sizes, and the observer's model.
struct DesignCtx<'a> {
    model: &'a Model,
    request: String,
    req: &'a DesignRequest,
    filter: Option<OutputFilter>,
    nz: usize,
    ny: usize,
    observer: &'a ObserverModel,
}

impl DesignCtx<'_> {
    /// The observer's model with the skew slack K_{k,l} the numbers were
    /// certified with added to N_k (flattened: per vertex, per k, row-major
    /// nz × nz; empty for no slack); None if its size does not fit.
    fn with_skew(&self, k: &[f64]) -> Option<PolytopicModel> {
        if k.is_empty() {
            return Some(self.observer.model.clone());
        }
        let (nv, nz) = (self.observer.plant.nv(), self.nz);
        if k.len() != nv * nz * nz * nz {
            return None;
        }
        let mats: Vec<Vec<_>> = k
            .chunks(nz * nz * nz)
            .map(|kl| {
                kl.chunks(nz * nz)
                    .map(|kk| rows_to_matrix(&rows(kk, nz)))
                    .collect()
            })
            .collect();
        self.observer.with_skew(&mats).ok()
    }

    /// The macro's own certificate of P, L_l at (α, γ) on `checked_model`:
    /// the discrete decrease S5d at h for a `sample = h` request
    /// (`certificate::check_sampled`), else the family the design's
    /// conditions call for (the cube by its slacks, or the full vertex one).
    fn certify(
        &self,
        checked_model: &PolytopicModel,
        (alpha, gamma): (f64, f64),
        (p, ls): (&DMatrix<f64>, &[DMatrix<f64>]),
        slacks: Option<&CubeSlacks>,
    ) -> qpv_solve::Certificate {
        match self.req.sample {
            Some(h) => qpv_solve::certificate::check_sampled(checked_model, alpha, gamma, h, p, ls),
            None => qpv_solve::certificate::check_with(
                checked_model,
                self.req.mode,
                alpha,
                gamma,
                p,
                ls,
                slacks,
            ),
        }
    }

    /// The numbers to emit for P, L_l that passed `cert` at (α, γ), with
    /// the noise and sampling figures computed on them.
    #[allow(clippy::too_many_arguments)]
    fn numbers(
        &self,
        checked_model: &PolytopicModel,
        (alpha, gamma): (f64, f64),
        (p, ls): (&DMatrix<f64>, &[DMatrix<f64>]),
        cert: &qpv_solve::Certificate,
        status: String,
        iterations: u32,
    ) -> CertifiedDesign {
        let poly = &self.observer.plant;
        let mut d = CertifiedDesign {
            request: self.request.clone(),
            mode: mode_name(self.req.mode).into(),
            certifies: self.req.mode == Mode::Sound,
            alpha,
            gamma,
            p: matrix_to_rows(p).concat(),
            l: ls.iter().map(|l| matrix_to_rows(l).concat()).collect(),
            margins: cert
                .families
                .iter()
                .map(|f| (f.name.clone(), f.margin))
                .collect(),
            // §16: the continuous noise bound and Euler figures say nothing
            // about a design certified at its sample period.
            figures: match self.req.sample {
                Some(_) => Figures::default(),
                None => figures(poly, checked_model, self.filter, alpha, gamma, p, ls),
            },
            status,
            iterations,
            filter: self.filter,
            sample: self.req.sample,
            float: self.req.float,
        };
        if d.float == qpv_dsl::Float::F32 {
            d.figures.f32_floor =
                f32_floor(self.model, &poly.scheduling, &d, checked_model, p, ls).ok();
        }
        d
    }

    /// A cache entry whose numbers pass the certificate again on the model
    /// as it is now; None if they do not (or do not fit it), and the design
    /// is solved afresh.
    fn recertified(&self, e: &cache::Entry) -> Option<Outcome> {
        let (nz, ny, nv) = (self.nz, self.ny, self.observer.plant.nv());
        let checked_model = self.with_skew(&e.skew)?;
        let fits =
            e.p.len() == nz * nz && e.l.len() == nv && e.l.iter().all(|l| l.len() == nz * ny);
        if !fits {
            return None;
        }
        let p = self.rounded(rows_to_matrix(&rows(&e.p, nz)));
        let ls: Vec<_> =
            e.l.iter()
                .map(|l| self.rounded(rows_to_matrix(&rows(l, ny))))
                .collect();
        // Cube slacks are checked as the search checked them; an entry
        // without slacks is checked on the full vertex family.
        let slacks = match &e.cube {
            Some(c) => Some(cube_slacks(c, nz)?),
            None => None,
        };
        let cert = self
            .certify(
                &checked_model,
                (e.alpha, e.gamma),
                (&p, &ls),
                slacks.as_ref(),
            )
            .with_gain_bound(&ls, self.req.max_gain);
        cert.passed.then(|| Outcome {
            origin: "cache hit, re-certified",
            numbers: self.numbers(
                &checked_model,
                (e.alpha, e.gamma),
                (&p, &ls),
                &cert,
                e.status.clone(),
                e.iterations,
            ),
        })
    }

    /// Solves the request, accepts only a certified design (or, in paper
    /// mode, a feasible reproduction), checks the numbers again itself, and
    /// returns them with the cache entry to store.
    /// The matrix as the generated code holds it: rounded to f32 for an
    /// f32 design (exactly representable in f64), as is for f64.
    fn rounded(&self, m: DMatrix<f64>) -> DMatrix<f64> {
        match self.req.float {
            qpv_dsl::Float::F32 => m.map(|v| f64::from(v as f32)),
            qpv_dsl::Float::F64 => m,
        }
    }

    /// [`DesignCtx::solved_once`]; for an f32 design whose rounded gains
    /// fail the certificate, solved again with the margin of the strict
    /// inequalities ten and a hundred times larger (never baked uncertified).
    fn solved(
        &self,
        settings: &Settings,
        bound: Option<cache::Bound>,
    ) -> Result<(Outcome, cache::Entry), String> {
        if self.req.float == qpv_dsl::Float::F64 {
            return self.solved_once(settings, bound);
        }
        let mut last = String::new();
        for k in 0..3 {
            let s = Settings {
                margin_rel: settings.margin_rel * 10f64.powi(k),
                ..settings.clone()
            };
            match self.solved_once(&s, bound.clone()) {
                Ok(x) => return Ok(x),
                Err(e) if e.contains(ROUNDED_FAILED) => last = e,
                Err(e) => return Err(e),
            }
        }
        Err(format!(
            "{last} (solved again with the margin 10 and 100 times larger: still failing)"
        ))
    }

    fn solved_once(
        &self,
        settings: &Settings,
        bound: Option<cache::Bound>,
    ) -> Result<(Outcome, cache::Entry), String> {
        let (request, req, poly) = (&self.request, self.req, &self.observer.plant);
        let design = qpv_solve::design(poly, req, settings)
            .map_err(|e| format!("design `{request}` cannot be attempted: {e}"))?;
        let accepted = match req.mode {
            Mode::Sound => design.feasible && design.certifies,
            Mode::Paper => design.feasible,
        };
        if !accepted {
            let mut msg = not_certified(request, &design, poly);
            if req.noise == NoiseObjective::Min && !design.search.iter().any(|s| s.certified) {
                let hint = best_tradeoff_point(poly, req);
                msg = msg.replace("; no gain was baked", &format!("{hint}; no gain was baked"));
            }
            return Err(msg);
        }
        let (nz, ny, nv) = (self.nz, self.ny, poly.nv());
        let p = design.p_matrix();
        let ls = design.l_matrices();
        let (p, ls) = (
            self.rounded(p),
            ls.into_iter().map(|l| self.rounded(l)).collect::<Vec<_>>(),
        );
        let shapes_ok = p.nrows() == nz
            && p.ncols() == nz
            && ls.len() == nv
            && ls.iter().all(|l| l.nrows() == nz && l.ncols() == ny);
        if !shapes_ok {
            return Err(format!(
                "design `{request}`: the solver returned matrices of unexpected size \
                 (an internal error; please report it)"
            ));
        }
        // The solver already certified; the macro checks again itself, on
        // exactly the numbers it is about to bake (and the skew slack they
        // came with).
        let skew: Vec<f64> = design
            .skew
            .iter()
            .flatten()
            .flatten()
            .flatten()
            .flatten()
            .copied()
            .collect();
        let checked_model = self.with_skew(&skew).ok_or_else(|| {
            format!(
                "design `{request}`: the solver returned a skew slack of unexpected size \
                 (an internal error; please report it)"
            )
        })?;
        let (alpha, gamma) = (design.alpha, design.gamma);
        // A cube design is checked by its slacks (as the search did), not
        // on the 2^nx region vertices.
        let slacks = design.cube.as_ref().map(CubeSlacks::from_report);
        let mut cert = self
            .certify(&checked_model, (alpha, gamma), (&p, &ls), slacks.as_ref())
            .with_gain_bound(&ls, req.max_gain);
        if !cert.passed && slacks.is_some() && req.float == qpv_dsl::Float::F32 {
            // the cube slacks were found for the f64 numbers: the rounded
            // ones may still hold on the full vertex family
            cert = self
                .certify(&checked_model, (alpha, gamma), (&p, &ls), None)
                .with_gain_bound(&ls, req.max_gain);
        }
        let finite = p
            .iter()
            .chain(ls.iter().flat_map(|l| l.iter()))
            .all(|v| v.is_finite());
        if !cert.passed || !finite {
            let worst = cert
                .families
                .iter()
                .filter(|f| !f.passed)
                .map(|f| format!("{} margin {}", f.name, sig(f.margin)))
                .collect::<Vec<_>>()
                .join(", ");
            if req.float == qpv_dsl::Float::F32 {
                return Err(format!(
                    "design `{request}`: {ROUNDED_FAILED} ({worst}); not baked"
                ));
            }
            return Err(format!(
                "design `{request}`: the solver's point did not pass the macro's own \
                 certificate check ({worst}); not baked"
            ));
        }
        let (status, iterations) = (design.solver.detail.clone(), design.solver.iterations);
        let numbers = self.numbers(
            &checked_model,
            (alpha, gamma),
            (&p, &ls),
            &cert,
            status.clone(),
            iterations,
        );
        let entry = cache::Entry {
            bound,
            alpha,
            gamma,
            status,
            iterations,
            p: numbers.p.clone(),
            l: numbers.l.clone(),
            skew,
            cube: slacks.as_ref().map(flat_cube),
        };
        Ok((
            Outcome {
                origin: "solved",
                numbers,
            },
            entry,
        ))
    }
}

/// The message of an f32 design whose rounded P and L_l fail the certificate.
const ROUNDED_FAILED: &str = "the f32-rounded P and L_l did not pass the certificate";

/// The certified f32 error floor of design `d` (P, L_l the f32 values,
/// certified on `checked`): the rounding of one evaluation of the generated
/// right-hand side ([`qpv_codegen::rounding::rhs_error`], over x ∈ F, the
/// estimate within E of it, θ ∈ Θ, the declared input ranges) as a
/// disturbance entering every state, through the noise bound
/// ([`qpv_solve::noise::disturbance_floor`]).
pub fn f32_floor(
    model: &Model,
    scheduling: &[usize],
    d: &CertifiedDesign,
    checked: &PolytopicModel,
    p: &DMatrix<f64>,
    ls: &[DMatrix<f64>],
) -> Result<f64, String> {
    if d.filter.is_some() {
        return Err("the f32 floor is not computed for the filter route".into());
    }
    let (plant_state, observer_state) = qpv_solve::noise::observer_boxes(checked, d.gamma, p)
        .ok_or("P is not positive definite")?;
    let nv = qpv_codegen::design::vertex_count(model, scheduling);
    let shape = qpv_codegen::Shape::of(model, nv, d);
    let boxes = qpv_codegen::rounding::Boxes {
        plant_state,
        observer_state,
    };
    let err = qpv_codegen::rounding::rhs_error(model, scheduling, d, shape, &boxes)?;
    let f = qpv_solve::noise::disturbance_floor(checked, d.alpha, d.gamma, p, ls, &err)?;
    Ok(f.error_bound)
}

/// Cube slacks flattened for the cache (per rate combination, per
/// generator, row-major).
fn flat_cube(c: &CubeSlacks) -> cache::Cube {
    let flat = |v: &Vec<Vec<DMatrix<f64>>>| -> Vec<f64> {
        v.iter()
            .flatten()
            .flat_map(|m| matrix_to_rows(m).concat())
            .collect()
    };
    cache::Cube {
        y: flat(&c.y),
        x: flat(&c.x),
        d: c.d.clone(),
    }
}

/// Cached cube slacks back as matrices (r = `d.len()` generators, nz × nz
/// matrices); None if the numbers cannot be split so. Whether they fit the
/// model is the certificate's check.
fn cube_slacks(c: &cache::Cube, nz: usize) -> Option<CubeSlacks> {
    let per_combo = c.d.len() * nz * nz;
    let ok = |v: &[f64]| per_combo > 0 && !v.is_empty() && v.len() % per_combo == 0;
    if !ok(&c.y) || c.x.len() != c.y.len() {
        return None;
    }
    let mats = |v: &[f64]| -> Vec<Vec<DMatrix<f64>>> {
        v.chunks(per_combo)
            .map(|combo| {
                combo
                    .chunks(nz * nz)
                    .map(|m| rows_to_matrix(&rows(m, nz)))
                    .collect()
            })
            .collect()
    };
    Some(CubeSlacks {
        y: mats(&c.y),
        x: mats(&c.x),
        d: c.d.clone(),
    })
}

/// A design ready for emission and where it came from (for `QPV_TIMING`).
struct Outcome {
    origin: &'static str,
    numbers: CertifiedDesign,
}

/// With `QPV_TIMING` set, prints how long each design took at expansion.
fn timing(model: &str, request: &str, origin: &str, start: std::time::Instant) {
    if std::env::var_os("QPV_TIMING").is_some() {
        eprintln!(
            "qpv!: model `{model}`, design `{request}`: {origin} in {:.1} ms",
            start.elapsed().as_secs_f64() * 1e3
        );
    }
}

/// A cached `state_bound auto` result (box size `h`, split of the invariance
/// check, Q row-major) as a claim for the builder of the observer's model,
/// which verifies it against the model as it is now: the observer's model
/// with that Q, or `None` (then Q is computed again).
fn recheck_bound(
    poly: &PolytopicModel,
    options: &ObserverOptions<'_>,
    b: &cache::Bound,
) -> Option<(ObserverModel, Option<cache::Bound>)> {
    if !matches!(poly.state_bound, StateBound::Auto { .. }) || b.q.len() != poly.nx() * poly.nx() {
        return None;
    }
    let claim = ClaimedBound {
        q: rows_to_matrix(&rows(&b.q, poly.nx())),
        h: Some(b.h),
        split: Some(if b.symmetric {
            Split::Symmetric
        } else {
            Split::AsWritten
        }),
    };
    let observer = ObserverModel::prepare(poly, options, StateBoundClaim::Claimed(&claim)).ok()?;
    Some((observer, Some(b.clone())))
}

/// The best certified sound design of a model, in words, for error
/// messages: a full α = max / γ = search run (default split and
/// conditions), or why there is none.
fn best_sound_design(poly: &PolytopicModel) -> String {
    let req = DesignRequest::default();
    match qpv_solve::design(poly, &req, &settings()) {
        Ok(d) if d.feasible && d.certifies => format!(
            "the best certified sound design of this model is alpha = {}, gamma = {}",
            sig(d.alpha),
            sig(d.gamma)
        ),
        Ok(_) => "no sound design of this model could be certified".into(),
        Err(e) => format!("a sound design of this model cannot be attempted: {e}"),
    }
}

/// For a request that fails a required data check (a property of the model
/// and the request alone, which no solver point can change): what the data
/// admit, instead of a search for the best design.
fn data_hint(requested_gamma: f64, poly: &PolytopicModel) -> String {
    match qpv_solve::conditions::gamma_max(poly) {
        Some(g) if g.is_finite() && g > 0.0 && requested_gamma > g => format!(
            "; this fails on the model's data alone: with this state bound, (S4) admits \
             gamma up to {} only",
            sig(g)
        ),
        _ => "; this fails on the model's data alone, whatever the solver finds".into(),
    }
}

/// The message for a design that was not certified: the request, the best
/// certified (α, γ) if any, and the failing condition families with margins.
fn not_certified(request: &str, d: &Design, poly: &PolytopicModel) -> String {
    let mut failing: Vec<String> = d
        .data_checks
        .iter()
        .filter(|(_, c)| c.required && !c.passed)
        .map(|(name, c)| {
            if c.description.contains(name.as_str()) {
                format!("{}, margin {}", c.description, sig(c.margin))
            } else {
                format!("{name} ({}), margin {}", c.description, sig(c.margin))
            }
        })
        .collect();
    failing.extend(
        d.margins
            .iter()
            .filter(|(_, m)| **m <= 0.0)
            .map(|(name, m)| format!("{name}, margin {}", sig(*m))),
    );
    let why = if failing.is_empty() {
        format!(
            "the solver found no certified point (status: {}{})",
            d.solver.status,
            if d.solver.detail.is_empty() {
                String::new()
            } else {
                format!(", {}", d.solver.detail)
            }
        )
    } else {
        format!("failing: {}", failing.join("; "))
    };
    // Best certified point inside this request's own search; else what the
    // data admit if a data check failed; else a full search.
    let data_failed = d.data_checks.values().any(|c| c.required && !c.passed);
    let own = d
        .search
        .iter()
        .filter(|s| s.certified)
        .map(|s| (s.alpha_certified.max(s.alpha), s.gamma))
        .fold(None, |best: Option<(f64, f64)>, p| match best {
            Some(b) if b.0 >= p.0 => Some(b),
            _ => Some(p),
        });
    let best = match own {
        Some((a, g)) => format!(
            "; best certified for this request: alpha = {}, gamma = {}",
            sig(a),
            sig(g)
        ),
        None if data_failed => data_hint(d.gamma, poly),
        None => format!("; {}", best_sound_design(poly)),
    };
    let verdict = match d.mode {
        Mode::Sound => "is not certified",
        Mode::Paper => "does not satisfy the paper's printed conditions",
    };
    format!("design `{request}` {verdict}: {why}{best}; no gain was baked")
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODEL: &str = "model t {
        state x1, x2; output y1;
        A = [-1, 1; 0, -2]; N1 = [0.1, 0; 0, 0]; N2 = 0;
        C = [1, 0]; M1 = 0;
        region box(1);
        state_bound Q = [0.1, 0; 0, 0.1];
        design { alpha = 0.5; gamma = 0.5; }
    }";

    #[test]
    fn cache_hits_are_recertified_and_tampered_entries_re_solved() {
        let models = qpv_dsl::parse(MODEL).expect("test model parses");
        let model = &models[0];
        let poly = model.polytopic();
        let req = &model.designs[0];
        let dir = std::env::temp_dir().join(format!("qpv-expand-test-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);

        let first = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(first.origin, "solved");
        let second = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(second.origin, "cache hit, re-certified");
        assert_eq!(second.numbers.p, first.numbers.p);
        assert_eq!(second.numbers.l, first.numbers.l);

        // A cached P that no longer certifies (here: negated) is not trusted.
        let key = cache::key(&poly, req, &format!("{:?}", settings()));
        let file = cache::file_for(&dir, &key);
        let text = std::fs::read_to_string(&file).expect("cache file written");
        let tampered: String = text
            .lines()
            .map(|l| match l.strip_prefix("P ") {
                Some(rest) => {
                    let neg: Vec<String> = rest.split(' ').map(|v| format!("-{v}")).collect();
                    format!("P {}\n", neg.join(" ").replace("--", ""))
                }
                None => format!("{l}\n"),
            })
            .collect();
        assert_ne!(tampered, text);
        std::fs::write(&file, tampered).expect("rewrite cache file");
        let third = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(third.origin, "solved", "a tampered entry is re-solved");
        assert_eq!(third.numbers.p, first.numbers.p);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn cube_designs_are_rechecked_and_cached_with_their_slacks() {
        let text = MODEL.replace(
            "design { alpha = 0.5; gamma = 0.5; }",
            "design { alpha = 0.5; gamma = 0.5; conditions = cube; }",
        );
        let models = qpv_dsl::parse(&text).expect("test model parses");
        let model = &models[0];
        let poly = model.polytopic();
        let req = &model.designs[0];
        assert_eq!(req.conditions, Conditions::Cube);
        let dir = std::env::temp_dir().join(format!("qpv-expand-cube-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);

        let first = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(first.origin, "solved");
        assert!(first.numbers.certifies && first.numbers.alpha == 0.5);
        // The baked margins are the cube's: the vertex family is the
        // region's slack condition, all positive.
        assert!(first.numbers.margins.iter().all(|(_, m)| *m > 0.0));
        let key = cache::key(&poly, req, &format!("{:?}", settings()));
        let file = cache::file_for(&dir, &key);
        let entry = cache::load(&dir, &key).expect("cached");
        let c = entry.cube.clone().expect("the slacks are cached");
        // box(1) in R²: two generators, 2 × 2 slack matrices
        assert_eq!(c.d.len(), 2);
        assert!(!c.y.is_empty() && c.y.len() % 8 == 0 && c.x.len() == c.y.len());
        assert!(c.d.iter().sum::<f64>() <= 1.0);

        let second = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(second.origin, "cache hit, re-certified");
        assert_eq!(second.numbers, first.numbers);

        // Slacks that break the cube's region condition (trace D = 2 > 1)
        // fail the re-check although P and L_l still satisfy the vertex
        // family: the hit is checked by its slacks, and re-solved.
        let text = std::fs::read_to_string(&file).expect("cache file written");
        let rewrite = |f: &dyn Fn(&str) -> Option<String>| -> String {
            text.lines()
                .filter_map(|l| f(l).map(|l| format!("{l}\n")))
                .collect()
        };
        let bad_d = rewrite(&|l| {
            Some(if l.starts_with("D ") {
                "D 1.0 1.0".to_string()
            } else {
                l.to_string()
            })
        });
        std::fs::write(&file, bad_d).expect("rewrite cache file");
        let p = rows_to_matrix(&rows(&entry.p, 2));
        let ls: Vec<_> = entry
            .l
            .iter()
            .map(|l| rows_to_matrix(&rows(l, 1)))
            .collect();
        let (observer, _) = observer_model(&poly, req, &settings(), None).expect("prepares");
        let full = qpv_solve::check(&observer.model, Mode::Sound, 0.5, 0.5, &p, &ls);
        assert!(full.passed, "the full vertex family alone would accept it");
        let third = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(third.origin, "solved", "bad slacks are re-solved");
        assert_eq!(third.numbers, first.numbers);

        // An entry written before the slacks were stored still loads, and
        // is re-certified on the full vertex family.
        let old = rewrite(&|l| {
            (!["Y ", "X ", "D "].iter().any(|t| l.starts_with(t))).then(|| l.to_string())
        });
        std::fs::write(&file, old).expect("rewrite cache file");
        assert_eq!(cache::load(&dir, &key).expect("loads").cube, None);
        let fourth = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(fourth.origin, "cache hit, re-certified");
        assert_eq!(fourth.numbers.p, first.numbers.p);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn an_auto_state_bound_is_cached_with_the_design() {
        let text = MODEL.replace("state_bound Q = [0.1, 0; 0, 0.1];", "state_bound auto;");
        let models = qpv_dsl::parse(&text).expect("test model parses");
        let model = &models[0];
        let poly = model.polytopic();
        let req = &model.designs[0];
        let dir = std::env::temp_dir().join(format!("qpv-expand-auto-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let first = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(first.origin, "solved");
        let key = cache::key(&poly, req, &format!("{:?}", settings()));
        let entry = cache::load(&dir, &key).expect("cached");
        let b = entry.bound.expect("the computed Q is cached");
        assert!(b.h > 0.0 && b.q.len() == 4);
        let options = ObserverOptions::for_request(req);
        let fresh = recheck_bound(&poly, &options, &b);
        assert!(fresh.is_some(), "the cached Q re-checks");
        let huge = cache::Bound {
            q: vec![1e6, 0.0, 0.0, 1e6],
            ..b.clone()
        };
        let rejected = recheck_bound(&poly, &options, &huge);
        assert!(rejected.is_none(), "a Q whose F leaves the box fails");
        let second = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(second.origin, "cache hit, re-certified");
        assert_eq!(second.numbers.l, first.numbers.l);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn filter_designs_are_augmented_cached_and_recertified() {
        let text = MODEL
            .replace(
                "state x1, x2; output y1;",
                "state x1, x2; output y1; param th in [0, 1];",
            )
            .replace("C = [1, 0];", "C = [1 + th, 0];")
            .replace(
                "design { alpha = 0.5; gamma = 0.5; }",
                "design { alpha = 0.5; gamma = 0.5; output_route = filter(pole = 10, gain = 5); }",
            );
        let models = qpv_dsl::parse(&text).expect("test model parses");
        let model = &models[0];
        let poly = model.polytopic();
        assert!(poly.output_varies());
        let req = &model.designs[0];
        let dir = std::env::temp_dir().join(format!("qpv-expand-filter-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let first = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(first.origin, "solved");
        let f = first.numbers.filter.expect("filter route");
        assert_eq!((f.pole, f.gain), (10.0, 5.0));
        // the design is for (x, x_y): P is 3 × 3, L_l is 3 × 1
        assert_eq!(first.numbers.p.len(), 9);
        assert!(first.numbers.l.iter().all(|l| l.len() == 3));
        let second = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(second.origin, "cache hit, re-certified");
        assert_eq!(second.numbers, first.numbers);
        assert!(describe(req).ends_with("output_route = filter(pole = 10, gain = 5)"));
        // the double-sum request of the same model is another cache entry
        let ds = DesignRequest {
            output_route: OutputRoute::DoubleSum,
            ..req.clone()
        };
        assert_ne!(
            cache::key(&poly, req, "s"),
            cache::key(&poly, &ds, "s"),
            "the route is part of the key"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The paper's example with its sound design (the nostd crate's model).
    fn paper() -> PolytopicModel {
        let models = qpv_dsl::parse(include_str!("../../tests/nostd/paper_sound.qpv"))
            .expect("the paper model parses");
        models[0].polytopic()
    }

    #[test]
    fn the_best_sound_design_hint_reports_the_full_search() {
        // Moved from the UI test of a paper-mode-only model, whose message
        // now names the reason no sound design can be attempted instead.
        let poly = paper();
        let hint = best_sound_design(&poly);
        let d = qpv_solve::design(&poly, &DesignRequest::default(), &settings())
            .expect("the paper model designs");
        assert!(d.feasible && d.certifies, "{}", d.summary);
        assert_eq!(
            hint,
            format!(
                "the best certified sound design of this model is alpha = {}, gamma = {}",
                sig(d.alpha),
                sig(d.gamma)
            )
        );
        // The symmetric split's optimum lies beyond α = 12, at γ ≤ γ_max.
        let gmax = qpv_solve::conditions::gamma_max(&poly).expect("Q is given");
        assert!(d.alpha > 12.0 && d.gamma <= gmax, "{} {}", d.alpha, d.gamma);
        let mut no_q = poly.clone();
        no_q.state_bound = StateBound::None;
        assert!(best_sound_design(&no_q)
            .starts_with("a sound design of this model cannot be attempted: "));
    }

    #[test]
    fn a_request_failing_on_the_data_names_the_limit_without_a_search() {
        let poly = paper();
        let mut req = poly.designs[0].clone();
        req.gamma = GammaSpec::Fixed(0.4);
        let d = qpv_solve::design(&poly, &req, &settings()).expect("design runs");
        assert!(!d.feasible && !d.certifies);
        let text = not_certified(&describe(&req), &d, &poly);
        assert!(text.contains("margin -3.48"), "{text}");
        let gmax = sig(qpv_solve::conditions::gamma_max(&poly).expect("Q is given"));
        assert!(
            text.contains(&format!("(S4) admits gamma up to {gmax} only")),
            "{text}"
        );
        assert!(!text.contains("best certified"), "no search: {text}");
    }

    #[test]
    fn sampled_designs_are_rechecked_on_the_discrete_family() {
        let text = MODEL.replace(
            "design { alpha = 0.5; gamma = 0.5; }",
            "design { alpha = 0.5; gamma = 0.5; sample = 0.01; }",
        );
        let models = qpv_dsl::parse(&text).expect("test model parses");
        let model = &models[0];
        let poly = model.polytopic();
        let req = &model.designs[0];
        let dir = std::env::temp_dir().join(format!("qpv-expand-sampled-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let first = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(first.numbers.sample, Some(0.01));
        let fams: Vec<&str> = first
            .numbers
            .margins
            .iter()
            .map(|(f, _)| f.as_str())
            .collect();
        assert!(fams.contains(&"S5d") && !fams.contains(&"S5"), "{fams:?}");
        assert_eq!(first.numbers.figures, Figures::default());
        assert!(first.numbers.request.ends_with("; sample = 0.01"));
        let second = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(second.origin, "cache hit, re-certified");
        assert_eq!(second.numbers, first.numbers);
        // the continuous request of the same model is another cache entry
        let continuous = DesignRequest {
            sample: None,
            ..req.clone()
        };
        assert_ne!(
            cache::key(&poly, req, "s"),
            cache::key(&poly, &continuous, "s")
        );
        let _ = std::fs::remove_dir_all(&dir);
        // the generated code's wording of h is the report's
        for h in [1e-4, 1e-3, 2e-3, 0.05, 3e-7] {
            assert_eq!(
                qpv_codegen::design::describe_period(h),
                qpv_solve::sampling::describe_period(h)
            );
        }
    }

    #[test]
    fn requests_are_described_as_written() {
        let models = qpv_dsl::parse(MODEL).expect("test model parses");
        assert_eq!(
            describe(&models[0].designs[0]),
            "alpha = 0.5; gamma = 0.5; mode = sound"
        );
    }
}
