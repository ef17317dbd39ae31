//! Dev tool: `make-test-blob DIR [NAME]` writes DIR/NAME.gpec (a synthetic,
//! randomly initialised SIREN G-PECNet of realistic shape) and DIR/NAME.golden
//! (its outputs, computed here with gpecnet-core + LibmSine). It exercises the
//! firmware pipeline (embedding, golden replay, host comparison, profiling)
//! before trained weights exist. Never ship its output in weights/.
//!
//! Both files are written by the project's one blob/golden writer (`gpecnet-blob-writer`).
use std::error::Error;
use std::path::PathBuf;

use gpecnet_blob_writer::{
    blob_bytes, golden_bytes, Activation, BlobHead, GoldenCase, GoldenInfo, ModelConfig,
    NumericKind, WireLayer,
};
use gpecnet_core::{LibmSine, Model, Predictor, Sine};

struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 40) as f32) / (1u64 << 24) as f32 * 2.0 - 1.0
    }
}

fn main() {
    if let Err(e) = run() {
        eprintln!("make-test-blob: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = PathBuf::from(args.first().ok_or("usage: make-test-blob DIR [NAME]")?);
    let name = args
        .get(1)
        .cloned()
        .unwrap_or_else(|| "synthetic-test".into());
    std::fs::create_dir_all(&dir).map_err(|e| format!("creating {}: {e}", dir.display()))?;
    let (past_len, future_len, fdim, zdim) = (8usize, 12usize, 16u16, 16u16);
    let mut rng = Lcg(0x1234_5678);
    // encoder_past 16 -> 64 -> 32 -> 16 ; decoder 32 -> 64 -> 64 -> 2 (SIREN: first layer w0 = 30 folded)
    let shapes_enc = [
        (16usize, 64usize, Activation::Sine, 30.0f32),
        (64, 32, Activation::Sine, 1.0),
        (32, 16, Activation::Linear, 1.0),
    ];
    let shapes_dec = [
        (32usize, 64usize, Activation::Sine, 30.0f32),
        (64, 64, Activation::Sine, 1.0),
        (64, 2, Activation::Linear, 1.0),
    ];
    let mut layers = Vec::new();
    for &(i, o, a, w0) in shapes_enc.iter().chain(shapes_dec.iter()) {
        let lim = if w0 > 1.0 {
            1.0 / i as f32
        } else {
            (6.0 / i as f32).sqrt()
        };
        let w: Vec<f32> = (0..i * o).map(|_| rng.next() * lim * w0).collect();
        let b: Vec<f32> = (0..o).map(|_| rng.next() * 0.1).collect();
        layers.push(WireLayer::f32(i, o, a, &w, &b));
    }
    let head = BlobHead {
        numeric: NumericKind::F32,
        name: &name,
        config: ModelConfig {
            past_len: past_len as u8,
            future_len: future_len as u8,
            fdim,
            zdim,
            data_scale: 1.86,
            sigma: 1.3,
            initial_pos_divisor: 1000.0,
            w0: 30.0,
            hidden_activation: Activation::Sine,
        },
        extensions: None,
        meta: None,
    };
    let blob = blob_bytes(&head, [&layers[0..3], &layers[3..6], &[], &[], &[]])?;
    let model = Model::from_blob(&blob).map_err(|e| format!("generated blob: {e}"))?;

    let k = 20usize;
    let n_cases = 12u32;
    let mut p = Predictor::<LibmSine, 128>::new(model).map_err(|e| format!("predictor: {e:?}"))?;
    let mut cases = Vec::new();
    for c in 0..n_cases {
        let (x0, y0) = (100.0 + 50.0 * c as f32, 700.0 - 40.0 * c as f32);
        let v = [rng.next() * 5.0, rng.next() * 5.0];
        let past: Vec<[f32; 2]> = (0..past_len)
            .map(|t| {
                [
                    x0 + v[0] * t as f32 + rng.next() * 0.5,
                    y0 + v[1] * t as f32 + rng.next() * 0.5,
                ]
            })
            .collect();
        let seed = 0x9e37_79b9_7f4a_7c15u64.wrapping_mul(c as u64 + 1);
        let mut endpoints = vec![[0.0f32; 2]; k];
        p.predict_samples(&past, seed, &mut endpoints)
            .map_err(|e| format!("prediction: {e:?}"))?;
        cases.push(GoldenCase {
            past,
            seed,
            endpoints,
            ..GoldenCase::default()
        });
    }
    let golden = golden_bytes(
        &GoldenInfo {
            model_name: &name,
            model_crc: model.crc(),
            sine: LibmSine::NAME,
            past_len: past_len as u8,
            future_len: future_len as u8,
            k: k as u8,
            n_cases,
        },
        &cases,
    )?;
    for (ext, bytes) in [("gpec", &blob), ("golden", &golden)] {
        let path = dir.join(format!("{name}.{ext}"));
        std::fs::write(&path, bytes).map_err(|e| format!("writing {}: {e}", path.display()))?;
    }
    println!(
        "wrote {}/{name}.gpec ({} B) and .golden ({} B, {n_cases} cases)",
        dir.display(),
        blob.len(),
        golden.len()
    );
    Ok(())
}
