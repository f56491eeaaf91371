//! Where noise and disturbances enter the plant: the noisy outputs and the
//! process-disturbance matrices B_w,l (docs/method.md, "Noise and disturbances").

use crate::error::SolveError;
use nalgebra::DMatrix;
use qpv_dsl::PolytopicModel;

/// Where noise and disturbances enter: which outputs are measured with
/// noise (all by default) and, optionally, a process-disturbance matrix
/// B_w,l per θ-vertex (nx × n_w, the same n_w at every vertex).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NoiseChannels {
    /// Indices (0-based) of the outputs that carry measurement noise;
    /// `None` = every output.
    pub outputs: Option<Vec<usize>>,
    /// B_w,l per θ-vertex (model order); `None` = no process disturbance.
    pub b_w: Option<Vec<DMatrix<f64>>>,
}

impl NoiseChannels {
    /// Noise on every output, no process disturbance (the default).
    pub fn all_outputs() -> Self {
        NoiseChannels::default()
    }

    /// The channels a model declares: noise on the outputs named by its
    /// `noise` declaration (every output without one), and its process
    /// disturbances B_w,l, if any.
    pub fn from_model(model: &PolytopicModel) -> Self {
        NoiseChannels {
            outputs: model.noise.outputs.clone(),
            b_w: (!model.noise.disturbances.is_empty()).then(|| model.noise.b_w.clone()),
        }
    }

    /// The noisy output indices for a model with `ny` outputs.
    pub fn noisy_outputs(&self, ny: usize) -> Vec<usize> {
        match &self.outputs {
            Some(o) => o.clone(),
            None => (0..ny).collect(),
        }
    }

    /// Number of disturbance inputs n_w.
    pub fn n_w(&self) -> usize {
        self.b_w
            .as_ref()
            .and_then(|b| b.first())
            .map_or(0, |b| b.ncols())
    }

    /// Checks the channels against `model`: output indices in range and
    /// without repeats, one finite nx × n_w matrix B_w,l per vertex, and at
    /// least one channel.
    pub fn validate(&self, model: &PolytopicModel) -> Result<(), SolveError> {
        let bad = |s: String| Err(SolveError::Dimensions(format!("noise channels: {s}")));
        let (nx, ny) = (model.nx(), model.ny());
        let outs = self.noisy_outputs(ny);
        for (k, &o) in outs.iter().enumerate() {
            if o >= ny {
                return bad(format!("output index {o} but the model has {ny} outputs"));
            }
            if outs[..k].contains(&o) {
                return bad(format!("output index {o} listed twice"));
            }
        }
        if let Some(b) = &self.b_w {
            if b.len() != model.nv() {
                return bad(format!(
                    "{} matrices B_w given, the model has {} vertices",
                    b.len(),
                    model.nv()
                ));
            }
            let nw = self.n_w();
            for (l, bl) in b.iter().enumerate() {
                if bl.shape() != (nx, nw) {
                    return bad(format!(
                        "B_w at vertex {} is {:?}, expected ({nx}, {nw})",
                        l + 1,
                        bl.shape()
                    ));
                }
                if bl.iter().any(|v| !v.is_finite()) {
                    return bad(format!("B_w at vertex {} has non-finite entries", l + 1));
                }
            }
        }
        if outs.is_empty() && self.n_w() == 0 {
            return bad("no noisy output and no disturbance: nothing to bound".into());
        }
        Ok(())
    }

    /// The channels in balanced coordinates z = D⁻¹x
    /// ([`crate::model::scaling::StateScaling`]): B_w,z = D⁻¹B_w (exact,
    /// D is powers of two); the noisy outputs are unchanged (y = C D z).
    pub(crate) fn in_z(&self, s: &crate::model::StateScaling) -> Self {
        NoiseChannels {
            outputs: self.outputs.clone(),
            b_w: self.b_w.as_ref().map(|b| {
                b.iter()
                    .map(|bl| DMatrix::from_fn(bl.nrows(), bl.ncols(), |r, c| bl[(r, c)] / s.d[r]))
                    .collect()
            }),
        }
    }

    /// The channels of the observer model of an output-filter design: noise
    /// on output k enters the filter state k through the filter gain b (a
    /// process disturbance of the augmented plant, x_{y,k}' = −a x_{y,k} +
    /// b (y_k + v_k)), and the filter states themselves are measured exactly.
    /// `plant_nx` is the plant's state count, `gain` the filter gain b;
    /// `self` must have passed [`NoiseChannels::validate`] on the plant.
    pub fn through_filter(&self, plant_nx: usize, ny: usize, nv: usize, gain: f64) -> Self {
        let outs = self.noisy_outputs(ny);
        let nw = self.n_w();
        let n = plant_nx + ny;
        let b_w = (0..nv)
            .map(|l| {
                let mut m = DMatrix::zeros(n, nw + outs.len());
                if let Some(b) = &self.b_w {
                    m.view_mut((0, 0), (plant_nx, nw)).copy_from(&b[l]);
                }
                for (c, &k) in outs.iter().enumerate() {
                    m[(plant_nx + k, nw + c)] = gain;
                }
                m
            })
            .collect();
        NoiseChannels {
            outputs: Some(Vec::new()),
            b_w: Some(b_w),
        }
    }
}
