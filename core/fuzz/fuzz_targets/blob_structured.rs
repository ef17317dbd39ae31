//! Valid blobs with arbitrary shapes and weights: the input is decoded into a model (numeric
//! kind, hyper-parameters, layer counts and widths, activations, every weight, bias, exponent
//! and shift, format 1 or 2 with a point head and test-time sampling), written through
//! `gpecnet-blob-writer` (so the CRC and the layout are right by construction), and every blob
//! the writer produces must be accepted by the reader and run through every predictor entry
//! point without panicking. Unlike `blob` and `blob_resealed`, nearly every input reaches the
//! engines with a model of its own. No corpus needed:
//!
//! `cd core/fuzz && RUSTC_BOOTSTRAP=1 cargo fuzz run blob_structured -- -max_total_time=60`
#![no_main]

use gpecnet_blob_writer::{
    blob_bytes, Activation, BlobHead, Extensions, FixedScale, ModelConfig, NumericKind, WireLayer,
};
use gpecnet_core::blob::{MAX_EXP, MAX_LAYERS, MAX_TTS_SAMPLES, MIN_EXP};
use gpecnet_core::fixed::{AFFINE_SHIFTS, SINE_SHIFTS};
use libfuzzer_sys::arbitrary::{Result, Unstructured};
use libfuzzer_sys::fuzz_target;

mod common;

/// Hidden widths stay small so one input runs fast; the engines' limits are the reader's job.
const MAX_HIDDEN: usize = 48;

/// One of the three activations.
fn activation(u: &mut Unstructured<'_>) -> Result<Activation> {
    Ok(match u.int_in_range(0..=2u8)? {
        0 => Activation::Linear,
        1 => Activation::Relu,
        _ => Activation::Sine,
    })
}

/// A finite f32: mostly small, sometimes any finite bit pattern.
fn weight(u: &mut Unstructured<'_>) -> Result<f32> {
    let bits: u32 = u.arbitrary()?;
    let v = f32::from_bits(bits);
    Ok(if v.is_finite() && u.ratio(1, 8)? {
        v
    } else {
        (bits >> 8) as f32 / 8_388_608.0 - 1.0
    })
}

/// A network from `input` to `output` with 1..=MAX_LAYERS layers; fixed point: the exponents
/// chain from `in_exp` and the last layer's output exponent is `out_exp` when given.
fn network(
    u: &mut Unstructured<'_>,
    numeric: NumericKind,
    input: usize,
    output: usize,
    in_exp: i8,
    out_exp: Option<i8>,
) -> Result<(Vec<WireLayer>, i8)> {
    let n = u.int_in_range(1..=MAX_LAYERS)?;
    let (mut layers, mut width, mut exp) = (Vec::with_capacity(n), input, in_exp);
    for i in 0..n {
        let last = i + 1 == n;
        let out = if last {
            output
        } else {
            u.int_in_range(1..=MAX_HIDDEN)?
        };
        // A sine layer outputs Q15, so a fixed output exponent other than 15 needs another one.
        let mut act = activation(u)?;
        if last && out_exp.is_some_and(|e| e != 15) && act == Activation::Sine {
            act = Activation::Linear;
        }
        let layer = match numeric {
            NumericKind::F32 => {
                let w = (0..width * out)
                    .map(|_| weight(u))
                    .collect::<Result<Vec<_>>>()?;
                let b = (0..out).map(|_| weight(u)).collect::<Result<Vec<_>>>()?;
                WireLayer::f32(width, out, act, &w, &b)
            }
            NumericKind::Int16Q15 => {
                let next_exp = match (act, last, out_exp) {
                    (Activation::Sine, _, _) => 15,
                    (_, true, Some(e)) => e,
                    _ => u.int_in_range(MIN_EXP..=MAX_EXP)?,
                };
                let shifts = match act {
                    Activation::Sine => SINE_SHIFTS,
                    _ => AFFINE_SHIFTS,
                };
                let w = (0..width * out)
                    .map(|_| u.arbitrary())
                    .collect::<Result<Vec<i16>>>()?;
                let b = (0..out)
                    .map(|_| u.arbitrary())
                    .collect::<Result<Vec<i32>>>()?;
                let scale = FixedScale {
                    in_exp: exp,
                    out_exp: next_exp,
                    shifts: (0..out)
                        .map(|_| u.int_in_range(shifts.clone()))
                        .collect::<Result<_>>()?,
                };
                exp = next_exp;
                WireLayer::q15(width, out, act, &w, &b, scale)
            }
        };
        layers.push(layer);
        width = out;
    }
    Ok((layers, exp))
}

