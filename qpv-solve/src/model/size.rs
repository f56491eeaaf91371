//! The size of a design problem, estimated before anything is assembled,
//! and the budget a design must fit in.
//!
//! A box region in R^nx has p = 2^nx vertices and the full rate family has
//! c·p² blocks (c rate combinations: one per θ-vertex, or r² for the double
//! sum), so the problem grows by 4× (full) or 2× (decoupled) per state.
//! Clarabel's memory is dominated by the constraint matrix, the KKT matrix
//! and its factor (each about the constraint nonzeros plus one dense
//! t×t block per PSD cone of t = d(d+1)/2 rows) and by the dense work of
//! each PSD cone (a few d×d matrices). The independent certificate checks
//! all c·p² blocks of the full family whatever was solved (one symmetric
//! eigenvalue problem each), which bounds the time of every accepted point.
//!
//! The constants were measured with `qpv design --alpha 1 --gamma 0.1`
//! (one solve) on a synthetic chain model (two parameters, so 4 θ-vertices;
//! two outputs; the box |x_i| ≤ 0.02) on a shared 2-core machine: maximum
//! resident memory of the process and Clarabel's solve time.
//!
//! | nx | conditions | PSD blocks | units (estimate) | measured RSS | solve |
//! |---:|---|---:|---:|---:|---:|
//! | 5 | decoupled | 267 | 0.49 M | 16 MB | 2.3 s, 7 iterations |
//! | 6 | decoupled | 525 | 1.67 M | 37 MB | 40 s, 33 iterations |
//! | 5 | full | 4 107 | 7.3 M | 134 MB | 31 s, 10 iterations |
//! | 6 | full | 16 397 | 51 M | ≥ 858 MB | > 300 s (stopped) |
//!
//! That is 12–18 bytes and 0.4–0.7 µs per iteration per unit; the estimate
//! uses [`BYTES_PER_UNIT`] = 24 and [`SECONDS_PER_UNIT`] (25 iterations of
//! 0.6 µs). Extrapolated: nx = 7 full needs about 8 GB, nx = 10 full about
//! 10¹² bytes, nx = 10 decoupled about 3.4 GB and half an hour per solve.
//!
//! [`MEMORY_BUDGET`] and [`CERTIFICATE_BUDGET`] are what a design may use;
//! above [`SLOW_BYTES`], [`SLOW_CERTIFICATE`] or [`SLOW_SECONDS`] per solve
//! it is accepted with a warning that it will be slow (a search runs tens
//! of solves).

use qpv_dsl::{
    AlphaSpec, Conditions, DesignRequest, GammaSpec, Mode, OutputRoute, PolytopicModel, Split,
};

/// Bytes per unit of [`SizeEstimate::units`] (the measurements in the
/// module documentation give 12–18; rounded up).
pub const BYTES_PER_UNIT: f64 = 24.0;

/// Seconds of one solve per unit of [`SizeEstimate::units`]: 25 interior-point
/// iterations of 0.6 µs per unit (measured, see the module documentation).
pub const SECONDS_PER_UNIT: f64 = 1.5e-5;

/// Memory a design may need before it is refused: 4 GiB.
pub const MEMORY_BUDGET: f64 = 4.0 * 1024.0 * 1024.0 * 1024.0;

/// Largest number of rate blocks the certificate may check per candidate
/// point (each an eigenvalue problem of size nx; a search certifies tens of
/// points): 2²², which a box in R^10 with 4 θ-vertices reaches.
pub const CERTIFICATE_BUDGET: f64 = 4_194_304.0;

/// Above this estimate (bytes) a design is accepted with a warning: 512 MiB.
pub const SLOW_BYTES: f64 = 512.0 * 1024.0 * 1024.0;

/// Above this many certificate blocks a design is accepted with a warning.
pub const SLOW_CERTIFICATE: f64 = 262_144.0;

/// Above this estimated time per solve (seconds) a design is accepted with
/// a warning.
pub const SLOW_SECONDS: f64 = 60.0;

