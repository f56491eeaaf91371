//! The expansion pipeline: input → `qpv_dsl::parse` → polytopic model →
//! for each design request: a cache hit or a solve → the library's baked,
//! certified numbers ([`qpv_solve::export`]) → emit. The macro parses,
//! calls and emits: the certificate, the figures and the explanation of a
//! failure are the library's.
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
use proc_macro2::TokenStream;
use qpv_dsl::{
    AlphaSpec, Conditions, DesignRequest, Float, GammaSpec, Mode, Model, NoiseObjective,
    OutputFilter, OutputRoute, PolytopicModel, Split,
};
use qpv_solve::export::{self, BakeError, Baked};
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
    if req.noise == NoiseObjective::Rms {
        let list = |v: &[f64]| v.iter().map(f64::to_string).collect::<Vec<_>>().join(", ");
        text.push_str(&format!(
            "; noise = rms; output_std = {}",
            list(&req.output_std)
        ));
        if !req.process_std.is_empty() {
            text.push_str(&format!("; process_std = {}", list(&req.process_std)));
        }
        if let Some(dt) = req.noise_period {
            text.push_str(&format!("; noise_period = {dt}"));
        }
    }
    if let Some(h) = req.sample {
        text.push_str(&format!("; sample = {h}"));
    }
    for (k, r) in req.poles.iter().enumerate() {
        text.push_str(if k == 0 { "; poles = " } else { ", " });
        text.push_str(&r.to_string());
    }
    text
}

