//! Endpoint (and optional trajectory) prediction over a validated [`Model`].
//!
//! # The computation, in order
//!
//! For observed positions `p_0 .. p_{P-1}` (caller's units, P = `past_len`):
//!
//! 1. `x[2t + c] = (p_t[c] - p_0[c]) · data_scale` (two f32 roundings); for a
//!    model with a heading frame the shifted point is rotated first
//!    ([`crate::frame`] gives the exact rule, shared by both engines).
//! 2. `f = encoder_past(x)` (width `fdim`).
//! 3. The decoder's first layer sees `[f, z]`. Its feature part is summed
//!    once per call: `a_j = b_j + Σ_{i<fdim} W_ji f_i`, strictly in `i` order.
//! 4. For each sample `s < k`: `z` = the next `zdim` normals of
//!    [`crate::prng::Gaussian`] seeded with `seed`, each times `sigma`; the
//!    first layer continues the same sum `a_j + Σ_i W_j,fdim+i z_i` (so the
//!    result equals one sequential pass over `[f, z]`), then the activation
//!    and the remaining decoder layers give `d` (normalised endpoint).
//! 5. Endpoint `e[c] = d[c] / data_scale + p_0[c]` (rotated back first in the
//!    heading frame, see [`crate::frame`]). The K endpoints a model reports
//!    follow its protocol ([`crate::sampling`]): plain samples, or test-time
//!    sampling reduced by k-means.
//! 6. Optionally, the intermediate points: `g = encoder_dest(d)`, `q =
//!    predictor([f, g, p_{P-1} / initial_pos_divisor])`, point `t` =
//!    `q[2t + c] / data_scale + p_0[c]`, and the last point is `e`.
//!
//! The point forecast ([`Predictor::predict_point`]) runs the point-forecast
//! head on the same input `x` and maps each output pair like an endpoint.
//!
//! Every dense layer computes `y_j = act(b_j + W_j0 x_0 + W_j1 x_1 + ...)`,
//! accumulating left to right in f32 with separate multiply and add (no FMA).
//! This order is the contract the trainer's reference implementation follows.
//!
//! # Memory
//!
//! `Predictor<S, W>` owns five scratch rows of `W` f32 (`20·W` bytes: 2.5 KiB
//! for `W = 128`, 20 KiB for the paper-size `W = 1024`) and borrows the model.
//! The weights are read in place from the blob. Calls use well under 1 KiB of
//! stack besides the returned `heapless::Vec`s (`8·K` bytes for endpoints,
//! `K·(8·MAX_FUTURE + 4)` for trajectories).
//!
//! ```
//! # fn demo(blob: &'static [u8]) -> Result<(), gpecnet_core::Error> {
//! use gpecnet_core::{LibmSine, Model, Predictor};
//! let model = Model::from_blob(blob)?;
//! let mut p: Predictor<'_, '_, LibmSine, 128> = Predictor::new(&model)?;
//! let past = [[10.0, 20.0], [11.0, 21.0], [12.0, 22.0], [13.0, 23.0],
//!             [14.0, 24.0], [15.0, 25.0], [16.0, 26.0], [17.0, 27.0]];
//! let ends = p.predict_endpoints::<20>(&past, 7, 20)?;
//! assert_eq!(ends.len(), 20);
//! # Ok(()) }
//! ```

use core::marker::PhantomData;

use crate::blob::{Activation, Layer, Model, Network, MAX_FUTURE};
use crate::frame::Frame;
use crate::prng::Gaussian;
use crate::sine::Sine;

/// A predicted trajectory: `future_len` points, the last is the endpoint.
pub type Trajectory = heapless::Vec<[f32; 2], MAX_FUTURE>;

/// Why a prediction was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PredictError {
    /// The model's widest layer is wider than the predictor's scratch capacity `W`.
    ScratchTooSmall {
        /// Width the model needs.
        needed: usize,
        /// The predictor's `W`.
        capacity: usize,
    },
    /// `past.len()` differs from the model's `past_len`.
    WrongPastLength {
        /// Length the model expects.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// `k` is 0 or larger than the output capacity.
    BadSampleCount,
    /// An input coordinate is NaN or infinite.
    NonFiniteInput,
    /// The model produced NaN or infinity (inputs far outside the training range).
    NonFiniteOutput,
    /// Trajectories were asked of a model without a predictor network.
    NoPredictor,
    /// A point forecast was asked of a model without a point-forecast head.
    NoPointHead,
    /// The model is not an f32 model (use [`crate::fixed::FixedPredictor`] for fixed point).
    NotF32,
}

