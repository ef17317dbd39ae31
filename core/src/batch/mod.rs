//! The batched path: `L` latent samples — of one track or of several —
//! computed side by side ("lanes"), each keeping exactly its own order of
//! operations, so the results are the same bits as [`crate::Predictor`]'s
//! and each weight is read once per `L` samples instead of once per sample.
//!
//! The scalar path ([`crate::engine`]) adds products one after the other in
//! one f32 register, so it waits for every add (about 1 GMAC/s on a
//! 2020s x86 core). Here the innermost loop runs over lanes
//! ([`crate::engine::Backend::dense_lanes`]): for each output row `j`, for
//! each input `i`, for each lane `l`, `acc[l] = acc[l] + W[j][i] · x[l][i]`
//! (separate multiply and add), so LLVM turns the lanes into SIMD vectors,
//! four rows at a time give independent sums, and no lane's summation
//! order changes. It is meant for hosts (evaluation, tests, companion
//! computers); the firmware keeps the scalar engine (whether an MCU should
//! use lanes is for the kernel work to measure), and the scalar engine stays
//! the reference: `tests/tests/batch_vs_scalar.rs` checks every shipped blob
//! on the SDD test set, bit for bit.
//!
//! # What is computed, in order
//!
//! A call takes one track (`past`, `seed`) or a slice of [`Query`]s and
//! `k` samples per track; it works through its tracks `L` at a time (a
//! *group*; lane `l` of the group = track `l`):
//!
//! 1. Guards and frame of each track of the group, exactly as
//!    [`crate::Engine::start`] ([`crate::frame::Frame::inputs`]); then
//!    `f = encoder_past(x)` for the `L` tracks side by side (unused lanes
//!    compute on zeros and are ignored).
//! 2. The group's `n·k` samples (track-major: track 0's samples `0..k`, then
//!    track 1's, …) go through the decoder `L` at a time (a *chunk*). Lane
//!    `l` of chunk `c` is sample `s` of track `t` with `c·L + l = t·k + s`;
//!    its latent is the next `zdim` normals of track `t`'s own sampler
//!    ([`crate::prng::Gaussian`] seeded with its seed, times `sigma`), so
//!    sample `s` sees the same normals as in the scalar stream. A model with
//!    a learned proposal (format version 5) computes instead, once per
//!    group, the proposal's hidden layers `h` on the group's features and
//!    the latent rows `0 .. k·zdim` of its last layer on `h`, in lanes (lane
//!    = track; when the rows do not fit `W`, each lane's `zdim` rows on their
//!    own); lane `l`'s latent is rows `s·zdim ..` of its track, each value
//!    clamped to `±latent_bound` as in [`crate::Engine::next_endpoint`]
//!    (the scalar engine recomputes `h` per sample for the Cortex-M0's RAM;
//!    its rows are the same numbers, each row's sum in the same order). The
//!    decoder's first layer runs over `[f, z]` in one left-to-right pass,
//!    which is what the scalar engine's split sum
//!    ([`crate::engine::Backend::partial`] then
//!    [`crate::engine::Backend::latent`]) equals by construction.
//! 3. Endpoints and, when asked, trajectories (`encoder_dest`, then the
//!    predictor on `[f, g, last / initial_pos_divisor]`) per lane, mapped
//!    to caller coordinates with that track's frame, exactly as
//!    [`crate::Engine::next_endpoint`] and
//!    [`crate::Engine::last_trajectory`].
//!
//! Results come out in track-major order, so a test-time-sampling model
//! collects one track's `N` samples at a time and reduces them
//! ([`crate::sampling`]) as the scalar path does.
//!
//! # Memory
//!
//! [`Batch`]`<B, W, L>` holds five `W × L` activation matrices (f32:
//! `20·W·L` bytes, 160 KiB for `W = 1024, L = 8`; Q15: `10·W·L` bytes; the
//! last two hold a proposal model's latent rows and hidden layer per track)
//! and a scalar row, `L`
//! frames, last points and samplers (about 40 bytes each), the model view
//! and a scalar [`crate::Engine`] (`20·W` bytes; one track's calls of at
//! most `L / 4` samples run on it, where lanes would compute mostly
//! padding). Too big for a small MCU's stack: on a host, box it
//! (`Box::new(BatchPredictor::new(model)?)`). It never allocates; the
//! per-window samples of a test-time-sampling model go to an `N`-sample
//! buffer on the stack (`8·N` bytes), as in the scalar path.
//!
//! # Files
//!
//! This file holds the types and the calls ([`Batch`], [`BatchPredictor`],
//! [`Query`]); `steps.rs` the steps above for groups of tracks and chunks
//! of lanes (the private methods of [`Batch`]).

