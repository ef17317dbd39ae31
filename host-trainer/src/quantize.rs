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
//! * **Integer reference** ([`QModel::predict`]): written from the
//!   specification in `gpecnet_core::fixed`, independently of it (own table,
//!   own rounding, a full decoder pass per sample); the workspace tests
//!   compare the two bit for bit.

use anyhow::{anyhow, bail, Context, Result};
use gpecnet_core::blob::NumericKind;
use serde::{Deserialize, Serialize};

use crate::core_eval::linear_fill;
use crate::data::{Dataset, Window, PAST};
use crate::eval::{dist_metrics, DistMetrics, Metrics, Prediction};
use crate::export::GoldenCase;
use crate::network::{Act, InferenceModel, Layer, Networks, QScale, Q15};
use crate::reference::{Normals, RefModel};

/// Headroom over the calibrated maximum of each activation vector.
pub const MARGIN: f64 = 1.5;
/// The name golden files and cards use for the fixed-point sine.
pub const SINE_NAME: &str = "q15-table";
const MIN_EXP: i32 = -8;
const MAX_EXP: i32 = 30;

/// One quantized layer (mirrors `LayerWireQ`).
pub type QLayer = Layer<Q15>;

/// A quantized model (the same networks as its f32 source, int16/int32 with scales).
pub type QModel = InferenceModel<Q15>;

// ---------------------------------------------------------------- calibration

/// Largest magnitudes seen while running the f32 model (f64 arithmetic).
#[derive(Clone, Debug, Default)]
pub struct Calibration {
    /// encoder_past input.
    pub input: f64,
    /// Per network (enc, dec, dest, pred, point head), per layer: max |output|.
    pub layers: [Vec<f64>; 5],
    /// The latent (`sigma · N(0, 1)`).
    pub z: f64,
    /// `initial_pos`.
    pub init: f64,
    /// Windows used.
    pub windows: usize,
}

fn run_f64(net: &[Layer], x: &[f64], maxes: &mut [f64]) -> Vec<f64> {
    let mut cur = x.to_vec();
    for (l, m) in net.iter().zip(maxes.iter_mut()) {
        let mut y = Vec::with_capacity(l.out_dim);
        for j in 0..l.out_dim {
            let mut s = l.b[j] as f64;
            for (w, x) in l.w[j * l.in_dim..(j + 1) * l.in_dim].iter().zip(&cur) {
                s += *w as f64 * x;
            }
            let v = match l.act {
                Act::Linear => s,
                Act::Relu => s.max(0.0),
                Act::Sine => s.sin(),
            };
            *m = m.max(v.abs());
            y.push(v);
        }
        cur = y;
    }
    cur
}

/// Runs `model` on `windows` with `k` latent samples each (window `i` uses seed `i`).
pub fn calibrate(model: &RefModel, windows: &[Window], k: usize) -> Calibration {
    let c = &model.config;
    let nets = model.nets.in_blob_order();
    let mut cal = Calibration {
        layers: nets.map(|n| vec![0.0; n.len()]),
        ..Default::default()
    };
    for (wi, w) in windows.iter().enumerate() {
        let past = w.obs();
        let fr = model.frame(&past);
        let x: Vec<f64> = past
            .iter()
            .flat_map(|p| fr.input(*p, c.data_scale).map(f64::from))
            .collect();
        cal.input = x.iter().fold(cal.input, |m, v| m.max(v.abs()));
        let f = run_f64(&model.nets.encoder_past, &x, &mut cal.layers[0]);
        if !model.nets.point_head.is_empty() {
            run_f64(&model.nets.point_head, &x, &mut cal.layers[4]);
        }
        let mut normals = Normals::new(wi as u64);
        let last = fr.predictor_position(past[PAST - 1]);
        for _ in 0..k {
            let mut input = f.clone();
            for _ in 0..c.zdim {
                let z = c.sigma * normals.next_normal();
                cal.z = cal.z.max(z.abs() as f64);
                input.push(z as f64);
            }
            let d = run_f64(&model.nets.decoder, &input, &mut cal.layers[1]);
            if !model.nets.predictor.is_empty() {
                let g = run_f64(&model.nets.encoder_dest, &d, &mut cal.layers[2]);
                let mut pin = f.clone();
                pin.extend(g);
                for v in last {
                    let ip = (v / c.initial_pos_divisor) as f64;
                    cal.init = cal.init.max(ip.abs());
                    pin.push(ip);
                }
                run_f64(&model.nets.predictor, &pin, &mut cal.layers[3]);
            }
        }
        cal.windows += 1;
    }
    cal
}

