//! The rate block's algebra, shared by every family: the one iterator over
//! the (combination, region-vertex pair) sites, the block's K and gain
//! terms H_l at a site (so that the block is He{P̂K − Σ_l Γ̂_l H_l}), the
//! columns of He{P̂K − Σ_l Γ̂_l H_l} and of a symmetric variable, and the
//! rate family's margins.

use super::Problem;
use crate::backend::builder::{Psd, SdpBuilder};
use crate::conditions::{rows, rows_he};
use crate::linalg::svec::svec_index;
use crate::model::noise::NoiseChannels;
use nalgebra::{DMatrix, DVector};

/// K and the gain terms (l, H_l) of a block He{P̂K − Σ_l Γ̂_l H_l}, the
/// terms sorted by l.
pub(super) type Kh = (DMatrix<f64>, Vec<(usize, DMatrix<f64>)>);

/// One site of a family written per combination and region-vertex pair:
/// combination `c` at the pair (i, j) (e-vertex i, x-vertex j), or — `pair`
/// None — the one block of a combination whose every pair gives the same
/// block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Site {
    pub(crate) c: usize,
    pub(crate) pair: Option<(usize, usize)>,
}

/// Every site of `n_combos` combinations over `n_vertices` region vertices,
/// combination by combination, i then j; a combination for which `one`
/// holds has the single site (c, None).
pub(crate) fn sites(
    n_combos: usize,
    n_vertices: usize,
    one: impl Fn(usize) -> bool,
) -> impl Iterator<Item = Site> {
    (0..n_combos).flat_map(move |c| {
        let pairs: Box<dyn Iterator<Item = Option<(usize, usize)>>> = if one(c) {
            Box::new(std::iter::once(None))
        } else {
            Box::new((0..n_vertices).flat_map(move |i| (0..n_vertices).map(move |j| Some((i, j)))))
        };
        pairs.map(move |pair| Site { c, pair })
    })
}

/// Where the nonlinear part of a block is evaluated: at a region vertex
/// (rows(N_l, x) from the precomputed [`crate::conditions::PairTerms`]) or at a vector g (a
/// cube generator; computed on the spot).
#[derive(Debug, Clone, Copy)]
pub(super) enum At<'a> {
    Vertex(usize),
    Vector(&'a DVector<f64>),
}

/// The unit directions of P̂: per packed entry v = (r, c), r ≤ c, column
/// by column, v and the symmetric E_v with ones at (r, c) and (c, r).
pub(super) fn p_units(nx: usize) -> impl Iterator<Item = (usize, DMatrix<f64>)> {
    (0..nx).flat_map(move |c| {
        (0..=c).map(move |r| {
            let mut e = DMatrix::zeros(nx, nx);
            e[(r, c)] = 1.0;
            e[(c, r)] = 1.0;
            (svec_index(r, c), e)
        })
    })
}

/// Adds `h` to the gain term of vertex `l` (a new term if there is none).
pub(super) fn add_term(hs: &mut Vec<(usize, DMatrix<f64>)>, l: usize, h: DMatrix<f64>) {
    match hs.iter_mut().find(|(g, _)| *g == l) {
        Some((_, acc)) => *acc += h,
        None => hs.push((l, h)),
    }
}

/// The max-margin variable t̂ and its coefficients svec(κW) in a rate block.
pub(super) struct MarginColumn {
    pub(super) var: usize,
    pub(super) coef: Vec<f64>,
}

/// The margins of the rate blocks: `eps` on the blocks that carry the rate
/// (zero for the max-margin objective, whose column `column` sits there
/// instead), `slack_eps` on the cube slack inequalities (always).
pub(super) struct RateMargins<'a> {
    pub(super) eps: f64,
    pub(super) slack_eps: f64,
    pub(super) column: Option<&'a MarginColumn>,
}

impl RateMargins<'_> {
    /// Adds the max-margin column to the block `blk`, if any.
    pub(super) fn push_column(&self, out: &mut SdpBuilder, blk: &Psd) {
        if let Some(m) = self.column {
            for (idx, &w) in m.coef.iter().enumerate() {
                out.a(blk.row0 + idx, m.var, w);
            }
        }
    }
}

