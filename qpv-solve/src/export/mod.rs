//! What a code generator takes from a design: the numbers as the generated
//! code holds them (f64, or rounded to f32), certified on exactly those
//! values ([`Baked`]); the figures computed on them ([`Figures`]: the noise
//! bound and the sampling figures, under the size guard of
//! [`crate::report::figures::attach`]); the certified f32 error floor
//! ([`Baked::f32_floor`]); the code generator's input built from all that
//! ([`Baked::certified_design`], the [`CertifiedDesign`] of
//! [`qpv_codegen`]); and for a design that is not certified, why
//! ([`explain`]).
//!
//! `qpv!` and `qpv codegen` both bake through here, so an observer is
//! generated from the same certificate whichever of them prints it
//! (docs/method.md §12, what "certified" means; §15, the figures).

pub mod explain;

pub use explain::{best_sound_design, explain, Best, Explanation, Failing, SoundDesign, Tradeoff};

use crate::certificate::rounding::{rounding_floor, FloorInputs, RhsRounding, RoundingFloor};
use crate::certificate::sampling::SampleInfo;
use crate::certificate::Certificate;
use crate::error::SolveError;
use crate::report::{Design, ReportedMatrices};
use crate::vocab::Verdict;
use nalgebra::DMatrix;
use qpv_codegen::{CertifiedDesign, Figures};
use qpv_dsl::{DesignRequest, Float, Mode, Model, OutputRoute, PolytopicModel};

/// A design whose P and L_l, as generated code holds them, passed the
/// independent certificate, with the figures computed on those numbers.
///
/// Only [`Baked::solved`] and [`Baked::claimed`] make one, so holding a
/// `Baked` means the numbers were certified: a design returned by
/// [`crate::design`] (its own certificate, on the f64 numbers) or, for
/// anything else, [`Design::recheck_on`] on exactly the numbers baked.
#[derive(Debug, Clone)]
pub struct Baked {
    design: Design,
    observer: PolytopicModel,
    float: Float,
}

/// Why a design was not baked.
#[derive(Debug, Clone)]
pub enum BakeError {
    /// The design is not certified (sound mode) or does not satisfy the
    /// printed conditions (paper mode): nothing to bake; [`explain`] says
    /// why.
    NotCertified,
    /// The design cannot be applied to the model (a refused state bound, a
    /// route or skew slack that does not fit).
    Model(SolveError),
    /// P and L_l do not have the sizes of the observer's model, or are not
    /// finite.
    Malformed(String),
    /// The numbers as baked (rounded to f32 when asked) failed the
    /// independent certificate, whose failing families it holds.
    Failed(Box<Certificate>),
}

impl std::fmt::Display for BakeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BakeError::NotCertified => f.write_str("the design is not certified"),
            BakeError::Model(e) => write!(f, "the design does not fit the model: {e}"),
            BakeError::Malformed(m) => f.write_str(m),
            BakeError::Failed(c) => write!(
                f,
                "the numbers did not pass the certificate ({})",
                failing_families(c)
            ),
        }
    }
}

/// What failed in a certificate, in words: its input errors, the failing
/// families ("NAME margin M", three significant digits) and the failing
/// required data checks ("NAME value > bound").
pub fn failing_families(cert: &Certificate) -> String {
    let mut v: Vec<String> = cert.input_errors.clone();
    v.extend(
        cert.families
            .iter()
            .filter(|f| !f.passed)
            .map(|f| format!("{} margin {}", f.name, explain::sig(f.margin))),
    );
    v.extend(
        cert.data_checks
            .iter()
            .filter(|(_, c)| c.required && !c.passed)
            .map(|(k, c)| format!("{k} {:.4} > {}", c.value, c.bound)),
    );
    if v.is_empty() {
        "no family failed, but the certificate did not pass".into()
    } else {
        v.join(", ")
    }
}

impl Baked {
    /// The numbers of a design [`crate::design`] returned, as a `float`
    /// observer holds them. An f64 design is baked as it is (its own
    /// certificate passed on exactly these numbers); for f32, P, L_l and
    /// the sample period are rounded to f32 and the rounded values
    /// re-checked ([`Design::recheck_on`]; where the cube slacks, found for
    /// the f64 numbers, no longer fit, on the full vertex family).
    pub fn solved(
        plant: &PolytopicModel,
        design: Design,
        float: Float,
    ) -> Result<Baked, BakeError> {
        let accepted = match design.mode {
            Mode::Sound => design.certifies(),
            Mode::Paper => design.feasible(),
        };
        if !accepted {
            return Err(BakeError::NotCertified);
        }
        let observer = design.observer_model(plant).map_err(BakeError::Model)?;
        match float {
            Float::F64 => Baked::finish(plant, design, observer, float),
            Float::F32 => {
                let mut rounded = rounded_to_f32(&design);
                // The RMS claim of the rounded numbers is their own.
                if let Some(b) = &design.rms {
                    let (p, l) = (rounded.p_matrix(), rounded.l_matrices());
                    rounded.rms = crate::certificate::rms::rms_bound(
                        &observer,
                        &b.noise,
                        rounded.gamma,
                        &p,
                        &l,
                    );
                }
                Baked::rechecked(plant, rounded, observer, float)
            }
        }
    }

