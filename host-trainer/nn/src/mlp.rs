//! Multi-layer perceptrons on candle: [`Dense`] layers with an activation after every layer
//! but the last, `sin(w0 * .)` (SIREN, G-PECNet) or ReLU (PECNet), initialised from the
//! seeded [`Rng`] (no candle randomness), exported to the reference's [`Layer`]s.

use candle_core::{Device, Tensor, Var};

use crate::ops::{linear, linear_sine};
use crate::rng::Rng;
use gpecnet_reference::network::{Act, Layer};

/// One affine layer; weight `[out, in]` (PyTorch layout), bias `[out]`.
#[derive(Clone, Debug)]
pub struct Dense {
    /// `[out, in]`.
    pub weight: Var,
    /// `[out]`.
    pub bias: Var,
}

/// A multi-layer perceptron with an activation after every layer but the last.
#[derive(Clone, Debug)]
pub struct Mlp {
    layers: Vec<Dense>,
    activation: Act,
    w0: f32,
    /// Inputs are multiplied by `1 / in_scale` before the first layer.
    in_scale: f32,
    /// Outputs are multiplied by `out_scale` after the last layer.
    out_scale: f32,
}

fn uniform_vec(rng: &mut Rng, n: usize, bound: f32) -> Vec<f32> {
    (0..n).map(|_| rng.uniform(-bound, bound)).collect()
}

impl Mlp {
    /// Build `input -> hidden... -> output` and initialise it from `rng`.
    ///
    /// Sine: first layer `W ~ U(-1/n, 1/n)`, later layers `W ~ U(-sqrt(6/n)/w0, sqrt(6/n)/w0)`
    /// (SIREN); ReLU: `W ~ U(-1/sqrt(n), 1/sqrt(n))` (PyTorch's default). Bias always
    /// `U(-1/sqrt(n), 1/sqrt(n))`. `n` is the fan-in. Weights are drawn before biases, layer by
    /// layer, row-major.
    pub fn new(
        input: usize,
        hidden: &[usize],
        output: usize,
        activation: Act,
        w0: f32,
        rng: &mut Rng,
    ) -> candle_core::Result<Self> {
        let dev = Device::Cpu;
        let mut layers = Vec::new();
        let mut prev = input;
        for (i, &out) in hidden.iter().chain(std::iter::once(&output)).enumerate() {
            let n = prev as f32;
            let wb = match activation {
                Act::Sine if i == 0 => 1.0 / n,
                Act::Sine => (6.0 / n).sqrt() / w0,
                Act::Relu | Act::Linear => 1.0 / n.sqrt(),
            };
            let w = uniform_vec(rng, out * prev, wb);
            let b = uniform_vec(rng, out, 1.0 / n.sqrt());
            layers.push(Dense {
                weight: Var::from_vec(w, (out, prev), &dev)?,
                bias: Var::from_vec(b, out, &dev)?,
            });
            prev = out;
        }
        Ok(Self {
            layers,
            activation,
            w0,
            in_scale: 1.0,
            out_scale: 1.0,
        })
    }

    /// An MLP over the given layers (ReLU or sine with `w0 = 1` after every layer but the last),
    /// without scales. The layers may hold f64 weights (the synthetic-data RL policy's,
    /// `gpecnet_train::synth::agent`): [`crate::ops::linear`] and [`crate::ops::add_bias`] then run candle's own ops.
    pub fn from_layers(layers: Vec<Dense>, activation: Act) -> Self {
        Self {
            layers,
            activation,
            w0: 1.0,
            in_scale: 1.0,
            out_scale: 1.0,
        }
    }

    /// Sets fixed input/output scales: the network sees `x / in_scale` and
    /// returns `out_scale · y`. They keep SIREN's first layer in its intended
    /// O(1) input range (PECNet's coordinates reach hundreds) and are folded
    /// into the first and last layers at export, so the shipped blob needs no
    /// extra step.
    pub fn with_scales(mut self, in_scale: f32, out_scale: f32) -> Self {
        self.in_scale = in_scale;
        self.out_scale = out_scale;
        self
    }

