//! The integer reference: the fixed-point specification of `gpecnet_core::fixed`, written
//! independently of it, and the golden cases it produces.

use anyhow::Result;

use super::{QLayer, QModel, SINE_NAME};
use crate::export::GoldenCase;
use crate::network::Act;
use crate::reference::Normals;

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
        // A proposal model's latents: the whole network once (each row's integer sum is
        // the same whichever rows are computed together), dequantised, clamped, requantised.
        let proposed = (!self.nets.proposal.is_empty()).then(|| {
            let e_p = self.nets.proposal.last().map_or(0, |l| l.scale.out_exp);
            run_q(&self.nets.proposal, &f)
                .into_iter()
                .map(|v| crate::reference::clamp_latent(deq(v, e_p), c.latent_bound))
                .collect::<Vec<f32>>()
        });
        for i in 0..k {
            let mut input = f.clone();
            if let Some(p) = &proposed {
                let Some(z) = p.get(i * c.zdim..(i + 1) * c.zdim) else {
                    break;
                };
                input.extend(z.iter().map(|&v| quantize_value(v, e_f)));
            } else {
                for _ in 0..c.zdim {
                    input.push(quantize_value(c.sigma * normals.next_normal(), e_f));
                }
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

    /// The endpoint set by the blob's protocol (see [`crate::reference::RefModel::predict_set`]).
    pub fn predict_set(&self, past: &[[f32; 2]], seed: u64, k: usize) -> Result<Vec<[f32; 2]>> {
        let c = &self.config;
        if c.tts_samples == 0 {
            return Ok(self.predict(past, seed, k).0);
        }
        let samples = self.predict(past, seed, c.tts_samples).0;
        crate::reference::tts_reduce(c, &samples, k)
    }

    /// The probabilities of the first `k` endpoints of a model with them, by the integer
    /// specification: the proposal's integer rows, its logit rows (after the `K·zdim`
    /// latent rows) dequantised with its output exponent, then the specified softmax
    /// ([`crate::reference::softmax`]); `None` for a model without them or `k` above K.
    pub fn probabilities(&self, past: &[[f32; 2]], k: usize) -> Option<Vec<f32>> {
        let c = &self.config;
        let last = self.nets.proposal.last()?;
        let latents = self.proposal_latents();
        if !self.is_scored() || k == 0 || k > latents {
            return None;
        }
        let f = run_q(&self.nets.encoder_past, &self.input(past));
        let out = run_q(&self.nets.proposal, &f);
        let first = latents * c.zdim;
        let logits: Vec<f32> = out
            .get(first..first + k)?
            .iter()
            .map(|&v| deq(v, last.scale.out_exp))
            .collect();
        crate::reference::softmax(&logits)
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
