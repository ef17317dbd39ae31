//! Status codes: [`GPECNET_OK`] and one `GPECNET_E_*` code per way a call
//! can fail, the exhaustive mapping of the core's errors onto them, and
//! [`gpecnet_status_str`], their English text.
use core::ffi::c_char;

use gpecnet_core::blob::signed::SignError;
use gpecnet_core::blob::NetworkId;
use gpecnet_core::camera::CameraError;
use gpecnet_core::online::OnlineError;
use gpecnet_core::units::UnitError;
use gpecnet_core::{BlobError, Error, PredictError};

#[cfg(doc)]
use crate::{
    gpecnet_init, GPECNET_MAX_FUTURE, GPECNET_MAX_SAMPLES, GPECNET_PREDICTOR_ALIGN,
    GPECNET_PREDICTOR_SIZE, GPECNET_SCRATCH_WIDTH, GPECNET_UNIT_MODEL,
};

/// Success.
pub const GPECNET_OK: i32 = 0;
/// A required pointer argument is NULL.
pub const GPECNET_E_NULL_POINTER: i32 = 1;
/// A length argument is wrong: storage shorter than [`GPECNET_PREDICTOR_SIZE`],
/// an output buffer too short, or a golden case index out of range.
pub const GPECNET_E_BAD_LENGTH: i32 = 2;
/// The storage is not aligned to [`GPECNET_PREDICTOR_ALIGN`].
pub const GPECNET_E_MISALIGNED: i32 = 3;
/// The storage holds no predictor (never initialised, or [`gpecnet_init`] failed).
pub const GPECNET_E_NOT_INITIALISED: i32 = 4;
/// A panic was caught (host builds with the `std` feature; never expected).
pub const GPECNET_E_PANIC: i32 = 5;
/// An error of the core that this build of the C ABI has no code for (the
/// core's error enums are `#[non_exhaustive]`; every variant known today has
/// its own code, so this appears only with a newer core).
pub const GPECNET_E_UNKNOWN_ERROR: i32 = 6;

/// Blob: the first four bytes are not `GPEC`.
pub const GPECNET_E_BLOB_BAD_MAGIC: i32 = 10;
/// Blob: a format version this reader does not support.
pub const GPECNET_E_BLOB_UNSUPPORTED_VERSION: i32 = 11;
/// Blob: the bytes end before the structure does.
pub const GPECNET_E_BLOB_TRUNCATED: i32 = 12;
/// Blob: the stored CRC-32 does not match the bytes.
pub const GPECNET_E_BLOB_CHECKSUM_MISMATCH: i32 = 13;
/// Blob: a value could not be decoded.
pub const GPECNET_E_BLOB_MALFORMED: i32 = 14;
/// Blob: bytes left between the last network and the checksum.
pub const GPECNET_E_BLOB_TRAILING_BYTES: i32 = 15;
/// Blob: a numeric kind this build cannot run.
pub const GPECNET_E_BLOB_UNSUPPORTED_NUMERIC: i32 = 16;
/// Blob: layer shapes do not match the model's configuration.
pub const GPECNET_E_BLOB_SHAPE_MISMATCH: i32 = 17;
/// Blob: a hyper-parameter is out of range.
pub const GPECNET_E_BLOB_BAD_CONFIG: i32 = 18;
/// Blob: more layers, history or future than this build's capacity.
pub const GPECNET_E_BLOB_EXCEEDS_CAPACITY: i32 = 19;
/// Blob: a weight, bias or hyper-parameter is NaN or infinite.
pub const GPECNET_E_BLOB_NON_FINITE: i32 = 20;
/// Blob: fixed-point exponents or shifts are out of range or do not chain.
pub const GPECNET_E_BLOB_BAD_SCALE: i32 = 21;