fn exp_for(max: f64) -> i32 {
    if max.is_nan() || max <= 0.0 {
        return MAX_EXP;
    }
    ((32767.0 / (max * MARGIN)).log2().floor() as i32).clamp(MIN_EXP, MAX_EXP)
}

fn quantize_layer(l: &Layer, in_exp: i32, out_exp: i32) -> QLayer {
    let (fold, target, s_lo) = match l.act {
        Act::Sine => (1.0 / std::f64::consts::TAU, 32, -31),
        _ => (1.0, out_exp, 0),
    };
    let mut q = QLayer {
        in_dim: l.in_dim,
        out_dim: l.out_dim,
        act: l.act,
        w: Vec::with_capacity(l.w.len()),
        b: Vec::with_capacity(l.out_dim),
        scale: QScale {
            in_exp: in_exp as i8,
            out_exp: if l.act == Act::Sine {
                15
            } else {
                out_exp as i8
            },
            shifts: Vec::with_capacity(l.out_dim),
        },
    };
    for j in 0..l.out_dim {
        let row: Vec<f64> = l.w[j * l.in_dim..(j + 1) * l.in_dim]
            .iter()
            .map(|&v| v as f64 * fold)
            .collect();
        let b = l.b[j] as f64 * fold;
        let wmax = row.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut ew = 62 + target - in_exp; // largest shift allowed
        if wmax > 0.0 {
            ew = ew.min((32767.0 / wmax).log2().floor() as i32);
        }
        if b != 0.0 {
            ew = ew.min((2_147_483_647.0 / b.abs()).log2().floor() as i32 - in_exp);
        }
        ew = ew.max(s_lo + target - in_exp); // smallest shift allowed (values saturate below)
        let sw = (ew as f64).exp2();
        q.w.extend(
            row.iter()
                .map(|v| (v * sw).round().clamp(-32768.0, 32767.0) as i16),
        );
        q.b.push(
            (b * ((ew + in_exp) as f64).exp2())
                .round()
                .clamp(-2_147_483_648.0, 2_147_483_647.0) as i32,
        );
        q.scale.shifts.push((ew + in_exp - target) as i8);
    }
    q
}

/// Quantizes one network: input exponent `e_in`, output exponent `e_out`,
/// hidden non-sine layers from their calibrated maxima.
fn quantize_net(net: &[Layer], maxes: &[f64], e_in: i32, e_out: i32) -> Vec<QLayer> {
    let mut e = e_in;
    net.iter()
        .enumerate()
        .map(|(i, l)| {
            let out = if i + 1 == net.len() {
                e_out
            } else if l.act == Act::Sine {
                15
            } else {
                exp_for(maxes[i])
            };
            let q = quantize_layer(l, e, out);
            e = q.scale.out_exp as i32;
            q
        })
        .collect()
}

/// Post-training quantization of `model` with calibration `cal`.
pub fn quantize(model: &RefModel, cal: &Calibration, name: &str) -> Result<QModel> {
    model.validate()?;
    let last_max = |n: usize| cal.layers[n].last().copied().unwrap_or(0.0);
    for net in model.nets.in_blob_order() {
        if net.last().is_some_and(|l| l.act == Act::Sine) {
            bail!("a network ending in a sine layer is not supported by the fixed-point kind");
        }
    }
    // The input exponent also covers the core's whole valid input range
    // (`gpecnet_core::frame::MAX_INPUT`, 2^12 → e ≤ 3), so the fixed-point blob
    // refuses exactly the inputs its f32 source refuses (`Model::input_limit`)
    // however few windows were calibrated on.
    let e_in = exp_for(cal.input).min(15 - gpecnet_core::frame::MAX_INPUT.log2() as i32);
    let mut e_f = exp_for(last_max(0)).min(exp_for(cal.z));
    let e_d = exp_for(last_max(1));
    let has_pred = !model.nets.predictor.is_empty();
    if has_pred {
        e_f = e_f.min(exp_for(last_max(2))).min(exp_for(cal.init));
    }
    let e_q = exp_for(last_max(3));
    Ok(QModel {
        name: name.to_string(),
        config: model.config.clone(),
        nets: Networks {
            encoder_past: quantize_net(&model.nets.encoder_past, &cal.layers[0], e_in, e_f),
            decoder: quantize_net(&model.nets.decoder, &cal.layers[1], e_f, e_d),
            encoder_dest: if has_pred {
                quantize_net(&model.nets.encoder_dest, &cal.layers[2], e_d, e_f)
            } else {
                vec![]
            },
            predictor: if has_pred {
                quantize_net(&model.nets.predictor, &cal.layers[3], e_f, e_q)
            } else {
                vec![]
            },
            point_head: quantize_net(
                &model.nets.point_head,
                &cal.layers[4],
                e_in,
                exp_for(last_max(4)),
            ),
        },
    })
}