/// The estimated size of one design problem (all counts as f64: they can
/// exceed any integer type for large models, which is the point).
#[derive(Debug, Clone, PartialEq)]
pub struct SizeEstimate {
    /// States of the observer model (plant + output filter states).
    pub nx: usize,
    /// Region vertices p.
    pub region_vertices: usize,
    /// Rate combinations c.
    pub combinations: usize,
    /// PSD blocks of size nx solved (rate blocks plus (S1)).
    pub psd_blocks: f64,
    /// PSD blocks of size nx + 1 solved (region facets, and vertices in paper mode).
    pub psd_blocks_plus: f64,
    /// Decision variables.
    pub variables: f64,
    /// Constraint rows (cone dimension).
    pub rows: f64,
    /// Nonzeros of the constraint matrix.
    pub nonzeros: f64,
    /// Stored numbers: constraint matrix, KKT matrix and factor, dense PSD work.
    pub units: f64,
    /// Estimated peak memory in bytes.
    pub bytes: f64,
    /// Estimated time of one solve in seconds (machine dependent).
    pub seconds_per_solve: f64,
    /// Rate blocks the independent certificate checks per point (c·p²).
    pub certificate_blocks: f64,
}

/// t = d(d+1)/2.
fn tri(d: f64) -> f64 {
    d * (d + 1.0) / 2.0
}

