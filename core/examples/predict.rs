//! Predict one pedestrian from a weight blob, on the host, exactly as the
//! firmware does: a point forecast 4.8 s ahead (when the model has one) and the
//! model's 20 endpoints. Any blob works, f32 or fixed point: the predictor
//! picks its engine from the blob at run time.
//!
//! ```sh
//! cargo run -p gpecnet-core --example predict                       # the shipped MCU model
//! cargo run -p gpecnet-core --example predict -- weights/sdd-small.gpec
//! ```
use gpecnet_core::sampling::samples_needed;
use gpecnet_core::{Error, LibmSine, Model, Predictor};

/// The default blob `BLOB`: the shipped MCU model, linked in 8-byte aligned and read in place.
mod common;
use common::BLOB;

/// Scratch width: at least `Model::scratch_width()` (the widest layer) of any
/// blob this example may be given; 1024 covers the paper-size model.
const W: usize = 1024;
/// Latent samples one endpoint set may draw (test-time sampling models draw more than 20).
const N: usize = gpecnet_core::blob::MAX_TTS_SAMPLES;

fn main() {
    let file = std::env::args().nth(1);
    let bytes = match &file {
        Some(path) => match std::fs::read(path) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("error: cannot read {path}: {e}");
                std::process::exit(2);
            }
        },
        None => BLOB.to_vec(),
    };
    if let Err(e) = run(&bytes) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run(blob: &[u8]) -> Result<(), Error> {
    let model = Model::from_blob(blob)?;
    println!(
        "model {} ({:?}, scratch width {}, {} test-time samples)",
        model.name(),
        model.numeric(),
        model.scratch_width(),
        samples_needed(model.extensions(), 20)
    );
    // ~20 KiB for W = 1024: on the heap here; on an MCU pick W = scratch_width().
    let mut p = Box::new(Predictor::<LibmSine, W>::new(model)?);
    // Eight positions 0.4 s apart (pixels, like the SDD training data), oldest first:
    // the walker firmware/src/profile.rs times on the MCU, so the outputs compare.
    let past = [
        [512.0, 300.0],
        [514.0, 301.0],
        [516.5, 302.0],
        [519.0, 303.5],
        [521.0, 304.5],
        [523.5, 305.0],
        [526.0, 306.0],
        [528.0, 307.5],
    ];
    if model.has_point_head() {
        let forecast = p.predict_point(&past)?;
        println!("point forecast (12 steps of 0.4 s):");
        for (t, q) in forecast.iter().enumerate() {
            let s = 0.4 * (t + 1) as f32;
            println!("  t = {s:.1} s: ({:.1}, {:.1})", q[0], q[1]);
        }
    }
    let mut ends = [[0.0f32; 2]; 20];
    p.predict_endpoint_set::<N>(&past, /* seed */ 7, &mut ends)?;
    println!(
        "20 possible positions 4.8 s ahead (sine {}):",
        p.sine_name()
    );
    for e in &ends {
        println!("  ({:.1}, {:.1})", e[0], e[1]);
    }
    Ok(())
}
