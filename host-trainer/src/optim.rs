//! Adam over candle [`Var`]s with PyTorch's semantics (`torch.optim.Adam`, no weight decay,
//! no amsgrad), and a serialisable state so that a resumed run continues bit-exactly.
//!
//! The update is computed on the host in f32, element by element, in exactly torch's order:
//! ```text
//! m = b1 * m + (1 - b1) * g
//! v = b2 * v + (1 - b2) * g * g
//! step_size = lr / (1 - b1^t)                      (f64, like torch's Python scalars)
//! denom = sqrt(v) / sqrt(1 - b2^t) + eps
//! p = p - step_size * m / denom
//! ```

use candle_core::backprop::GradStore;
use candle_core::{Device, Tensor, Var};
use serde::{Deserialize, Serialize};

/// Adam hyper-parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AdamParams {
    /// Learning rate.
    pub lr: f64,
    /// First-moment decay (0.9).
    pub beta1: f64,
    /// Second-moment decay (0.999).
    pub beta2: f64,
    /// Denominator epsilon (1e-8).
    pub eps: f64,
}

impl AdamParams {
    /// PyTorch defaults with learning rate `lr`.
    pub fn with_lr(lr: f64) -> Self {
        Self {
            lr,
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-8,
        }
    }
}

/// Optimizer state: step count and both moment estimates (one flat vector per parameter).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AdamState {
    /// Number of steps taken.
    pub step: u64,
    /// First moments.
    pub m: Vec<Vec<f32>>,
    /// Second moments.
    pub v: Vec<Vec<f32>>,
}

/// Adam bound to a fixed list of parameters.
pub struct Adam {
    vars: Vec<Var>,
    params: AdamParams,
    state: AdamState,
}

impl Adam {
    /// Fresh optimizer (zero moments) over `vars`.
    pub fn new(vars: Vec<Var>, params: AdamParams) -> Self {
        let m: Vec<Vec<f32>> = vars.iter().map(|v| vec![0.0; v.elem_count()]).collect();
        let state = AdamState {
            step: 0,
            v: m.clone(),
            m,
        };
        Self {
            vars,
            params,
            state,
        }
    }

    /// Restore from a saved state; fails if the shapes do not match `vars`.
    pub fn from_state(
        vars: Vec<Var>,
        params: AdamParams,
        state: AdamState,
    ) -> candle_core::Result<Self> {
        if state.m.len() != vars.len() || state.v.len() != vars.len() {
            candle_core::bail!(
                "Adam state has {} tensors, model {}",
                state.m.len(),
                vars.len()
            );
        }
        for ((var, m), v) in vars.iter().zip(&state.m).zip(&state.v) {
            if m.len() != var.elem_count() || v.len() != var.elem_count() {
                candle_core::bail!("Adam state shape mismatch for {:?}", var.shape());
            }
        }
        Ok(Self {
            vars,
            params,
            state,
        })
    }

    /// The state, for checkpoints.
    pub fn state(&self) -> &AdamState {
        &self.state
    }

    /// Hyper-parameters.
    pub fn params(&self) -> AdamParams {
        self.params
    }

    /// Sets the learning rate of the next steps (a schedule's job).
    pub fn set_lr(&mut self, lr: f64) {
        self.params.lr = lr;
    }

    /// Backpropagate `loss` and apply one update.
    pub fn backward_step(&mut self, loss: &Tensor) -> candle_core::Result<()> {
        let grads = loss.backward()?;
        self.step(&grads)
    }

    /// Apply one update from precomputed gradients (a parameter without a gradient is
    /// treated as having a zero gradient, like torch with `grad = 0`).
    pub fn step(&mut self, grads: &GradStore) -> candle_core::Result<()> {
        self.state.step += 1;
        let t = self.state.step as i32;
        let p = self.params;
        let bc1 = 1.0 - p.beta1.powi(t);
        let bc2_sqrt = (1.0 - p.beta2.powi(t)).sqrt();
        let step_size = (p.lr / bc1) as f32;
        let (b1, b2) = (p.beta1 as f32, p.beta2 as f32);
        let (one_b1, one_b2) = ((1.0 - p.beta1) as f32, (1.0 - p.beta2) as f32);
        let bc2_sqrt = bc2_sqrt as f32;
        let eps = p.eps as f32;
        for (i, var) in self.vars.iter().enumerate() {
            let n = var.elem_count();
            let g = match grads.get(var.as_tensor()) {
                Some(g) => g.flatten_all()?.to_vec1::<f32>()?,
                None => vec![0.0; n],
            };
            let mut w = var.as_tensor().flatten_all()?.to_vec1::<f32>()?;
            let (m, v) = (&mut self.state.m[i], &mut self.state.v[i]);
            for j in 0..n {
                m[j] = b1 * m[j] + one_b1 * g[j];
                v[j] = b2 * v[j] + one_b2 * (g[j] * g[j]);
                let denom = v[j].sqrt() / bc2_sqrt + eps;
                w[j] -= step_size * (m[j] / denom);
            }
            var.set(&Tensor::from_vec(w, var.shape(), &Device::Cpu)?)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimises_a_quadratic_and_matches_torch_first_step() {
        let x = Var::from_vec(vec![1.0f32, -2.0], 2, &Device::Cpu).unwrap();
        let mut opt = Adam::new(vec![x.clone()], AdamParams::with_lr(0.1));
        // First Adam step moves each coordinate by ~lr * sign(g).
        let loss = x.as_tensor().sqr().unwrap().sum_all().unwrap();
        opt.backward_step(&loss).unwrap();
        let w = x.as_tensor().to_vec1::<f32>().unwrap();
        assert!(
            (w[0] - 0.9).abs() < 1e-6 && (w[1] + 1.9).abs() < 1e-6,
            "{w:?}"
        );
        for _ in 0..500 {
            let loss = x.as_tensor().sqr().unwrap().sum_all().unwrap();
            opt.backward_step(&loss).unwrap();
        }
        let w = x.as_tensor().to_vec1::<f32>().unwrap();
        assert!(w.iter().all(|v| v.abs() < 0.05), "{w:?}");
        assert_eq!(opt.state().step, 501);
    }
}