/// Estimates the size of the design problem `request` poses on `model`
/// (the plant as written; the output route and conditions of the request
/// are taken into account).
pub fn estimate(model: &PolytopicModel, request: &DesignRequest) -> SizeEstimate {
    let ny = model.ny() as f64;
    let filter = matches!(request.output_route, OutputRoute::Filter(_)) && model.output_varies();
    let nx_u = model.nx() + if filter { model.ny() } else { 0 };
    let nx = nx_u as f64;
    let nv = model.nv().max(1) as f64;
    let double = model.nv() > 1 && model.output_varies() && !filter;
    let c = if double { nv * nv } else { nv };
    let terms = if double { 3.0 } else { 1.0 };
    let p = model.region.vertices.len() as f64;
    let t = tri(nx);
    let t1 = tri(nx + 1.0);
    let conditions = match request.conditions {
        // A sampled design: the full or the decoupled family.
        Conditions::Auto if request.sample.is_some() => choose_sampled(model, request).0,
        Conditions::Auto => choose(model, request).0,
        c => c,
    };
    let r = model
        .region
        .zonotope_generators()
        .map_or(0.0, |g| g.len() as f64);
    let cube = conditions == Conditions::Cube;
    // Cube conditions solve one slack per generator when N_k and M_k are
    // symmetric (H = −2G; the symmetric split makes them so), else a pair,
    // and one facet block per pair of opposite facets (a zonotope's come in
    // pairs); the certificate checks all 4r + 1 inequalities per combination.
    let per_k = cube_slacks_per_generator(model, request);
    let q = model.region.facets.len() as f64 / if cube { 2.0 } else { 1.0 };
    let rate_blocks = match conditions {
        Conditions::Full | Conditions::Auto => c * p * p,
        Conditions::Decoupled => c * 2.0 * p,
        Conditions::Cube => c * (2.0 * per_k * r + 1.0),
    };
    let slack = match conditions {
        Conditions::Full | Conditions::Auto => 0.0,
        Conditions::Decoupled => c * t,
        Conditions::Cube => c * per_k * r * t + r,
    };
    let variables = t + nv * nx * ny + slack + 1.0;
    // The region's vertex rows: p scalars (sound) or p blocks of nx + 1
    // (paper); for cube conditions one block of r (sound) or r + nx (paper).
    let vertex_psd = if request.mode == Mode::Paper && !cube {
        p
    } else {
        0.0
    };
    let vertex_rows = match (cube, request.mode) {
        (true, Mode::Sound) => tri(r) + 1.0,
        (true, Mode::Paper) => tri(r + nx) + 1.0,
        (false, Mode::Sound) => p,
        (false, Mode::Paper) => 0.0,
    };
    // A sampled design's rate block is the discrete decrease, of side 2nx
    // (lmi/sampled.rs); each pole region adds its blocks (side nx or 2nx)
    // beside every rate block (conditions/poles.rs).
    let rate_side = if request.sample.is_some() { 2.0 } else { 1.0 } * nx;
    let pole_sides = pole_sides(request, nx_u);
    let rate_work = |f: &dyn Fn(f64) -> f64| {
        rate_blocks * (f(rate_side) + pole_sides.iter().map(|&d| f(d)).sum::<f64>())
    };
    let rate_rows = rate_work(&tri);
    let psd_blocks = rate_blocks * (1.0 + pole_sides.len() as f64) + 1.0;
    let psd_blocks_plus = q + vertex_psd;
    let rows = rate_rows + t + psd_blocks_plus * t1 + vertex_rows + 1.0;
    // Each rate row depends on P̂ (t), the Γ̂ of its terms, its slack and the
    // margin: a bound for dense data. The cube family is counted from the
    // data's sparsity instead (cheap: c(2r + 1) blocks): there the bound is
    // tens of times too large on a sparse plant (method.md, "Held-out plants").
    let per_rate_row = t + terms * nx * ny + 2.0;
    let gains = if double { 2.0 } else { 1.0 };
    let rate_nnz = match cube_rate_nonzeros(model, nx_u, per_k, gains)
        .filter(|_| cube && request.sample.is_none())
    {
        Some(n) => {
            n * c + rate_blocks * pole_sides.iter().map(|&d| tri(d)).sum::<f64>() * per_rate_row
        }
        None => rate_rows * per_rate_row,
    };
    let vertex_nnz = if cube { vertex_rows * t } else { p * t };
    // A facet block holds P̂ once (t entries) and, in paper mode, γP̂â in its
    // border (at most nx² more); a paper vertex block P̂ and its constant.
    let facet_nnz = t + if request.mode == Mode::Paper {
        nx * nx
    } else {
        0.0
    };
    let nonzeros = rate_nnz + psd_blocks_plus * facet_nnz + vertex_nnz + t;
    // KKT: A, the dense t×t scaling block of every PSD cone, the dense
    // variable block; the factor about as much again; cone work ~12 d².
    // (Blocks wider than nx — the sampled and pole blocks — are counted
    // in proportion to their rows, at the continuous blocks' measured cost
    // per row: the dense d² law over-predicts them several times.)
    let cone_dense = rate_work(&|d| tri(d) * tri(nx)) + tri(t) + psd_blocks_plus * tri(t1);
    // The cube's slacks each touch three blocks of their own combination,
    // so they add fill per slack entry rather than a dense block.
    let kkt = if cube {
        nonzeros + cone_dense + tri(variables - slack) + slack * t
    } else {
        nonzeros + cone_dense + tri(variables)
    };
    let cone_work =
        12.0 * (rate_work(&|d| d * nx) + nx * nx + psd_blocks_plus * (nx + 1.0) * (nx + 1.0));
    let units = nonzeros + 2.0 * kkt + cone_work + rows;
    SizeEstimate {
        nx: nx_u,
        region_vertices: model.region.vertices.len(),
        combinations: c as usize,
        psd_blocks,
        psd_blocks_plus,
        variables,
        rows,
        nonzeros,
        units,
        bytes: units * BYTES_PER_UNIT,
        seconds_per_solve: units * SECONDS_PER_UNIT,
        certificate_blocks: if cube { c * (4.0 * r + 1.0) } else { c * p * p }
            * (1.0 + pole_sides.len() as f64),
    }
}

/// The side of every pole-region block beside a rate block.
fn pole_sides(request: &DesignRequest, nx_u: usize) -> Vec<f64> {
    request
        .poles
        .iter()
        .flat_map(|r| std::iter::repeat(r.block_side(nx_u) as f64).take(r.n_blocks()))
        .collect()
}