// ------------------------------------------------------- integer reference

/// The quarter-wave table, `round(32768 · sin(π/2 · i / 256))`, computed here in f64.
fn table() -> &'static [i64; 257] {
    static T: std::sync::OnceLock<[i64; 257]> = std::sync::OnceLock::new();
    T.get_or_init(|| {
        std::array::from_fn(|i| {
            (32768.0 * (std::f64::consts::FRAC_PI_2 * i as f64 / 256.0).sin()).round() as i64
        })
    })
}

/// `sin(2π · phase / 2^32)` in Q15 from the specification (saturated to
/// ±32767 so every activation fits an i16).
pub fn sin_q15_ref(phase: u32) -> i64 {
    let t = table();
    let q = phase / (1 << 30);
    let off = phase % (1 << 30);
    let p = if q % 2 == 1 { (1u32 << 30) - off } else { off };
    let i = (p / (1 << 22)) as usize;
    let frac = ((p % (1 << 22)) / 64) as i64;
    let a = t[i];
    let b = if i < 256 { t[i + 1] } else { t[256] };
    let v = (a + ((b - a) * frac + 32768).div_euclid(65536)).min(32767);
    if q >= 2 {
        -v
    } else {
        v
    }
}

/// Rounds half up at `s` fractional bits (`floor((a + 2^(s−1)) / 2^s)`).
fn round_shift(a: i64, s: i32) -> i64 {
    if s <= 0 {
        a
    } else {
        (a + (1i64 << (s - 1))).div_euclid(1i64 << s)
    }
}

/// `clamp(round_ties_even(x · 2^e), −32768, 32767)` with f32 arithmetic.
pub fn quantize_value(x: f32, e: i8) -> i64 {
    let v = x * (e as f32).exp2();
    let r = if v.abs() < 4_194_304.0 {
        (v + 12_582_912.0) - 12_582_912.0
    } else {
        v
    };
    if r.is_nan() {
        0
    } else {
        r.clamp(-32768.0, 32767.0) as i64
    }
}

impl QLayer {
    fn forward(&self, x: &[i64]) -> Vec<i64> {
        (0..self.out_dim)
            .map(|j| {
                let row = &self.w[j * self.in_dim..(j + 1) * self.in_dim];
                let acc: i64 =
                    self.b[j] as i64 + row.iter().zip(x).map(|(&w, &v)| w as i64 * v).sum::<i64>();
                let s = self.scale.shifts[j] as i32;
                match self.act {
                    Act::Linear => round_shift(acc, s).clamp(-32768, 32767),
                    Act::Relu => round_shift(acc, s).clamp(0, 32767),
                    Act::Sine => {
                        let phase = if s >= 0 {
                            round_shift(acc, s).rem_euclid(1 << 32)
                        } else {
                            (acc.rem_euclid(1 << 32) << -s).rem_euclid(1 << 32)
                        };
                        sin_q15_ref(phase as u32)
                    }
                }
            })
            .collect()
    }
}

fn run_q(net: &[QLayer], x: &[i64]) -> Vec<i64> {
    net.iter().fold(x.to_vec(), |cur, l| l.forward(&cur))
}

fn deq(v: i64, e: i8) -> f32 {
    v as f32 * (-(e as f32)).exp2()
}

