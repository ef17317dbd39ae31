//! Adam over candle [`Var`]s with PyTorch's semantics (`torch.optim.Adam`, no weight decay,
//! no amsgrad), and a serialisable state so that a resumed run continues bit-exactly.
//!
//! One optimizer for the trainer: [`Adam<f32>`] (the default) trains the model, [`Adam<f64>`]
//! the synthetic-data RL policy (`gpecnet_train::synth::agent`). The update is computed on the host
//! in the parameters' element type `T` ([`AdamFloat`]), element by element, in exactly torch's
//! order (the scalars below are f64 and rounded to `T` once per step):
//! ```text
//! m = b1 * m + (1 - b1) * g
//! v = b2 * v + (1 - b2) * g * g
//! step_size = lr / (1 - b1^t)                      (f64, like torch's Python scalars)
//! denom = sqrt(v) / sqrt(1 - b2^t) + eps
//! p = p - step_size * m / denom
//! ```
//!
//! Every element is updated on its own, in place (the weights through a candle in-place op, the
//! gradients read where backprop left them), split into chunks over the run's threads
//! (`model::chunk_len`); the split does not change any bit.

use candle_core::backprop::GradStore;
use candle_core::{CpuStorage, InplaceOp1, Layout, Storage, Tensor, Var, WithDType};

use crate::pool::{chunk_len, for_each_job};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

/// An element type [`Adam`] updates: `f32` (the model) or `f64` (the RL policy).
pub trait AdamFloat: WithDType + Serialize + DeserializeOwned {
    /// Square root (IEEE, correctly rounded).
    fn sqrt(self) -> Self;
    /// The values of a CPU storage of this type, mutably; `None` for another type.
    fn storage_mut(s: &mut CpuStorage) -> Option<&mut Vec<Self>>;
}

/// [`AdamFloat`] for a float type and its [`CpuStorage`] variant.
macro_rules! adam_float {
    ($t:ty, $variant:ident) => {
        impl AdamFloat for $t {
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }

            fn storage_mut(s: &mut CpuStorage) -> Option<&mut Vec<Self>> {
                match s {
                    CpuStorage::$variant(w) => Some(w),
                    _ => None,
                }
            }
        }
    };
}

adam_float!(f32, F32);
adam_float!(f64, F64);

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
#[serde(bound = "")]
pub struct AdamState<T: AdamFloat = f32> {
    /// Number of steps taken.
    pub step: u64,
    /// First moments.
    pub m: Vec<Vec<T>>,
    /// Second moments.
    pub v: Vec<Vec<T>>,
}

/// Adam bound to a fixed list of parameters whose element type is `T`.
pub struct Adam<T: AdamFloat = f32> {
    vars: Vec<Var>,
    params: AdamParams,
    state: AdamState<T>,
}

impl<T: AdamFloat> Adam<T> {
    /// Fresh optimizer (zero moments) over `vars`.
    pub fn new(vars: Vec<Var>, params: AdamParams) -> Self {
        let m: Vec<Vec<T>> = vars
            .iter()
            .map(|v| vec![T::zero(); v.elem_count()])
            .collect();
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
        state: AdamState<T>,
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
    pub fn state(&self) -> &AdamState<T> {
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
        let k = Coefficients {
            step_size: T::from_f64(p.lr / bc1),
            b1: T::from_f64(p.beta1),
            b2: T::from_f64(p.beta2),
            one_b1: T::from_f64(1.0 - p.beta1),
            one_b2: T::from_f64(1.0 - p.beta2),
            bc2_sqrt: T::from_f64(bc2_sqrt),
            eps: T::from_f64(p.eps),
        };
        for (i, var) in self.vars.iter().enumerate() {
            let n = var.elem_count();
            let (m, v) = (&mut self.state.m[i], &mut self.state.v[i]);
            if m.len() != n || v.len() != n {
                candle_core::bail!("Adam state shape mismatch for {:?}", var.shape());
            }
            match grads.get(var.as_tensor()) {
                Some(g) => {
                    let (storage, layout) = g.storage_and_layout();
                    match (&*storage, layout.contiguous_offsets()) {
                        (Storage::Cpu(cpu), Some((a, b))) => {
                            let g = cpu.as_slice::<T>()?;
                            let g = g.get(a..b).filter(|g| g.len() == n).ok_or_else(|| {
                                candle_core::Error::Msg("Adam: gradient shape mismatch".into())
                            })?;
                            update_var(var, k, g, m, v)?;
                        }
                        _ => {
                            drop(storage);
                            let g = g.flatten_all()?.to_vec1::<T>()?;
                            if g.len() != n {
                                candle_core::bail!("Adam: gradient shape mismatch");
                            }
                            update_var(var, k, &g, m, v)?;
                        }
                    }
                }
                None => update_var(var, k, &vec![T::zero(); n], m, v)?,
            }
        }
        Ok(())
    }
}

/// The coefficients of one Adam step, rounded to the parameters' element type.
#[derive(Clone, Copy, Debug)]
struct Coefficients<T> {
    step_size: T,
    b1: T,
    b2: T,
    one_b1: T,
    one_b2: T,
    bc2_sqrt: T,
    eps: T,
}

/// One step for the elements of one chunk, in torch's order (see the module docs).
fn update_chunk<T: AdamFloat>(k: Coefficients<T>, w: &mut [T], g: &[T], m: &mut [T], v: &mut [T]) {
    for (((w, &g), m), v) in w.iter_mut().zip(g).zip(m.iter_mut()).zip(v.iter_mut()) {
        *m = k.b1 * *m + k.one_b1 * g;
        *v = k.b2 * *v + k.one_b2 * (g * g);
        let denom = v.sqrt() / k.bc2_sqrt + k.eps;
        *w -= k.step_size * (*m / denom);
    }
}

/// The in-place update of one parameter tensor (a candle [`InplaceOp1`] on its storage).
struct AdamUpdate<'a, T> {
    k: Coefficients<T>,
    g: &'a [T],
    /// First and second moments (a lock only because candle hands the op out by `&self`).
    mv: std::sync::Mutex<(&'a mut [T], &'a mut [T])>,
}

