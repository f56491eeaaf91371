//! The region family: (S1), the region's vertex condition ((S2) or (13),
//! or the cube form of [`super::cube`]) and its facet condition ((S3) or
//! (14)); for the global observer, which has no region rows, the
//! normalisation of P̂ in their place.

use super::Problem;
use crate::backend::builder::SdpBuilder;
use crate::conditions::{FacetForm, VertexForm};
use crate::linalg::svec::svec_index;
use nalgebra::DVector;
use qpv_dsl::Conditions;

impl Problem<'_> {
    /// The region rows at γ with margin `eps`, or the global observer's
    /// normalisation (for the `noise` family, or the max-margin objective).
    pub(super) fn push_region(
        &self,
        out: &mut SdpBuilder,
        (gamma, eps): (f64, f64),
        max_margin: bool,
        noise: bool,
    ) {
        if self.global && noise {
            self.push_global_noise_normalisation(out);
        } else if self.global {
            self.push_global_normalisation(out, eps, max_margin);
        } else {
            self.push_s1(out, eps);
            match self.conditions {
                Conditions::Cube => self.push_cube_region(out, eps),
                _ => self.push_region_vertices(out, eps),
            }
            self.push_region_facets(out, gamma, eps);
        }
    }

    /// (S1): P̂ − εI ⪰ 0: s = svec(P̂) − ε svec(I) ⇒ b = −ε svec(I), A = −svec(E_v).
    pub(super) fn push_s1(&self, out: &mut SdpBuilder, eps: f64) {
        let blk = out.psd(self.nx, eps);
        self.push_sym_var(out, &blk, 0, -1.0);
    }

    /// The region vertices: (S2) 1 − ε − x̂ᵀP̂x̂ ≥ 0 per vertex (one
    /// nonnegative cone), or (13) [1 x̂ᵀ; x̂ P̂] − εI ⪰ 0 per vertex.
    fn push_region_vertices(&self, out: &mut SdpBuilder, eps: f64) {
        let nx = self.nx;
        match self.set.vertex_form() {
            VertexForm::Quadratic => {
                // 1 − ε − x̂ᵀP̂x̂ ≥ 0: b = 1 − ε, A[v] = x̂ᵀ E_v x̂.
                let row0 = out.nonneg(self.xs_hat.len());
                for (i, x) in self.xs_hat.iter().enumerate() {
                    out.set_b(row0 + i, 1.0 - eps);
                    for c in 0..nx {
                        for r in 0..=c {
                            let v = if r == c {
                                x[r] * x[r]
                            } else {
                                2.0 * x[r] * x[c]
                            };
                            out.a(row0 + i, svec_index(r, c), v);
                        }
                    }
                }
            }
            VertexForm::Schur => {
                for x in &self.xs_hat {
                    self.push_schur(out, x, 1.0, eps);
                }
            }
        }
    }

    /// The region facets: (S3) [1 γâₖᵀ; γâₖ P̂] − εI ⪰ 0 or (14)
    /// [1 γâₖᵀP̂; γP̂âₖ P̂] − εI ⪰ 0 per facet.
    fn push_region_facets(&self, out: &mut SdpBuilder, gamma: f64, eps: f64) {
        let nx = self.nx;
        for a in &self.as_hat {
            match self.set.facet_form() {
                FacetForm::Schur => self.push_schur(out, a, gamma, eps),
                FacetForm::SchurP => {
                    let blk = out.psd(nx + 1, eps);
                    out.rhs(&blk, 0, 0, 1.0 - eps);
                    // Off-diagonal block row 0, column m+1: γ (P̂ â)_m, linear in P̂.
                    // ∂(P̂â)_m/∂P̂_rc = [m==r] a_c + [m==c] a_r (r≠c); [m==r] a_r (r==c).
                    for c in 0..nx {
                        for r in 0..=c {
                            let v = svec_index(r, c);
                            // Entries (0, m+1) for m ∈ {r, c}, and (r+1, c+1).
                            if r == c {
                                out.entry(&blk, 0, r + 1, v, -gamma * a[r]);
                            } else {
                                out.entry(&blk, 0, r + 1, v, -gamma * a[c]);
                                out.entry(&blk, 0, c + 1, v, -gamma * a[r]);
                            }
                            out.entry(&blk, r + 1, c + 1, v, -1.0);
                        }
                    }
                }
            }
        }
    }

    /// [1 wvᵀ; wv P̂] − εI ⪰ 0 (indices: 0 = the scalar, 1.. = P̂): (13) for
    /// a region vertex (w = 1), (S3) for a facet normal (w = γ).
    fn push_schur(&self, out: &mut SdpBuilder, v: &DVector<f64>, w: f64, eps: f64) {
        let nx = self.nx;
        let blk = out.psd(nx + 1, eps);
        out.rhs(&blk, 0, 0, 1.0 - eps);
        for c in 0..nx {
            out.rhs(&blk, 0, c + 1, w * v[c]);
        }
        for c in 0..nx {
            for r in 0..=c {
                out.entry(&blk, r + 1, c + 1, svec_index(r, c), -1.0);
            }
        }
    }

    /// The global observer's normalisation in place of the region rows
    /// (its conditions are homogeneous in (P, Γ_l)): P̂ − I ⪰ 0; for the
    /// max-margin objective P̂ − εI ⪰ 0 and I − P̂ ⪰ 0 instead, which bound
    /// P̂ so that the optimal margin measures the depth of the point rather
    /// than the size of P̂ (any strictly feasible (P̂, Γ̂) scaled into
    /// εI ⪯ P̂ ⪯ I is feasible for it).
    fn push_global_normalisation(&self, out: &mut SdpBuilder, eps: f64, max_margin: bool) {
        if !max_margin {
            self.push_s1(out, 1.0);
            return;
        }
        self.push_s1(out, eps);
        // I − P̂ ⪰ 0: s = svec(I) − svec(P̂) ⇒ b = svec(I), A = svec(E_v).
        let blk = out.psd(self.nx, -1.0);
        self.push_sym_var(out, &blk, 0, 1.0);
    }

    /// The global observer's normalisation for the noise objective: P ⪰ cI
    /// in the model's own coordinates (P̂_z ⪰ cD² in balanced ones, P =
    /// D⁻¹P̂_zD⁻¹). The noise block is homogeneous in (P, Γ_l, σ), so with
    /// λ_min(P) ≥ 1 the smallest σ is the smallest certified error bound
    /// √(σ/(α λ_min(P))) per unit noise (docs/method.md §17).
    fn push_global_noise_normalisation(&self, out: &mut SdpBuilder) {
        let blk = out.psd(self.nx, 0.0);
        self.push_sym_var(out, &blk, 0, -1.0);
        // The blocks are homogeneous, so P ⪰ cI for any c > 0 gives the
        // same smallest bound; c = 1/max_i d_i² keeps P̂_z ⪰ D²c ⪯ I.
        let dmax = self.scaling.as_ref().map_or(1.0, |s| s.max());
        for d in 0..self.nx {
            let di = self.scaling.as_ref().map_or(1.0, |s| s.d[d]) / dmax;
            out.rhs(&blk, d, d, -di * di / self.scale);
        }
    }
}
