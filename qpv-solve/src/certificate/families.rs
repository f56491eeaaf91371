//! The condition families of one check: (S1), the region's vertex and
//! facet families and the rate family (vertex, cube or sampled form).

use super::cube::{cube_region, CubeTerms};
use super::margins::{block_guard, lambda_max, lambda_min, Acc, FamilyMargin, GUARD_C};
use super::rate::Terms;
use super::{sampled, RateCheck, Witness};
use crate::conditions::cube::CubeSlacks;
use crate::conditions::{pair_suffix, rate_combos, ConditionSet};
use crate::model::is_double_sum;
use crate::vocab::{Candidate, Family};
use nalgebra::{DMatrix, DVector};
use qpv_dsl::PolytopicModel;

/// The conditions of one check: the model and γ the blocks use (for the
/// global observer its region-free model and γ = 1), the condition set, the
/// witness, the rate family and the cube's generators.
pub(super) struct Stage<'a> {
    pub(super) model: &'a PolytopicModel,
    pub(super) set: ConditionSet,
    pub(super) global: bool,
    pub(super) alpha: f64,
    pub(super) gamma: f64,
    pub(super) w: &'a Witness<'a>,
    pub(super) ps: DMatrix<f64>,
    pub(super) rate: RateCheck<'a>,
    pub(super) gens: Vec<DVector<f64>>,
}

impl Stage<'_> {
    pub(super) fn cube(&self) -> Option<&CubeSlacks> {
        match self.rate {
            RateCheck::Cube(c) => Some(c),
            _ => None,
        }
    }

    /// Every family of the check in report order: (S1) and the rate family
    /// for the global observer, else (S1), the region's vertex and facet
    /// families and the rate family.
    pub(super) fn families(&self) -> Vec<FamilyMargin> {
        let [f1, fv, ff, fr] = self.set.families();
        let fr = match self.rate {
            RateCheck::Sampled(_) => Family::S5d,
            _ if self.global => Family::G5,
            _ => fr,
        };
        let mut out = vec![self.s1(f1)];
        if !self.global {
            out.extend([self.vertices(fv), self.facets(ff)]);
        }
        out.push(self.rate(fr));
        out
    }

    /// (S1) P ≻ 0, P symmetric.
    pub(super) fn s1(&self, family: Family) -> FamilyMargin {
        let (p, nx) = (self.w.p, self.model.nx());
        let pn = p.norm();
        let mut s1 = Acc::new(family);
        let asym = (p - p.transpose()).norm();
        if asym > 4.0 * f64::EPSILON * pn {
            s1.add(-asym, 0.0, || {
                format!("P is not symmetric (‖P − Pᵀ‖_F = {asym:e})")
            });
        } else {
            s1.add(
                lambda_min(&self.ps),
                GUARD_C * (nx as f64 + 1.0) * pn,
                || "P".into(),
            );
        }
        s1.finish()
    }

    /// The region's vertex family (for cube slacks: through D).
    pub(super) fn vertices(&self, family: Family) -> FamilyMargin {
        let (nx, pn, ps) = (self.model.nx(), self.w.p.norm(), &self.ps);
        let mut sv = Acc::new(family);
        if let Some(c) = self.cube() {
            cube_region(&mut sv, self.set, ps, &self.gens, &c.d);
        }
        let xs = match self.cube() {
            Some(_) => &[],
            None => &self.model.region.vertices[..],
        };
        for (i, x) in xs.iter().enumerate() {
            match self.set {
                ConditionSet::Sound => {
                    let v = 1.0 - x.dot(&(ps * x));
                    let g = GUARD_C * (nx as f64 + 1.0) * (1.0 + pn * x.norm_squared());
                    sv.add(v, g, || format!("i={}", i + 1));
                }
                ConditionSet::Paper => {
                    let m = bordered(1.0, x, ps);
                    let g = GUARD_C * (nx as f64 + 2.0) * m.norm();
                    sv.add(lambda_min(&m), g, || format!("i={}", i + 1));
                }
            }
        }
        sv.finish()
    }

    /// The region's facet family.
    pub(super) fn facets(&self, family: Family) -> FamilyMargin {
        let (nx, pn, ps, gamma) = (self.model.nx(), self.w.p.norm(), &self.ps, self.gamma);
        let mut sf = Acc::new(family);
        for (k, a) in self.model.region.facets.iter().enumerate() {
            let off: DVector<f64> = match self.set {
                ConditionSet::Sound => a * gamma,
                ConditionSet::Paper => (ps * a) * gamma,
            };
            let m = bordered(1.0, &off, ps);
            let g = GUARD_C * (nx as f64 + 2.0) * (m.norm() + gamma * pn * a.norm());
            sf.add(lambda_min(&m), g, || format!("k={}", k + 1));
        }
        sf.finish()
    }

    /// The rate family: Σ_t w_t Ξ_{l_t m_t}(i, j) ≺ 0 for every combination
    /// (conditions::Combo), Ξ_{lm} = He{γ(PA_l − Γ_lC_m) + σP R_l − Γ_l S_m}
    /// + γαP; or the cube's slack inequalities; or the discrete decrease.
    pub(super) fn rate(&self, family: Family) -> FamilyMargin {
        let (model, nx, set) = (self.model, self.model.nx(), self.set);
        let (alpha, gamma) = (self.alpha, self.gamma);
        let double = is_double_sum(model);
        let mut sr = Acc::new(family);
        let xs = &model.region.vertices;
        let terms = || Terms::new(model, xs, &self.ps, self.w.gammas, self.w.lnorm, gamma);
        match self.rate {
            RateCheck::Cube(c) => {
                let at = Candidate::new(alpha, gamma);
                let ct = CubeTerms::new(model, &self.ps, self.w.gammas, self.w.lnorm, set, at);
                for (ci, combo) in rate_combos(model).iter().enumerate() {
                    ct.check(&mut sr, (combo, ci, double), &self.gens, c);
                }
            }
            RateCheck::Sampled(h) => {
                sampled::check_family(&mut sr, &terms(), alpha, h);
            }
            RateCheck::Vertex => {
                let terms = terms();
                for combo in rate_combos(model) {
                    // A linear combination (N and M vanish in every term):
                    // every pair (i, j) gives the same block (rows(0, x) = 0
                    // exactly), so it is checked once.
                    let linear = combo.is_linear(model);
                    for (i, j) in combo.pairs(model) {
                        let sigma = set.nonlinear_sign();
                        let (m, size) = terms.combo(&combo, sigma, alpha, (i, j));
                        sr.add(-lambda_max(&m), block_guard(nx, size, &m), || {
                            match (linear, self.global) {
                                (true, true) => combo.label(double),
                                (true, false) => {
                                    format!("{} (every pair: N = M = 0)", combo.label(double))
                                }
                                _ => format!("{}{}", combo.label(double), pair_suffix(model, i, j)),
                            }
                        });
                    }
                }
            }
        }
        sr.finish()
    }
}

/// [s vᵀ; v M]: the bordered matrices of the region's vertex and facet
/// conditions.
pub(super) fn bordered(s: f64, v: &DVector<f64>, m: &DMatrix<f64>) -> DMatrix<f64> {
    let n = m.nrows();
    let mut out = DMatrix::zeros(n + 1, n + 1);
    out[(0, 0)] = s;
    for r in 0..n {
        out[(0, r + 1)] = v[r];
        out[(r + 1, 0)] = v[r];
    }
    out.view_mut((1, 1), (n, n)).copy_from(m);
    out
}