/// The model's scratch width exceeds [`GPECNET_SCRATCH_WIDTH`].
pub const GPECNET_E_SCRATCH_TOO_SMALL: i32 = 30;
/// `past_len` differs from the model's observed steps.
pub const GPECNET_E_WRONG_PAST_LENGTH: i32 = 31;
/// The number of endpoints asked for is 0 or more than the model gives
/// (`GpecnetModelInfo::max_endpoints`: its test-time samples, at most 64, or a
/// proposal model's K latents).
pub const GPECNET_E_BAD_SAMPLE_COUNT: i32 = 32;
/// The endpoint set needs more than [`GPECNET_MAX_SAMPLES`] samples, or a
/// model output is longer than [`GPECNET_MAX_FUTURE`] points.
pub const GPECNET_E_CAPACITY_EXCEEDED: i32 = 33;
/// An input coordinate is NaN or infinite.
pub const GPECNET_E_NON_FINITE_INPUT: i32 = 34;
/// An input coordinate or displacement is outside the valid range.
pub const GPECNET_E_INPUT_OUT_OF_RANGE: i32 = 35;
/// The model produced NaN or infinity.
pub const GPECNET_E_NON_FINITE_OUTPUT: i32 = 36;
/// Trajectories were asked of a model without a predictor network.
pub const GPECNET_E_NO_PREDICTOR: i32 = 37;
/// A point forecast was asked of a model without a point-forecast head.
pub const GPECNET_E_NO_POINT_HEAD: i32 = 38;
/// A sample was asked for before a stream was started.
pub const GPECNET_E_NOT_STARTED: i32 = 39;
/// The model produced a point beyond ±2·10^6 (twice the input range): not a
/// forecast, so nothing is written (`PredictError::OutputOutOfRange`).
pub const GPECNET_E_OUTPUT_OUT_OF_RANGE: i32 = 40;

/// The blob does not record its unit (format < 4): declare
/// [`GPECNET_UNIT_MODEL`] to use it as it is.
pub const GPECNET_E_UNIT_UNKNOWN_MODEL: i32 = 50;
/// The declared unit is not the model's and cannot be converted (e.g.
/// pixels of an unknown scale into a metre model).
pub const GPECNET_E_UNIT_MISMATCH: i32 = 51;
/// The pixel model has no single ground scale: it takes only its own pixels.
pub const GPECNET_E_UNIT_NO_MODEL_SCALE: i32 = 52;
/// Metres per pixel (or the conversion factor) not finite or outside [1e-6, 1e6].
pub const GPECNET_E_UNIT_BAD_SCALE: i32 = 53;
/// The track table's timestamp is before its last one: the whole update was refused.
pub const GPECNET_E_TRACKS_STALE_TIME: i32 = 60;
/// `period_ms` is 0: the track table needs the model's period (400 for the
/// shipped models; `GpecnetModelInfo::period_s` × 1000).
pub const GPECNET_E_TRACKS_BAD_PERIOD: i32 = 61;

/// The blob is not signed (`gpecnet_init_signed`).
pub const GPECNET_E_SIGN_UNSIGNED: i32 = 70;
/// The signature trailer's version is unknown.
pub const GPECNET_E_SIGN_BAD_TRAILER: i32 = 71;
/// No trusted key has the blob's key id.
pub const GPECNET_E_SIGN_UNKNOWN_KEY: i32 = 72;
/// The signature does not verify (a changed byte, or a forgery).
pub const GPECNET_E_SIGN_BAD_SIGNATURE: i32 = 73;
/// The blob's model version is below the caller's minimum.
pub const GPECNET_E_SIGN_ROLLED_BACK: i32 = 74;

/// Online loop: a `GpecnetOnlineConfig` field (or the blob's radius
/// multipliers as the starting point) is out of range
/// (`gpecnet_core::online::Config::validate`).
pub const GPECNET_E_ONLINE_BAD_CONFIG: i32 = 80;
/// Online loop: the model does not forecast 12 steps from 8 on a period of
/// whole milliseconds.
pub const GPECNET_E_ONLINE_MODEL_SHAPE: i32 = 81;
/// Online loop: a calibration state of the wrong length (not
/// `GPECNET_ONLINE_STATE_LEN` bytes).
pub const GPECNET_E_ONLINE_STATE_LENGTH: i32 = 82;
/// Online loop: a calibration state without the magic `GPOL`.
pub const GPECNET_E_ONLINE_STATE_MAGIC: i32 = 83;
/// Online loop: a calibration state of another layout version.
pub const GPECNET_E_ONLINE_STATE_VERSION: i32 = 84;
/// Online loop: a calibration state of another shape (motion states,
/// horizons, radius levels, experts).
pub const GPECNET_E_ONLINE_STATE_SHAPE: i32 = 85;
/// Online loop: a calibration state whose CRC-32 does not match (damaged).
pub const GPECNET_E_ONLINE_STATE_CRC: i32 = 86;
/// Online loop: a calibration state with a value outside the bounds of the
/// forecaster's config.
pub const GPECNET_E_ONLINE_STATE_VALUE: i32 = 87;
/// Online loop: an output buffer is too small (a state buffer shorter than
/// `GPECNET_ONLINE_STATE_LEN`).
pub const GPECNET_E_ONLINE_BUFFER_TOO_SMALL: i32 = 88;
/// Online loop: the frame was applied (tracks, feedback, calibration), but
/// it made more forecasts than the output array holds: the first `out_cap`
/// were written, `*n_out` says how many there were.
pub const GPECNET_E_ONLINE_FORECASTS_DROPPED: i32 = 89;
/// Online loop: the predictor holds another blob or converts another unit
/// than the one the forecaster was initialised with.
pub const GPECNET_E_ONLINE_OTHER_MODEL: i32 = 90;