fn mode_name(m: Mode) -> &'static str {
    match m {
        Mode::Sound => "sound",
        Mode::Paper => "paper",
    }
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
                    export::best_sound_design(&poly, &settings())
                ),
            ),
            no_stub(),
        ));
    }

    // The stub used if a design fails: the real API with zero data.
    let stub = || {
        let zero = |req: &DesignRequest| {
            let filter = filter_of(req.output_route);
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
                noise_missing: None,
                float: req.float,
                sample: req.sample,
                time_unit: model.time_unit,
                alpha_sup: None,
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

/// The output post-filter of the filter route.
fn filter_of(route: OutputRoute) -> Option<OutputFilter> {
    match route {
        OutputRoute::Filter(f) => Some(f),
        OutputRoute::DoubleSum => None,
    }
}

/// The cached or freshly solved design for one request, certified on the
/// numbers to bake; or the message of the compile error.
fn one_design(
    model: &Model,
    poly: &PolytopicModel,
    req: &DesignRequest,
    cache: Option<&std::path::Path>,
) -> Result<Outcome, String> {
    let settings = settings();
    let request = describe(req);
    // The key is the model as written (`state_bound auto` included), so an
    // auto bound is cached with the design.
    let key = cache::key(poly, req, &settings);
    // A hit is a claim: re-checked as the request asks, never trusted.
    let hit = cache
        .and_then(|dir| cache::load(dir, &key))
        .and_then(|d| Baked::claimed_for(poly, d, req).ok());
    if let Some(baked) = hit {
        return Ok(Outcome {
            origin: "cache hit, re-certified",
            numbers: numbers(model, poly, (req, &request), &baked),
        });
    }
    let (design, baked) = solve(poly, req, &settings, &request)?;
    if let Some(dir) = cache {
        cache::store(dir, &key, &design);
    }
    Ok(Outcome {
        origin: "solved",
        numbers: numbers(model, poly, (req, &request), &baked),
    })
}

/// Solves the request and bakes the design ([`Baked::solved`]): only a
/// certified design (or, in paper mode, a feasible reproduction) is baked,
/// and an f32 design whose rounded numbers fail the certificate is solved
/// again with the margin of the strict inequalities ten and a hundred times
/// larger (never baked uncertified). Returns the design to cache with its
/// baked numbers.
fn solve(
    poly: &PolytopicModel,
    req: &DesignRequest,
    settings: &Settings,
    request: &str,
) -> Result<(Design, Baked), String> {
    let tries = match req.float {
        Float::F64 => 1,
        Float::F32 => 3,
    };
    let mut failing = String::new();
    for k in 0..tries {
        let s = Settings {
            margin_rel: settings.margin_rel * 10f64.powi(k),
            ..settings.clone()
        };
        let design = qpv_solve::design(poly, req, &s)
            .map_err(|e| format!("design `{request}` cannot be attempted: {e}"))?;
        match Baked::solved(poly, design.clone(), req.float) {
            Ok(baked) => return Ok((design, baked)),
            Err(BakeError::NotCertified) => {
                let why = export::explain(poly, req, &design, settings);
                return Err(format!("design `{request}` {why}; no gain was baked"));
            }
            Err(BakeError::Failed(cert)) if req.float == Float::F32 => {
                failing = export::failing_families(&cert);
            }
            Err(e) => {
                return Err(format!(
                    "design `{request}`: {e} (an internal error; please report it)"
                ))
            }
        }
    }
    Err(format!(
        "design `{request}`: the f32-rounded P and L_l did not pass the certificate \
         ({failing}); not baked (solved again with the margin 10 and 100 times larger: \
         still failing)"
    ))
}

/// The numbers to emit for a baked design ([`Baked::certified_design`]:
/// P, L_l, the margins of their certificate, the figures computed on them,
/// α_sup for `alpha = max` and, for f32, the certified error floors of the
/// generated arithmetic, absent where none is certified).
fn numbers(
    model: &Model,
    poly: &PolytopicModel,
    (req, request): (&DesignRequest, &str),
    baked: &Baked,
) -> CertifiedDesign {
    baked
        .certified_design(model, &poly.scheduling, request, req.alpha)
        .0
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

    /// The model of `MODEL` with its first design block replaced by `design`.
    fn model_with(design: &str) -> Model {
        let text = MODEL.replace("design { alpha = 0.5; gamma = 0.5; }", design);
        qpv_dsl::parse(&text).expect("test model parses").remove(0)
    }

    /// A cache directory of its own for one test.
    fn fresh_dir(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("qpv-expand-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    /// Rewrites the cached design of `req` through `edit`.
    fn tamper(
        dir: &std::path::Path,
        poly: &PolytopicModel,
        req: &DesignRequest,
        edit: impl FnOnce(&mut Design),
    ) {
        let key = cache::key(poly, req, &settings());
        let mut d = cache::load(dir, &key).expect("cached");
        edit(&mut d);
        cache::store(dir, &key, &d);
    }

    #[test]
    fn cache_hits_are_recertified_and_tampered_entries_re_solved() {
        let model = model_with("design { alpha = 0.5; gamma = 0.5; }");
        let poly = model.polytopic();
        let req = &model.designs[0];
        let dir = fresh_dir("test");

        let first = one_design(&model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(first.origin, "solved");
        let second = one_design(&model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(second.origin, "cache hit, re-certified");
        assert_eq!(second.numbers.p, first.numbers.p);
        assert_eq!(second.numbers.l, first.numbers.l);
        // the cache holds the design itself, as `qpv design --json` writes it
        let key = cache::key(&poly, req, &settings());
        let text =
            std::fs::read_to_string(cache::file_for(&dir, &key)).expect("cache file written");
        let (stored_key, json) = text.split_once("---\n").expect("key, then the design");
        assert_eq!(stored_key, key);
        let cached = Design::from_json(json).expect("a design");
        assert!(cached.certifies() && cached.recheck(&poly).passed);

        // A cached P that no longer certifies (here: negated) is not trusted.
        tamper(&dir, &poly, req, |d| {
            for row in &mut d.p {
                row.iter_mut().for_each(|v| *v = -*v);
            }
        });
        assert_ne!(
            std::fs::read_to_string(cache::file_for(&dir, &key)).expect("file"),
            text
        );
        let third = one_design(&model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(third.origin, "solved", "a tampered entry is re-solved");
        assert_eq!(third.numbers.p, first.numbers.p);

        // What the request asks of the certificate is the request's, not the
        // entry's: a cached design claiming a paper-mode check is checked in
        // sound mode, and a gain bound the request sets is checked although
        // the entry drops it.
        tamper(&dir, &poly, req, |d| d.mode = Mode::Paper);
        let fourth = one_design(&model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(fourth.origin, "cache hit, re-certified");
        assert_eq!(fourth.numbers, first.numbers);
        let gain = cached.gain_norms.iter().copied().fold(0.0, f64::max);
        assert!(gain > 0.0);
        let bounded = DesignRequest {
            max_gain: Some(gain / 2.0),
            ..req.clone()
        };
        let key = cache::key(&poly, &bounded, &settings());
        cache::store(&dir, &key, &cached);
        let hit = cache::load(&dir, &key).expect("stored under the bounded request");
        assert_eq!(hit.max_gain, None);
        assert!(
            Baked::claimed_for(&poly, hit, &bounded).is_err(),
            "gains above the request's bound are refused"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn cube_designs_are_rechecked_and_cached_with_their_slacks() {
        let model = model_with("design { alpha = 0.5; gamma = 0.5; conditions = cube; }");
        let poly = model.polytopic();
        let req = &model.designs[0];
        assert_eq!(req.conditions, Conditions::Cube);
        let dir = fresh_dir("cube");

        let first = one_design(&model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(first.origin, "solved");
        assert!(first.numbers.certifies && first.numbers.alpha == 0.5);
        // The baked margins are the cube's: the vertex family is the
        // region's slack condition, all positive.
        assert!(first.numbers.margins.iter().all(|(_, m)| *m > 0.0));
        let key = cache::key(&poly, req, &settings());
        let entry = cache::load(&dir, &key).expect("cached");
        let c = entry.cube.clone().expect("the slacks are cached");
        // box(1) in R²: two generators, 2 × 2 slack matrices
        assert_eq!(c.d.len(), 2);
        assert!(!c.y.is_empty() && c.x.len() == c.y.len());
        assert!(c
            .y
            .iter()
            .chain(&c.x)
            .all(|combo| combo.len() == 2 && combo.iter().all(|m| m.len() == 2)));
        assert!(c.d.iter().sum::<f64>() <= 1.0);

        let second = one_design(&model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(second.origin, "cache hit, re-certified");
        assert_eq!(second.numbers, first.numbers);

        // Slacks that break the cube's region condition (trace D = 2 > 1)
        // fail the re-check although P and L_l still satisfy the vertex
        // family: the hit is checked by its slacks, and re-solved.
        let mut full = entry.clone();
        full.cube = None;
        assert!(
            full.recheck(&poly).passed,
            "the full vertex family alone would accept it"
        );
        tamper(&dir, &poly, req, |d| {
            if let Some(c) = d.cube.as_mut() {
                c.d = vec![1.0, 1.0];
            }
        });
        let third = one_design(&model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(third.origin, "solved", "bad slacks are re-solved");
        assert_eq!(third.numbers, first.numbers);

        // A design without its slacks (the `cube` key) still loads, and is
        // re-certified on the full vertex family.
        tamper(&dir, &poly, req, |d| d.cube = None);
        assert_eq!(cache::load(&dir, &key).expect("loads").cube, None);
        let fourth = one_design(&model, &poly, req, Some(&dir)).expect("certified");
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
        let dir = fresh_dir("auto");
        let first = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(first.origin, "solved");
        let key = cache::key(&poly, req, &settings());
        let entry = cache::load(&dir, &key).expect("cached");
        let b = entry.state_bound.clone().expect("the computed Q is cached");
        assert!(b.h.is_some_and(|h| h > 0.0));
        assert!(b
            .q
            .as_ref()
            .is_some_and(|q| q.len() == 2 && q.iter().all(|r| r.len() == 2)));
        assert!(entry.recheck(&poly).passed, "the cached Q re-checks");
        let mut huge = entry.clone();
        if let Some(sb) = huge.state_bound.as_mut() {
            sb.q = Some(vec![vec![1e6, 0.0], vec![0.0, 1e6]]);
        }
        let rejected = huge.recheck(&poly);
        assert!(!rejected.passed, "a Q whose F leaves the box fails");
        let second = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(second.origin, "cache hit, re-certified");
        assert_eq!(second.numbers.l, first.numbers.l);
        // an entry with that Q is not used
        cache::store(&dir, &key, &huge);
        let third = one_design(model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(third.origin, "solved");
        assert_eq!(third.numbers, first.numbers);
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
        let dir = fresh_dir("filter");
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
            cache::key(&poly, req, &settings()),
            cache::key(&poly, &ds, &settings()),
            "the route is part of the key"
        );
        // and a design for the other route is never taken for this one
        let key = cache::key(&poly, req, &settings());
        let cached = cache::load(&dir, &key).expect("cached");
        assert!(Baked::claimed_for(&poly, cached, &ds).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn sampled_designs_are_rechecked_on_the_discrete_family() {
        let model = model_with("design { alpha = 0.5; gamma = 0.5; sample = 0.01; }");
        let poly = model.polytopic();
        let req = &model.designs[0];
        let dir = fresh_dir("sampled");
        let first = one_design(&model, &poly, req, Some(&dir)).expect("certified");
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
        let second = one_design(&model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(second.origin, "cache hit, re-certified");
        assert_eq!(second.numbers, first.numbers);
        // an entry that drops its sample period is still checked at the
        // request's h, on the discrete family
        tamper(&dir, &poly, req, |d| d.sample = None);
        let third = one_design(&model, &poly, req, Some(&dir)).expect("certified");
        assert_eq!(third.origin, "cache hit, re-certified");
        assert_eq!(third.numbers, first.numbers);
        // the continuous request of the same model is another cache entry
        let continuous = DesignRequest {
            sample: None,
            ..req.clone()
        };
        assert_ne!(
            cache::key(&poly, req, &settings()),
            cache::key(&poly, &continuous, &settings())
        );
        let _ = std::fs::remove_dir_all(&dir);
        // the generated code's wording of h is the report's (one function),
        // and a huge or tiny h stays short
        let seconds = qpv_dsl::TimeUnit::Seconds;
        assert_eq!(seconds.describe_period(2e-3), "h = 2e-3 s (500 Hz)");
        for h in [1e305, 1e-300] {
            let text = seconds.describe_period(h);
            assert!(text.len() < 48, "{text}");
        }
    }

    #[test]
    fn a_failed_design_is_explained_by_the_library() {
        // The explanation and its searches are the library's
        // (qpv-solve/tests/export.rs tests their content); the macro only
        // names the request and says that nothing was baked.
        let model = qpv_dsl::parse(include_str!("../../tests/nostd/paper_sound.qpv"))
            .expect("the paper model parses")
            .remove(0);
        let poly = model.polytopic();
        let mut req = poly.designs[0].clone();
        req.gamma = GammaSpec::Fixed(0.4);
        let Err(text) = one_design(&model, &poly, &req, None) else {
            panic!("gamma = 0.4 exceeds the (S4) limit")
        };
        let d = qpv_solve::design(&poly, &req, &settings()).expect("design runs");
        let why = export::explain(&poly, &req, &d, &settings());
        assert_eq!(
            text,
            format!("design `{}` {why}; no gain was baked", describe(&req))
        );
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