impl core::fmt::Display for PredictError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            PredictError::ScratchTooSmall { needed, capacity } => {
                write!(
                    f,
                    "model needs scratch width {needed}, predictor has {capacity}"
                )
            }
            PredictError::WrongPastLength { expected, got } => {
                write!(f, "expected {expected} observed steps, got {got}")
            }
            PredictError::BadSampleCount => {
                f.write_str("sample count is 0 or exceeds the output capacity")
            }
            PredictError::NonFiniteInput => f.write_str("non-finite input coordinate"),
            PredictError::NonFiniteOutput => f.write_str("model output is not finite"),
            PredictError::NoPredictor => f.write_str("model has no trajectory predictor"),
            PredictError::NoPointHead => f.write_str("model has no point-forecast head"),
            PredictError::NotF32 => {
                f.write_str("model is not an f32 model (use the fixed-point predictor)")
            }
        }
    }
}

impl core::error::Error for PredictError {}

/// Applies `act` with sine `S`.
#[inline]
fn activate<S: Sine>(act: Activation, v: f32) -> f32 {
    match act {
        Activation::Linear => v,
        // `v < 0` is false for NaN, so NaN propagates instead of turning into 0.
        Activation::Relu => {
            if v < 0.0 {
                0.0
            } else {
                v
            }
        }
        Activation::Sine => S::sin(v),
    }
}

/// `acc_j += Σ_{i} W[j][col0 + i] · x[i]`, left to right, for `j < out.len()`.
#[inline]
fn accumulate(layer: &Layer<'_>, col0: usize, x: &[f32], acc: &mut [f32]) {
    for (j, a) in acc.iter_mut().enumerate() {
        let row = layer.row_bytes(j);
        let cols = row.get(col0 * 4..).unwrap_or(&[]);
        let mut s = *a;
        for (w, &xi) in cols.chunks_exact(4).zip(x) {
            let w = match w {
                &[b0, b1, b2, b3] => f32::from_le_bytes([b0, b1, b2, b3]),
                _ => 0.0,
            };
            s += w * xi;
        }
        *a = s;
    }
}

/// One dense layer: `out_j = act(b_j + Σ_i W_ji x_i)`.
#[inline]
fn dense<S: Sine>(layer: &Layer<'_>, x: &[f32], out: &mut [f32]) {
    for (j, o) in out.iter_mut().enumerate() {
        *o = layer.bias(j);
    }
    accumulate(layer, 0, x, out);
    for o in out.iter_mut() {
        *o = activate::<S>(layer.activation(), *o);
    }
}

/// Runs `net` on `input` using `a`/`b` as ping-pong buffers; returns the
/// output slice (which lives in `a` or `b`).
fn run_network<'s, S: Sine>(
    net: &Network<'_>,
    input: &[f32],
    a: &'s mut [f32],
    b: &'s mut [f32],
) -> &'s [f32] {
    let n = input.len().min(a.len());
    a[..n].copy_from_slice(&input[..n]);
    let (mut src, mut dst) = (a, b);
    let mut width = n;
    for layer in net.layers() {
        let out = layer.out_dim().min(dst.len());
        dense::<S>(layer, &src[..width], &mut dst[..out]);
        core::mem::swap(&mut src, &mut dst);
        width = out;
    }
    &src[..width]
}

/// Predicts endpoints (and trajectories) with sine `S` and scratch width `W`.
pub struct Predictor<'m, 'a, S: Sine, const W: usize> {
    model: &'m Model<'a>,
    a: [f32; W],
    b: [f32; W],
    feat: [f32; W],
    part: [f32; W],
    z: [f32; W],
    frame: Frame,
    _sine: PhantomData<S>,
}