    /// The numbers of a design read from somewhere (a cache, a gains file),
    /// as a `float` observer holds them: a claim, so they are re-checked
    /// whatever the design says of itself ([`Design::recheck_on`], its
    /// cube slacks, skew slack, state bound and sample period included),
    /// and its margins and figures are recomputed.
    pub fn claimed(
        plant: &PolytopicModel,
        design: Design,
        float: Float,
    ) -> Result<Baked, BakeError> {
        let observer = design.observer_model(plant).map_err(BakeError::Model)?;
        let design = match float {
            Float::F64 => design,
            Float::F32 => rounded_to_f32(&design),
        };
        Baked::rechecked(plant, design, observer, float)
    }

    /// [`Baked::claimed`] for a design read back as the answer to `request`
    /// (`qpv!`'s cache): the certificate is the one the request asks for
    /// (its mode, sample period, gain bound and pole regions replace the design's own),
    /// the numbers are those of the request's `float`, and a design for
    /// another output route is refused.
    pub fn claimed_for(
        plant: &PolytopicModel,
        mut design: Design,
        request: &DesignRequest,
    ) -> Result<Baked, BakeError> {
        if design.route() != request.output_route {
            return Err(BakeError::Malformed(
                "the design is for another output route than the request".into(),
            ));
        }
        design.mode = request.mode;
        design.max_gain = request.max_gain;
        design.poles = request.poles.clone();
        design.sample = request.sample.map(|h| SampleInfo::new(h, design.alpha));
        Baked::claimed(plant, design, request.float)
    }

    /// The design with the baked P and L_l: its margins are those of the
    /// certificate of exactly these numbers, and its `noise` and
    /// `sampling` were computed on them.
    pub fn design(&self) -> &Design {
        &self.design
    }

    /// For an `alpha = max` request, the search's certified supremum
    /// estimate α_sup: the fastest α it certified (the practical design
    /// returns α ≥ (1 − within)·α_sup at a smaller gain; with `within = 0`
    /// the design's own α). An estimate of the supremum, not a rate this
    /// design certifies. `None` for a fixed α.
    pub fn alpha_sup(&self, alpha: qpv_dsl::AlphaSpec) -> Option<f64> {
        match alpha {
            qpv_dsl::AlphaSpec::Max => Some(
                self.design
                    .practical
                    .as_ref()
                    .map_or(self.design.alpha, |p| p.alpha_sup),
            ),
            qpv_dsl::AlphaSpec::Fixed(_) => None,
        }
    }

    /// The float type the numbers are held in (f32: rounded, each exactly
    /// representable in f64).
    pub fn float(&self) -> Float {
        self.float
    }

    /// The observer's model the numbers are certified on
    /// ([`Design::observer_model`]).
    pub fn observer(&self) -> &PolytopicModel {
        &self.observer
    }

    /// The RMS bound of a `noise = rms` design, recomputed on the baked P
    /// and L_l (its claim is only baked when that recomputation holds it).
    fn rms(&self) -> Option<(f64, Vec<f64>)> {
        let claimed = self.design.rms.as_ref()?;
        let (p, l) = (self.design.p_matrix(), self.design.l_matrices());
        let b = crate::certificate::rms::rms_bound(
            &self.observer,
            &claimed.noise,
            self.design.gamma,
            &p,
            &l,
        )?;
        Some((b.total, b.per_state))
    }

    /// The figures of the baked numbers, each present only if its own check
    /// passed (none for a sampled design, whose continuous-time figures say
    /// nothing, docs/method.md §16, nor for a cube design too large for
    /// them); the f32 floor is [`Baked::f32_floor`]'s (None here).
    pub fn figures(&self) -> Figures {
        // A sampled design's noise key is the discrete claim (docs/method.md
        // §16), not the continuous σ these constants document: not baked.
        let noise = self
            .design
            .noise
            .as_ref()
            .filter(|_| self.design.sample.is_none());
        let sampling = self.design.sampling.as_ref();
        Figures {
            sigma: noise.map(|b| b.sigma),
            error_bound: noise.map(|b| b.error_bound),
            max_amplitude: noise.map(|b| b.max_amplitude),
            euler: sampling
                .filter(|s| s.max_step_euler > 0.0)
                .map(|s| (s.max_step_euler, s.beta)),
            rk4: sampling.map(|s| s.step_estimate_rk4).filter(|h| *h > 0.0),
            f32_floor: None,
            f32_euler: None,
            f32_rounding: None,
            f32_step_floor: None,
            rms: self.rms(),
        }
    }

