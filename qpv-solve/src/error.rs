//! Why a design (or a preparation of the observer's model) could not be attempted.

/// Why a design could not even be attempted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SolveError {
    /// Sound mode needs the state bound F (Q) for (S4) and for the γ range.
    #[error("model `{0}` has no state_bound Q: sound mode needs it for (S4) and the γ range")]
    MissingStateBound(String),
    /// The convergence region has no vertices or no facets.
    #[error("the convergence region is empty (it needs vertices and facets)")]
    EmptyRegion,
    /// The model has no parameter vertex.
    #[error("the polytopic model has no vertices")]
    NoVertices,
    /// A fixed γ outside (0, 1).
    #[error("γ = {0} is not in (0, 1)")]
    BadGamma(f64),
    /// A fixed α that is not a positive finite number.
    #[error("α = {0} is not a positive finite number")]
    BadAlpha(f64),
    /// A sampled request whose rate needs a decrease factor 1 − hα ≤ 0.
    #[error(
        "α = {} at sample = {}: hα = {} ≥ 1, so V(e_k+1) ≤ (1 − hα)·V(e_k) ≤ 0 cannot hold for any e_k ≠ 0 and no design exists; at this period every certified α is below 1/h = {}",
        qpv_dsl::diagnostic::fmt_num(*alpha),
        qpv_dsl::diagnostic::fmt_num(*h),
        qpv_dsl::fmt_sig(h * alpha, 5),
        qpv_dsl::fmt_sig(1.0 / h, 5)
    )]
    StepTooLong {
        /// The sample period.
        h: f64,
        /// The requested rate.
        alpha: f64,
    },
    /// (S4) leaves no admissible γ: γ_max = 1/max_k sqrt(a_kᵀQa_k) is not positive/finite.
    #[error("no admissible γ: γ_max from (S4) is {0}")]
    NoGammaRange(f64),
    /// Inconsistent dimensions in the model data.
    #[error("inconsistent model data: {0}")]
    Dimensions(String),
    /// A requested option that this version does not implement.
    #[error("not implemented: {0}")]
    Unsupported(String),
    /// Options of one design request that cannot be combined (the
    /// language's rule, [`qpv_dsl::DesignRequest::validate`]).
    #[error("{0}")]
    Clash(qpv_dsl::Clash),
    /// Paper mode on an LPV plant written without a region: the printed
    /// conditions need a region; the plant's sound design is the global
    /// observer.
    #[error("model `{0}`: paper mode reproduces the printed conditions on a region, and this LPV plant has none; its sound design is the global observer (docs/method.md §17)")]
    PaperWithoutRegion(String),
    /// `split = skew_slack` on an LPV plant: the slack reshapes N_k, which
    /// is zero there.
    #[error("model `{0}`: split = skew_slack (its slack reshapes N_k, which is zero) is not built for an LPV plant, whose observer is the global one (docs/method.md §17); design with the symmetric split")]
    SkewOnLpv(String),
    /// `split = skew_slack` in paper mode, or from a design that does not
    /// certify: the alternation starts from a certified sound design.
    #[error("split = skew_slack needs mode = sound and starts from a certified sound design (the paper's conditions are reproduced as printed)")]
    SkewNeedsSound,
    /// `state_bound auto` ran and found no usable state bound (no invariant
    /// ellipsoid in any box tried), or a claimed Q does not hold for the
    /// model: an outcome about the plant, not a mistake in the input.
    #[error("state_bound auto: {0}")]
    StateBound(String),
    /// `state_bound auto` cannot be attempted on this input (too many
    /// states or invariance blocks, a box size h that does not enclose the
    /// region): nothing was solved; giving Q or changing the model helps.
    #[error("state_bound auto: {0}")]
    StateBoundInput(String),
    /// Clarabel refused the problem data (a bug here, reported as an error).
    #[error("solver setup failed: {0}")]
    Setup(String),
    /// The problem would not fit the size budget ([`crate::model::size`]): what it
    /// needs, what would fit and which option helps. Nothing was solved.
    #[error("{0}")]
    TooLarge(String),
}
