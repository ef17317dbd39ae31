//! The one inference engine, generic over a numeric [`Backend`]: the f32
//! path ([`crate::float::Float`] with a [`crate::Sine`]) and the integer path
//! ([`crate::fixed::Q15`]) run the same steps in the same order; only the
//! dense layers and the conversions at the network boundaries differ.
//!
//! Most callers want [`crate::Predictor`], which picks the backend at run
//! time from the blob. `Engine<B, W>` is for callers that know the blob's kind
//! at compile time and want only that backend linked (a profiling build, a
//! flash-tight image).
//!
//! # The computation, in order
//!
//! For observed positions `p_0 .. p_{P-1}` (caller's units, P = `past_len`):
//!
//! 1. Guards and frame ([`crate::frame::Frame::inputs`]): the length, every
//!    coordinate finite and within ±[`crate::frame::MAX_COORDINATE`], then
//!    `x[2t + c] = (p_t[c] − p_0[c]) · data_scale` (two f32 roundings; rotated
//!    into the heading frame first when the model has one), each within
//!    ±[`crate::Model::input_limit`]. The backend converts `x` to its
//!    activations (f32: as is; Q15: quantised with `encoder_past`'s input
//!    exponent).
//! 2. `f = encoder_past(x)` (width `fdim`).
//! 3. The decoder's first layer sees `[f, z]`. Its feature part is summed once
//!    per call: `a_j = b_j + Σ_{i<fdim} W_ji f_i` ([`Backend::partial`]).
//! 4. For each sample: `z` = the next `zdim` normals of
//!    [`crate::prng::Gaussian`] seeded with `seed`, each times `sigma` (f32),
//!    converted with the decoder's input exponent — or, for a model with a
//!    learned proposal (format version 5), latent `i` of the proposal:
//!    sample `i` runs its hidden layers on `f` and rows `i·zdim ..` of its
//!    last layer, clamps each value to `±latent_bound` in f32 and converts it
//!    likewise (`weights/FORMAT.md`, "Format version 5"); the first layer continues
//!    the same sum over the latent columns ([`Backend::latent`]: equal to one
//!    sequential pass over `[f, z]`), then the remaining decoder layers give
//!    `d` (the normalised endpoint).
//! 5. Endpoint: `d` converted to f32 with the decoder's output exponent, then
//!    `e[c] = d[c] / data_scale + p_0[c]` (rotated back first in the heading
//!    frame). The K endpoints a model reports follow its protocol
//!    ([`crate::sampling`]): plain samples, or test-time sampling reduced by
//!    k-means.
//! 6. Optionally, the intermediate points of the last sample: `g =
//!    encoder_dest(d)`, `q = predictor([f, g, last / initial_pos_divisor])`
//!    (`last` = the last observed point, rotated in the heading frame;
//!    converted with `encoder_past`'s output exponent), point `t` = `q[2t..]`
//!    mapped like an endpoint, and the last point is `e`.
//!
//! The point forecast runs the point-forecast head on `x` (step 1) and maps
//! each output pair like an endpoint.
//!
//! # Memory
//!
//! `Engine<B, W>` holds four activation rows and one partial-sum row of `W`
//! (f32: `20·W` bytes; Q15: `16·W` bytes), the model view (about 1.8 KiB on
//! a 32-bit target: six networks of up to eight layer descriptors) and the
//! sampler state. Weights are read in place. A call
//! uses under 1 KiB of stack besides what the caller passes; the endpoint set
//! of a test-time-sampling model adds its `N`-sample buffer (`8·N` bytes).
//! `cargo xtask profile` measures both on the Cortex-M4F.

use crate::backend::{in_exp, out_exp};
use crate::blob::{Layer, Model, Network, MAX_PAST};
use crate::frame::Frame;
use crate::output::{PredictError, Trajectory};
use crate::prng::Gaussian;
use crate::{BlobError, Error};

mod planner_steps;

// The numeric backend the engine is generic over, defined in `backend`
// (below the engine, so that the backends need not import it) and named here
// too, where it has always been.
pub use crate::backend::Backend;

/// Runs `net` on `input` using `a`/`b` as ping-pong buffers; returns the
/// output slice (which lives in `a` or `b`).
fn run_network<'s, B: Backend>(
    net: &Network<'_>,
    input: &[B::Act],
    a: &'s mut [B::Act],
    b: &'s mut [B::Act],
) -> &'s [B::Act] {
    run_network_layers::<B>(net.layers(), input, a, b)
}