impl<T: AdamFloat> InplaceOp1 for AdamUpdate<'_, T> {
    fn name(&self) -> &'static str {
        "gpecnet-adam"
    }

    fn cpu_fwd(&self, storage: &mut CpuStorage, layout: &Layout) -> candle_core::Result<()> {
        let mut mv = self
            .mv
            .lock()
            .map_err(|_| candle_core::Error::Msg("Adam: moment lock poisoned".into()))?;
        let (m, v) = &mut *mv;
        let Some(w) = T::storage_mut(storage) else {
            candle_core::bail!("Adam: parameters must be {:?}", T::DTYPE);
        };
        let n = self.g.len();
        let w = match layout.contiguous_offsets() {
            Some((a, b)) if b - a == n && m.len() == n && v.len() == n => &mut w[a..b],
            _ => candle_core::bail!("Adam: parameter layout mismatch"),
        };
        let chunk = chunk_len(n);
        let jobs = w
            .chunks_mut(chunk)
            .zip(self.g.chunks(chunk))
            .zip(m.chunks_mut(chunk))
            .zip(v.chunks_mut(chunk));
        for_each_job(jobs, |(((w, g), m), v)| update_chunk(self.k, w, g, m, v));
        Ok(())
    }
}

/// Updates `var` in place from its gradient `g` (flat, `var`'s element count).
fn update_var<T: AdamFloat>(
    var: &Var,
    k: Coefficients<T>,
    g: &[T],
    m: &mut [T],
    v: &mut [T],
) -> candle_core::Result<()> {
    let op = AdamUpdate {
        k,
        g,
        mv: std::sync::Mutex::new((m, v)),
    };
    var.as_tensor().inplace_op1(&op)
}

#[cfg(test)]
mod tests {
    use super::*;
    use candle_core::Device;

    /// The update as it was before it became in place and multi-threaded: copies of weights
    /// and gradients, one serial loop.
    fn reference_step(
        w: &mut [f32],
        g: &[f32],
        m: &mut [f32],
        v: &mut [f32],
        p: AdamParams,
        t: i32,
    ) {
        let bc1 = 1.0 - p.beta1.powi(t);
        let bc2_sqrt = ((1.0 - p.beta2.powi(t)).sqrt()) as f32;
        let step_size = (p.lr / bc1) as f32;
        let (b1, b2) = (p.beta1 as f32, p.beta2 as f32);
        let (one_b1, one_b2) = ((1.0 - p.beta1) as f32, (1.0 - p.beta2) as f32);
        let eps = p.eps as f32;
        for j in 0..w.len() {
            m[j] = b1 * m[j] + one_b1 * g[j];
            v[j] = b2 * v[j] + one_b2 * (g[j] * g[j]);
            let denom = v[j].sqrt() / bc2_sqrt + eps;
            w[j] -= step_size * (m[j] / denom);
        }
    }