    /// `x`: `[batch, in]` -> `[batch, out]`.
    pub fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        let mut h = if self.in_scale == 1.0 {
            x.clone()
        } else {
            x.affine(f64::from(1.0 / self.in_scale), 0.0)?
        };
        let last = self.layers.len() - 1;
        for (i, l) in self.layers.iter().enumerate() {
            let (w, b) = (l.weight.as_tensor(), l.bias.as_tensor());
            h = match self.activation {
                Act::Sine if i < last => linear_sine(&h, w, b, self.w0)?,
                Act::Relu if i < last => linear(&h, w, b)?.relu()?,
                _ => linear(&h, w, b)?,
            };
        }
        if self.out_scale != 1.0 {
            h = h.affine(f64::from(self.out_scale), 0.0)?;
        }
        Ok(h)
    }

    /// Parameters in order `w0, b0, w1, b1, ...`.
    pub fn vars(&self) -> Vec<Var> {
        self.layers
            .iter()
            .flat_map(|l| [l.weight.clone(), l.bias.clone()])
            .collect()
    }

    /// The layers.
    pub fn layers(&self) -> &[Dense] {
        &self.layers
    }

    /// Export with `w0` folded into sine layers (see [`Layer`]).
    pub fn export(&self) -> candle_core::Result<Vec<Layer>> {
        let last = self.layers.len() - 1;
        let mut out = Vec::with_capacity(self.layers.len());
        for (i, l) in self.layers.iter().enumerate() {
            let (out_dim, in_dim) = l.weight.as_tensor().dims2()?;
            let mut weight = l.weight.as_tensor().flatten_all()?.to_vec1::<f32>()?;
            let mut bias = l.bias.as_tensor().to_vec1::<f32>()?;
            if i == 0 && self.in_scale != 1.0 {
                let inv = 1.0 / self.in_scale;
                weight.iter_mut().for_each(|x| *x *= inv);
            }
            if i == last && self.out_scale != 1.0 {
                weight.iter_mut().for_each(|x| *x *= self.out_scale);
                bias.iter_mut().for_each(|x| *x *= self.out_scale);
            }
            let activation = if i == last {
                Act::Linear
            } else {
                if self.activation == Act::Sine {
                    weight.iter_mut().for_each(|x| *x *= self.w0);
                    bias.iter_mut().for_each(|x| *x *= self.w0);
                }
                self.activation
            };
            out.push(Layer::new(in_dim, out_dim, activation, weight, bias));
        }
        Ok(out)
    }

    /// Overwrite the weights from exported `layers` (the inverse of [`Mlp::export`], for
    /// fine-tuning from a blob): `w0` is divided out of every sine layer, `in_scale` back into
    /// the first layer and `out_scale` out of the last. The shapes must be this network's and
    /// the hidden activations its own; every error says which layer differs. The weights come
    /// back equal to the exported ones up to the rounding of those divisions (exactly equal for
    /// `w0 = 1` and power-of-two scales).
    pub fn import(&self, layers: &[Layer]) -> candle_core::Result<()> {
        if layers.len() != self.layers.len() {
            candle_core::bail!(
                "{} layers where this network has {}",
                layers.len(),
                self.layers.len()
            );
        }
        let last = self.layers.len() - 1;
        for (i, (dense, l)) in self.layers.iter().zip(layers).enumerate() {
            let (out_dim, in_dim) = dense.weight.as_tensor().dims2()?;
            if (l.out_dim, l.in_dim) != (out_dim, in_dim)
                || l.w.len() != out_dim * in_dim
                || l.b.len() != out_dim
            {
                candle_core::bail!(
                    "layer {i} is {}x{} where this network's is {out_dim}x{in_dim}",
                    l.out_dim,
                    l.in_dim
                );
            }
            let want = if i == last {
                Act::Linear
            } else {
                self.activation
            };
            if l.act != want {
                candle_core::bail!(
                    "layer {i} has activation {:?} where this network has {want:?}",
                    l.act
                );
            }
            let mut weight = l.w.clone();
            let mut bias = l.b.clone();
            if i != last && self.activation == Act::Sine {
                weight.iter_mut().for_each(|x| *x /= self.w0);
                bias.iter_mut().for_each(|x| *x /= self.w0);
            }
            if i == last && self.out_scale != 1.0 {
                weight.iter_mut().for_each(|x| *x /= self.out_scale);
                bias.iter_mut().for_each(|x| *x /= self.out_scale);
            }
            if i == 0 && self.in_scale != 1.0 {
                weight.iter_mut().for_each(|x| *x *= self.in_scale);
            }
            let dev = Device::Cpu;
            dense
                .weight
                .set(&Tensor::from_vec(weight, (out_dim, in_dim), &dev)?)?;
            dense.bias.set(&Tensor::from_vec(bias, out_dim, &dev)?)?;
        }
        Ok(())
    }
}