impl QModel {
    /// Endpoints (and trajectories) by the integer specification, naively.
    pub fn predict(
        &self,
        past: &[[f32; 2]],
        seed: u64,
        k: usize,
    ) -> (Vec<[f32; 2]>, Vec<Vec<[f32; 2]>>) {
        let c = &self.config;
        let e_f = self.nets.decoder[0].scale.in_exp;
        let e_d = self.nets.decoder.last().map_or(0, |l| l.scale.out_exp);
        let fr = self.frame(past);
        let x = self.input(past);
        let f = run_q(&self.nets.encoder_past, &x);
        let mut normals = Normals::new(seed);
        let last = fr.predictor_position(past[past.len() - 1]);
        let (mut ends, mut trajs) = (Vec::with_capacity(k), Vec::new());
        for _ in 0..k {
            let mut input = f.clone();
            for _ in 0..c.zdim {
                input.push(quantize_value(c.sigma * normals.next_normal(), e_f));
            }
            let d = run_q(&self.nets.decoder, &input);
            let e = fr.output([deq(d[0], e_d), deq(d[1], e_d)], c.data_scale);
            ends.push(e);
            if !self.nets.predictor.is_empty() {
                let mut pin = f.clone();
                pin.extend(run_q(&self.nets.encoder_dest, &d));
                pin.push(quantize_value(last[0] / c.initial_pos_divisor, e_f));
                pin.push(quantize_value(last[1] / c.initial_pos_divisor, e_f));
                let q = run_q(&self.nets.predictor, &pin);
                let e_q = self.nets.predictor.last().map_or(0, |l| l.scale.out_exp);
                let mut t: Vec<[f32; 2]> = q
                    .chunks(2)
                    .map(|p| fr.output([deq(p[0], e_q), deq(p[1], e_q)], c.data_scale))
                    .collect();
                t.push(e);
                trajs.push(t);
            }
        }
        (ends, trajs)
    }

    /// The quantised network input (encoder_past's exponent; the point head shares it).
    fn input(&self, past: &[[f32; 2]]) -> Vec<i64> {
        let (c, fr) = (&self.config, self.frame(past));
        let e_in = self.nets.encoder_past[0].scale.in_exp;
        past.iter()
            .flat_map(|p| fr.input(*p, c.data_scale).map(|v| quantize_value(v, e_in)))
            .collect()
    }

    /// The endpoint set by the blob's protocol (see [`RefModel::predict_set`]).
    pub fn predict_set(&self, past: &[[f32; 2]], seed: u64, k: usize) -> Result<Vec<[f32; 2]>> {
        let c = &self.config;
        if c.tts_samples == 0 {
            return Ok(self.predict(past, seed, k).0);
        }
        let samples = self.predict(past, seed, c.tts_samples).0;
        crate::reference::tts_reduce(c, &samples, k)
    }

    /// The point head's forecast by the integer specification, or `None` without a head.
    pub fn predict_point(&self, past: &[[f32; 2]]) -> Option<Vec<[f32; 2]>> {
        let last = self.nets.point_head.last()?;
        let (c, fr) = (&self.config, self.frame(past));
        let q = run_q(&self.nets.point_head, &self.input(past));
        let e = last.scale.out_exp;
        Some(
            q.chunks(2)
                .map(|p| fr.output([deq(p[0], e), deq(p[1], e)], c.data_scale))
                .collect(),
        )
    }
}

// ------------------------------------------------------------------ export

/// Golden cases of a fixed-point model from the integer reference (sine name [`SINE_NAME`]).
pub fn qgolden_bytes(
    m: &QModel,
    model_crc: u32,
    k: usize,
    inputs: &[(Vec<[f32; 2]>, u64)],
) -> Result<Vec<u8>> {
    let c = &m.config;
    let cases: Vec<GoldenCase> = inputs
        .iter()
        .map(|(past, seed)| {
            let (endpoints, trajectory0) = if c.tts_samples > 0 {
                (m.predict_set(past, *seed, k)?, Vec::new())
            } else {
                let (ends, trajs) = m.predict(past, *seed, k);
                (ends, trajs.first().cloned().unwrap_or_default())
            };
            Ok(GoldenCase {
                past: past.clone(),
                seed: *seed,
                endpoints,
                trajectory0,
                point: m.predict_point(past).unwrap_or_default(),
            })
        })
        .collect::<Result<_>>()?;
    crate::export::golden_bytes(m, model_crc, SINE_NAME, k, &cases)
}

// -------------------------------------------------------------- evaluation