/// Slacks per cube generator: one when N_k and M_k are symmetric (H = −2G;
/// the symmetric split makes them so), else a pair.
fn cube_slacks_per_generator(model: &PolytopicModel, request: &DesignRequest) -> f64 {
    let symmetric = |ms: &[nalgebra::DMatrix<f64>]| ms.iter().all(|m| m == &m.transpose());
    let one_slack = request.split == Split::Symmetric
        || model
            .vertices
            .iter()
            .all(|v| symmetric(&v.n) && symmetric(&v.m));
    if one_slack {
        1.0
    } else {
        2.0
    }
}

/// The structural nonzeros of one combination's cube rate blocks (2·per_k·r
/// slack blocks and the main block, lmi/cube.rs) from the support of the
/// model's data, over every θ-vertex (None without zonotope generators).
///
/// A block He{P̂K − Γ̂_l H} has at most nx·nnz(K) nonzeros in the columns of
/// P̂ (the column of P̂_ij holds rows i and j of K) and nx·nnz(H) in those of
/// Γ̂_l; a slack adds its t entries. K is γA_l + (γα/2)I for the constant
/// part and rows(N_l, g_k) (row j = g_kᵀN_{l,j}) for the part of generator k,
/// H is C_m and rows(M_m, g_k); supports are taken of N + Nᵀ (the symmetric
/// split, and rowsHe), unions over the θ-vertices (and the main block's
/// over the generators), so the count bounds the assembly's; `gains` is the
/// number of Γ̂_l per block (2 for the double sum's combinations).
fn cube_rate_nonzeros(model: &PolytopicModel, nx_u: usize, per_k: f64, gains: f64) -> Option<f64> {
    let nx = model.nx();
    if nx_u != nx || model.vertices.is_empty() {
        return None;
    }
    let gens = model.region.zonotope_generators()?;
    let nzf = |x: f64| x != 0.0;
    // supp(rows(T, g)) for the matrices T_j (one per row j of the result).
    let rows_support =
        |ts: &[nalgebra::DMatrix<f64>], g: &nalgebra::DVector<f64>, out: &mut Vec<bool>| {
            for (j, tj) in ts.iter().enumerate() {
                for i in (0..g.len()).filter(|&i| nzf(g[i])) {
                    for col in 0..tj.ncols() {
                        if nzf(tj[(i, col)]) || nzf(tj[(col, i)]) {
                            out[j * tj.ncols() + col] = true;
                        }
                    }
                }
            }
        };
    let ny = model.ny();
    let (mut k_main, mut h_main) = (vec![false; nx * nx], vec![false; ny * nx]);
    for v in &model.vertices {
        for r in 0..nx {
            k_main[r * nx + r] = true;
            for c in 0..nx {
                k_main[r * nx + c] |= nzf(v.a[(r, c)]);
            }
        }
        for r in 0..ny {
            for c in 0..nx {
                h_main[r * nx + c] |= nzf(v.c[(r, c)]);
            }
        }
    }
    let t = tri(nx as f64);
    let count = |m: &[bool]| m.iter().filter(|&&b| b).count() as f64;
    let mut slack_blocks = 0.0;
    for g in &gens {
        let (mut k, mut h) = (vec![false; nx * nx], vec![false; ny * nx]);
        for v in &model.vertices {
            rows_support(&v.n, g, &mut k);
            rows_support(&v.m, g, &mut h);
        }
        // Ŝ alone (t), Ŝ ± G (t + the data's), per slack of the generator.
        slack_blocks += per_k * (2.0 * t + nx as f64 * (count(&k) + gains * count(&h)));
        k_main.iter_mut().zip(&k).for_each(|(a, b)| *a |= *b);
        h_main.iter_mut().zip(&h).for_each(|(a, b)| *a |= *b);
    }
    let main =
        per_k * gens.len() as f64 * t + nx as f64 * (count(&k_main) + gains * count(&h_main));
    Some(slack_blocks + main)
}

