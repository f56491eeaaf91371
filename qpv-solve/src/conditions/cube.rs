//! `conditions = cube`: the matrix-cube relaxation for a region that is a
//! zonotope P = {Σ_k t_k g_k : |t_k| ≤ 1} (a box, a parallelotope or a
//! `region zonotope`), as data: the generators and the slacks a solution
//! carries. docs/method.md ("Cube conditions: zonotope regions without vertex
//! enumeration") derives it.
//!
//! Write the rate matrix of combination c at the pair (e, x) as
//! F0_c + G_c(e) + H_c(x), G_c and H_c linear (the e-vertex and x-vertex
//! terms of [`crate::conditions`]). With one pair of symmetric slacks per
//! generator,
//!
//! ```text
//!     Y_{c,k} ⪰ ±G_c(g_k),   X_{c,k} ⪰ ±H_c(g_k),   F0_c + Σ_k Y_{c,k} + Σ_k X_{c,k} ≺ 0
//! ```
//!
//! imply F0_c + G_c(e) + H_c(x) ≺ 0 for every e, x in P (t G(g) ⪯ Y for
//! |t| ≤ 1), hence the full vertex family: 4r + 1 blocks of size nx per
//! combination instead of p² or 2p (2r + 1 solved when N_k and M_k are
//! symmetric, where H_c = −2G_c folds the pair into one slack: see
//! docs/method.md, "Cube conditions: zonotope regions without vertex
//! enumeration"). The region condition "every vertex in
//! E" becomes a diagonal D with trace D ≤ 1 and D ⪰ GᵀPG (sound (S2)) or
//! [D Gᵀ; G P] ⪰ 0 (the printed (13), GᵀP⁻¹G ⪯ D): xᵀPx = tᵀGᵀPGt ≤ tᵀDt ≤ Σ D_kk.
//! The facet family (S3)/(14) is unchanged.

use crate::linalg::{matrix_to_rows, rows_to_matrix};
use nalgebra::{DMatrix, DVector};
use qpv_dsl::PolytopicModel;
use serde::{Deserialize, Serialize};

/// The generators of the model's region as a zonotope, if it is one
/// (see [`qpv_dsl::Region::zonotope_generators`]).
pub fn generators(model: &PolytopicModel) -> Option<Vec<DVector<f64>>> {
    model.region.zonotope_generators()
}

/// The slacks of a `conditions = cube` solution, in model units.
#[derive(Debug, Clone, PartialEq)]
pub struct CubeSlacks {
    /// Y_{c,k} (nx × nx, symmetric): per rate combination c, per generator k.
    pub y: Vec<Vec<DMatrix<f64>>>,
    /// X_{c,k} (nx × nx, symmetric), indexed like `y`.
    pub x: Vec<Vec<DMatrix<f64>>>,
    /// The diagonal of D (one entry per generator).
    pub d: Vec<f64>,
}

/// The `cube` key of a report: [`CubeSlacks`] as lists of rows, so that
/// anyone can re-check the design's slack inequalities.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CubeReport {
    /// Y_{c,k} as rows, per rate combination, per generator.
    #[serde(rename = "Y")]
    pub y: Vec<Vec<Vec<Vec<f64>>>>,
    /// X_{c,k} as rows, per rate combination, per generator.
    #[serde(rename = "X")]
    pub x: Vec<Vec<Vec<Vec<f64>>>>,
    /// The diagonal of D.
    #[serde(rename = "D")]
    pub d: Vec<f64>,
}

impl CubeSlacks {
    /// The report form.
    pub(crate) fn to_report(&self) -> CubeReport {
        let rows = |v: &Vec<Vec<DMatrix<f64>>>| {
            v.iter()
                .map(|c| c.iter().map(matrix_to_rows).collect())
                .collect()
        };
        CubeReport {
            y: rows(&self.y),
            x: rows(&self.x),
            d: self.d.clone(),
        }
    }

    /// Back from the report form.
    pub fn from_report(r: &CubeReport) -> Self {
        let mats = |v: &Vec<Vec<Vec<Vec<f64>>>>| {
            v.iter()
                .map(|c| c.iter().map(|m| rows_to_matrix(m)).collect())
                .collect()
        };
        CubeSlacks {
            y: mats(&r.y),
            x: mats(&r.x),
            d: r.d.clone(),
        }
    }
}
