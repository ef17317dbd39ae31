//! What a prediction returns and why it can be refused: [`Trajectory`] and
//! [`PredictError`], shared by the engine, the frame guards, the endpoint
//! protocols and the predictors above them (a bottom module: it imports no
//! other module of this crate but the blob's limits).

use crate::blob::MAX_FUTURE;

/// A predicted trajectory: `future_len` points, the last is the endpoint.
pub type Trajectory = heapless::Vec<[f32; 2], MAX_FUTURE>;

/// Why a prediction was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum PredictError {
    /// The model's scratch width ([`Model::scratch_width`](crate::Model::scratch_width)) exceeds the predictor's `W`.
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
    /// The number of endpoints asked for is 0, or more than the model's
    /// test-time samples.
    BadSampleCount,
    /// A buffer is too small: the sample buffer `N` of
    /// [`Predictor::predict_endpoint_set`](crate::Predictor::predict_endpoint_set) (see [`crate::sampling::samples_needed`]),
    /// or a model output longer than [`MAX_FUTURE`] points.
    CapacityExceeded,
    /// An input coordinate is NaN or infinite.
    NonFiniteInput,
    /// An input is outside the valid range: a coordinate beyond
    /// ±[`crate::frame::MAX_COORDINATE`], or a displacement from the first
    /// observed point beyond ±[`Model::input_limit`](crate::Model::input_limit) in normalised units.
    InputOutOfRange,
    /// The model produced NaN or infinity.
    NonFiniteOutput,
    /// The model produced a finite point beyond ±[`crate::frame::MAX_OUTPUT`]
    /// (twice the input range): not a forecast, so not returned.
    OutputOutOfRange,
    /// Trajectories were asked of a model without a predictor network.
    NoPredictor,
    /// A point forecast was asked of a model without a point-forecast head.
    NoPointHead,
    /// A sample was asked for before a stream was started
    /// ([`Predictor::start`](crate::Predictor::start)), or a trajectory before a sample was drawn.
    NotStarted,
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
                f.write_str("endpoint count is 0 or exceeds the model's samples")
            }
            PredictError::CapacityExceeded => {
                f.write_str("an output or sample buffer is too small")
            }
            PredictError::NonFiniteInput => f.write_str("non-finite input coordinate"),
            PredictError::InputOutOfRange => {
                f.write_str("input coordinate outside the valid range")
            }
            PredictError::NonFiniteOutput => f.write_str("model output is not finite"),
            PredictError::OutputOutOfRange => {
                f.write_str("model output outside the plausible range (not a forecast)")
            }
            PredictError::NoPredictor => f.write_str("model has no trajectory predictor"),
            PredictError::NoPointHead => f.write_str("model has no point-forecast head"),
            PredictError::NotStarted => f.write_str("no sample stream started"),
        }
    }
}

impl core::error::Error for PredictError {}
