//! The derived scheduling variables φ_j of a model: the functions of the
//! parameters its matrices use that are not multi-affine (see the method
//! page, docs/method.md). The expressions created them while they were
//! evaluated; here the ones a matrix entry still uses are kept (in order of
//! first use), renumbered after the declared parameters, and described.

use super::build::{Builder, R};
use crate::diagnostic::Diag;
use crate::expr::bits;
use crate::expr::PolyMatrix;
use crate::sched::Derived;

impl Builder<'_> {
    /// Keeps the derived variables the matrices use, renumbers their bits
    /// to follow the declared parameters (`np + j` for the j-th kept one),
    /// and returns their descriptions.
    pub(super) fn derived(
        &mut self,
        a: &mut PolyMatrix,
        n: &mut [PolyMatrix],
        b: &mut PolyMatrix,
        b_w: &mut PolyMatrix,
        c: &mut PolyMatrix,
        m: &mut [PolyMatrix],
    ) -> R<Vec<Derived>> {
        let atoms = self.names.atoms.borrow().clone();
        let np = atoms.np;
        if atoms.list.is_empty() {
            return Ok(Vec::new());
        }
        let mut labelled: Vec<(String, &mut PolyMatrix)> = vec![("A".into(), a), ("B".into(), b)];
        labelled.push(("B_w".into(), b_w));
        labelled.push(("C".into(), c));
        for (k, nk) in n.iter_mut().enumerate() {
            labelled.push((format!("N{}", k + 1), nk));
        }
        for (k, mk) in m.iter_mut().enumerate() {
            labelled.push((format!("M{}", k + 1), mk));
        }
        let used: u64 = labelled
            .iter()
            .fold(0, |acc, (_, pm)| acc | pm.param_mask())
            >> np;
        // kept atoms in creation order (their order of first use)
        let kept: Vec<usize> = bits(used).collect();
        let new_bit =
            |old: usize| -> usize { np + kept.iter().position(|&k| k == old - np).unwrap_or(0) };
        let mut used_in: Vec<Vec<String>> = vec![Vec::new(); kept.len()];
        for (label, pm) in labelled.iter_mut() {
            let cols = pm.cols;
            for (idx, entry) in pm.entries.iter_mut().enumerate() {
                let mut changed = false;
                for t in entry.terms.iter_mut() {
                    if t.0 >> np == 0 {
                        continue;
                    }
                    let mut mask = t.0 & ((1u64 << np) - 1);
                    for old in bits(t.0 >> np) {
                        let nb = new_bit(np + old);
                        mask |= 1 << nb;
                        let label = format!("{label}[{},{}]", idx / cols + 1, idx % cols + 1);
                        let list = &mut used_in[nb - np];
                        if !list.contains(&label) {
                            list.push(label);
                        }
                    }
                    t.0 = mask;
                    changed = true;
                }
                if changed {
                    entry.terms.sort_by_key(|t| t.0);
                }
            }
        }
        let mut names_taken: Vec<String> = self.names.lookup.keys().cloned().collect();
        let mut counter = 0;
        let derived: Vec<Derived> = kept
            .iter()
            .zip(used_in)
            .map(|(&j, used_in)| {
                let at = &atoms.list[j];
                let name = match &at.name {
                    Some(n) => n.clone(),
                    None => loop {
                        counter += 1;
                        let n = format!("phi{counter}");
                        if !names_taken.contains(&n) {
                            names_taken.push(n.clone());
                            break n;
                        }
                    },
                };
                Derived {
                    name,
                    text: at.text.clone(),
                    expr: at.expr.clone(),
                    lo: at.lo,
                    hi: at.hi,
                    range: at.info.clone(),
                    used_in,
                    span: at.span,
                }
            })
            .collect();
        // the masks of one entry are still unique after renumbering (the
        // map is injective), so the invariants of ThetaPoly hold
        if np + derived.len() > 64 {
            return Err(Diag::new(
                derived[0].span,
                "too many derived scheduling variables",
            ));
        }
        Ok(derived)
    }
}
