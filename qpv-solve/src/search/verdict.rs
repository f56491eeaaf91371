//! The verdict line that opens every design's summary, written in one
//! place for every observer kind, mode, objective and sample period
//! ([`Verdict::line`]); the summary is that line and then every note.

use super::attempt::append_notes;
use crate::backend::Status;
use crate::certificate::noise::NoiseBound;
use crate::model::ObserverKind;
use crate::report::Note;
use qpv_dsl::{Mode, TimeUnit};

/// What a design's verdict line states.
pub(super) struct Verdict<'a> {
    /// The observer built.
    pub kind: ObserverKind,
    /// Sound conditions or the paper's printed ones.
    pub mode: Mode,
    /// Whether the reported point passed the independent certificate.
    pub certified: bool,
    /// The reported (or requested) α.
    pub alpha: f64,
    /// The reported (or requested) γ (unused by the global observer).
    pub gamma: f64,
    /// The sample period of a `sample = h` design.
    pub sample: Option<f64>,
    /// The model's unit of time (of α and h).
    pub unit: TimeUnit,
    /// The final solve's status (named when nothing certified).
    pub status: Status,
    /// The families the shown point fails, with their worst margins.
    pub failed: &'a [String],
    /// The largest ‖L_l‖₂ of the reported gains.
    pub max_gain: f64,
    /// `noise = min`: the certified noise bound, if any (None: an ordinary
    /// design).
    pub noise: Option<Option<&'a NoiseBound>>,
}

