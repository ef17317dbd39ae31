//! Dev tool: `make-test-blob DIR [NAME]` writes DIR/NAME.gpec (a synthetic,
//! randomly initialised SIREN G-PECNet of realistic shape) and DIR/NAME.golden
//! (its outputs, computed here with gpecnet-core + LibmSine). It exercises the
//! firmware pipeline (embedding, golden replay, host comparison, profiling)
//! before trained weights exist. Never ship its output in weights/.
use gpecnet_core::blob::{
    Activation, LayerWire, ModelConfig, ModelInfo, NumericKind, Preamble, CRC32, MIN_FORMAT_VERSION,
    MAGIC,
};
use gpecnet_core::golden::{
    GoldenCaseWire, GoldenInfo, GoldenPreamble, GOLDEN_MAGIC, GOLDEN_VERSION,
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

fn f32s(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn put<T: serde_like::Ser>(out: &mut Vec<u8>, v: &T) {
    out.extend(v.ser());
}

mod serde_like {
    pub trait Ser {
        fn ser(&self) -> Vec<u8>;
    }
    impl<T: serde::Serialize> Ser for T {
        fn ser(&self) -> Vec<u8> {
            postcard::to_allocvec(self).expect("postcard")
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = std::path::PathBuf::from(args.first().expect("usage: make-test-blob DIR [NAME]"));
    let name = args
        .get(1)
        .cloned()
        .unwrap_or_else(|| "synthetic-test".into());
    std::fs::create_dir_all(&dir).unwrap();
    let (past_len, future_len, fdim, zdim) = (8u8, 12u8, 16u16, 16u16);
    let mut rng = Lcg(0x1234_5678);
    // encoder_past 16 -> 64 -> 32 -> 16 ; decoder 32 -> 64 -> 64 -> 2 (SIREN: first layer w0 = 30 folded)
    let shapes_enc = [
        (16u16, 64u16, Activation::Sine, 30.0f32),
        (64, 32, Activation::Sine, 1.0),
        (32, 16, Activation::Linear, 1.0),
    ];
    let shapes_dec = [
        (32u16, 64u16, Activation::Sine, 30.0f32),
        (64, 64, Activation::Sine, 1.0),
        (64, 2, Activation::Linear, 1.0),
    ];
    let mut tensors: Vec<(u16, u16, Activation, Vec<u8>, Vec<u8>)> = Vec::new();
    for &(i, o, a, w0) in shapes_enc.iter().chain(shapes_dec.iter()) {
        let lim = if w0 > 1.0 {
            1.0 / i as f32
        } else {
            (6.0 / i as f32).sqrt()
        };
        let w: Vec<f32> = (0..i as usize * o as usize)
            .map(|_| rng.next() * lim * w0)
            .collect();
        let b: Vec<f32> = (0..o as usize).map(|_| rng.next() * 0.1).collect();
        tensors.push((i, o, a, f32s(&w), f32s(&b)));
    }
    let mut blob = Vec::new();
    put(
        &mut blob,
        &Preamble {
            magic: MAGIC,
            version: MIN_FORMAT_VERSION,
        },
    );
    let config = ModelConfig {
        past_len,
        future_len,
        fdim,
        zdim,
        data_scale: 1.86,
        sigma: 1.3,
        initial_pos_divisor: 1000.0,
        w0: 30.0,
        hidden_activation: Activation::Sine,
    };
    put(
        &mut blob,
        &ModelInfo {
            numeric: NumericKind::F32,
            name: &name,
            config,
        },
    );
    for net in [&tensors[0..3], &tensors[3..6], &[][..], &[][..]] {
        put(&mut blob, &(net.len() as u8));
        for (i, o, a, w, b) in net {
            put(
                &mut blob,
                &LayerWire {
                    in_dim: *i,
                    out_dim: *o,
                    activation: *a,
                    weights: w,
                    bias: b,
                },
            );
        }
    }
    let crc = CRC32.checksum(&blob);
    blob.extend(crc.to_le_bytes());
    let model = Model::from_blob(&blob).expect("generated blob must validate");

    let k = 20u8;
    let n_cases = 12u32;
    let mut p = Predictor::<LibmSine, 128>::new(model).unwrap();
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
        let mut ends = vec![[0.0f32; 2]; k as usize];
        p.predict_samples(&past, seed, &mut ends).unwrap();
        let pb = f32s(&past.iter().flatten().copied().collect::<Vec<_>>());
        let eb = f32s(&ends.iter().flatten().copied().collect::<Vec<_>>());
        cases.push((pb, seed, eb));
    }
    let mut g = Vec::new();
    put(
        &mut g,
        &GoldenPreamble {
            magic: GOLDEN_MAGIC,
            version: GOLDEN_VERSION,
        },
    );
    put(
        &mut g,
        &GoldenInfo {
            model_name: &name,
            model_crc: model.crc(),
            sine: LibmSine::NAME,
            past_len,
            future_len,
            k,
            n_cases,
        },
    );
    for (pb, seed, eb) in &cases {
        put(
            &mut g,
            &GoldenCaseWire {
                past: pb,
                seed: *seed,
                endpoints: eb,
                trajectory0: &[],
            },
        );
    }
    let crc = CRC32.checksum(&g);
    g.extend(crc.to_le_bytes());
    gpecnet_core::golden::GoldenSet::parse(&g).expect("generated golden must validate");
    std::fs::write(dir.join(format!("{name}.gpec")), &blob).unwrap();
    std::fs::write(dir.join(format!("{name}.golden")), &g).unwrap();
    println!(
        "wrote {}/{name}.gpec ({} B) and .golden ({} B, {n_cases} cases)",
        dir.display(),
        blob.len(),
        g.len()
    );
}