/// K samples for one window of a fixed-point blob through `gpecnet_core`
/// (the run-time dispatching predictor; the sine argument is irrelevant for
/// fixed-point blobs).
pub fn predict_core_fixed(
    model: &gpecnet_core::Model<'_>,
    w: &Window,
    seed: u64,
    k: usize,
) -> Result<Prediction> {
    crate::core_eval::predict_core(model, crate::reference::SineKind::Libm, w, seed, k)
}

/// K samples for one window through the integer reference.
pub fn predict_reference_fixed(m: &QModel, w: &Window, seed: u64, k: usize) -> Prediction {
    let past = w.obs();
    let (ends, trajs) = if m.config.tts_samples > 0 {
        (
            m.predict_set(&past, seed, k).unwrap_or_default(),
            Vec::new(),
        )
    } else {
        m.predict(&past, seed, k)
    };
    let trajectories = if trajs.is_empty() {
        ends.iter()
            .map(|e| linear_fill(past[PAST - 1], *e))
            .collect()
    } else {
        trajs
            .iter()
            .map(|t| crate::core_eval::to_fixed(t))
            .collect()
    };
    Prediction { trajectories }
}

/// Evaluates a fixed-point blob through `gpecnet-core` (window `i` uses seed `base_seed + i`).
pub fn evaluate_core_fixed(
    blob: &[u8],
    ds: &Dataset,
    k: usize,
    base_seed: u64,
) -> Result<(Metrics, Vec<Prediction>)> {
    let model = gpecnet_core::Model::from_blob(blob).map_err(|e| anyhow!("{e}"))?;
    let preds = crate::core_eval::parallel_map(ds.windows.len(), |i| {
        predict_core_fixed(&model, &ds.windows[i], base_seed.wrapping_add(i as u64), k)
    })?;
    Ok((crate::core_eval::accumulate(ds, &preds)?, preds))
}

/// Evaluates the integer reference on every window of `ds`.
pub fn evaluate_reference_fixed(
    m: &QModel,
    ds: &Dataset,
    k: usize,
    base_seed: u64,
) -> Result<(Metrics, Vec<Prediction>)> {
    let preds = crate::core_eval::parallel_map(ds.windows.len(), |i| {
        Ok(predict_reference_fixed(
            m,
            &ds.windows[i],
            base_seed.wrapping_add(i as u64),
            k,
        ))
    })?;
    Ok((crate::core_eval::accumulate(ds, &preds)?, preds))
}

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

// ------------------------------------------------------- gpecnet quantize

/// The machine-readable card of a fixed-point blob (`weights/<name>-q.json`);
/// the workspace tests re-evaluate the blob and require these exact numbers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct QuantCard {
    /// Model name (file stem).
    pub name: String,
    /// File name of the f32 source blob.
    pub source: String,
    /// CRC-32 of the f32 source blob.
    pub source_crc: u32,
    /// Size of the f32 source blob in bytes.
    pub source_bytes: usize,
    /// CRC-32 of the fixed-point blob.
    pub blob_crc: u32,
    /// Size of the fixed-point blob in bytes.
    pub blob_bytes: usize,
    /// Parameters.
    pub parameters: usize,
    /// Sine of the f32 numbers (`libm` / `fast-f32`).
    pub source_sine: String,
    /// Samples per window.
    pub k: usize,
    /// Window `i` of the test set uses latent seed `base_seed + i`.
    pub base_seed: u64,
    /// SDD training windows used for calibration.
    pub calibration_windows: usize,
    /// f32 source through `gpecnet_core::Predictor` on SDD test (pixels).
    pub test_f32: Metrics,
    /// Fixed point through `gpecnet_core::Predictor` (its fixed-point engine) on SDD test (pixels).
    pub test_fixed: Metrics,
    /// Fixed-point engine scratch bytes (`16·W`) at the smallest width the model allows.
    pub scratch_bytes: usize,
    /// Distribution quality of the f32 source's K samples on SDD test (KDE NLL in nats/px,
    /// hit rates at 20 / 40 px).
    pub test_f32_dist: DistMetrics,
    /// The same for the fixed-point blob.
    pub test_fixed_dist: DistMetrics,
    /// Format-2 inference settings (absent for format-1 models).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inference: Option<crate::ship::Inference>,
    /// The f32 source's point forecast on SDD test (K = 1 metrics), for models with a head.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_f32_point: Option<Metrics>,
    /// The fixed-point point forecast on SDD test.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_fixed_point: Option<Metrics>,
    /// Constant velocity with its window chosen on validation, on SDD test.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test_cv: Option<crate::ship::CvBaseline>,
}

