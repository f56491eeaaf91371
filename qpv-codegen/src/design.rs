//! The certified numbers an emitter bakes, and the sizes of one design.

use qpv_dsl::OutputFilter;

/// The numbers of one certified design.
#[derive(Debug, Clone, PartialEq)]
pub struct CertifiedDesign {
    /// The request as the user wrote it, in words (`alpha = 10, gamma = 0.18, mode = sound`).
    pub request: String,
    /// `"sound"` or `"paper"`.
    pub mode: String,
    /// True for a certified sound-mode design: an `Observer` is generated.
    /// False for a paper-mode reproduction: only its record is generated
    /// (the printed conditions hold, but they certify nothing), no gain.
    pub certifies: bool,
    /// Certified decay rate α.
    pub alpha: f64,
    /// Certified region scaling γ.
    pub gamma: f64,
    /// The Lyapunov matrix P, nz × nz row-major (nz = nx, or nx + ny for a filter design).
    pub p: Vec<f64>,
    /// The vertex gains L_l, each nz × ny row-major, one per vertex.
    pub l: Vec<Vec<f64>>,
    /// Worst margin per condition family (positive = satisfied).
    pub margins: Vec<(String, f64)>,
    /// The solver's final status.
    pub status: String,
    /// Solver iterations of the accepted solve.
    pub iterations: u32,
    /// The output post-filter of a filter-route design (`output_route =
    /// filter`): then P is (nx+ny)² and each L_l is (nx+ny) × ny, the
    /// design being for the plant augmented by the filter. `None`: the
    /// double-sum route, P is nx × nx, L_l is nx × ny.
    pub filter: Option<OutputFilter>,
    /// The float type of the generated observer (`float = f32` in the design
    /// block): for f32, P and L_l here are already rounded to f32 and
    /// certified as such.
    pub float: qpv_dsl::Float,
    /// The noise and sampling figures computed on the baked numbers; `None`
    /// where nothing could be certified (then the generated constants say
    /// "no bound": an infinite σ and zero steps).
    pub figures: Figures,
    /// Why a certified design has no noise bound (`figures.sigma` is
    /// `None`), when that is known; printed in place of "none certified".
    pub noise_missing: Option<String>,
    /// `alpha = max`: the search's estimate of the certified supremum α_sup
    /// (the fastest α it certified, at another γ or a higher gain). An
    /// estimate of the supremum, not a certified rate of this design
    /// (`alpha` is). `None` for a fixed α.
    pub alpha_sup: Option<f64>,
    /// `sample = h`: the sample period (seconds) the design is certified at
    /// (the discrete decrease S5d: the observer stepped by one explicit
    /// Euler step of exactly h, V(e_{k+1}) ≤ (1 − hα)V(e_k)); then the
    /// emitted observer has `SAMPLE_PERIOD` and a fixed-step `step`.
    /// `None`: a continuous-time design.
    pub sample: Option<f64>,
    /// The model's unit of time: α is per this unit, h is in it.
    pub time_unit: qpv_dsl::TimeUnit,
}

/// The noise bound and the sampling figures of a certified design, each
/// present only if its own check passed on the baked P and L_l.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Figures {
    /// σ in V' + αV ≤ σ(|v|² + |w|²) on the model's noise channels.
    pub sigma: Option<f64>,
    /// ‖e(∞)‖ per unit noise amplitude, √(σ/(α λ_min(P))).
    pub error_bound: Option<f64>,
    /// ν_max = √(α/σ): the noise amplitude up to which the certified set stays invariant.
    pub max_amplitude: Option<f64>,
    /// The largest certified explicit Euler step, and its contraction rate β.
    pub euler: Option<(f64, f64)>,
    /// The RK4 step estimate (frozen vertex dynamics; not a proof).
    pub rk4: Option<f64>,
    /// The certified f32 error floor (f32 designs): lim sup ‖e(t)‖ caused by
    /// the rounding of the right-hand side in f32 alone
    /// ([`crate::rounding`]; docs/method.md §15, "The f32 error floor").
    pub f32_floor: Option<f64>,
    /// The f32 floor of explicit Euler steps, the state update's rounding
    /// included: lim sup ‖e‖ ≤ base + per_step/h for min_step < h ≤ the
    /// certified Euler step.
    pub f32_euler: Option<EulerFloor>,
    /// The split of the f32 rounding of one right-hand side evaluation
    /// behind `f32_floor` (f32 designs with a floor).
    pub f32_rounding: Option<F32Rounding>,
    /// A sampled f32 design: the certified bound on lim sup ‖e_k‖ of its
    /// fixed step at the sample period, the state update's rounding
    /// included (docs/embedded.md, "The f32 floor of a sampled step").
    pub f32_step_floor: Option<f64>,
    /// `noise = rms`: the certified bound on the time-averaged RMS error
    /// under the design's white noise, in total and per state (recomputed
    /// from the baked P and L_l); None for other designs.
    pub rms: Option<(f64, Vec<f64>)>,
}