mod steps;

use crate::backend::{out_exp, Backend};
use crate::blob::{Model, NumericKind};
use crate::engine::Engine;
use crate::fixed::Q15;
use crate::float::Float;
use crate::frame::Frame;
use crate::output::{PredictError, Trajectory};
use crate::planner::PlannerOutput;
use crate::predictor::{on_kind, ByKind};
use crate::prng::Gaussian;
use crate::sine::Sine;
use crate::Error;

/// Lanes the host uses ([`HostBatchPredictor`]): 8 f32 lanes are two SSE
/// vectors, and 4 rows × 8 lanes of sums fill x86-64's 16 vector registers;
/// with AVX2 ([`set_wide_vectors`]) one `ymm` register, 8 rows at a time.
pub const HOST_LANES: usize = 8;

/// Whether the f32 batched path may use AVX2 on an x86-64 CPU that has it
/// (checked once with CPUID), process-wide; the default is `true`. The
/// results are the same bits either way (each lane's operations keep their
/// order; no fused multiply-add, see `docs/host-speed.md`), so this only
/// changes the speed: tests and benchmarks turn it off to compare both
/// paths. No effect on other targets.
///
/// ```
/// gpecnet_core::batch::set_wide_vectors(false); // SSE2 only from here on
/// gpecnet_core::batch::set_wide_vectors(true);
/// ```
pub fn set_wide_vectors(enabled: bool) {
    #[cfg(target_arch = "x86_64")]
    crate::kernels::x86::set_wide_vectors(enabled);
    #[cfg(not(target_arch = "x86_64"))]
    let _ = enabled;
}

/// One track of a batched call: its observed past (`past_len` points, the
/// caller's units) and its sampler seed (as `seed` of
/// [`crate::Predictor::predict_samples`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Query<'p> {
    /// The observed positions, oldest first.
    pub past: &'p [[f32; 2]],
    /// Latent sampler seed of this track.
    pub seed: u64,
}

/// Which track of a batched call failed, and why (the error the scalar
/// path gives for that track).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct QueryError {
    /// Index of the track in the call's slice (0 for a one-track call).
    pub index: usize,
    /// The error.
    pub error: PredictError,
}

impl QueryError {
    /// An error of the call as a whole (bad counts or lengths, a network the
    /// model lacks), reported at index 0.
    fn of_call(error: PredictError) -> Self {
        Self { index: 0, error }
    }
}

impl core::fmt::Display for QueryError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "track {}: {}", self.index, self.error)
    }
}

impl core::error::Error for QueryError {}

/// `W` rows of `L` lanes: row `i` holds activation `i` of every lane.
type Lanes<T, const L: usize, const W: usize> = [[T; L]; W];

/// What one lane of a chunk produced: the endpoint, and the trajectory
/// when one was asked for.
struct LaneOut<'t> {
    endpoint: [f32; 2],
    trajectory: Option<&'t Trajectory>,
}

