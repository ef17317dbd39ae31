//! Post-training quantization to the fixed-point blob kind
//! (`NumericKind::Int16Q15`, `weights/FORMAT.md`), the trainer's own integer
//! reference inference, and `gpecnet quantize`.
//!
//! * **Calibration**: the f32 model runs on SDD *training* windows (each with
//!   K latent samples drawn by the specified sampler); the largest magnitude
//!   of every network input, every non-sine layer output and every vector
//!   handed between networks is recorded. A vector with maximum `M` gets the
//!   exponent `floor(log2(32767 / (M · MARGIN)))` (clamped to −8..=30);
//!   shared vectors take the smallest exponent of their parts.
//! * **Weights**: int16 with a power-of-two scale per output channel, as
//!   large as the row's largest weight, the bias (i32 accumulator units) and
//!   the shift range allow. Sine layers are divided by 2π first, so their
//!   pre-activation is a phase in turns (full circle 2^32).
//! * **Integer reference** ([`QModel::predict`], `integer.rs`): written from the
//!   specification in `gpecnet_core::fixed`, independently of it (own table,
//!   own rounding, a full decoder pass per sample); the workspace tests
//!   compare the two bit for bit.
//!
//! Files: `calibrate.rs` (the f32 model's activation maxima), `weights.rs` (exponents and
//! int16/int32 weights: [`quantize`]), `integer.rs` (the integer reference and its golden
//! cases), `evaluate.rs` (both fixed-point paths on a data set), `command.rs` (`gpecnet
//! quantize` and its model card).

mod calibrate;
mod command;
mod evaluate;
mod integer;
mod weights;

pub use calibrate::{calibrate, Calibration};
pub use command::{
    check_fixed_tolerance, quant_card_dist_rows, quantize_blob_with, QuantCard, GOLDEN_STRIDE,
    MAX_FIXED_FDE_DIFF_M, MAX_FIXED_FDE_DIFF_PX,
};
pub use evaluate::{
    evaluate_core_fixed, evaluate_reference_fixed, predict_core_fixed, predict_reference_fixed,
    quantize_with_data,
};
pub use integer::{qgolden_bytes, quantize_value, sin_q15_ref};
pub use weights::quantize;

use crate::network::{InferenceModel, Layer, Q15};

/// Headroom over the calibrated maximum of each activation vector.
pub const MARGIN: f64 = 1.5;
/// The name golden files and cards use for the fixed-point sine.
pub const SINE_NAME: &str = "q15-table";

/// One quantized layer (mirrors `LayerWireQ`).
pub type QLayer = Layer<Q15>;

/// A quantized model (the same networks as its f32 source, int16/int32 with scales).
pub type QModel = InferenceModel<Q15>;