/// The rounding of one evaluation of the f32 right-hand side, as the floor
/// uses it: |δ_k| ≤ d₀_k + d₁_k ρ (ρ = √(eᵀPe)), and in the P-norm D₀, D₁.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct F32Rounding {
    /// D₀: the part independent of the error, in the P-norm.
    pub d0: f64,
    /// D₁: the part per unit ρ, in the P-norm; it lowers the rate by 2D₁.
    pub d1: f64,
    /// The lowered rate α − 2D₁ (per second) the floor is certified with.
    pub rate: f64,
}

/// The f32 floor of explicit Euler steps ([`Figures::f32_euler`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EulerFloor {
    /// The part of the floor that does not depend on h.
    pub base: f64,
    /// The rounding of the state update x̂ + h·k, divided by h in the floor.
    pub per_step: f64,
    /// The smallest step at which the floor is certified (exclusive).
    pub min_step: f64,
}

impl CertifiedDesign {
    /// "h = 1e-4 s (10 kHz)": the sample period of a sampled design and
    /// its rate (the shortest round-tripping form of h), or `None`.
    pub fn sample_text(&self) -> Option<String> {
        self.sample.map(|h| self.time_unit.describe_period(h))
    }

    /// Entry `[k][o]` of the vertex gain L_l (0 if missing).
    pub fn gain_entry(&self, ny: usize, l: usize, k: usize, o: usize) -> f64 {
        self.l
            .get(l)
            .and_then(|lv| lv.get(k * ny + o))
            .copied()
            .unwrap_or(0.0)
    }
}

/// The sizes of one design and of its observer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shape {
    /// Plant states.
    pub nx: usize,
    /// Measured outputs.
    pub ny: usize,
    /// Known inputs.
    pub nu: usize,
    /// Vertices of the parameter box (of every piece of a cover).
    pub nv: usize,
    /// The design's state: the plant's (double sum), or the plant's and
    /// one filter state per output (filter route).
    pub nz: usize,
    /// The observer's state: the design's, plus the filtered measurement
    /// x_y for the filter route.
    pub ns: usize,
    /// The output post-filter of a filter-route design.
    pub filter: Option<OutputFilter>,
}

impl Shape {
    /// The shape of design `d` of model `m` with `nv` vertices.
    pub fn of(m: &qpv_dsl::Model, nv: usize, d: &CertifiedDesign) -> Self {
        let (nx, ny) = (m.nx(), m.ny());
        let filter = d.filter;
        Shape {
            nx,
            ny,
            nu: m.nu(),
            nv,
            nz: if filter.is_some() { nx + ny } else { nx },
            ns: if filter.is_some() { nx + 2 * ny } else { nx },
            filter,
        }
    }

    /// The output route's name, as `ROUTE` spells it.
    pub fn route(&self) -> &'static str {
        if self.filter.is_some() {
            "filter"
        } else {
            "double_sum"
        }
    }

    /// The observer state's names: x̂ (`x<i>`), then for the filter route
    /// the filter estimate x̂_y (`zh<k>`) and the filtered measurement x_y
    /// (`zm<k>`).
    pub fn state_names(&self) -> Vec<String> {
        let mut names: Vec<String> = (0..self.nx).map(|i| format!("x{i}")).collect();
        if self.filter.is_some() {
            names.extend((0..self.ny).map(|k| format!("zh{k}")));
            names.extend((0..self.ny).map(|k| format!("zm{k}")));
        }
        names
    }
}

/// Number of vertices of a model: 2^s corners (s scheduling parameters and
/// derived variables) per piece of its cover.
pub fn vertex_count(m: &qpv_dsl::Model, scheduling: &[usize]) -> usize {
    let pieces = m.cover.as_ref().map_or(1, |c| c.len());
    pieces << (scheduling.len() + m.derived.len())
}