    /// The code generator's input for the baked numbers, as `qpv!` and
    /// `qpv codegen` both emit it: P and L_l row-major, the margins of
    /// their certificate, the solver's record, the output filter, the
    /// sample period, the figures and, for an `alpha = max` request
    /// (`alpha`), the supremum estimate ([`Baked::alpha_sup`]); for f32
    /// numbers also the certified error floors of the generated arithmetic
    /// ([`Baked::f32_floor`] over [`qpv_codegen::rounding::design_error`],
    /// one gain per θ-vertex: Jacobian corners share theirs,
    /// `scheduling` being the plant's scheduling parameters). The second
    /// value is that floor, or why an f32 design has none (None for f64).
    pub fn certified_design(
        &self,
        model: &Model,
        scheduling: &[usize],
        request: &str,
        alpha: qpv_dsl::AlphaSpec,
    ) -> (CertifiedDesign, Option<Result<RoundingFloor, String>>) {
        let d = &self.design;
        let mut out = CertifiedDesign {
            request: request.to_string(),
            mode: d.mode.name().into(),
            certifies: d.certifies(),
            alpha: d.alpha,
            gamma: d.gamma,
            p: d.p.concat(),
            // one gain per θ-vertex: the Jacobian corners of a vertex share it
            l: d.l
                .iter()
                .step_by(1 << self.observer.gain_shift())
                .map(|l| l.concat())
                .collect(),
            margins: d.margins.iter().map(|(k, m)| (k.to_string(), *m)).collect(),
            status: d.solver.detail.clone(),
            iterations: d.solver.iterations,
            filter: match d.route() {
                OutputRoute::Filter(f) => Some(f),
                OutputRoute::DoubleSum => None,
            },
            figures: self.figures(),
            noise_missing: crate::report::figures::no_noise_bound(d)
                .filter(|_| d.sample.is_none())
                .map(|why| format!("{why}; {}", crate::report::NOISE_MIN_ADVICE)),
            float: self.float,
            sample: d.sample.map(|s| s.h),
            time_unit: model.time_unit,
            alpha_sup: self.alpha_sup(alpha),
        };
        if self.float != Float::F32 {
            return (out, None);
        }
        let floor = self.f32_floor(|xs, radius| {
            qpv_codegen::rounding::design_error(model, scheduling, &out, xs, radius).map(|r| {
                RhsRounding {
                    constant: r.constant,
                    proportional: r.proportional,
                    derivative: r.derivative,
                    state: r.state,
                }
            })
        });
        if let Ok(f) = &floor {
            out.figures.f32_floor = Some(f.error_bound);
            out.figures.f32_rounding = Some(qpv_codegen::design::F32Rounding {
                d0: f.constant,
                d1: f.proportional,
                rate: d.alpha - 2.0 * f.proportional,
            });
            out.figures.f32_step_floor = f.sampled;
            out.figures.f32_euler = f.euler.as_ref().map(|e| qpv_codegen::design::EulerFloor {
                base: e.base,
                per_step: e.per_step,
                min_step: e.min_step,
            });
        }
        (out, Some(floor))
    }