/// Every `GOLDEN_STRIDE`-th test window becomes a golden case (as in `ship`).
pub const GOLDEN_STRIDE: usize = 10;

/// `gpecnet quantize`: quantizes the f32 blob `src` (calibrating on every
/// `cal_stride`-th SDD training window, `cal_k` latent samples each) and
/// writes `<out>.gpec/.golden/.json/.md`, the numbers computed through
/// `gpecnet-core` and cross-checked bit for bit against the integer reference.
///
/// With `endpoint_only`: `encoder_dest` and
/// `predictor` are dropped (the format allows both absent), so the blob holds
/// only what endpoint prediction runs (`encoder_past` + `decoder`, about half
/// the parameters); trajectories are then the straight line from the last
/// observation to each endpoint (so ADE differs, FDE does not).
#[allow(clippy::too_many_arguments)]
pub fn quantize_blob_with(
    src: &std::path::Path,
    out: &std::path::Path,
    data_root: &std::path::Path,
    k: usize,
    base_seed: u64,
    cal_stride: usize,
    cal_k: usize,
    endpoint_only: bool,
) -> Result<QuantCard> {
    use crate::data::{load_sdd, SddSplit};
    let name = out
        .file_stem()
        .and_then(|s| s.to_str())
        .ok_or_else(|| anyhow!("--out needs a file name"))?
        .to_string();
    if name.is_empty()
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    {
        bail!("model name {name:?}: use letters, digits, '-' and '_'");
    }
    let src_bytes = std::fs::read(src).with_context(|| format!("reading {}", src.display()))?;
    let src_model = gpecnet_core::Model::from_blob(&src_bytes)
        .map_err(|e| anyhow!("{}: {e}", src.display()))?;
    if src_model.numeric() != NumericKind::F32 {
        bail!("{} is not an f32 blob", src.display());
    }
    let mut model = crate::export::read_blob(&src_bytes)?;
    if endpoint_only {
        model.nets.encoder_dest.clear();
        model.nets.predictor.clear();
    }
    let train = load_sdd(data_root, SddSplit::Train)?;
    let cal_windows: Vec<Window> = train
        .windows
        .iter()
        .step_by(cal_stride.max(1))
        .cloned()
        .collect();
    eprintln!(
        "calibrating on {} SDD training windows (K = {cal_k}) ...",
        cal_windows.len()
    );
    let cal = calibrate(&model, &cal_windows, cal_k);
    let q = quantize(&model, &cal, &name)?;
    let blob = crate::export::blob_bytes(&q)?;
    let core = gpecnet_core::Model::from_blob(&blob).map_err(|e| anyhow!("{e}"))?;
    let test = load_sdd(data_root, SddSplit::Test)?;
    let sine = crate::ship::sine_of_blob(src).unwrap_or(crate::reference::SineKind::Libm);
    eprintln!(
        "evaluating f32 and fixed point on {} SDD test windows (K = {k}) ...",
        test.windows.len()
    );
    let (test_f32, pf) = crate::core_eval::evaluate_core(&src_bytes, sine, &test, k, base_seed)?;
    let test_f32_dist = dist_metrics(&test, &pf).context("empty SDD test set")?;
    let (test_fixed, pc) = evaluate_core_fixed(&blob, &test, k, base_seed)?;
    let test_fixed_dist = dist_metrics(&test, &pc).context("empty SDD test set")?;
    let (ref_fixed, pr) = evaluate_reference_fixed(&q, &test, k, base_seed)?;
    if test_fixed != ref_fixed
        || pc
            .iter()
            .zip(&pr)
            .any(|(a, b)| a.trajectories != b.trajectories)
    {
        bail!("gpecnet-core's fixed path and the integer reference disagree");
    }
    let inputs: Vec<(Vec<[f32; 2]>, u64)> = test
        .windows
        .iter()
        .enumerate()
        .step_by(GOLDEN_STRIDE)
        .map(|(i, w)| (w.obs().to_vec(), base_seed.wrapping_add(i as u64)))
        .collect();
    let golden = qgolden_bytes(&q, core.crc(), k, &inputs)?;
    let test_f32_point = crate::core_eval::evaluate_point_core(&src_bytes, sine, &test)?;
    let test_fixed_point = crate::core_eval::evaluate_point_core(&blob, sine, &test)?;
    if let Some((_, pc)) = &test_fixed_point {
        let same = pc.iter().zip(&test.windows).all(|(p, w)| {
            q.predict_point(&w.obs())
                .is_some_and(|r| p.trajectories[0].as_slice() == r.as_slice())
        });
        if !same {
            bail!("gpecnet-core's fixed point forecast and the integer reference disagree");
        }
    }
    let inference = crate::ship::Inference::of(&model);
    let test_cv = match inference {
        Some(_) => Some(crate::ship::cv_baseline(data_root, &test)?),
        None => None,
    };
    let c = core.config();
    let width = core.max_width().max(c.fdim as usize + c.zdim as usize);
    let card = QuantCard {
        name: name.clone(),
        source: src
            .file_name()
            .and_then(|s| s.to_str())
            .unwrap_or("")
            .to_string(),
        source_crc: src_model.crc(),
        source_bytes: src_bytes.len(),
        blob_crc: core.crc(),
        blob_bytes: blob.len(),
        parameters: q.parameter_count(),
        source_sine: sine.core_name().to_string(),
        k,
        base_seed,
        calibration_windows: cal.windows,
        test_f32,
        test_fixed,
        scratch_bytes: 16 * width,
        test_f32_dist,
        test_fixed_dist,
        inference,
        test_f32_point: test_f32_point.map(|p| p.0),
        test_fixed_point: test_fixed_point.map(|p| p.0),
        test_cv,
    };
    let dir = out.parent().unwrap_or(std::path::Path::new("."));
    let path = |ext: &str| dir.join(format!("{name}.{ext}"));
    crate::rundir::write_atomic(&path("gpec"), &blob)?;
    crate::rundir::write_atomic(&path("golden"), &golden)?;
    crate::rundir::write_atomic(
        &path("json"),
        serde_json::to_string_pretty(&card)?.as_bytes(),
    )?;
    crate::rundir::write_atomic(&path("md"), quant_card_md(&card, &q).as_bytes())?;
    Ok(card)
}

