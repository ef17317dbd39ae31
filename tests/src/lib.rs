//! Shared helpers for the workspace tests: finding the data and the shipped blobs.

use std::path::{Path, PathBuf};

use gpecnet_core::golden::GoldenSet;
use gpecnet_core::{Model, NumericKind, Predictor, Sine};

use gpecnet_data::Dataset;
use gpecnet_metrics::eval::Prediction;

use gpecnet_reference::network::RefConfig;
use gpecnet_reference::network::{Act, Layer, Networks};
use gpecnet_reference::reference::RefModel;

/// The workspace root.
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(PathBuf::from)
        .unwrap_or_default()
}

/// `../shared/data` next to the checkout (or `GPECNET_DATA`).
pub fn data_root() -> PathBuf {
    std::env::var_os("GPECNET_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("../shared/data"))
}

/// Every `weights/*.gpec` blob, sorted.
pub fn shipped_blobs() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(workspace_root().join("weights"))
        .map(|d| {
            d.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "gpec"))
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// The data set a shipped blob's card is about (`dataset` in `<blob>.json`; `sdd` when the card
/// does not say).
pub fn card_dataset(blob: &Path) -> gpecnet_data::DatasetSpec {
    let card: serde_json::Value =
        serde_json::from_slice(&std::fs::read(blob.with_extension("json")).unwrap()).unwrap();
    gpecnet_metrics::card::card_dataset(&card).unwrap()
}

/// The test split of the data set a shipped blob's card is about.
pub fn card_test_set(blob: &Path) -> Dataset {
    gpecnet_metrics::card::test_windows(&data_root(), &card_dataset(blob))
        .expect("test set (see ../shared/data/README.md)")
}

/// The shipped blobs of one numeric kind, sorted.
pub fn shipped_blobs_of(kind: NumericKind) -> Vec<PathBuf> {
    shipped_blobs()
        .into_iter()
        .filter(|p| {
            let b = std::fs::read(p).unwrap();
            Model::from_blob(&b).is_ok_and(|m| m.numeric() == kind)
        })
        .collect()
}

/// Asserts that a shipped blob has its golden file and model card (`.json`, `.md`) beside it.
pub fn assert_sidecars(blob: &Path) {
    for ext in ["golden", "json", "md"] {
        assert!(
            blob.with_extension(ext).exists(),
            "{} has no .{ext}",
            blob.display()
        );
    }
}

/// A shipped blob and its golden file, read.
pub struct Shipped {
    /// The blob's path.
    pub path: PathBuf,
    /// The blob's bytes.
    pub blob: Vec<u8>,
    /// The golden file's bytes.
    pub golden: Vec<u8>,
}

impl Shipped {
    /// Reads `path` and the golden file beside it.
    pub fn read(path: &Path) -> Self {
        Self {
            path: path.to_path_buf(),
            blob: std::fs::read(path).unwrap(),
            golden: std::fs::read(path.with_extension("golden")).unwrap(),
        }
    }

    /// The blob's model.
    pub fn model(&self) -> Model<'_> {
        Model::from_blob(&self.blob).unwrap()
    }

    /// The golden file, checked to be for these weights.
    pub fn golden(&self) -> GoldenSet<'_> {
        let golden = GoldenSet::parse(&self.golden).unwrap();
        assert_eq!(
            golden.info().model_crc,
            self.model().crc(),
            "{}: golden file is for other weights",
            self.path.display()
        );
        golden
    }

    /// Replays every golden case through `gpecnet_core::Predictor` with the sine the golden
    /// file names ([`replay_golden`]) and asserts that every value is reproduced bit for bit.
    pub fn assert_replays(&self) {
        let (model, golden) = (self.model(), self.golden());
        let bad = match golden.info().sine {
            "libm" | "q15-table" => replay_golden::<gpecnet_core::LibmSine>(&model, &golden),
            "fast-f32" => replay_golden::<gpecnet_core::FastSine>(&model, &golden),
            other => panic!("{}: unknown sine {other}", self.path.display()),
        };
        assert_eq!(
            bad,
            0,
            "{}: {bad} values differ from the trainer's",
            self.path.display()
        );
    }
}

/// How many trajectory points of `a` and `b` (prediction by prediction, sample by sample)
/// differ in their bits; the sample counts must agree.
pub fn mismatches(a: &[Prediction], b: &[Prediction]) -> usize {
    let mut n = 0;
    for (x, y) in a.iter().zip(b) {
        assert_eq!(x.trajectories.len(), y.trajectories.len());
        for (tx, ty) in x.trajectories.iter().zip(&y.trajectories) {
            for (p, q) in tx.iter().zip(ty) {
                n += usize::from(p.map(f32::to_bits) != q.map(f32::to_bits));
            }
        }
    }
    n
}

/// Golden-file inputs from every `stride`-th window of `test`: the observed positions and
/// the latent seed (the input's index).
pub fn golden_inputs(test: &Dataset, stride: usize) -> Vec<(Vec<[f32; 2]>, u64)> {
    test.windows
        .iter()
        .step_by(stride)
        .enumerate()
        .map(|(i, w)| (w.obs().to_vec(), i as u64))
        .collect()
}

/// SplitMix64: a tiny deterministic generator for test inputs.
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1), 24 bits.
    pub fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in `0..n`.
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    /// Uniform in [lo, hi), 53 bits.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }
}

