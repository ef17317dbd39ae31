//! Any byte string given to the blob reader: `Ok` or a typed error, never a
//! panic; whatever is accepted must predict without panicking.
//!
//! `cd core/fuzz && RUSTC_BOOTSTRAP=1 cargo fuzz run blob -- -max_total_time=60`
#![no_main]

use gpecnet_core::{FastSine, LibmSine, Model, Predictor};
use libfuzzer_sys::fuzz_target;

mod common;
use common::{exercise, PAST};

fuzz_target!(|data: &[u8]| {
    let Ok(model) = Model::from_blob(data) else {
        return;
    };
    let past = &PAST[..(model.config().past_len as usize).min(8)];
    // Any kind: the predictor picks the engine (the sine matters for f32 blobs only).
    if let Ok(mut p) = Predictor::<LibmSine, 256>::new(model) {
        exercise(&mut p, past);
    }
    if let Ok(mut p) = Predictor::<FastSine, 256>::new(model) {
        exercise(&mut p, past);
    }
});