/// Rows for the format-2 features of a fixed-point card (empty for format-1 models): the
/// point forecast in f32 and fixed point beside the validation-chosen constant velocity, and
/// the inference settings.
fn quant_card_v2_rows(c: &QuantCard) -> String {
    let mut s = String::new();
    if let (Some(f), Some(x), Some(cv)) = (&c.test_f32_point, &c.test_fixed_point, &c.test_cv) {
        s += &format!(
            "| point forecast ADE | {:.3} | {:.3} | {:+.3} |\n| point forecast FDE | {:.3} | {:.3} | {:+.3} |\n\
| constant velocity, last {} steps (chosen on validation), ADE / FDE | {:.3} / {:.3} | same | – |\n",
            f.ade_k1,
            x.ade_k1,
            x.ade_k1 - f.ade_k1,
            f.fde_k1,
            x.fde_k1,
            x.fde_k1 - f.fde_k1,
            cv.n,
            cv.test.ade_k1,
            cv.test.fde_k1
        );
    }
    if c.inference.is_some() {
        let rows = crate::ship::card_v2_rows(c.inference.as_ref(), None, None);
        s += &rows.replace(" | – |\n", " | same | – |\n");
    }
    s
}

fn quant_card_md(c: &QuantCard, q: &QModel) -> String {
    let (f, x) = (&c.test_f32, &c.test_fixed);
    let exps: Vec<String> = crate::network::NETWORK_NAMES
        .iter()
        .zip(q.nets.in_blob_order())
        .filter(|(_, n)| !n.is_empty())
        .map(|(name, n)| {
            format!(
                "{name}: {}",
                n.iter()
                    .map(|l| format!("{}→{}", l.scale.in_exp, l.scale.out_exp))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
        .collect();
    format!(
        "# Model card: `{name}` (fixed point)\n\n\
Post-training quantization of `weights/{src}` to the `Int16Q15` blob kind (`weights/FORMAT.md`): int16 weights with a \
power-of-two scale per output channel, int32 biases, 16-bit activations, 64-bit accumulators, integer table sine \
(`q15-table`, saturated to ±32767, max error 3.1e-5). Inference inside the networks is pure integer (`gpecnet_core::Predictor` runs such a blob on its fixed-point engine, `Engine<Q15>`).\n\n\
| | |\n|---|---|\n\
| blob | `weights/{name}.gpec`, {bytes} bytes (f32 source: {sbytes} bytes), CRC-32 `{crc:#010x}` |\n\
| source | `{src}`, CRC-32 `{scrc:#010x}`, numbers with sine `{ssine}` |\n\
| parameters | {params} |\n\
| calibration | {cal} SDD training windows, margin {margin} |\n\
| exponents (in→out per layer) | {exps} |\n\
| fixed-point engine scratch at minimum width (`Engine<Q15, W>` rows, `16·W`) | {scratch} bytes |\n\
| networks | {nets} |\n\
| produced by | `gpecnet quantize --blob weights/{src} --out weights/{name}.gpec{flag}` |\n\n\
## SDD test set ({n} windows, pixels), both through `gpecnet-core`\n\n\
Latent seed of window `i` = {seed} + i.\n\n\
| metric | f32 source | fixed point | difference |\n|---|---|---|---|\n\
| minADE, best of K = {k} | {fa:.3} | {xa:.3} | {da:+.3} |\n\
| minFDE, best of K = {k} | {ff:.3} | {xf:.3} | {df:+.3} |\n\
| ADE, K = 1 | {fa1:.3} | {xa1:.3} | {da1:+.3} |\n\
| FDE, K = 1 | {ff1:.3} | {xf1:.3} | {df1:+.3} |\n\
{dist}\n\
## Data licence\n\n\
Derived from weights trained on the Stanford Drone Dataset (CC BY-NC-SA 3.0): attribution required, no commercial use, share alike.\n",
        name = c.name,
        src = c.source,
        nets = if q.nets.predictor.is_empty() {
            "encoder_past + decoder only (endpoint-only: the trajectory predictor is left out; \
endpoints are the product, e.g. for a drone's path planner; ADE below uses the straight line \
from the last observation to each endpoint, FDE is unaffected)"
        } else {
            "encoder_past, decoder, encoder_dest, predictor"
        },
        flag = if q.nets.predictor.is_empty() { " --endpoint-only" } else { "" },
        bytes = c.blob_bytes,
        sbytes = c.source_bytes,
        crc = c.blob_crc,
        scrc = c.source_crc,
        ssine = c.source_sine,
        params = c.parameters,
        cal = c.calibration_windows,
        margin = MARGIN,
        exps = exps.join("; "),
        scratch = c.scratch_bytes,
        n = x.n,
        seed = c.base_seed,
        k = c.k,
        fa = f.min_ade,
        xa = x.min_ade,
        da = x.min_ade - f.min_ade,
        ff = f.min_fde,
        xf = x.min_fde,
        df = x.min_fde - f.min_fde,
        fa1 = f.ade_k1,
        xa1 = x.ade_k1,
        da1 = x.ade_k1 - f.ade_k1,
        ff1 = f.fde_k1,
        xf1 = x.fde_k1,
        df1 = x.fde_k1 - f.fde_k1,
        dist = quant_card_dist_rows(&c.test_f32_dist, &c.test_fixed_dist, c.k)
            + &quant_card_v2_rows(c),
    )
}

/// The fixed-point model card's table rows for the distribution metrics of the f32 source
/// (`f`) and the fixed-point blob (`x`); each row ends in a newline, after the "FDE, K = 1" row.
pub fn quant_card_dist_rows(f: &DistMetrics, x: &DistMetrics, k: usize) -> String {
    format!(
        "| KDE NLL of the true endpoint, K = {k} (nats, px) | {fn_:.3} | {xn:.3} | {dn:+.3} |\n\
| true endpoint within 20 px of a sample, K = {k} | {f20:.2} % | {x20:.2} % | {d20:+.2} % |\n\
| true endpoint within 40 px of a sample, K = {k} | {f40:.2} % | {x40:.2} % | {d40:+.2} % |\n",
        fn_ = f.kde_nll,
        xn = x.kde_nll,
        dn = x.kde_nll - f.kde_nll,
        f20 = 100.0 * f.hit20,
        x20 = 100.0 * x.hit20,
        d20 = 100.0 * (x.hit20 - f.hit20),
        f40 = 100.0 * f.hit40,
        x40 = 100.0 * x.hit40,
        d40 = 100.0 * (x.hit40 - f.hit40),
    )
}