/// [`run_network`] over some of a network's layers.
fn run_network_layers<'s, 'l, 'a: 'l, B: Backend>(
    net: impl Iterator<Item = &'l Layer<'a>>,
    input: &[B::Act],
    a: &'s mut [B::Act],
    b: &'s mut [B::Act],
) -> &'s [B::Act] {
    let n = input.len().min(a.len());
    if let (Some(dst), Some(src)) = (a.get_mut(..n), input.get(..n)) {
        dst.copy_from_slice(src);
    }
    layers::<B>(net, a, b, n)
}

/// The proposal's hidden layers (all but the last) on the features `feat`: the input of
/// both its latent rows and its logit rows.
fn proposal_hidden<'s, B: Backend>(
    model: &Model<'_>,
    feat: &[B::Act],
    a: &'s mut [B::Act],
    b: &'s mut [B::Act],
) -> &'s [B::Act] {
    let prop = model.proposal();
    let hidden = prop.len().saturating_sub(1);
    run_network_layers::<B>(prop.layers().take(hidden), feat, a, b)
}

/// Runs `layers` on the first `width` values of `a`; returns the output.
fn layers<'s, 'l, 'a: 'l, B: Backend>(
    layers: impl Iterator<Item = &'l Layer<'a>>,
    a: &'s mut [B::Act],
    b: &'s mut [B::Act],
    width: usize,
) -> &'s [B::Act] {
    let (mut src, mut dst) = (a, b);
    let mut width = width.min(src.len());
    for layer in layers {
        let out = layer.out_dim().min(dst.len());
        B::dense(layer, &src[..width], &mut dst[..out]);
        core::mem::swap(&mut src, &mut dst);
        width = out;
    }
    &src[..width]
}

/// Where a sample stream stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stream {
    /// No stream started (or the last start failed).
    Idle,
    /// Encoded; no sample drawn yet.
    Started,
    /// At least one sample drawn; its `d` is kept for its trajectory.
    Drawn,
}

/// A scratch row, 4-byte aligned (as `[T; W]` otherwise), so that the
/// Cortex-M4/M7 kernels can load two i16 activations per word, four per
/// `LDRD` (`crate::kernels`). Field `.0` is the row.
#[repr(C, align(4))]
struct Row<T, const W: usize>([T; W]);

/// The engine over backend `B` with scratch width `W` (see the module docs).
pub struct Engine<'a, B: Backend, const W: usize> {
    model: Model<'a>,
    a: Row<B::Act, W>,
    b: Row<B::Act, W>,
    feat: Row<B::Act, W>,
    z: Row<B::Act, W>,
    /// Samples drawn since [`Engine::start`].
    drawn: usize,
    part: [B::Acc; W],
    frame: Frame,
    last: [f32; 2],
    gauss: Gaussian,
    d: [B::Act; 2],
    stream: Stream,
}

impl<'a, B: Backend, const W: usize> Engine<'a, B, W> {
    /// An engine for `model`. Fails with [`BlobError::UnsupportedNumeric`]
    /// when the blob is not of kind `B::KIND` and with
    /// [`PredictError::ScratchTooSmall`] when
    /// [`Model::scratch_width`] exceeds `W`.
    pub fn new(model: Model<'a>) -> Result<Self, Error> {
        if model.numeric() != B::KIND {
            return Err(Error::Blob(BlobError::UnsupportedNumeric));
        }
        let needed = model.scratch_width();
        if needed > W {
            return Err(Error::Predict(PredictError::ScratchTooSmall {
                needed,
                capacity: W,
            }));
        }
        Ok(Self {
            model,
            a: Row([B::Act::default(); W]),
            b: Row([B::Act::default(); W]),
            feat: Row([B::Act::default(); W]),
            z: Row([B::Act::default(); W]),
            drawn: 0,
            part: [B::Acc::default(); W],
            frame: Frame::raw(),
            last: [0.0; 2],
            gauss: Gaussian::new(0),
            d: [B::Act::default(); 2],
            stream: Stream::Idle,
        })
    }