impl<'m, 'a, S: Sine, const W: usize> Predictor<'m, 'a, S, W> {
    /// A predictor for `model`; fails if it is not an f32 model or is wider than `W`.
    pub fn new(model: &'m Model<'a>) -> Result<Self, PredictError> {
        if model.numeric() != crate::blob::NumericKind::F32 {
            return Err(PredictError::NotF32);
        }
        let c = model.config();
        let needed = model.max_width().max(c.fdim as usize + c.zdim as usize);
        if needed > W {
            return Err(PredictError::ScratchTooSmall {
                needed,
                capacity: W,
            });
        }
        Ok(Self {
            model,
            a: [0.0; W],
            b: [0.0; W],
            feat: [0.0; W],
            part: [0.0; W],
            z: [0.0; W],
            frame: Frame::raw(),
            _sine: PhantomData,
        })
    }

    /// The model.
    pub fn model(&self) -> &'m Model<'a> {
        self.model
    }

    /// Step 1: checks `past`, sets the frame and writes the network input into `x`.
    fn input(
        &mut self,
        past: &[[f32; 2]],
        x: &mut [f32; 2 * crate::blob::MAX_PAST],
    ) -> Result<usize, PredictError> {
        let c = *self.model.config();
        self.frame = Frame::checked(past, self.model)?;
        for (t, pt) in past.iter().enumerate() {
            let v = self.frame.input(*pt, c.data_scale);
            x[2 * t] = v[0];
            x[2 * t + 1] = v[1];
        }
        Ok(2 * past.len())
    }

    /// Steps 1–3: normalise, encode, and sum the decoder's feature columns.
    fn encode(&mut self, past: &[[f32; 2]]) -> Result<(), PredictError> {
        let c = *self.model.config();
        let mut x = [0.0f32; 2 * crate::blob::MAX_PAST];
        let p = self.input(past, &mut x)?;
        let fdim = c.fdim as usize;
        let f = run_network::<S>(self.model.encoder_past(), &x[..p], &mut self.a, &mut self.b);
        self.feat[..fdim].copy_from_slice(&f[..fdim]);
        if let Some(l0) = self.model.decoder().layer(0) {
            let out = l0.out_dim();
            for (j, v) in self.part[..out].iter_mut().enumerate() {
                *v = l0.bias(j);
            }
            accumulate(l0, 0, &self.feat[..fdim], &mut self.part[..out]);
        }
        Ok(())
    }

    /// The model's deterministic point forecast (its point-forecast head): the
    /// whole future, `future_len` points, the last one the endpoint. Needs a
    /// model with a point head ([`Model::has_point_head`]).
    pub fn predict_point(&mut self, past: &[[f32; 2]]) -> Result<Trajectory, PredictError> {
        if !self.model.has_point_head() {
            return Err(PredictError::NoPointHead);
        }
        let c = *self.model.config();
        let mut x = [0.0f32; 2 * crate::blob::MAX_PAST];
        let p = self.input(past, &mut x)?;
        let q = run_network::<S>(self.model.point_head(), &x[..p], &mut self.a, &mut self.b);
        let pairs = q.chunks_exact(2).map(|p| [p[0], p[1]]);
        self.frame.points(pairs, c.data_scale)
    }

    /// Step 4 for one latent already in `self.z`: the normalised endpoint.
    fn decode(&mut self) -> [f32; 2] {
        let c = self.model.config();
        let (fdim, zdim) = (c.fdim as usize, c.zdim as usize);
        let dec = self.model.decoder();
        let Some(l0) = dec.layer(0) else {
            return [f32::NAN; 2];
        };
        let out0 = l0.out_dim();
        self.a[..out0].copy_from_slice(&self.part[..out0]);
        accumulate(l0, fdim, &self.z[..zdim], &mut self.a[..out0]);
        for v in self.a[..out0].iter_mut() {
            *v = activate::<S>(l0.activation(), *v);
        }
        let (mut src, mut dst) = (&mut self.a, &mut self.b);
        let mut width = out0;
        for layer in dec.layers().skip(1) {
            let out = layer.out_dim();
            dense::<S>(layer, &src[..width], &mut dst[..out]);
            core::mem::swap(&mut src, &mut dst);
            width = out;
        }
        [src[0], src[1]]
    }

    /// The model's endpoint set (see [`crate::sampling`]): `out.len()` endpoints,
    /// plain latent samples or, when the blob asks for test-time sampling,
    /// the k-means reduction of its `tts_samples` samples. `N` bounds the
    /// samples drawn (8 bytes of stack each); it must be at least
    /// [`crate::sampling::samples_needed`].
    pub fn predict_endpoint_set<const N: usize>(
        &mut self,
        past: &[[f32; 2]],
        seed: u64,
        out: &mut [[f32; 2]],
    ) -> Result<(), PredictError> {
        let ext = *self.model.extensions();
        crate::sampling::endpoint_set::<N>(&ext, out, |n, buf| {
            self.run::<N>(past, seed, n, |e, _| buf.push(e).is_ok())
        })
    }