/// Camera: an input is NaN or infinite (intrinsics, distortion, angles, a
/// NaN quaternion, position, ground height, a pixel, a ground point).
pub const GPECNET_E_CAMERA_NON_FINITE: i32 = 100;
/// Camera: a focal length is zero, negative or under 1 pixel.
pub const GPECNET_E_CAMERA_FOCAL_LENGTH: i32 = 101;
/// Camera: `max_range` is not positive.
pub const GPECNET_E_CAMERA_MAX_RANGE: i32 = 102;
/// Camera: the attitude's `|q|²` is outside `1 ± 10⁻³` (not normalised, all
/// zero, or not a quaternion).
pub const GPECNET_E_CAMERA_QUATERNION: i32 = 103;
/// Camera: the camera is at or below the ground plane.
pub const GPECNET_E_CAMERA_BELOW_GROUND: i32 = 104;
/// Camera: the pixel's ray points at or above the horizon (a camera looking
/// at the sky): it never meets the ground.
pub const GPECNET_E_CAMERA_ABOVE_HORIZON: i32 = 105;
/// Camera: the ray meets the ground farther than `max_range` from the point
/// below the camera.
pub const GPECNET_E_CAMERA_BEYOND_RANGE: i32 = 106;
/// Camera: the ground point is at or behind the camera's image plane.
pub const GPECNET_E_CAMERA_BEHIND_CAMERA: i32 = 107;
/// Camera: the lens model cannot be inverted at this pixel (far outside the
/// calibrated field of view).
pub const GPECNET_E_CAMERA_UNDISTORTION: i32 = 108;
/// Camera: a result overflowed f32 (a pixel or point absurdly far outside
/// the image).
pub const GPECNET_E_CAMERA_OVERFLOW: i32 = 109;
/// Camera: the detection array was full; this box has no detection.
pub const GPECNET_E_CAMERA_OUTPUT_FULL: i32 = 110;
/// Camera: a bounding box's edges are out of order (`x_min > x_max` or
/// `y_min > y_max`).
pub const GPECNET_E_CAMERA_BAD_BOX: i32 = 111;
/// Camera: a measurement-noise standard deviation is negative or not
/// finite.
pub const GPECNET_E_CAMERA_NOISE: i32 = 112;

/// The status code of a blob error (exhaustive: a new core variant fails to compile here).
pub fn blob_status(e: BlobError) -> i32 {
    match e {
        BlobError::BadMagic => GPECNET_E_BLOB_BAD_MAGIC,
        BlobError::UnsupportedVersion(_) => GPECNET_E_BLOB_UNSUPPORTED_VERSION,
        BlobError::Truncated => GPECNET_E_BLOB_TRUNCATED,
        BlobError::ChecksumMismatch { .. } => GPECNET_E_BLOB_CHECKSUM_MISMATCH,
        BlobError::Malformed => GPECNET_E_BLOB_MALFORMED,
        BlobError::TrailingBytes => GPECNET_E_BLOB_TRAILING_BYTES,
        BlobError::UnsupportedNumeric => GPECNET_E_BLOB_UNSUPPORTED_NUMERIC,
        BlobError::ShapeMismatch(
            NetworkId::EncoderPast
            | NetworkId::Decoder
            | NetworkId::EncoderDest
            | NetworkId::Predictor
            | NetworkId::PointHead
            | NetworkId::Proposal,
        ) => GPECNET_E_BLOB_SHAPE_MISMATCH,
        BlobError::BadConfig => GPECNET_E_BLOB_BAD_CONFIG,
        BlobError::ExceedsCapacity => GPECNET_E_BLOB_EXCEEDS_CAPACITY,
        BlobError::NonFinite(_) => GPECNET_E_BLOB_NON_FINITE,
        BlobError::BadScale(_) => GPECNET_E_BLOB_BAD_SCALE,
        _ => GPECNET_E_UNKNOWN_ERROR,
    }
}