/// Largest full family (c·p² rate blocks) that `conditions = auto` solves
/// as it is (docs/method.md, "The automatic choice", has the measurements).
pub const AUTO_FULL_BLOCKS: usize = 4096;

/// Largest full family that `conditions = auto` solves as it is when the
/// design searches both α and γ (`alpha = max; gamma = search`: 50 to 150
/// solves instead of one to twenty). The elastic arm's 4096 blocks took
/// 1114 s on two cores that way with full conditions and 32 s decoupled.
pub const AUTO_FULL_SEARCH_BLOCKS: usize = 2048;

/// Largest decoupled family (c·2p rate blocks) that `conditions = auto`
/// prefers to the cube relaxation when the region is a zonotope.
pub const AUTO_DECOUPLED_BLOCKS: usize = 512;

/// The conditions `conditions = auto` stands for on `model`, and why (one
/// sentence for the report): full while the full family has at most
/// [`AUTO_FULL_BLOCKS`] blocks ([`AUTO_FULL_SEARCH_BLOCKS`] when α and γ
/// are both searched; exact on the vertices, and what every small model
/// has always used); then decoupled while it has at most
/// [`AUTO_DECOUPLED_BLOCKS`] blocks or the region is not a zonotope; then
/// cube. An explicit choice is returned unchanged, with an empty reason.
pub fn choose(model: &PolytopicModel, request: &DesignRequest) -> (Conditions, String) {
    if request.conditions != Conditions::Auto {
        return (request.conditions, String::new());
    }
    let filter = matches!(request.output_route, OutputRoute::Filter(_)) && model.output_varies();
    let nv = model.nv().max(1);
    let c = if model.nv() > 1 && model.output_varies() && !filter {
        nv * nv
    } else {
        nv
    };
    let p = model.region.vertices.len();
    let full = c.saturating_mul(p).saturating_mul(p);
    let decoupled = c.saturating_mul(2 * p);
    let gens = model.region.zonotope_generators().map(|g| g.len());
    let searches = request.alpha == AlphaSpec::Max && request.gamma == GammaSpec::Search;
    let limit = if searches {
        AUTO_FULL_SEARCH_BLOCKS
    } else {
        AUTO_FULL_BLOCKS
    };
    if full <= limit {
        return (
            Conditions::Full,
            format!(
                "conditions = auto chose full: {c} rate combinations × {p}² region-vertex pairs = {full} blocks (at most {limit} are solved exactly{})",
                if searches { " in a search of α and γ" } else { "" }
            ),
        );
    }
    match gens {
        Some(r) if decoupled > AUTO_DECOUPLED_BLOCKS => (
            Conditions::Cube,
            format!(
                "conditions = auto chose cube: the full family would have {full} blocks and the decoupled one {decoupled} (more than {AUTO_DECOUPLED_BLOCKS}); the region is a zonotope with {r} generators, so {} blocks suffice",
                c * (4 * r + 1)
            ),
        ),
        _ => (
            Conditions::Decoupled,
            format!(
                "conditions = auto chose decoupled: the full family would have {full} blocks (more than {limit}{}), the decoupled one has {decoupled}{}",
                if searches { " in a search of α and γ" } else { "" },
                if gens.is_none() {
                    " (the region is not a zonotope, so cube conditions do not apply)"
                } else {
                    ""
                }
            ),
        ),
    }
}

/// The conditions `conditions = auto` stands for in a sampled design, and
/// why (a clause): the full discrete family while it has at most the
/// limit of [`choose`], else its decoupled form (the discrete decrease has
/// no cube form).
pub fn choose_sampled(model: &PolytopicModel, request: &DesignRequest) -> (Conditions, String) {
    let (c, why) = choose(model, request);
    if c == Conditions::Full {
        return (c, why);
    }
    let p = model.region.vertices.len();
    (
        Conditions::Decoupled,
        format!("2·{p} blocks per rate combination in place of {p}²"),
    )
}

