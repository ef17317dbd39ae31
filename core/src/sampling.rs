//! The blob's endpoint protocol: what "predict `k` endpoints" means for a
//! model, shared by the f32 and the fixed-point engines (one place for it).
//!
//! * Plain sampling (`tts_samples = 0`, every format-1 blob): the `k`
//!   endpoints are the first `k` latent samples of the seeded sampler.
//! * Test-time sampling (`tts_samples = N > 0`): the engine draws the first
//!   `N` latent samples (the same stream, so sample `i` does not depend on
//!   `N`), and [`crate::cluster::kmeans_reduce`] reduces them to `k` centres
//!   with the blob's initialisation and iteration count. `k ≤ N` is required.
//! * Learned proposal (format version 5, [`crate::Model::has_proposal`]):
//!   plain sampling whose stream is not drawn from the prior but computed
//!   from the past: sample `i` decodes the proposal's latent `i` (rows
//!   `i·zdim ..` of its last layer on its hidden vector, each component
//!   clamped to `±latent_bound`), so the seed does not matter and the stream
//!   ends after [`crate::Model::proposal_latents`] samples (`k` beyond that is
//!   [`PredictError::BadSampleCount`]). The latents are trained as a set
//!   for `K` endpoints: ask for all `K`.
//!
//! The engines call `endpoint_set` (crate-private) with a closure that draws `n` samples
//! into a caller-sized buffer of capacity `N` (a const generic: 8 bytes of
//! stack per sample).

use crate::blob::Extensions;
use crate::cluster::{kmeans_reduce, Init};
use crate::output::PredictError;

/// Fills `out` (length `k`) by the protocol of `ext`, drawing samples with
/// `draw(n, buffer)`; `N` is the most samples the buffer holds. `most` is
/// [`stream_bound`] of the model: a `k` above it is
/// [`PredictError::BadSampleCount`] before anything is drawn.
pub(crate) fn endpoint_set<const N: usize>(
    ext: &Extensions,
    most: usize,
    out: &mut [[f32; 2]],
    mut draw: impl FnMut(usize, &mut heapless::Vec<[f32; 2], N>) -> Result<(), PredictError>,
) -> Result<(), PredictError> {
    let n = samples_needed(ext, out.len());
    if out.is_empty() || out.len() > n || out.len() > most {
        return Err(PredictError::BadSampleCount);
    }
    if n > N {
        return Err(PredictError::CapacityExceeded);
    }
    let mut buf = heapless::Vec::<[f32; 2], N>::new();
    draw(n, &mut buf)?;
    reduce(ext, &buf, out)
}

/// The last step of the protocol of `ext`: the `samples` a stream drew (the
/// first [`samples_needed`]`(ext, out.len())` of it, e.g. from
/// [`crate::Predictor::start`] and [`crate::Predictor::next_endpoint`] with a
/// yield between samples) become the `out.len()` endpoints. With the same
/// samples this gives exactly [`crate::Predictor::predict_endpoint_set`].
pub fn reduce(
    ext: &Extensions,
    samples: &[[f32; 2]],
    out: &mut [[f32; 2]],
) -> Result<(), PredictError> {
    let k = out.len();
    if k == 0 || k > samples_needed(ext, k) {
        return Err(PredictError::BadSampleCount);
    }
    if samples.len() != samples_needed(ext, k) {
        return Err(PredictError::BadSampleCount);
    }
    if ext.tts_samples == 0 {
        out.copy_from_slice(samples);
        return Ok(());
    }
    reduce_tts(ext, samples, out)
}

/// The k-means step of test-time sampling, out of line: a model without it
/// never runs (nor, in the profile's count of executed code, pays for) it.
#[inline(never)]
fn reduce_tts(
    ext: &Extensions,
    samples: &[[f32; 2]],
    out: &mut [[f32; 2]],
) -> Result<(), PredictError> {
    let init = if ext.tts_init == 1 {
        Init::Farthest
    } else {
        Init::First
    };
    kmeans_reduce(samples, out, ext.tts_iters, init).map_err(|_| PredictError::BadSampleCount)
}

/// The most endpoints one prediction can return under the protocol of `ext`
/// when the caller can hold `capacity` samples (the `N` of
/// `predict_endpoint_set::<N>`): `capacity` for plain sampling; for test-time
/// sampling `min(tts_samples, MAX_CENTERS)` (k-means reduces to at most
/// [`crate::cluster::MAX_CENTERS`] centres), or 0 when `tts_samples` exceeds
/// `capacity` (no `k` works then). Every `k` in `1..=max_endpoints` is
/// accepted; what this returns is exactly what the predictor accepts.
pub fn max_endpoints(ext: &Extensions, capacity: usize) -> usize {
    match ext.tts_samples as usize {
        0 => capacity,
        n if n > capacity => 0,
        n => n.min(crate::cluster::MAX_CENTERS),
    }
}

/// [`max_endpoints`] for `model`, which also knows a proposal's stream
/// length: `min(K, capacity)` for a proposal model.
pub fn max_endpoints_of(model: &crate::Model<'_>, capacity: usize) -> usize {
    if model.has_proposal() {
        model.proposal_latents().min(capacity)
    } else {
        max_endpoints(model.extensions(), capacity)
    }
}

/// The most endpoints `model` gives whatever the caller's buffer:
/// [`max_endpoints_of`] with an unbounded capacity (K for a proposal model,
/// `min(tts_samples, MAX_CENTERS)` with test-time sampling, no bound for
/// plain sampling). The capacity check (`CapacityExceeded`) stays separate.
pub(crate) fn stream_bound(model: &crate::Model<'_>) -> usize {
    max_endpoints_of(model, usize::MAX)
}

/// Samples a prediction of `k` endpoints draws under the protocol of `ext`
/// (the capacity `N` it needs): `k` for plain sampling, `tts_samples` otherwise.
pub fn samples_needed(ext: &Extensions, k: usize) -> usize {
    match ext.tts_samples as usize {
        0 => k,
        n => n,
    }
}