/// The one-track calls of [`Batch`]: [`Batch::one_track`] with the scalar
/// engine's call of the same name and the many-track call `$many` on
/// `$n` samples, as `#[many($many, $n)]` names them. Each written as its
/// documented signature (which `tests/public_api.rs` reads from the
/// invocation), the body generated; `self` is the invocation's, so that
/// `$n` can read the model.
macro_rules! one_track_calls {
    ($(
        #[many($many:ident, $n:expr)]
        $(#[$doc:meta])*
        pub fn $name:ident $(<const $c:ident: usize>)?
            (&mut $this:ident, $past:ident: $pt:ty, $seed:ident: $st:ty, $out:ident: $ot:ty $(,)?)
            -> $ret:ty;
    )*) => {
        $(
            $(#[$doc])*
            pub fn $name $(<const $c: usize>)? (&mut $this, $past: $pt, $seed: $st, $out: $ot) -> $ret {
                $this.one_track(
                    $n,
                    Query { past: $past, seed: $seed },
                    $out,
                    Engine::$name $(::<$c>)?,
                    Self::$many $(::<$c>)?,
                )
            }
        )*
    };
}

/// The batched engine over backend `B`, scratch width `W` and `L` lanes
/// (see the module docs). Bit-identical to [`crate::Engine`]`<B, W>`.
pub struct Batch<'a, B: Backend, const W: usize, const L: usize> {
    model: Model<'a>,
    a: Lanes<B::Act, L, W>,
    b: Lanes<B::Act, L, W>,
    /// Rows `0..fdim`: the features of the group's tracks (lane = track).
    feat: Lanes<B::Act, L, W>,
    frames: [Frame; L],
    lasts: [[f32; 2]; L],
    gauss: [Gaussian; L],
    /// A proposal model's latent rows for the group's tracks (lane = track):
    /// row `s·zdim + i` is component `i` of sample `s`, as the last layer
    /// gives it (before the clamp), when `K·zdim` rows fit `W`
    /// ([`Batch::latent_rows`]).
    latents: Lanes<B::Act, L, W>,
    /// Whether [`Batch::latents`] holds the group's latents (`false`: each
    /// lane's rows are computed on their own, from [`Batch::hidden`]).
    latents_ready: bool,
    /// A proposal model's hidden activations per track of the group (row
    /// `t` = track `t`'s `h`, its first `hidden_dim` values), for latents
    /// that do not fit [`Batch::latents`].
    hidden: [[B::Act; W]; L],
    /// The width of [`Batch::hidden`]'s rows.
    hidden_dim: usize,
    /// A scalar row: a latent's `zdim` rows when computed lane by lane.
    row_a: [B::Act; W],
    /// The scalar engine, for one track's calls of at most `L / 4` samples
    /// (where lanes would mostly compute on padding).
    scalar: Engine<'a, B, W>,
}

impl<'a, B: Backend, const W: usize, const L: usize> Batch<'a, B, W, L> {
    /// A batched engine for `model`; fails as [`crate::Engine::new`] does
    /// (wrong numeric kind, [`Model::scratch_width`] over `W`). `L = 0` is
    /// refused with [`PredictError::CapacityExceeded`].
    pub fn new(model: Model<'a>) -> Result<Self, Error> {
        if model.numeric() != B::KIND {
            return Err(Error::Blob(crate::BlobError::UnsupportedNumeric));
        }
        let needed = model.scratch_width();
        if needed > W {
            return Err(Error::Predict(PredictError::ScratchTooSmall {
                needed,
                capacity: W,
            }));
        }
        if L == 0 {
            return Err(Error::Predict(PredictError::CapacityExceeded));
        }
        Ok(Self {
            model,
            a: [[B::Act::default(); L]; W],
            b: [[B::Act::default(); L]; W],
            feat: [[B::Act::default(); L]; W],
            frames: [Frame::raw(); L],
            lasts: [[0.0; 2]; L],
            gauss: core::array::from_fn(|_| Gaussian::new(0)),
            latents: [[B::Act::default(); L]; W],
            latents_ready: false,
            hidden: [[B::Act::default(); W]; L],
            hidden_dim: 0,
            row_a: [B::Act::default(); W],
            scalar: Engine::new(model)?,
        })
    }

    /// The model.
    pub fn model(&self) -> &Model<'a> {
        &self.model
    }

    /// A one-track call that draws `n` samples and fills `out`: `scalar` on
    /// the scalar engine when `n` is [`few`], else `many` on the one
    /// `query` with `k = out.len()` (its error without the index); the same
    /// bits either way.
    fn one_track<T>(
        &mut self,
        n: usize,
        query: Query<'_>,
        out: &mut [T],
        scalar: impl FnOnce(
            &mut Engine<'a, B, W>,
            &[[f32; 2]],
            u64,
            &mut [T],
        ) -> Result<(), PredictError>,
        many: impl FnOnce(&mut Self, &[Query<'_>], usize, &mut [T]) -> Result<(), QueryError>,
    ) -> Result<(), PredictError> {
        if few::<L>(n) {
            return scalar(&mut self.scalar, query.past, query.seed, out);
        }
        let k = out.len();
        many(self, &[query], k, out).map_err(|e| e.error)
    }

    one_track_calls! {
        #[many(predict_samples_many, out.len())]
        /// `out.len()` plain latent samples of one track: exactly
        /// [`crate::Engine::predict_samples`]' bits.
        pub fn predict_samples(&mut self, past: &[[f32; 2]], seed: u64, out: &mut [[f32; 2]]) -> Result<(), PredictError>;

        #[many(predict_trajectories_many, out.len())]
        /// `out.len()` full trajectories of plain latent samples of one track:
        /// exactly [`crate::Engine::predict_trajectories`]' bits.
        pub fn predict_trajectories(&mut self, past: &[[f32; 2]], seed: u64, out: &mut [Trajectory]) -> Result<(), PredictError>;

        #[many(predict_endpoint_sets, crate::sampling::samples_needed(self.model.extensions(), out.len()))]
        /// The model's endpoint set of one track: exactly
        /// [`crate::Engine::predict_endpoint_set`]' bits (`N` as there).
        pub fn predict_endpoint_set<const N: usize>(&mut self, past: &[[f32; 2]], seed: u64, out: &mut [[f32; 2]]) -> Result<(), PredictError>;
    }

    /// `k` plain latent samples of each of `queries`: `out[t·k + s]` is
    /// sample `s` of track `t` (`out.len() = queries.len()·k`), equal to
    /// [`crate::Engine::predict_samples`] on that track alone.
    pub fn predict_samples_many(
        &mut self,
        queries: &[Query<'_>],
        k: usize,
        out: &mut [[f32; 2]],
    ) -> Result<(), QueryError> {
        check_len(queries.len(), k, out.len())?;
        self.run(queries, k, false, |t, s, o| {
            let slot = out
                .get_mut(t * k + s)
                .ok_or(PredictError::CapacityExceeded)?;
            *slot = o.endpoint;
            Ok(())
        })
    }

    /// `k` trajectories of each of `queries`: `out[t·k + s]` is sample `s`
    /// of track `t`, equal to [`crate::Engine::predict_trajectories`] on
    /// that track alone. Needs [`Model::has_predictor`].
    pub fn predict_trajectories_many(
        &mut self,
        queries: &[Query<'_>],
        k: usize,
        out: &mut [Trajectory],
    ) -> Result<(), QueryError> {
        if !self.model.has_predictor() {
            return Err(QueryError::of_call(PredictError::NoPredictor));
        }
        check_len(queries.len(), k, out.len())?;
        self.run(queries, k, true, |t, s, o| {
            let slot = out
                .get_mut(t * k + s)
                .ok_or(PredictError::CapacityExceeded)?;
            *slot = o.trajectory.cloned().unwrap_or_default();
            Ok(())
        })
    }

    /// The model's endpoint set, `k` endpoints, of each of `queries`:
    /// `out[t·k..(t + 1)·k]` for track `t`, equal to
    /// [`crate::Engine::predict_endpoint_set`] on that track alone (plain
    /// samples, or the k-means reduction of its `tts_samples` samples, one
    /// track at a time in an `N`-sample buffer).
    pub fn predict_endpoint_sets<const N: usize>(
        &mut self,
        queries: &[Query<'_>],
        k: usize,
        out: &mut [[f32; 2]],
    ) -> Result<(), QueryError> {
        let ext = *self.model.extensions();
        let n = crate::sampling::samples_needed(&ext, k);
        check_len(queries.len(), k, out.len())?;
        if k == 0 || k > n || k > crate::sampling::stream_bound(&self.model) {
            return Err(QueryError::of_call(PredictError::BadSampleCount));
        }
        if n > N {
            return Err(QueryError::of_call(PredictError::CapacityExceeded));
        }
        let mut buf = heapless::Vec::<[f32; 2], N>::new();
        self.run(queries, n, false, |t, s, o| {
            buf.push(o.endpoint)
                .map_err(|_| PredictError::CapacityExceeded)?;
            if s + 1 == n {
                let dst = out
                    .get_mut(t * k..(t + 1) * k)
                    .ok_or(PredictError::CapacityExceeded)?;
                crate::sampling::reduce(&ext, &buf, dst)?;
                buf.clear();
            }
            Ok(())
        })
    }

    /// The point forecast of each of `queries` (seeds unused): `out[t]`
    /// equals [`crate::Engine::predict_point`] on track `t`. Needs
    /// [`Model::has_point_head`].
    pub fn predict_points(
        &mut self,
        queries: &[Query<'_>],
        out: &mut [Trajectory],
    ) -> Result<(), QueryError> {
        if !self.model.has_point_head() {
            return Err(QueryError::of_call(PredictError::NoPointHead));
        }
        check_len(queries.len(), 1, out.len())?;
        let scale = self.model.config().data_scale;
        let eo = out_exp(self.model.point_head());
        for (gi, (group, outs)) in queries.chunks(L).zip(out.chunks_mut(L)).enumerate() {
            let base = gi * L;
            // Guard errors first in track order: tracks before a failing
            // one are still forecast.
            let (w, in_a) = match self.encode(group, base, true) {
                Ok(r) => r,
                Err(e) => {
                    let ok = e.index - base;
                    if let (Some(g), true) = (group.get(..ok), ok > 0) {
                        let (w, in_a) = self.encode(g, base, true)?;
                        self.points_out(
                            w,
                            in_a,
                            eo,
                            scale,
                            base,
                            outs.get_mut(..ok).unwrap_or(&mut []),
                        )?;
                    }
                    return Err(e);
                }
            };
            self.points_out(w, in_a, eo, scale, base, outs)?;
        }
        Ok(())
    }
}

impl<'a, B: Backend, const W: usize, const L: usize> Batch<'a, B, W, L> {
    /// What a planner gets for each of `queries`, `k` endpoints each:
    /// `endpoints[t·k..(t + 1)·k]` and `probabilities[t·k..(t + 1)·k]` for
    /// track `t`, and `out[t]` (point forecast, radii), equal to
    /// [`crate::Predictor::predict_planner`]`::<N>` on that track alone.
    /// The endpoint sets go through the lanes
    /// ([`Batch::predict_endpoint_sets`]), the point forecasts too
    /// ([`Batch::predict_points`], `L` tracks at a time); each track's
    /// probabilities are the scalar engine's (a model's logit rows on its
    /// track: a few hundred multiply-adds) and its radii
    /// [`crate::planner::radii`]. On an error, the lowest failing track and
    /// the error the scalar sequence gives it (endpoints, then
    /// probabilities, point, radii); the tracks before it are filled.
    pub fn predict_forecasts<const N: usize>(
        &mut self,
        queries: &[Query<'_>],
        k: usize,
        endpoints: &mut [[f32; 2]],
        probabilities: &mut [f32],
        out: &mut [PlannerOutput],
    ) -> Result<(), QueryError> {
        check_len(queries.len(), k, endpoints.len())?;
        check_len(queries.len(), k, probabilities.len())?;
        check_len(queries.len(), 1, out.len())?;
        let ends_failed = self.predict_endpoint_sets::<N>(queries, k, endpoints).err();
        // Tracks before the first failing one have their endpoints.
        let done = ends_failed.map_or(queries.len(), |e| e.index.min(queries.len()));
        let (head, scales) = (self.model.has_point_head(), self.model.radius_scales());
        let mut points: [Trajectory; L] = core::array::from_fn(|_| Trajectory::new());
        for (ci, chunk) in queries[..done].chunks(L).enumerate() {
            let base = ci * L;
            let point_failed = if head {
                self.predict_points(chunk, &mut points[..chunk.len()]).err()
            } else {
                None
            };
            for (j, q) in chunk.iter().enumerate() {
                let t = base + j;
                let fail = |error| QueryError { index: t, error };
                let range = t * k..(t + 1) * k;
                let (Some(probs), Some(ends), Some(o)) = (
                    probabilities.get_mut(range.clone()),
                    endpoints.get(range),
                    out.get_mut(t),
                ) else {
                    return Err(fail(PredictError::CapacityExceeded));
                };
                let learned = if self.model.has_probabilities() {
                    self.scalar.start(q.past, q.seed).map_err(fail)?;
                    self.scalar.probabilities(probs).map_err(fail)?
                } else {
                    crate::planner::uniform(probs);
                    false
                };
                let point = match point_failed {
                    Some(e) if e.index == j => return Err(fail(e.error)),
                    _ if head => points.get(j).cloned(),
                    _ => None,
                };
                let radii = match point.as_ref().and_then(|p| p.last()) {
                    Some(&pt) if learned => {
                        Some(crate::planner::radii(pt, ends, probs, scales).map_err(fail)?)
                    }
                    _ => None,
                };
                *o = PlannerOutput {
                    learned,
                    point,
                    radii,
                };
            }
        }
        ends_failed.map_or(Ok(()), Err)
    }
}

/// Whether one track's `n` samples are few enough (at most `L / 4`) for
/// the scalar engine to be faster than mostly empty lanes (same bits).
fn few<const L: usize>(n: usize) -> bool {
    n <= L / 4
}

/// `out_len == n·k` with `k > 0`, else [`PredictError::BadSampleCount`].
fn check_len(n: usize, k: usize, out_len: usize) -> Result<(), QueryError> {
    if k == 0 || n.checked_mul(k) != Some(out_len) {
        return Err(QueryError::of_call(PredictError::BadSampleCount));
    }
    Ok(())
}

/// The methods of [`BatchPredictor`] that only pass their arguments to the
/// [`Batch`] of the blob's numeric kind ([`on_kind!`]): each written as its
/// documented signature, the call generated from it. `tests/public_api.rs`
/// reads the signatures from the invocation, so they stay in the snapshot.
macro_rules! forward {
    ($(
        $(#[$doc:meta])*
        pub fn $name:ident $(<const $n:ident: usize>)?
            (&mut self $(, $arg:ident: $ty:ty)* $(,)?) -> $ret:ty;
    )*) => {
        $(
            $(#[$doc])*
            pub fn $name $(<const $n: usize>)? (&mut self $(, $arg: $ty)*) -> $ret {
                on_kind!(&mut self.0, e => e.$name $(::<$n>)? ($($arg),*))
            }
        )*
    };
}

/// Like [`crate::Predictor`] (any valid blob, kind chosen at run time, the
/// same bits) but on the batched path: one track's samples, or many
/// tracks', `L` side by side. `W` is the scratch width, at least
/// [`Model::scratch_width`]; `S` the sine of f32 blobs.
///
/// ```
/// # fn demo(blob: &'static [u8], past: &[[f32; 2]]) -> Result<(), gpecnet_core::Error> {
/// use gpecnet_core::batch::{BatchPredictor, Query};
/// use gpecnet_core::{LibmSine, Model};
/// let model = Model::from_blob(blob)?;
/// // 1024 = scratch width, 8 = lanes; ~170 KiB, so box it on a host.
/// let mut p = BatchPredictor::<LibmSine, 1024, 8>::new(model)?;
/// let mut ends = [[0.0f32; 2]; 20];
/// p.predict_samples(past, 7, &mut ends)?; // == Predictor::predict_samples
/// let tracks = [Query { past, seed: 0 }, Query { past, seed: 1 }];
/// let mut many = [[0.0f32; 2]; 40]; // track-major: 20 of track 0, then 20 of track 1
/// p.predict_samples_many(&tracks, 20, &mut many).map_err(|e| e.error)?;
/// # Ok(()) }
/// ```
pub struct BatchPredictor<'a, S: Sine, const W: usize, const L: usize>(
    ByKind<Batch<'a, Float<S>, W, L>, Batch<'a, Q15, W, L>>,
);

/// [`BatchPredictor`] with the host's lane count [`HOST_LANES`].
pub type HostBatchPredictor<'a, S, const W: usize> = BatchPredictor<'a, S, W, HOST_LANES>;

impl<'a, S: Sine, const W: usize, const L: usize> BatchPredictor<'a, S, W, L> {
    /// A batched predictor for `model`, whatever its numeric kind; fails
    /// as [`crate::Predictor::new`] does.
    pub fn new(model: Model<'a>) -> Result<Self, Error> {
        Ok(Self(match model.numeric() {
            NumericKind::F32 => ByKind::F32(Batch::new(model)?),
            NumericKind::Int16Q15 => ByKind::Q15(Batch::new(model)?),
        }))
    }

    /// The model.
    pub fn model(&self) -> &Model<'a> {
        on_kind!(&self.0, e => e.model())
    }

    forward! {
        /// [`crate::Predictor::predict_samples`], batched (same bits).
        pub fn predict_samples(&mut self, past: &[[f32; 2]], seed: u64, out: &mut [[f32; 2]]) -> Result<(), PredictError>;

        /// [`crate::Predictor::predict_trajectories`], batched (same bits).
        pub fn predict_trajectories(&mut self, past: &[[f32; 2]], seed: u64, out: &mut [Trajectory]) -> Result<(), PredictError>;

        /// [`crate::Predictor::predict_endpoint_set`], batched (same bits).
        pub fn predict_endpoint_set<const N: usize>(&mut self, past: &[[f32; 2]], seed: u64, out: &mut [[f32; 2]]) -> Result<(), PredictError>;

        /// [`Batch::predict_samples_many`]: `k` samples of each track,
        /// track-major in `out`.
        pub fn predict_samples_many(&mut self, queries: &[Query<'_>], k: usize, out: &mut [[f32; 2]]) -> Result<(), QueryError>;

        /// [`Batch::predict_trajectories_many`]: `k` trajectories of each
        /// track, track-major in `out`.
        pub fn predict_trajectories_many(&mut self, queries: &[Query<'_>], k: usize, out: &mut [Trajectory]) -> Result<(), QueryError>;

        /// [`Batch::predict_endpoint_sets`]: the endpoint set (`k` endpoints)
        /// of each track, track-major in `out`.
        pub fn predict_endpoint_sets<const N: usize>(&mut self, queries: &[Query<'_>], k: usize, out: &mut [[f32; 2]]) -> Result<(), QueryError>;

        /// [`Batch::predict_points`]: the point forecast of each track.
        pub fn predict_points(&mut self, queries: &[Query<'_>], out: &mut [Trajectory]) -> Result<(), QueryError>;

        /// [`Batch::predict_forecasts`]: what a planner gets for each track
        /// ([`crate::Predictor::predict_planner`]`::<N>`, same bits), `k`
        /// endpoints and probabilities each, track-major.
        pub fn predict_forecasts<const N: usize>(&mut self, queries: &[Query<'_>], k: usize, endpoints: &mut [[f32; 2]], probabilities: &mut [f32], out: &mut [PlannerOutput]) -> Result<(), QueryError>;
    }
}