impl Verdict<'_> {
    /// The summary: the verdict line, then every note as a sentence.
    pub fn summary(&self, notes: &[Note]) -> String {
        let mut s = self.line();
        append_notes(&mut s, notes);
        s
    }

    /// The verdict line alone.
    pub fn line(&self) -> String {
        if let Some(bound) = self.noise {
            return self.noise_line(bound);
        }
        match self.kind {
            ObserverKind::Global => self.global_line(),
            ObserverKind::Regional => self.regional_line(),
        }
    }

    /// "; failed: …" when the shown point fails families, else nothing.
    fn failed(&self) -> String {
        if self.failed.is_empty() {
            String::new()
        } else {
            format!("; failed: {}", self.failed.join(", "))
        }
    }

    fn regional_line(&self) -> String {
        let (alpha, gamma, max_norm) = (self.alpha, self.gamma, self.max_gain);
        let per = self.unit.singular();
        let (status, failed) = (self.status, self.failed());
        match (self.mode, self.certified, self.sample) {
            (Mode::Sound, true, Some(h)) => format!(
                "CERTIFIED at {} (sound conditions S1-S4 and the discrete decrease S5d): the Euler-stepped observer has V(e_(k+1)) ≤ (1 − hα)V(e_k) = {:.6}·V(e_k) with α = {alpha:.6} per {per}, γ = {gamma:.6}; every e(0) in the region converges. max ‖L_l‖₂ = {max_norm:.4}.",
                self.unit.describe_period(h),
                1.0 - h * alpha
            ),
            (Mode::Sound, false, Some(h)) => format!(
                "NOT CERTIFIED at {} (sound conditions S1-S4 and the discrete decrease S5d) at α = {alpha:.6}, γ = {gamma:.6}: solver {status}{failed}.",
                self.unit.describe_period(h)
            ),
            (Mode::Sound, true, None) => format!(
                "CERTIFIED (sound conditions S1-S5): V' ≤ −αV with α = {alpha:.6}, γ = {gamma:.6}; every e(0) in the region converges. max ‖L_l‖₂ = {max_norm:.4}."
            ),
            (Mode::Sound, false, None) => format!(
                "NOT CERTIFIED (sound conditions) at α = {alpha:.6}, γ = {gamma:.6}: solver {status}{failed}."
            ),
            (Mode::Paper, true, _) => format!(
                "PAPER MODE (certifies nothing): the printed conditions (13), (14), (26) hold at α = {alpha:.6}, γ = {gamma:.6}; max ‖L_l‖₂ = {max_norm:.4}."
            ),
            (Mode::Paper, false, _) => format!(
                "PAPER MODE (certifies nothing): the printed conditions are not satisfied at α = {alpha:.6}, γ = {gamma:.6}: solver {status}{failed}."
            ),
        }
    }

    fn global_line(&self) -> String {
        let (alpha, max_norm) = (self.alpha, self.max_gain);
        let per = self.unit.singular();
        match (self.certified, self.sample) {
            (true, None) => format!(
                "CERTIFIED, GLOBAL (LPV plant: P ≻ 0 and G5): V' ≤ −αV with α = {alpha:.6} for every e(0) and every θ(t) in the box; max ‖L_l‖₂ = {max_norm:.4}."
            ),
            (true, Some(h)) => format!(
                "CERTIFIED, GLOBAL at {} (LPV plant: P ≻ 0 and the discrete decrease S5d): the Euler-stepped observer has V(e_(k+1)) ≤ (1 − hα)V(e_k) = {:.6}·V(e_k) with α = {alpha:.6} per {per} for every e(0) and every θ_k in the box; max ‖L_l‖₂ = {max_norm:.4}.",
                self.unit.describe_period(h),
                1.0 - h * alpha
            ),
            (false, _) => {
                let at = self
                    .sample
                    .map(|h| format!(" at {}", self.unit.describe_period(h)))
                    .unwrap_or_default();
                format!(
                    "NOT CERTIFIED, GLOBAL (LPV plant){at} at α = {alpha:.6}: solver {}{}.",
                    self.status,
                    self.failed()
                )
            }
        }
    }

    fn noise_line(&self, bound: Option<&NoiseBound>) -> String {
        let (alpha, gamma, max_gain) = (self.alpha, self.gamma, self.max_gain);
        let global = self.kind.is_global();
        let Some(nb) = bound.filter(|_| self.certified) else {
            return format!(
                "NOT CERTIFIED (noise = min{}) at α = {alpha:.6}, γ = {gamma:.6}: solver {}.",
                self.sample.map_or(String::new(), |h| format!(
                    ", {}",
                    self.unit.describe_period(h)
                )),
                self.status
            );
        };
        match self.sample {
            Some(h) if global => format!(
                "CERTIFIED, GLOBAL at {} (LPV plant: P ≻ 0, the discrete decrease S5d and the discrete noise block LMI, no region terms): V(e_k+1) − (1 − hα)V(e_k) ≤ hσ(|w_k|² + |v_k|²) with α = {alpha:.6}, σ = {:.6e}, for every e(0), every θ_k in the box and every noise amplitude ν; lim sup ‖e_k‖ ≤ {:.4}·ν. max ‖L_l‖₂ = {max_gain:.4}.",
                self.unit.describe_period(h),
                nb.sigma, nb.error_bound
            ),
            None if global => format!(
                "CERTIFIED, GLOBAL (LPV plant: P ≻ 0 and the noise block LMI, no region terms): V' + αV ≤ σ(|w|² + |v|²) with α = {alpha:.6}, σ = {:.6e}, for every e(0), every θ(t) in the box and every noise amplitude ν; ‖e(∞)‖ ≤ {:.4}·ν. max ‖L_l‖₂ = {max_gain:.4}.",
                nb.sigma, nb.error_bound
            ),
            Some(h) => format!(
                "CERTIFIED at {} (sound conditions S1-S3, the discrete decrease S5d and the discrete noise block LMI): V(e_k+1) − (1 − hα)V(e_k) ≤ hσ(|w_k|² + |v_k|²) with α = {alpha:.6}, γ = {gamma:.6}, σ = {:.6e}; E stays invariant for noise amplitude up to ν_max = {:.4e}; lim sup ‖e_k‖ ≤ {:.4}·ν. max ‖L_l‖₂ = {max_gain:.4}.",
                self.unit.describe_period(h),
                nb.sigma, nb.max_amplitude, nb.error_bound
            ),
            None => format!(
                "CERTIFIED (sound conditions S1-S5 and the noise block LMI): V' + αV ≤ σ(|w|² + |v|²) with α = {alpha:.6}, γ = {gamma:.6}, σ = {:.6e}; E stays invariant for noise amplitude up to ν_max = {:.4e}; ‖e(∞)‖ ≤ {:.4}·ν. max ‖L_l‖₂ = {max_gain:.4}.",
                nb.sigma, nb.max_amplitude, nb.error_bound
            ),
        }
    }
}