    #[test]
    fn in_place_chunked_step_is_bit_identical_to_the_serial_loop() {
        let mut rng = crate::rng::Rng::new(4);
        // One tensor split into several chunks, one small, one without a gradient.
        let sizes = [3 * crate::pool::PAR_MIN_CHUNK + 5, 7, 11];
        let init: Vec<Vec<f32>> = sizes
            .iter()
            .map(|&n| (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect())
            .collect();
        let vars: Vec<Var> = init
            .iter()
            .map(|w| Var::from_vec(w.clone(), w.len(), &Device::Cpu).unwrap())
            .collect();
        let params = AdamParams::with_lr(3e-4);
        let mut opt = Adam::<f32>::new(vars.clone(), params);
        let mut w = init.clone();
        let mut m: Vec<Vec<f32>> = sizes.iter().map(|&n| vec![0.0; n]).collect();
        let mut v = m.clone();
        for t in 1..=3 {
            let c: Vec<Vec<f32>> = sizes
                .iter()
                .map(|&n| (0..n).map(|_| rng.uniform(-2.0, 2.0)).collect())
                .collect();
            // loss = sum(c0 * x0) + sum(c1 * x1): gradients c0, c1; none for x2.
            let mut loss = Tensor::new(0f32, &Device::Cpu).unwrap();
            for i in 0..2 {
                let ct = Tensor::from_vec(c[i].clone(), sizes[i], &Device::Cpu).unwrap();
                loss = (loss + (vars[i].as_tensor() * ct).unwrap().sum_all().unwrap()).unwrap();
            }
            opt.backward_step(&loss).unwrap();
            for i in 0..3 {
                let g = if i < 2 {
                    c[i].clone()
                } else {
                    vec![0.0; sizes[i]]
                };
                reference_step(&mut w[i], &g, &mut m[i], &mut v[i], params, t);
            }
        }
        for i in 0..3 {
            let got = vars[i].as_tensor().to_vec1::<f32>().unwrap();
            let same = got
                .iter()
                .zip(&w[i])
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "tensor {i}");
            assert_eq!(opt.state().m[i], m[i]);
            assert_eq!(opt.state().v[i], v[i]);
        }
    }

    #[test]
    fn f64_parameters_take_the_same_steps_in_f64() {
        // The RL policy's case: f64 weights, moments and arithmetic, torch's order.
        let x = Var::from_vec(vec![1.0f64, -2.0, 0.5], 3, &Device::Cpu).unwrap();
        let params = AdamParams::with_lr(0.01);
        let mut opt = Adam::<f64>::new(vec![x.clone()], params);
        let (mut w, mut m, mut v) = (vec![1.0f64, -2.0, 0.5], [0.0f64; 3], [0.0f64; 3]);
        for t in 1..=4 {
            // loss = Σ c x: the gradient is exactly c.
            let c = [0.3 * t as f64, -1.7, 2.5 / t as f64];
            let ct = Tensor::new(&c, &Device::Cpu).unwrap();
            let loss = (x.as_tensor() * ct).unwrap().sum_all().unwrap();
            opt.backward_step(&loss).unwrap();
            let step_size = params.lr / (1.0 - params.beta1.powi(t));
            let bc2_sqrt = (1.0 - params.beta2.powi(t)).sqrt();
            for j in 0..3 {
                let g = c[j];
                m[j] = params.beta1 * m[j] + (1.0 - params.beta1) * g;
                v[j] = params.beta2 * v[j] + (1.0 - params.beta2) * (g * g);
                w[j] -= step_size * (m[j] / (v[j].sqrt() / bc2_sqrt + params.eps));
            }
        }
        assert_eq!(x.as_tensor().to_vec1::<f64>().unwrap(), w);
        assert_eq!(opt.state().step, 4);
        assert_eq!(opt.state().m[0], m);
        assert_eq!(opt.state().v[0], v);
        let mut wrong = Adam::<f32>::new(vec![x.clone()], params);
        let loss = x.as_tensor().sum_all().unwrap();
        assert!(
            wrong.backward_step(&loss).is_err(),
            "f64 weights with Adam<f32>"
        );
    }

    #[test]
    fn minimises_a_quadratic_and_matches_torch_first_step() {
        let x = Var::from_vec(vec![1.0f32, -2.0], 2, &Device::Cpu).unwrap();
        let mut opt = Adam::<f32>::new(vec![x.clone()], AdamParams::with_lr(0.1));
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