    /// The certified f32 error floor of the baked numbers
    /// ([`crate::certificate::rounding::rounding_floor`]): `rhs_error`
    /// bounds, per observer state, the rounding of one evaluation of the
    /// generated right-hand side, split into a part independent of the
    /// error and one per unit ρ = √(eᵀPe), over the plant state's box and
    /// the error's per-state radius √((P⁻¹)_kk) (given in that order; the
    /// box from [`crate::certificate::noise::observer_boxes`]). `Err` says why there
    /// is none.
    pub fn f32_floor(
        &self,
        rhs_error: impl FnOnce(&[(f64, f64)], &[f64]) -> Result<RhsRounding, String>,
    ) -> Result<RoundingFloor, String> {
        let d = &self.design;
        if matches!(d.route(), qpv_dsl::OutputRoute::Filter(_)) {
            return Err("the f32 floor is not computed for the filter route".into());
        }
        if d.global {
            // the rounding scales with |x|, which nothing bounds here
            return Err(
                "a global (LPV) design has no region or state bound, so the \
                        rounding of the f32 arithmetic, which grows with |x|, has no bound"
                    .into(),
            );
        }
        let p = d.p_matrix();
        let (plant_state, _) =
            crate::certificate::noise::observer_boxes(&self.observer, d.gamma, &p)
                .ok_or("P is not positive definite")?;
        // |e_k| ≤ ρ √((P⁻¹)_kk) on E_ρ, padded for the inverse's rounding
        let pinv = ((&p + p.transpose()) * 0.5)
            .cholesky()
            .ok_or("P is not positive definite")?
            .inverse();
        let radius: Vec<f64> = (0..p.nrows())
            .map(|k| pinv[(k, k)].max(0.0).sqrt() * (1.0 + 1e-9))
            .collect();
        let rounding = rhs_error(&plant_state, &radius)?;
        let l = d.l_matrices();
        let inputs = FloorInputs {
            model: &self.observer,
            alpha: d.alpha,
            gamma: d.gamma,
            p: &p,
            l: &l,
            euler: self.figures().euler,
            sample: d.sample.map(|s| s.h),
        };
        rounding_floor(&inputs, &rounding)
    }

    /// Re-checks `design` on `observer`; for numbers rounded to f32 whose
    /// cube slacks fail, again on the full vertex family.
    fn rechecked(
        plant: &PolytopicModel,
        mut design: Design,
        observer: PolytopicModel,
        float: Float,
    ) -> Result<Baked, BakeError> {
        fits(&design, &observer)?;
        let mut cert = design.recheck_on(&observer);
        if !cert.passed && float == Float::F32 && design.cube.is_some() {
            // The cube slacks were found for the f64 numbers: the rounded
            // ones may still hold on the full vertex family.
            design.cube = None;
            cert = design.recheck_on(&observer);
        }
        if !cert.passed {
            return Err(BakeError::Failed(Box::new(cert)));
        }
        design.margins = cert.margins();
        design.data_checks = cert.data_checks;
        design.verdict = Verdict::of(true, design.mode);
        Baked::finish(plant, design, observer, float)
    }

    /// The certified numbers with their figures computed on them.
    fn finish(
        plant: &PolytopicModel,
        mut design: Design,
        observer: PolytopicModel,
        float: Float,
    ) -> Result<Baked, BakeError> {
        fits(&design, &observer)?;
        design.noise = None;
        design.sampling = None;
        if design.sample.is_none() {
            crate::report::figures::attach(plant, &mut design);
        }
        Ok(Baked {
            design,
            observer,
            float,
        })
    }
}

/// The design with P, L_l and the sample period rounded to f32 (each
/// exactly representable in f64), Γ_l = P L_l and ‖L_l‖₂ recomputed from
/// them; the claim to re-check for an f32 observer.
fn rounded_to_f32(design: &Design) -> Design {
    let round = |m: DMatrix<f64>| m.map(|v| f64::from(v as f32));
    let p = round(design.p_matrix());
    let l: Vec<DMatrix<f64>> = design.l_matrices().into_iter().map(round).collect();
    let gammas: Vec<DMatrix<f64>> = l.iter().map(|li| &p * li).collect();
    let m = ReportedMatrices::of(&p, &gammas, &l);
    let mut out = design.clone();
    out.p = m.p;
    out.gamma_l = m.gamma_l;
    out.l = m.l;
    out.gain_norms = m.gain_norms;
    // The f32 code steps by the float nearest h: that h is certified.
    out.sample = design
        .sample
        .map(|s| SampleInfo::new(f64::from(s.h as f32), design.alpha));
    out
}

/// Whether P is n × n and there is one finite n × ny gain per vertex of the
/// observer's model (n its states).
fn fits(design: &Design, observer: &PolytopicModel) -> Result<(), BakeError> {
    let (n, ny, nv) = (observer.nx(), observer.ny(), observer.nv());
    let p = &design.p;
    let shapes = p.len() == n
        && p.iter().all(|r| r.len() == n)
        && design.l.len() == nv
        && design
            .l
            .iter()
            .all(|l| l.len() == n && l.iter().all(|r| r.len() == ny));
    if !shapes {
        return Err(BakeError::Malformed(format!(
            "P and L_l do not have the sizes of the observer's model ({n} states, {ny} outputs, \
             {nv} vertices)"
        )));
    }
    let finite = p
        .iter()
        .chain(design.l.iter().flatten())
        .flatten()
        .all(|v| v.is_finite());
    if !finite {
        return Err(BakeError::Malformed(
            "P or L_l has a non-finite entry".into(),
        ));
    }
    Ok(())
}