    /// The model.
    pub fn model(&self) -> &Model<'a> {
        &self.model
    }

    /// Step 1: guards, frame, and the network input in `x`; returns its length.
    fn input(
        &self,
        past: &[[f32; 2]],
        x: &mut [B::Act; 2 * MAX_PAST],
    ) -> Result<(Frame, usize), PredictError> {
        let (frame, pts) = Frame::inputs(past, &self.model)?;
        let e = in_exp(self.model.encoder_past());
        for (dst, v) in x.chunks_exact_mut(2).zip(pts.iter().take(past.len())) {
            if let [d0, d1] = dst {
                *d0 = B::from_f32(v[0], e);
                *d1 = B::from_f32(v[1], e);
            }
        }
        Ok((frame, 2 * past.len()))
    }

    /// Network output pairs with exponent `exp` as caller points.
    fn points(
        frame: &Frame,
        q: &[B::Act],
        exp: i8,
        scale: f32,
    ) -> Result<Trajectory, PredictError> {
        let pairs = q
            .chunks_exact(2)
            .map(|p| [B::to_f32(p[0], exp), B::to_f32(p[1], exp)]);
        frame.points(pairs, scale)
    }

    /// The model's deterministic point forecast (its point-forecast head): the
    /// whole future, `future_len` points, the last one the endpoint. Needs a
    /// model with a point head ([`Model::has_point_head`]). Does not disturb
    /// a sample stream in progress.
    pub fn predict_point(&mut self, past: &[[f32; 2]]) -> Result<Trajectory, PredictError> {
        if !self.model.has_point_head() {
            return Err(PredictError::NoPointHead);
        }
        let mut x = [B::Act::default(); 2 * MAX_PAST];
        let (frame, n) = self.input(past, &mut x)?;
        let head = self.model.point_head();
        let q = run_network::<B>(head, &x[..n], &mut self.a.0, &mut self.b.0);
        Self::points(&frame, q, out_exp(head), self.model.config().data_scale)
    }

    /// Starts a sample stream for `past` with sampler seed `seed` (steps 1–3):
    /// afterwards each [`Engine::next_endpoint`] draws one sample, so a
    /// cooperative task can yield between samples. Same inputs, same bits, on
    /// every target.
    pub fn start(&mut self, past: &[[f32; 2]], seed: u64) -> Result<(), PredictError> {
        self.stream = Stream::Idle;
        let c = *self.model.config();
        let mut x = [B::Act::default(); 2 * MAX_PAST];
        let (frame, n) = self.input(past, &mut x)?;
        let fdim = c.fdim as usize;
        let f = run_network::<B>(
            self.model.encoder_past(),
            &x[..n],
            &mut self.a.0,
            &mut self.b.0,
        );
        let fdim = fdim.min(f.len());
        self.feat.0[..fdim].copy_from_slice(&f[..fdim]);
        if let Some(l0) = self.model.decoder().layer(0) {
            B::partial(l0, &self.feat.0[..fdim], &mut self.part);
        }
        self.drawn = 0;
        self.frame = frame;
        self.last = past.last().copied().unwrap_or([0.0; 2]);
        self.gauss = Gaussian::new(seed);
        self.stream = Stream::Started;
        Ok(())
    }

    /// Step 4–5 for the next sample of the stream: its endpoint in the
    /// caller's units. Fails with [`PredictError::NotStarted`] before a
    /// successful [`Engine::start`].
    pub fn next_endpoint(&mut self) -> Result<[f32; 2], PredictError> {
        if self.stream == Stream::Idle {
            return Err(PredictError::NotStarted);
        }
        // Field borrows only (no copy of the model's network tables per sample).
        let c = self.model.config();
        let (fdim, zdim, sigma, scale) = (
            c.fdim as usize,
            (c.zdim as usize).min(W),
            c.sigma,
            c.data_scale,
        );
        let ez = in_exp(self.model.decoder());
        if self.model.has_proposal() {
            self.proposed_latent(zdim, ez)?;
        } else {
            // Two draws at a time (the same stream order as one `next()` per
            // element), an odd last element alone.
            let mut pairs = self.z.0[..zdim].chunks_exact_mut(2);
            for p in &mut pairs {
                let g = self.gauss.next_pair();
                for (zi, &gi) in p.iter_mut().zip(&g) {
                    *zi = B::from_f32(sigma * gi, ez);
                }
            }
            for zi in pairs.into_remainder() {
                *zi = B::from_f32(sigma * self.gauss.next_alone(), ez);
            }
        }
        self.drawn = self.drawn.saturating_add(1);
        let dec = self.model.decoder();
        let Some(l0) = dec.layer(0) else {
            return Err(PredictError::NonFiniteOutput);
        };
        let out0 = l0.out_dim().min(W);
        B::latent(
            l0,
            fdim,
            &self.z.0[..zdim],
            &self.part[..out0],
            &mut self.a.0[..out0],
        );
        let d = layers::<B>(dec.layers().skip(1), &mut self.a.0, &mut self.b.0, out0);
        let (Some(&d0), Some(&d1)) = (d.first(), d.get(1)) else {
            return Err(PredictError::NonFiniteOutput);
        };
        let eo = out_exp(dec);
        self.d = [d0, d1];
        self.stream = Stream::Drawn;
        let e = self
            .frame
            .output([B::to_f32(d0, eo), B::to_f32(d1, eo)], scale);
        crate::frame::check_output(e)
    }

    /// Step 4 of a proposal model: latent `i` (the `i`-th sample since
    /// [`Engine::start`]) into `z`: the proposal's hidden layers on the
    /// features (recomputed per sample: their MACs, 128 for an 8-wide
    /// hidden layer, against a scratch row the Cortex-M0 has no RAM for), rows `i·zdim ..` of its
    /// last layer on them, each value as f32 (its output exponent), clamped
    /// to `±latent_bound` (NaN stays NaN), converted with the decoder's input
    /// exponent `ez`. [`PredictError::BadSampleCount`] past the model's
    /// [`Model::proposal_latents`].
    fn proposed_latent(&mut self, zdim: usize, ez: i8) -> Result<(), PredictError> {
        // The stream has K latents; the rows after them (a format-6 model's
        // logits) are not latents and must never be decoded as one.
        if self.drawn >= self.model.proposal_latents() {
            return Err(PredictError::BadSampleCount);
        }
        let first = self
            .drawn
            .checked_mul(zdim)
            .ok_or(PredictError::BadSampleCount)?;
        let eo = self.proposal_rows(first, zdim)?;
        let bound = self.model.latent_bound();
        for zi in self.z.0[..zdim].iter_mut() {
            let v = B::to_f32(*zi, eo);
            let v = if v > bound {
                bound
            } else if v < -bound {
                -bound
            } else {
                v
            };
            *zi = B::from_f32(v, ez);
        }
        Ok(())
    }

    /// Rows `first .. first + n` of the proposal's last layer on its hidden
    /// activations (the features through its other layers) into `z[..n]`;
    /// returns the layer's output exponent. The one path of both the latent
    /// rows and the logit rows (out of line: one copy in flash).
    /// [`PredictError::BadSampleCount`] when the rows do not exist or `n`
    /// exceeds `W`.
    #[inline(never)]
    fn proposal_rows(&mut self, first: usize, n: usize) -> Result<i8, PredictError> {
        let rows = self
            .model
            .proposal()
            .layers()
            .last()
            .filter(|_| n <= W)
            .and_then(|l| l.rows(first, n))
            .ok_or(PredictError::BadSampleCount)?;
        let fdim = (self.model.config().fdim as usize).min(W);
        let h = proposal_hidden::<B>(
            &self.model,
            &self.feat.0[..fdim],
            &mut self.a.0,
            &mut self.b.0,
        );
        B::dense(&rows, h, &mut self.z.0[..n]);
        Ok(rows.out_exp())
    }

    /// The probabilities of the first `out.len()` endpoints of the stream
    /// begun by [`Engine::start`] (any time after it): for a model with
    /// probabilities ([`Model::has_probabilities`]) the proposal's hidden
    /// layers on the features, its `k` logit rows after the `K·zdim` latent
    /// rows, each as f32 (its output exponent), then
    /// [`crate::planner::softmax`]; `Ok(true)`. For any other model `1/k`
    /// each and `Ok(false)`. [`PredictError::NotStarted`] before a start,
    /// [`PredictError::BadSampleCount`] for `k` = 0 or above K.
    #[inline(never)]
    pub fn probabilities(&mut self, out: &mut [f32]) -> Result<bool, PredictError> {
        if self.stream == Stream::Idle {
            return Err(PredictError::NotStarted);
        }
        if out.is_empty() {
            return Err(PredictError::BadSampleCount);
        }
        if !self.model.has_probabilities() {
            crate::planner::uniform(out);
            return Ok(false);
        }
        let k = out.len();
        let latents = self.model.proposal_latents();
        if k > latents {
            return Err(PredictError::BadSampleCount);
        }
        let first = latents.saturating_mul(self.model.config().zdim as usize);
        let eo = self.proposal_rows(first, k)?;
        for (o, &l) in out.iter_mut().zip(&self.z.0[..k]) {
            *o = B::to_f32(l, eo);
        }
        crate::planner::softmax(out)?;
        Ok(true)
    }

    /// Step 6 for the sample [`Engine::next_endpoint`] drew last: its full
    /// trajectory (`future_len` points; the last is that sample's endpoint).
    /// Needs a model with a trajectory predictor ([`Model::has_predictor`]).
    pub fn last_trajectory(&mut self) -> Result<Trajectory, PredictError> {
        if !self.model.has_predictor() {
            return Err(PredictError::NoPredictor);
        }
        if self.stream != Stream::Drawn {
            return Err(PredictError::NotStarted);
        }
        let c = *self.model.config();
        let fdim = c.fdim as usize;
        let (dest, pred) = (self.model.encoder_dest(), self.model.predictor());
        let eo = out_exp(self.model.decoder());
        let e = self.frame.output(
            [B::to_f32(self.d[0], eo), B::to_f32(self.d[1], eo)],
            c.data_scale,
        );
        let g = run_network::<B>(dest, &self.d, &mut self.a.0, &mut self.b.0);
        let ddim = g.len();
        let n_in = fdim + ddim + 2;
        if n_in > W {
            return Err(PredictError::CapacityExceeded);
        }
        // Predictor input [f, g, initial_pos] assembled in `z` (redrawn per sample).
        self.z.0[..fdim].copy_from_slice(&self.feat.0[..fdim]);
        self.z.0[fdim..fdim + ddim].copy_from_slice(g);
        let last = self.frame.predictor_position(self.last);
        let ef = out_exp(self.model.encoder_past());
        self.z.0[fdim + ddim] = B::from_f32(last[0] / c.initial_pos_divisor, ef);
        self.z.0[fdim + ddim + 1] = B::from_f32(last[1] / c.initial_pos_divisor, ef);
        let q = run_network::<B>(pred, &self.z.0[..n_in], &mut self.a.0, &mut self.b.0);
        let mut t = Self::points(&self.frame, q, out_exp(pred), c.data_scale)?;
        let e = crate::frame::check_output(e)?;
        t.push(e).map_err(|_| PredictError::CapacityExceeded)?;
        Ok(t)
    }

    /// Starts the stream of `seed` for `past` and fills `out` in order, one
    /// `draw` per element (each draws the next sample);
    /// [`PredictError::BadSampleCount`] for an empty `out`.
    fn each_sample<T>(
        &mut self,
        past: &[[f32; 2]],
        seed: u64,
        out: &mut [T],
        mut draw: impl FnMut(&mut Self) -> Result<T, PredictError>,
    ) -> Result<(), PredictError> {
        if out.is_empty() {
            return Err(PredictError::BadSampleCount);
        }
        self.start(past, seed)?;
        for o in out.iter_mut() {
            *o = draw(self)?;
        }
        Ok(())
    }

    /// `out.len()` plain latent samples: the first `out.len()` endpoints of the
    /// stream seeded with `seed`, whatever the blob's protocol (the building
    /// block of [`Engine::predict_endpoint_set`]).
    pub fn predict_samples(
        &mut self,
        past: &[[f32; 2]],
        seed: u64,
        out: &mut [[f32; 2]],
    ) -> Result<(), PredictError> {
        self.each_sample(past, seed, out, Self::next_endpoint)
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
        let most = crate::sampling::stream_bound(&self.model);
        crate::sampling::endpoint_set::<N>(&ext, most, out, |n, buf| {
            self.start(past, seed)?;
            for _ in 0..n {
                let e = self.next_endpoint()?;
                buf.push(e).map_err(|_| PredictError::CapacityExceeded)?;
            }
            Ok(())
        })
    }

    /// `out.len()` full trajectories of plain latent samples (sample `i`'s
    /// endpoint is the last point of `out[i]`, and equals
    /// [`Engine::predict_samples`]' `i`-th endpoint).
    pub fn predict_trajectories(
        &mut self,
        past: &[[f32; 2]],
        seed: u64,
        out: &mut [Trajectory],
    ) -> Result<(), PredictError> {
        if !self.model.has_predictor() {
            return Err(PredictError::NoPredictor);
        }
        self.each_sample(past, seed, out, |e| {
            e.next_endpoint()?;
            e.last_trajectory()
        })
    }
}