/// The family of blocks that holds the rate of decay.
#[derive(Debug, Clone, Copy)]
pub(crate) enum RateFamily<'a> {
    /// The decay conditions of the problem's conditions ((S5), its
    /// decoupled or cube relaxation, or the discrete decrease).
    Decay,
    /// The noise blocks on these channels (the bounded-real form of the
    /// rate block, docs/method.md "Noise and disturbances").
    Noise(&'a NoiseChannels),
}

impl Problem<'_> {
    /// The sites of the rate family: every combination at every pair, or
    /// with `dedupe` one site for a linear combination
    /// ([`Problem::combo_is_linear`]).
    pub(super) fn rate_sites(&self, dedupe: bool) -> impl Iterator<Item = Site> + '_ {
        sites(self.combos.len(), self.xs_hat.len(), move |c| {
            dedupe && self.linear[c]
        })
    }

    /// K and the gain terms of the block at `site` in scaled form (see
    /// [`crate::conditions::Combo`]): at a pair (i, j), for a constant
    /// output map (combination c is θ-vertex c), He{P̂K − Γ̂_c H} with
    /// K = γA_c + σR_{c,i,j} + (γα/2)I, H = γC + S_{i,j}; for the one block
    /// of a linear combination ([`Problem::combo_is_linear`]) K = γA +
    /// (γα/2)I, H = γC, the block every vertex pair shares.
    pub(super) fn site_kh(&self, alpha: f64, gamma: f64, site: Site) -> Kh {
        let (e, x) = (site.pair.map(|p| p.0), site.pair.map(|p| p.1));
        self.combo_kh(
            (alpha, gamma),
            site.c,
            (true, 1.0),
            e.map(At::Vertex),
            x.map(At::Vertex),
        )
    }

    /// K and the gain terms H_l of combination `c` (its weights times
    /// `sign`) at the e-point `e` and/or the x-point `x`, so that the block
    /// is He{P̂K − Σ_l Γ̂_l H_l}: for each term (l, m, w) the linear part
    /// (when `linear` holds) adds w(γA_l + (γα/2)I) to K and wγC_m to H_l;
    /// the e-part adds −wσ rows(N_l, x_e) to K and −w rows(M_m, x_e) to
    /// H_l; the x-part adds wσ rowsHe(N_l, x_x) to K and w rowsHe(M_m, x_x)
    /// to H_l.
    pub(super) fn combo_kh(
        &self,
        (alpha, gamma): (f64, f64),
        c: usize,
        (linear, sign): (bool, f64),
        e: Option<At>,
        x: Option<At>,
    ) -> Kh {
        let sigma = self.set.nonlinear_sign();
        let mut k = DMatrix::zeros(self.nx, self.nx);
        let mut hs: Vec<(usize, DMatrix<f64>)> = Vec::new();
        for &(l, m, w) in &self.combos[c].terms {
            let (vl, vm) = (&self.model.vertices[l], &self.model.vertices[m]);
            let w = w * sign;
            let mut h = DMatrix::zeros(self.ny, self.nx);
            if linear {
                k += &vl.a * (gamma * w);
                for d in 0..self.nx {
                    k[(d, d)] += 0.5 * gamma * alpha * w;
                }
                h += &vm.c * (gamma * w);
            }
            match e {
                Some(At::Vertex(i)) => {
                    k -= &self.terms().nrw[l][i] * (sigma * w);
                    h -= &self.terms().mrw[m][i] * w;
                }
                Some(At::Vector(g)) => {
                    k -= rows(&vl.n, g) * (sigma * w);
                    h -= rows(&vm.m, g) * w;
                }
                None => {}
            }
            match x {
                Some(At::Vertex(j)) => {
                    k += &self.terms().nhe[l][j] * (sigma * w);
                    h += &self.terms().mhe[m][j] * w;
                }
                Some(At::Vector(g)) => {
                    k += rows_he(&vl.n, g) * (sigma * w);
                    h += rows_he(&vm.m, g) * w;
                }
                None => {}
            }
            add_term(&mut hs, l, h);
        }
        hs.sort_by_key(|(g, _)| *g);
        (k, hs)
    }

    /// The e-vertex part F0_c + G_c(x_i) of the decoupled conditions (module
    /// doc of [`crate::conditions`]).
    pub(super) fn decoupled_e_kh(&self, alpha: f64, gamma: f64, c: usize, i: usize) -> Kh {
        self.combo_kh((alpha, gamma), c, (true, 1.0), Some(At::Vertex(i)), None)
    }

    /// The x-vertex part H_c(x_j) of the decoupled conditions. With
    /// [`Problem::decoupled_e_kh`] at (c, i) it adds up to
    /// [`Problem::site_kh`] at (c, (i, j)).
    pub(super) fn decoupled_x_kh(&self, c: usize, j: usize) -> Kh {
        self.combo_kh((0.0, 0.0), c, (false, 1.0), None, Some(At::Vertex(j)))
    }

    /// Pushes the coefficients of He{P̂K − Σ_l Γ̂_l H_l} (svec, √2 off the
    /// diagonal) into the block `blk`; `df` is scratch of nx².
    pub(super) fn push_he_block(&self, out: &mut SdpBuilder, blk: &Psd, kh: &Kh, df: &mut [f64]) {
        let (nx, k) = (self.nx, &kh.0);
        // P̂ variables.
        for pc in 0..nx {
            for pr in 0..=pc {
                let v = svec_index(pr, pc);
                // W = E K; ∂F = W + Wᵀ, computed on the upper triangle.
                df.iter_mut().for_each(|x| *x = 0.0);
                for cc in 0..nx {
                    for rr in 0..=cc {
                        let mut w = 0.0;
                        if pr == pc {
                            if rr == pr {
                                w += k[(pr, cc)];
                            }
                            if cc == pr {
                                w += k[(pr, rr)];
                            }
                        } else {
                            if rr == pr {
                                w += k[(pc, cc)];
                            }
                            if rr == pc {
                                w += k[(pr, cc)];
                            }
                            if cc == pr {
                                w += k[(pc, rr)];
                            }
                            if cc == pc {
                                w += k[(pr, rr)];
                            }
                        }
                        df[svec_index(rr, cc)] = w;
                    }
                }
                for cc in 0..nx {
                    for rr in 0..=cc {
                        out.entry(blk, rr, cc, v, df[svec_index(rr, cc)]);
                    }
                }
            }
        }
        for (l, h) in &kh.1 {
            self.push_gain_columns(out, blk, *l, h);
        }
    }

    /// The Γ̂_l columns of one block: −He{Γ̂_l H}, entry (a, b) of
    /// ∂/∂Γ̂_l[r, c] being −([a == r] H[c, b] + [b == r] H[c, a]).
    fn push_gain_columns(&self, out: &mut SdpBuilder, blk: &Psd, l: usize, h: &DMatrix<f64>) {
        let (nx, ny) = (self.nx, self.ny);
        for gr in 0..nx {
            for gc in 0..ny {
                let v = self.gvar(l, gr, gc);
                for cc in 0..nx {
                    for rr in 0..=cc {
                        let mut w = 0.0;
                        if rr == gr {
                            w += h[(gc, cc)];
                        }
                        if cc == gr {
                            w += h[(gc, rr)];
                        }
                        if w != 0.0 {
                            out.entry(blk, rr, cc, v, -w);
                        }
                    }
                }
            }
        }
    }

    /// The columns of ±Ŝ in an nx-block, Ŝ a symmetric variable whose upper
    /// triangle starts at variable `first`: ∂(±Ŝ)/∂Ŝ_rc = ±E_rc, svec entry
    /// ±1 (diagonal) or ±√2.
    pub(super) fn push_sym_var(&self, out: &mut SdpBuilder, blk: &Psd, first: usize, sign: f64) {
        for c in 0..self.nx {
            for r in 0..=c {
                out.entry(blk, r, c, first + svec_index(r, c), sign);
            }
        }
    }
}