/// A blob the reader must accept, decoded from the fuzzer's bytes.
fn model(u: &mut Unstructured<'_>) -> Result<Vec<u8>> {
    let numeric = if u.arbitrary()? {
        NumericKind::Int16Q15
    } else {
        NumericKind::F32
    };
    let past_len = u.int_in_range(2..=8u8)?;
    let future_len = u.int_in_range(2..=16u8)?;
    let (fdim, zdim) = (u.int_in_range(1..=16u16)?, u.int_in_range(1..=8u16)?);
    let config = ModelConfig {
        past_len,
        future_len,
        fdim: fdim.into(),
        zdim: zdim.into(),
        data_scale: 0.01 + u.int_in_range(0..=400u16)? as f32 / 100.0,
        sigma: u.int_in_range(0..=300u16)? as f32 / 100.0,
        initial_pos_divisor: 1.0 + u.int_in_range(0..=2000u16)? as f32,
        w0: u.int_in_range(1..=60u8)? as f32,
        hidden_activation: activation(u)?,
    };
    let (p2, f, z) = (2 * past_len as usize, fdim as usize, zdim as usize);
    let in_exp = u.int_in_range(MIN_EXP..=MAX_EXP)?;
    let (enc, fexp) = network(u, numeric, p2, f, in_exp, None)?;
    let (dec, dexp) = network(u, numeric, f + z, 2, fexp, None)?;
    let (dest, pred) = if u.arbitrary()? {
        let ddim = u.int_in_range(1..=16usize)?;
        let (dest, _) = network(u, numeric, 2, ddim, dexp, Some(fexp))?;
        let out = 2 * (future_len as usize - 1);
        let (pred, _) = network(u, numeric, f + ddim + 2, out, fexp, None)?;
        (dest, pred)
    } else {
        (Vec::new(), Vec::new()) // endpoint-only
    };
    let (extensions, head) = if u.arbitrary()? {
        let ext = Extensions {
            heading_steps: u.int_in_range(0..=past_len - 1)?,
            tts_samples: u.int_in_range(0..=MAX_TTS_SAMPLES as u16)?,
            tts_iters: u.int_in_range(0..=5u8)?,
            tts_init: u.int_in_range(0..=1u8)?,
        };
        let head = if u.arbitrary()? {
            network(u, numeric, p2, 2 * future_len as usize, in_exp, None)?.0
        } else {
            Vec::new()
        };
        (Some(ext), head)
    } else {
        (None, Vec::new())
    };
    let head_ = BlobHead {
        numeric,
        name: "fuzz",
        config,
        extensions,
        // Format 3 (no meta record): the networks are what this target varies.
        meta: None,
    };
    let blob = blob_bytes(&head_, [&enc, &dec, &dest, &pred, &head]);
    // Only what the generator cannot rule out may be refused: a zero-width result, or a
    // writer limit. Everything else the writer accepts is read back by the core's reader.
    Ok(blob.unwrap_or_default())
}

fuzz_target!(|data: &[u8]| {
    let mut u = Unstructured::new(data);
    let Ok(blob) = model(&mut u) else {
        return;
    };
    if !blob.is_empty() {
        assert!(
            common::read_and_predict(&blob),
            "the writer's blob was refused"
        );
    }
});