/// What the guard decided.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// Fits comfortably.
    Fits,
    /// Fits the budget but will be slow: the warning text.
    Slow(String),
    /// Does not fit: the refusal text (what would fit, which option helps).
    TooLarge(String),
}

fn human_bytes(b: f64) -> String {
    const UNITS: [&str; 6] = ["B", "KiB", "MiB", "GiB", "TiB", "PiB"];
    let mut v = b;
    let mut i = 0;
    while v >= 1024.0 && i + 1 < UNITS.len() {
        v /= 1024.0;
        i += 1;
    }
    if i == UNITS.len() - 1 && v >= 1024.0 {
        return format!("{b:.1e} B");
    }
    format!("{v:.1} {}", UNITS[i])
}

/// Checks `request` on `model` against [`MEMORY_BUDGET`] and
/// [`CERTIFICATE_BUDGET`].
pub fn guard(model: &PolytopicModel, request: &DesignRequest) -> Verdict {
    let e = estimate(model, request);
    let describe = |e: &SizeEstimate| {
        format!(
            "nx = {}, {} region vertices, {} rate combinations: {:.3e} PSD blocks, {:.3e} variables, \
             {:.3e} constraint nonzeros, about {} of solver memory and {:.0} s per solve; the certificate checks {:.3e} blocks",
            e.nx,
            e.region_vertices,
            e.combinations,
            e.psd_blocks + e.psd_blocks_plus,
            e.variables,
            e.nonzeros,
            human_bytes(e.bytes),
            e.seconds_per_solve,
            e.certificate_blocks
        )
    };
    let too_big = e.bytes > MEMORY_BUDGET || e.certificate_blocks > CERTIFICATE_BUDGET;
    if too_big {
        let mut help = Vec::new();
        if matches!(request.conditions, Conditions::Full | Conditions::Decoupled)
            && model.region.zonotope_generators().is_some()
        {
            let mut d = request.clone();
            d.conditions = Conditions::Cube;
            let ed = estimate(model, &d);
            if ed.bytes <= MEMORY_BUDGET {
                help.push(format!(
                    "`conditions = cube` (--conditions cube; the region is a box or zonotope) would need about {}",
                    human_bytes(ed.bytes)
                ));
            }
        }
        if request.conditions == Conditions::Full {
            let mut d = request.clone();
            d.conditions = Conditions::Decoupled;
            let ed = estimate(model, &d);
            if ed.bytes <= MEMORY_BUDGET && ed.certificate_blocks <= CERTIFICATE_BUDGET {
                help.push(format!(
                    "`conditions = decoupled` (--conditions decoupled) would need about {}",
                    human_bytes(ed.bytes)
                ));
            } else if ed.bytes <= MEMORY_BUDGET {
                help.push(format!(
                    "`conditions = decoupled` would fit the solver ({}) but the certificate would still check {:.3e} blocks",
                    human_bytes(ed.bytes),
                    ed.certificate_blocks
                ));
            }
        }
        help.push(
            "a region with fewer vertices (a box in R^n has 2^n; a simplex or a diamond `region vertices [...]` has far fewer) \
             or fewer states"
                .to_string(),
        );
        return Verdict::TooLarge(format!(
            "the design problem is too large: {}; the budget is {} of memory and {:.3e} certificate blocks. \
             What would help: {}",
            describe(&e),
            human_bytes(MEMORY_BUDGET),
            CERTIFICATE_BUDGET,
            help.join("; ")
        ));
    }
    if e.bytes > SLOW_BYTES
        || e.certificate_blocks > SLOW_CERTIFICATE
        || e.seconds_per_solve > SLOW_SECONDS
    {
        return Verdict::Slow(format!(
            "a large design problem ({}); a search runs tens of solver calls{}",
            describe(&e),
            if request.conditions == Conditions::Full {
                "; `conditions = decoupled` is smaller"
            } else {
                ""
            }
        ));
    }
    Verdict::Fits
}