    /// Predicts `k` endpoints (`k <= K`) for the observed `past`, drawing the
    /// latents from a sampler seeded with `seed`. Same inputs, same bits, on
    /// every target.
    pub fn predict_endpoints<const K: usize>(
        &mut self,
        past: &[[f32; 2]],
        seed: u64,
        k: usize,
    ) -> Result<heapless::Vec<[f32; 2], K>, PredictError> {
        let mut out = heapless::Vec::new();
        self.run::<K>(past, seed, k, |e, _| out.push(e).is_ok())?;
        Ok(out)
    }

    /// Predicts `k` full trajectories: each sample's endpoint and the
    /// intermediate points the predictor network conditions on it.
    pub fn predict_trajectories<const K: usize>(
        &mut self,
        past: &[[f32; 2]],
        seed: u64,
        k: usize,
    ) -> Result<heapless::Vec<Trajectory, K>, PredictError> {
        if !self.model.has_predictor() {
            return Err(PredictError::NoPredictor);
        }
        let mut out: heapless::Vec<Trajectory, K> = heapless::Vec::new();
        let mut err = None;
        let last = past.last().copied().unwrap_or([0.0; 2]);
        let mut pending = heapless::Vec::<([f32; 2], [f32; 2]), K>::new();
        self.run::<K>(past, seed, k, |e, d| pending.push((e, d)).is_ok())?;
        for (e, d) in pending {
            match self.trajectory(last, e, d) {
                Ok(t) => {
                    if out.push(t).is_err() {
                        err = Some(PredictError::BadSampleCount);
                    }
                }
                Err(e) => err = Some(e),
            }
        }
        match err {
            Some(e) => Err(e),
            None => Ok(out),
        }
    }

    fn run<const K: usize>(
        &mut self,
        past: &[[f32; 2]],
        seed: u64,
        k: usize,
        mut sink: impl FnMut([f32; 2], [f32; 2]) -> bool,
    ) -> Result<(), PredictError> {
        if k == 0 || k > K {
            return Err(PredictError::BadSampleCount);
        }
        self.encode(past)?;
        let c = *self.model.config();
        let zdim = c.zdim as usize;
        let mut g = Gaussian::new(seed);
        for _ in 0..k {
            for zi in self.z[..zdim].iter_mut() {
                *zi = c.sigma * g.next();
            }
            let d = self.decode();
            let e = self.frame.output(d, c.data_scale);
            if !(e[0].is_finite() && e[1].is_finite()) {
                return Err(PredictError::NonFiniteOutput);
            }
            if !sink(e, d) {
                return Err(PredictError::BadSampleCount);
            }
        }
        Ok(())
    }

    /// Step 6 for one normalised endpoint `d` (features already in `self.feat`).
    fn trajectory(
        &mut self,
        last: [f32; 2],
        e: [f32; 2],
        d: [f32; 2],
    ) -> Result<Trajectory, PredictError> {
        let c = *self.model.config();
        let fdim = c.fdim as usize;
        let g = run_network::<S>(self.model.encoder_dest(), &d, &mut self.a, &mut self.b);
        let ddim = g.len();
        // Predictor input [f, g, initial_pos] assembled in `z` (free by now).
        self.z[..fdim].copy_from_slice(&self.feat[..fdim]);
        self.z[fdim..fdim + ddim].copy_from_slice(g);
        let last = self.frame.predictor_position(last);
        self.z[fdim + ddim] = last[0] / c.initial_pos_divisor;
        self.z[fdim + ddim + 1] = last[1] / c.initial_pos_divisor;
        let n_in = fdim + ddim + 2;
        let q = run_network::<S>(
            self.model.predictor(),
            &self.z[..n_in],
            &mut self.a,
            &mut self.b,
        );
        let pairs = q.chunks_exact(2).map(|p| [p[0], p[1]]);
        let mut t = self.frame.points(pairs, c.data_scale)?;
        if t.push(e).is_err() {
            return Err(PredictError::NonFiniteOutput);
        }
        Ok(t)
    }
}
