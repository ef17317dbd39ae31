//! Post-training quantization to the fixed-point blob kind
//! (`NumericKind::Int16Q15`, `weights/FORMAT.md`), the trainer's own integer
//! reference inference.
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
//! cases). Both fixed-point paths on a data set are `gpecnet_metrics::fixed_eval`; the
//! `gpecnet quantize` command and its model card are `gpecnet_ship::quantize_blob`.

mod calibrate;
mod integer;
mod weights;

pub use calibrate::{calibrate, Calibration};
pub use integer::{qgolden_bytes, quantize_value, sin_q15_ref};
pub use weights::quantize;

use anyhow::Result;

use crate::data::{Dataset, Window};
use crate::network::{InferenceModel, Layer, Q15};
use crate::reference::RefModel;

/// Headroom over the calibrated maximum of each activation vector.
pub const MARGIN: f64 = 1.5;
/// The name golden files and cards use for the fixed-point sine.
pub const SINE_NAME: &str = "q15-table";

/// One quantized layer (mirrors `LayerWireQ`).
pub type QLayer = Layer<Q15>;

/// A quantized model (the same networks as its f32 source, int16/int32 with scales).
pub type QModel = InferenceModel<Q15>;

/// Calibrates on (every `stride`-th window of) `train` and quantizes.
pub fn quantize_with_data(
    model: &RefModel,
    train: &Dataset,
    stride: usize,
    k: usize,
    name: &str,
) -> Result<QModel> {
    let windows: Vec<Window> = train
        .windows
        .iter()
        .step_by(stride.max(1))
        .cloned()
        .collect();
    let cal = calibrate(model, &windows, k);
    quantize(model, &cal, name)
}