/// The status code of a prediction error (exhaustive, like [`blob_status`]).
pub fn predict_status(e: PredictError) -> i32 {
    match e {
        PredictError::ScratchTooSmall { .. } => GPECNET_E_SCRATCH_TOO_SMALL,
        PredictError::WrongPastLength { .. } => GPECNET_E_WRONG_PAST_LENGTH,
        PredictError::BadSampleCount => GPECNET_E_BAD_SAMPLE_COUNT,
        PredictError::CapacityExceeded => GPECNET_E_CAPACITY_EXCEEDED,
        PredictError::NonFiniteInput => GPECNET_E_NON_FINITE_INPUT,
        PredictError::InputOutOfRange => GPECNET_E_INPUT_OUT_OF_RANGE,
        PredictError::NonFiniteOutput => GPECNET_E_NON_FINITE_OUTPUT,
        PredictError::NoPredictor => GPECNET_E_NO_PREDICTOR,
        PredictError::NoPointHead => GPECNET_E_NO_POINT_HEAD,
        PredictError::NotStarted => GPECNET_E_NOT_STARTED,
        PredictError::OutputOutOfRange => GPECNET_E_OUTPUT_OUT_OF_RANGE,
        _ => GPECNET_E_UNKNOWN_ERROR,
    }
}

/// The status code of a unit error (exhaustive, like [`blob_status`]).
pub fn unit_status(e: UnitError) -> i32 {
    match e {
        UnitError::UnknownModelUnit => GPECNET_E_UNIT_UNKNOWN_MODEL,
        UnitError::Mismatch { .. } => GPECNET_E_UNIT_MISMATCH,
        UnitError::NoModelScale => GPECNET_E_UNIT_NO_MODEL_SCALE,
        UnitError::BadScale => GPECNET_E_UNIT_BAD_SCALE,
        _ => GPECNET_E_UNKNOWN_ERROR,
    }
}

/// The status code of a signed-blob refusal (exhaustive, like [`blob_status`]).
pub fn sign_status(e: SignError) -> i32 {
    match e {
        SignError::UnsignedBlob => GPECNET_E_SIGN_UNSIGNED,
        SignError::BadTrailer => GPECNET_E_SIGN_BAD_TRAILER,
        SignError::UnknownKey => GPECNET_E_SIGN_UNKNOWN_KEY,
        SignError::BadSignature => GPECNET_E_SIGN_BAD_SIGNATURE,
        SignError::RolledBack { .. } => GPECNET_E_SIGN_ROLLED_BACK,
        SignError::Blob(b) => blob_status(b),
        _ => GPECNET_E_UNKNOWN_ERROR,
    }
}

/// The status code of an online-loop error (exhaustive, like
/// [`blob_status`]; a refused prediction keeps its own code).
pub fn online_status(e: OnlineError) -> i32 {
    match e {
        OnlineError::BadConfig => GPECNET_E_ONLINE_BAD_CONFIG,
        OnlineError::ModelShape => GPECNET_E_ONLINE_MODEL_SHAPE,
        OnlineError::StateLength => GPECNET_E_ONLINE_STATE_LENGTH,
        OnlineError::StateMagic => GPECNET_E_ONLINE_STATE_MAGIC,
        OnlineError::StateVersion => GPECNET_E_ONLINE_STATE_VERSION,
        OnlineError::StateShape => GPECNET_E_ONLINE_STATE_SHAPE,
        OnlineError::StateCrc => GPECNET_E_ONLINE_STATE_CRC,
        OnlineError::StateValue => GPECNET_E_ONLINE_STATE_VALUE,
        OnlineError::BufferTooSmall => GPECNET_E_ONLINE_BUFFER_TOO_SMALL,
        OnlineError::Predict(p) => predict_status(p),
        _ => GPECNET_E_UNKNOWN_ERROR,
    }
}