/// A SIREN model with SIREN-initialised random weights (w0 folded), of the
/// given widths, for tests that need a model before training.
pub fn random_siren(
    name: &str,
    enc: &[usize],
    dec: &[usize],
    dest: &[usize],
    pred: &[usize],
    seed: u32,
) -> RefModel {
    let (fdim, zdim, w0) = (16usize, 16usize, 30.0f32);
    let mut s = seed.wrapping_mul(0x9E37_79B9) | 1;
    let mut uni = move || {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        (s >> 8) as f32 / 16_777_216.0 * 2.0 - 1.0
    };
    let mut net = |dims: Vec<usize>| -> Vec<Layer> {
        let n = dims.len() - 1;
        (0..n)
            .map(|l| {
                let (i, o) = (dims[l], dims[l + 1]);
                let last = l + 1 == n;
                let bound = if l == 0 {
                    1.0 / i as f32
                } else {
                    (6.0 / i as f32).sqrt() / w0
                };
                let fold = if last { 1.0 } else { w0 };
                let w = (0..i * o).map(|_| uni() * bound * fold).collect();
                let b = (0..o).map(|_| uni() / (i as f32).sqrt() * fold).collect();
                Layer::new(i, o, if last { Act::Linear } else { Act::Sine }, w, b)
            })
            .collect()
    };
    let ddim = *dest.last().unwrap_or(&16);
    let with = |a: usize, mid: &[usize], b: usize| [&[a][..], mid, &[b][..]].concat();
    RefModel {
        name: name.to_string(),
        config: RefConfig {
            past_len: 8,
            future_len: 12,
            fdim,
            zdim,
            data_scale: 1.86,
            sigma: 1.3,
            initial_pos_divisor: 1000.0,
            w0,
            hidden_act: Act::Sine,
            heading_steps: 0,
            tts_samples: 0,
            tts_iters: 0,
            tts_init: 0,
            latent_bound: 0.0,
            radius_scales: [0.0; 2],
            meta: None,
        },
        nets: Networks {
            encoder_past: net(with(16, enc, fdim)),
            decoder: net(with(fdim + zdim, dec, 2)),
            encoder_dest: net(with(2, &dest[..dest.len() - 1], ddim)),
            predictor: net(with(fdim + ddim + 2, pred, 22)),
            point_head: Vec::new(),
            proposal: Vec::new(),
        },
    }
}

/// `m` with the format-2 features: the heading frame over `heading_steps`, a random point
/// head of hidden widths `head`, and test-time sampling of `tts` samples (3 Lloyd
/// iterations, first-K init; 0 = off).
pub fn with_v2_features(
    mut m: RefModel,
    heading_steps: usize,
    head: &[usize],
    tts: usize,
    seed: u32,
) -> RefModel {
    let donor = random_siren("donor", head, &[8], &[8, 16], &[8], seed);
    // The donor's past encoder has the point head's input width; re-draw its output layer
    // at the head's output width (2 · future_len) with the same bounds.
    let mut layers = donor.nets.encoder_past;
    if let Some(last) = layers.last_mut() {
        let out = 2 * m.config.future_len;
        let i = last.in_dim;
        last.out_dim = out;
        last.w = (0..out * i)
            .map(|j| last.w[j % last.w.len()] * if j % 3 == 0 { -1.0 } else { 1.0 })
            .collect();
        last.b = (0..out).map(|j| last.b[j % last.b.len()]).collect();
    }
    m.nets.point_head = layers;
    m.config.heading_steps = heading_steps;
    m.config.tts_samples = tts;
    m.config.tts_iters = if tts > 0 { 3 } else { 0 };
    m.config.tts_init = 0;
    m
}

/// Replays every case of `golden` through `gpecnet_core::Predictor` with sine `S` (the engine
/// of the blob's numeric kind): the endpoint set, the point forecast and sample 0's trajectory
/// where recorded. Returns how many values differ from the recorded bits.
pub fn replay_golden<S: Sine>(model: &Model<'_>, golden: &GoldenSet<'_>) -> usize {
    let mut p = Box::new(Predictor::<S, 1024>::new(*model).unwrap());
    let mut bad = 0;
    for case in golden.cases() {
        // The model's endpoint set (test-time sampling when the blob asks for it).
        let mut ends = vec![[0.0f32; 2]; case.k()];
        p.predict_endpoint_set::<{ gpecnet_core::blob::MAX_TTS_SAMPLES }>(
            &case.past, case.seed, &mut ends,
        )
        .unwrap();
        for (i, e) in ends.iter().enumerate() {
            bad += usize::from(e.map(f32::to_bits) != case.endpoint_bits(i));
        }
        // The point forecast, recorded for models with a point head (golden version 2).
        assert_eq!(model.has_point_head(), case.point_len() > 0);
        if model.has_point_head() {
            let t = p.predict_point(&case.past).unwrap();
            for (j, pt) in t.iter().enumerate() {
                bad += usize::from(Some(pt.map(f32::to_bits)) != case.point_bits(j));
            }
        }
        if case.trajectory0_len() > 0 {
            let mut t = [gpecnet_core::Trajectory::new()];
            p.predict_trajectories(&case.past, case.seed, &mut t)
                .unwrap();
            for (j, pt) in t[0].iter().enumerate() {
                bad += usize::from(Some(pt.map(f32::to_bits)) != case.trajectory0_bits(j));
            }
        }
    }
    bad
}
