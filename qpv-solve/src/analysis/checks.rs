//! The input checks of every simulation and falsification: the model's
//! shapes and boxes, the gains, vectors; [`SimError`] says what is wrong.

use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;

/// Largest number of scheduling parameters accepted (2^20 vertices).
const MAX_SCHEDULING: usize = 20;

/// Why a simulation or falsification could not be run on its input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// A vector has the wrong number of entries.
    #[error("{what} has {got} entries, expected {expected}")]
    Length {
        /// Which vector.
        what: String,
        /// The length implied by the model.
        expected: usize,
        /// The length given.
        got: usize,
    },
    /// A matrix has the wrong shape.
    #[error("{what} is {}×{}, expected {}×{}", got.0, got.1, expected.0, expected.1)]
    Shape {
        /// Which matrix.
        what: String,
        /// The shape implied by the model (rows, columns).
        expected: (usize, usize),
        /// The shape given (rows, columns).
        got: (usize, usize),
    },
    /// An input contains NaN or an infinity.
    #[error("{what} must be finite")]
    NotFinite {
        /// Which input.
        what: String,
    },
    /// A matrix that must be symmetric positive definite is not.
    #[error("{what} is not symmetric positive definite")]
    NotPositiveDefinite {
        /// Which matrix.
        what: String,
    },
    /// The model's own data is inconsistent (vertex count, parameter box).
    #[error("inconsistent model: {0}")]
    Model(String),
    /// The time grid is unusable: t_end < 0, dt ≤ 0, non-finite, or too many steps.
    #[error("invalid time grid: {0}")]
    TimeGrid(String),
    /// Some other argument is out of its documented range.
    #[error("invalid argument: {0}")]
    Argument(String),
}

pub(crate) fn check_len(what: &str, v: &[f64], expected: usize) -> Result<(), SimError> {
    if v.len() != expected {
        return Err(SimError::Length {
            what: what.to_string(),
            expected,
            got: v.len(),
        });
    }
    if v.iter().any(|x| !x.is_finite()) {
        return Err(SimError::NotFinite {
            what: what.to_string(),
        });
    }
    Ok(())
}

fn check_matrix(what: &str, m: &DMatrix<f64>, rows: usize, cols: usize) -> Result<(), SimError> {
    if m.shape() != (rows, cols) {
        return Err(SimError::Shape {
            what: what.to_string(),
            expected: (rows, cols),
            got: m.shape(),
        });
    }
    if m.iter().any(|x| !x.is_finite()) {
        return Err(SimError::NotFinite {
            what: what.to_string(),
        });
    }
    Ok(())
}

/// Checks that every matrix of `model` has the shape implied by its names,
/// that the vertex count matches the scheduling parameters and that every
/// parameter box is a finite, non-empty interval.
pub(crate) fn check_model(model: &PolytopicModel) -> Result<(), SimError> {
    let (nx, nu, ny) = (model.nx(), model.nu(), model.ny());
    for p in &model.params {
        if !(p.lo.is_finite() && p.hi.is_finite() && p.lo < p.hi) {
            return Err(SimError::Model(format!(
                "parameter {} has the box [{}, {}]",
                p.name, p.lo, p.hi
            )));
        }
    }
    // derived scheduling variables φ_j(θ) double the vertices like parameters
    let s = model.scheduling.len() + model.derived.len();
    if s > MAX_SCHEDULING {
        return Err(SimError::Model(format!(
            "{s} scheduling parameters (at most {MAX_SCHEDULING} supported)"
        )));
    }
    if let Some(&i) = model.scheduling.iter().find(|&&i| i >= model.ntheta()) {
        return Err(SimError::Model(format!(
            "scheduling index {i} but only {} parameters",
            model.ntheta()
        )));
    }
    // 2^s corners per piece of the cover (one piece without a cover), each
    // repeated at the 2^q corners of a Jacobian box
    let s = s + model.gain_shift();
    let pieces = model.pieces();
    if let Some(c) = &model.cover {
        if c.pieces.iter().any(|p| {
            p.theta.len() != model.ntheta()
                || p.phi.len() != model.derived.len()
                || !p.theta.iter().chain(&p.phi).all(|&(lo, hi)| lo < hi)
        }) {
            return Err(SimError::Model(
                "a piece of the cover has ranges that do not match the model".into(),
            ));
        }
    }
    if model.nv() != pieces << s {
        return Err(SimError::Model(format!(
            "{} vertices for {s} scheduling parameters and {pieces} piece(s) (expected {})",
            model.nv(),
            pieces << s
        )));
    }
    for (l, v) in model.vertices.iter().enumerate() {
        check_matrix(&format!("A_{}", l + 1), &v.a, nx, nx)?;
        check_matrix(&format!("B_{}", l + 1), &v.b, nx, nu)?;
        if v.n.len() != nx {
            return Err(SimError::Model(format!(
                "vertex {} has {} matrices N_k, expected {nx}",
                l + 1,
                v.n.len()
            )));
        }
        for (k, n) in v.n.iter().enumerate() {
            check_matrix(&format!("N_{},{}", k + 1, l + 1), n, nx, nx)?;
        }
    }
    for (l, v) in model.vertices.iter().enumerate() {
        check_matrix(&format!("C_{}", l + 1), &v.c, ny, nx)?;
        if v.m.len() != ny {
            return Err(SimError::Model(format!(
                "vertex {} has {} matrices M_k, expected one per output ({ny})",
                l + 1,
                v.m.len()
            )));
        }
        for (k, m) in v.m.iter().enumerate() {
            check_matrix(&format!("M_{},{}", k + 1, l + 1), m, nx, nx)?;
        }
    }
    Ok(())
}

/// Checks that there is one finite nx × ny gain L_l per vertex.
pub(crate) fn check_gains(model: &PolytopicModel, gains: &[DMatrix<f64>]) -> Result<(), SimError> {
    if gains.len() != model.nv() {
        return Err(SimError::Length {
            what: "gains".to_string(),
            expected: model.nv(),
            got: gains.len(),
        });
    }
    for (l, g) in gains.iter().enumerate() {
        check_matrix(&format!("L_{}", l + 1), g, model.nx(), model.ny())?;
    }
    Ok(())
}