/// The status code of a camera error (exhaustive, like [`blob_status`]).
pub fn camera_status(e: CameraError) -> i32 {
    match e {
        CameraError::NonFinite => GPECNET_E_CAMERA_NON_FINITE,
        CameraError::FocalLength => GPECNET_E_CAMERA_FOCAL_LENGTH,
        CameraError::MaxRange => GPECNET_E_CAMERA_MAX_RANGE,
        CameraError::Quaternion => GPECNET_E_CAMERA_QUATERNION,
        CameraError::BelowGround => GPECNET_E_CAMERA_BELOW_GROUND,
        CameraError::AboveHorizon => GPECNET_E_CAMERA_ABOVE_HORIZON,
        CameraError::BeyondRange => GPECNET_E_CAMERA_BEYOND_RANGE,
        CameraError::BehindCamera => GPECNET_E_CAMERA_BEHIND_CAMERA,
        CameraError::Undistortion => GPECNET_E_CAMERA_UNDISTORTION,
        CameraError::Overflow => GPECNET_E_CAMERA_OVERFLOW,
        CameraError::OutputFull => GPECNET_E_CAMERA_OUTPUT_FULL,
        CameraError::BadBox => GPECNET_E_CAMERA_BAD_BOX,
        CameraError::Noise => GPECNET_E_CAMERA_NOISE,
        _ => GPECNET_E_UNKNOWN_ERROR,
    }
}

pub(crate) fn error_status(e: Error) -> i32 {
    match e {
        Error::Blob(b) => blob_status(b),
        Error::Predict(p) => predict_status(p),
        Error::Unit(u) => unit_status(u),
        _ => GPECNET_E_UNKNOWN_ERROR,
    }
}

