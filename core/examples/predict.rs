//! Predict one pedestrian with the shipped MCU model, on the host, exactly as the
//! firmware does: a point forecast 4.8 s ahead and the model's 20 endpoints.
//!
//! ```sh
//! cargo run -p gpecnet-core --example predict
//! ```
use gpecnet_core::{Error, FixedPredictor, Model};

/// The blob is read in place: on a microcontroller it stays in flash.
static BLOB: &[u8] = include_bytes!("../../weights/sdd-tiny-v2-qe.gpec");

fn main() -> Result<(), Error> {
    let model = Model::from_blob(BLOB)?;
    // Scratch width: the widest layer (`Model::max_width`), here 64 → 1 KiB of i16/i64 rows.
    let mut p = FixedPredictor::<64>::new(&model)?;
    // Eight positions 0.4 s apart (pixels, like the SDD training data), oldest first.
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
    let forecast = p.predict_point(&past)?;
    println!("point forecast (12 steps of 0.4 s):");
    for (t, q) in forecast.iter().enumerate() {
        println!(
            "  t = {:.1} s: ({:.1}, {:.1})",
            0.4 * (t + 1) as f32,
            q[0],
            q[1]
        );
    }
    // The blob asks for 80 latent samples reduced to 20 by k-means: the buffer holds 128.
    let mut ends = [[0.0f32; 2]; 20];
    p.predict_endpoint_set::<128>(&past, /* seed */ 7, &mut ends)?;
    println!("20 possible positions 4.8 s ahead:");
    for e in &ends {
        println!("  ({:.1}, {:.1})", e[0], e[1]);
    }
    Ok(())
}
