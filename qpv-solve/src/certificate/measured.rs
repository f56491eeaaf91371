//! The intervals of parameters computed from a measured output
//! (`param p = y1 ...`, and those a rewrite added): each must cover its
//! output over the state bound F, recomputed here from the model (the
//! output's row c and Q: y = cᵀx ranges over [−√(cᵀQc), √(cᵀQc)] on
//! F = {xᵀQ⁻¹x ≤ 1}), a required data check per parameter.

use super::margins::DataCheck;
use super::Certificate;
use qpv_dsl::{PolytopicModel, StateBound};

/// The data check's key for parameter `name`.
pub fn key(name: &str) -> String {
    format!("measured_{name}")
}

/// One required data check per measured parameter: the excess of the
/// output's range over F past the declared interval,
/// max(√(cᵀQc) + lo, √(cᵀQc) − hi) ≤ 0 (NaN, failing, without a given
/// state bound). The row c is padded with zeros when the model's state is
/// longer than the plant's (an output filter's augmented state, whose
/// state bound has Q as its leading block).
pub fn checks(model: &PolytopicModel) -> Vec<(String, DataCheck)> {
    let nx = model.nx();
    model
        .params
        .iter()
        .filter_map(|p| {
            let m = p.measured.as_ref()?;
            let reach = match (&model.state_bound, &m.bound) {
                (StateBound::Given(q), _) if m.row.len() <= nx => {
                    let mut c = nalgebra::DVector::zeros(nx);
                    c.rows_mut(0, m.row.len()).copy_from_slice(&m.row);
                    c.dot(&(q * &c)).max(0.0).sqrt()
                }
                // the global observer's model carries no state bound: the
                // model's own given Q
                (_, Some(q)) => m.reach(q),
                _ => f64::NAN,
            };
            let excess = (reach + p.lo).max(reach - p.hi);
            let desc = format!(
                "√(cᵀQc) − the interval [{}, {}] of `{}` ≤ 0: the parameter's interval covers \
                 the output {} = cᵀx over the state bound F ({} ranges over ±{})",
                qpv_dsl::fmt_sig(p.lo, 6),
                qpv_dsl::fmt_sig(p.hi, 6),
                p.name,
                m.output_name,
                m.output_name,
                qpv_dsl::fmt_sig(reach, 6)
            );
            Some((key(&p.name), DataCheck::at_most(excess, 0.0, true, &desc)))
        })
        .collect()
}

/// `c` with the measured parameters' checks added (a failed one fails it).
pub(super) fn attach(model: &PolytopicModel, mut c: Certificate) -> Certificate {
    for (k, d) in checks(model) {
        c.passed &= d.passed;
        c.data_checks.insert(k, d);
    }
    c
}

/// The report's notes on the measured parameters: what each is computed
/// from, its interval and the output's range over F, and the terms
/// rewritten onto it.
pub fn notes(model: &PolytopicModel) -> Vec<String> {
    let q = match &model.state_bound {
        StateBound::Given(q) => Some(q.as_slice()),
        _ => None,
    };
    model
        .params
        .iter()
        .filter_map(|p| {
            let m = p.measured.as_ref()?;
            let q = q
                .filter(|q| q.len() == m.row.len() * m.row.len())
                .or(m.bound.as_deref());
            Some(m.describe(&p.name, p.lo, p.hi, q))
        })
        .collect()
}