/// A static, NUL-terminated English description of `status` (never NULL;
/// unknown codes give "unknown status code").
#[no_mangle]
pub extern "C" fn gpecnet_status_str(status: i32) -> *const c_char {
    let s: &'static core::ffi::CStr = match status {
        GPECNET_OK => c"ok",
        GPECNET_E_NULL_POINTER => c"a required pointer is NULL",
        GPECNET_E_BAD_LENGTH => {
            c"a length argument is wrong (storage or buffer too short, index out of range)"
        }
        GPECNET_E_MISALIGNED => c"storage is not aligned to GPECNET_PREDICTOR_ALIGN",
        GPECNET_E_NOT_INITIALISED => {
            c"storage holds no predictor (gpecnet_init not called or failed)"
        }
        GPECNET_E_PANIC => c"internal panic caught",
        GPECNET_E_BLOB_BAD_MAGIC => c"not a gpecnet blob (bad magic)",
        GPECNET_E_BLOB_UNSUPPORTED_VERSION => c"unsupported blob format version",
        GPECNET_E_BLOB_TRUNCATED => c"blob is truncated",
        GPECNET_E_BLOB_CHECKSUM_MISMATCH => c"blob checksum mismatch",
        GPECNET_E_BLOB_MALFORMED => c"malformed value in blob",
        GPECNET_E_BLOB_TRAILING_BYTES => c"unexpected bytes before the blob checksum",
        GPECNET_E_BLOB_UNSUPPORTED_NUMERIC => c"numeric kind not supported by this build",
        GPECNET_E_BLOB_SHAPE_MISMATCH => c"layer shapes do not match the model config",
        GPECNET_E_BLOB_BAD_CONFIG => c"model hyper-parameters out of range",
        GPECNET_E_BLOB_EXCEEDS_CAPACITY => c"model exceeds this build's capacity",
        GPECNET_E_BLOB_NON_FINITE => c"non-finite value in blob",
        GPECNET_E_BLOB_BAD_SCALE => c"inconsistent fixed-point scales in blob",
        GPECNET_E_SCRATCH_TOO_SMALL => c"model needs a wider scratch than GPECNET_SCRATCH_WIDTH",
        GPECNET_E_WRONG_PAST_LENGTH => c"past_len differs from the model's observed steps",
        GPECNET_E_BAD_SAMPLE_COUNT => c"endpoint count is 0 or exceeds the model's samples",
        GPECNET_E_CAPACITY_EXCEEDED => {
            c"more samples than GPECNET_MAX_SAMPLES, or an output too long"
        }
        GPECNET_E_NON_FINITE_INPUT => c"non-finite input coordinate",
        GPECNET_E_INPUT_OUT_OF_RANGE => c"input coordinate outside the valid range",
        GPECNET_E_NON_FINITE_OUTPUT => c"model output is not finite",
        GPECNET_E_NO_PREDICTOR => c"model has no trajectory predictor",
        GPECNET_E_NO_POINT_HEAD => c"model has no point-forecast head",
        GPECNET_E_NOT_STARTED => c"no sample stream started",
        GPECNET_E_OUTPUT_OUT_OF_RANGE => c"model output outside the plausible range",
        GPECNET_E_UNIT_UNKNOWN_MODEL => {
            c"the blob does not record its unit: declare GPECNET_UNIT_MODEL to use it as it is"
        }
        GPECNET_E_UNIT_MISMATCH => {
            c"the declared unit is not the model's (give the camera's metres per pixel)"
        }
        GPECNET_E_UNIT_NO_MODEL_SCALE => {
            c"the pixel model has no single ground scale: it takes only its own pixels"
        }
        GPECNET_E_UNIT_BAD_SCALE => c"metres per pixel not finite or outside [1e-6, 1e6]",
        GPECNET_E_TRACKS_STALE_TIME => c"timestamp before the track table's last one",
        GPECNET_E_TRACKS_BAD_PERIOD => c"track table period is 0 ms",
        GPECNET_E_SIGN_UNSIGNED => c"the blob is not signed",
        GPECNET_E_SIGN_BAD_TRAILER => c"unknown signature trailer version",
        GPECNET_E_SIGN_UNKNOWN_KEY => c"signed by a key that is not trusted",
        GPECNET_E_SIGN_BAD_SIGNATURE => c"the signature does not verify",
        GPECNET_E_SIGN_ROLLED_BACK => c"model version older than the minimum accepted",
        GPECNET_E_ONLINE_BAD_CONFIG => c"online loop config out of range",
        GPECNET_E_ONLINE_MODEL_SHAPE => {
            c"the online loop needs a model forecasting 12 steps from 8 on a whole-millisecond period"
        }
        GPECNET_E_ONLINE_STATE_LENGTH => c"calibration state has the wrong length",
        GPECNET_E_ONLINE_STATE_MAGIC => c"not a calibration state (bad magic)",
        GPECNET_E_ONLINE_STATE_VERSION => c"calibration state of another layout version",
        GPECNET_E_ONLINE_STATE_SHAPE => c"calibration state of another shape",
        GPECNET_E_ONLINE_STATE_CRC => c"calibration state checksum mismatch (damaged)",
        GPECNET_E_ONLINE_STATE_VALUE => c"calibration state value outside the config's bounds",
        GPECNET_E_ONLINE_BUFFER_TOO_SMALL => c"output buffer too small for the calibration state",
        GPECNET_E_ONLINE_FORECASTS_DROPPED => {
            c"frame applied, but more forecasts than the output array holds (the rest dropped)"
        }
        GPECNET_E_ONLINE_OTHER_MODEL => {
            c"the predictor's blob or unit is not the one the forecaster was initialised with"
        }
        GPECNET_E_CAMERA_NON_FINITE => c"camera input not finite (intrinsics, angles, quaternion, position, pixel or point)",
        GPECNET_E_CAMERA_FOCAL_LENGTH => c"focal length under one pixel",
        GPECNET_E_CAMERA_MAX_RANGE => c"camera maximum range not positive",
        GPECNET_E_CAMERA_QUATERNION => c"attitude quaternion not normalised",
        GPECNET_E_CAMERA_BELOW_GROUND => c"camera at or below the ground plane",
        GPECNET_E_CAMERA_ABOVE_HORIZON => c"ray at or above the horizon: it never meets the ground",
        GPECNET_E_CAMERA_BEYOND_RANGE => c"ground point beyond the camera's maximum range",
        GPECNET_E_CAMERA_BEHIND_CAMERA => c"ground point behind the camera",
        GPECNET_E_CAMERA_UNDISTORTION => c"lens distortion not invertible at this pixel",
        GPECNET_E_CAMERA_OVERFLOW => c"camera arithmetic overflowed",
        GPECNET_E_CAMERA_OUTPUT_FULL => c"detection array full: the box has no detection",
        GPECNET_E_CAMERA_BAD_BOX => c"bounding box edges out of order (x_min > x_max or y_min > y_max)",
        GPECNET_E_CAMERA_NOISE => c"measurement noise standard deviation negative or not finite",
        GPECNET_E_UNKNOWN_ERROR => c"an error this build of the C ABI has no code for",
        _ => c"unknown status code",
    };
    s.as_ptr()
}
