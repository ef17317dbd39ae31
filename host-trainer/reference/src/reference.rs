//! The trainer's **canonical f32 inference path**: the numbers this crate
//! reports (and writes into model cards and golden files) come from here.
//!
//! It is written independently of `gpecnet-core` — its own PRNG, Gaussian,
//! sines and layer loops — from the specification in `gpecnet_core::prng`
//! and `gpecnet_core::predictor`, so that the workspace tests comparing the
//! two (bit for bit, on every shipped blob) check the specification, the
//! blob export and the embedded reader together, not one piece of code
//! against itself.

use anyhow::{bail, Result};

use crate::frame::RefFrame;
use crate::network::RefConfig;
use crate::network::{Act, InferenceModel, Layer, F32};

/// The f32 model as exported: what the reference path runs and an f32 blob holds.
pub type RefModel = InferenceModel<F32>;

/// Which sine the SIREN layers use (must match the device's choice).
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize, serde::Deserialize,
)]
pub enum SineKind {
    /// `libm::sinf`, the reference.
    Libm,
    /// The fixed-order single-precision sine (`gpecnet_core::FastSine`).
    Fast,
}

impl SineKind {
    /// The name `gpecnet_core::Sine::NAME` uses.
    pub fn core_name(self) -> &'static str {
        match self {
            SineKind::Libm => "libm",
            SineKind::Fast => "fast-f32",
        }
    }
}

// ---- the latent sampler, from the specification in gpecnet_core::prng ----

struct Xoshiro([u32; 4]);

impl Xoshiro {
    fn new(seed: u64) -> Self {
        let mut x = seed;
        let mut split = || {
            x = x.wrapping_add(0x9E3779B97F4A7C15);
            let mut z = x;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
            z ^ (z >> 31)
        };
        let (a, b) = (split(), split());
        let s = [a as u32, (a >> 32) as u32, b as u32, (b >> 32) as u32];
        Xoshiro(if s == [0; 4] { [1, 0, 0, 0] } else { s })
    }
    fn next(&mut self) -> u32 {
        let [s0, s1, s2, s3] = self.0;
        let r = s0.wrapping_add(s3).rotate_left(7).wrapping_add(s0);
        let t = s1 << 9;
        let s2 = s2 ^ s0;
        let s3 = s3 ^ s1;
        let s1 = s1 ^ s2;
        let s0 = s0 ^ s3;
        self.0 = [s0, s1, s2 ^ t, s3.rotate_left(11)];
        r
    }
}

fn round_even(x: f32) -> f32 {
    if x.abs() < 4_194_304.0 {
        (x + 12_582_912.0) - 12_582_912.0
    } else {
        x
    }
}

/// `sin(2π t)`, the spec's degree-11 polynomial after folding to [-1/4, 1/4].
fn sin_turns(t: f32) -> f32 {
    if !t.is_finite() {
        return f32::NAN;
    }
    let mut r = t - round_even(t);
    if r > 0.25 {
        r = 0.5 - r;
    } else if r < -0.25 {
        r = -0.5 - r;
    }
    let r2 = r * r;
    let c = [
        std::f32::consts::TAU,
        -41.341_7f32,
        81.605_25,
        -76.705_86,
        42.058_693,
        -15.094_643,
    ];
    r * (c[0] + r2 * (c[1] + r2 * (c[2] + r2 * (c[3] + r2 * (c[4] + r2 * c[5])))))
}

fn ln(x: f32) -> f32 {
    if x.is_nan() || x < f32::MIN_POSITIVE || !x.is_finite() {
        return f32::NAN;
    }
    let bits = x.to_bits();
    let mut e = ((bits >> 23) & 0xff) as i32 - 127;
    let mut m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    if m > std::f32::consts::SQRT_2 {
        m *= 0.5;
        e += 1;
    }
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let a = s * (1.0 + s2 * (0.333_333_34 + s2 * (0.2 + s2 * (0.142_857_15 + s2 * 0.111_111_11))));
    let ef = e as f32;
    (ef * 0.693_145_75 + (a + a)) + ef * 1.428_606_8e-6
}

/// Standard normals by the specified Box–Muller recipe.
pub struct Normals {
    rng: Xoshiro,
    spare: Option<f32>,
}

impl Normals {
    /// Sampler for `seed`.
    pub fn new(seed: u64) -> Self {
        Self {
            rng: Xoshiro::new(seed),
            spare: None,
        }
    }
    /// Next N(0, 1).
    pub fn next_normal(&mut self) -> f32 {
        if let Some(v) = self.spare.take() {
            return v;
        }
        let u1 = (((self.rng.next() >> 8) + 1) as f32) * (1.0 / 16_777_216.0);
        let t = ((self.rng.next() >> 8) as f32) * (1.0 / 16_777_216.0);
        let l = ln(u1);
        let rho = (-(l + l)).sqrt();
        self.spare = Some(rho * sin_turns(t));
        rho * sin_turns(t + 0.25)
    }
}

fn sine(kind: SineKind, x: f32) -> f32 {
    match kind {
        SineKind::Libm => libm::sinf(x),
        SineKind::Fast => {
            let t = x * 0.159_154_94;
            if t.is_nan() || t.abs() >= 65_536.0 {
                return sin_turns(t);
            }
            let n = round_even(t);
            sin_turns(((x - n * 6.281_25) - n * 1.935_307_2e-3) * 0.159_154_94)
        }
    }
}

impl Layer<F32> {
    /// `y_j = act(b_j + Σ_i W_ji x_i)`, summed left to right. Four rows are
    /// processed together (independent sums, each in the documented order).
    pub fn forward_into(&self, x: &[f32], y: &mut Vec<f32>, kind: SineKind) {
        y.clear();
        y.extend_from_slice(&self.b);
        accumulate(&self.w, self.in_dim, 0, x, y);
        for v in y.iter_mut() {
            *v = activate(self.act, *v, kind);
        }
    }
}

fn activate(act: Act, v: f32, kind: SineKind) -> f32 {
    match act {
        Act::Linear => v,
        Act::Relu => {
            if v < 0.0 {
                0.0
            } else {
                v
            }
        }
        Act::Sine => sine(kind, v),
    }
}

/// `acc_j += Σ_{i < x.len()} W[j][col0 + i] x_i` for every row `j`.
fn accumulate(w: &[f32], in_dim: usize, col0: usize, x: &[f32], acc: &mut [f32]) {
    let n = x.len();
    let mut rows = acc.chunks_exact_mut(4);
    let mut j = 0;
    for a in &mut rows {
        let r0 = &w[j * in_dim + col0..][..n];
        let r1 = &w[(j + 1) * in_dim + col0..][..n];
        let r2 = &w[(j + 2) * in_dim + col0..][..n];
        let r3 = &w[(j + 3) * in_dim + col0..][..n];
        let (mut s0, mut s1, mut s2, mut s3) = (a[0], a[1], a[2], a[3]);
        for i in 0..n {
            let xi = x[i];
            s0 += r0[i] * xi;
            s1 += r1[i] * xi;
            s2 += r2[i] * xi;
            s3 += r3[i] * xi;
        }
        a.copy_from_slice(&[s0, s1, s2, s3]);
        j += 4;
    }
    for a in rows.into_remainder() {
        let r = &w[j * in_dim + col0..][..n];
        let mut s = *a;
        for i in 0..n {
            s += r[i] * x[i];
        }
        *a = s;
        j += 1;
    }
}

fn run(net: &[Layer<F32>], x: &[f32], kind: SineKind) -> Vec<f32> {
    let mut cur = x.to_vec();
    let mut next = Vec::new();
    for l in net {
        l.forward_into(&cur, &mut next, kind);
        std::mem::swap(&mut cur, &mut next);
    }
    cur
}

/// A proposed latent component clamped to `±bound` (NaN passes), as `gpecnet_core`'s
/// engine does before the decoder.
pub fn clamp_latent(v: f32, bound: f32) -> f32 {
    if v > bound {
        bound
    } else if v < -bound {
        -bound
    } else {
        v
    }
}

/// The specified softmax (`weights/FORMAT.md`, "Format version 6"): `m` the largest logit,
/// `e_k = expf(l_k − m)` (libm), `s = e_0 + e_1 + …` left to right, `p_k = e_k / s`, all in
/// f32. `None` when a logit is not finite.
pub fn softmax(logits: &[f32]) -> Option<Vec<f32>> {
    if logits.is_empty() || logits.iter().any(|l| !l.is_finite()) {
        return None;
    }
    let m = logits.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let e: Vec<f32> = logits.iter().map(|&l| libm::expf(l - m)).collect();
    let mut s = 0.0f32;
    for v in &e {
        s += *v;
    }
    Some(e.iter().map(|v| v / s).collect())
}

/// The specified radii of a forecast: `s² = Σ_k p_k·(dx_k² + dy_k²)` summed left to right in
/// f32 from 0 (`dx_k = e_k[0] − point[0]`, each term `p_k · ((dx·dx) + (dy·dy))`), `s =
/// sqrtf(s²)` (libm), and `[scales[0]·s, scales[1]·s]`.
pub fn radii(point: [f32; 2], endpoints: &[[f32; 2]], probs: &[f32], scales: [f32; 2]) -> [f32; 2] {
    let mut s2 = 0.0f32;
    for (e, &p) in endpoints.iter().zip(probs) {
        let (dx, dy) = (e[0] - point[0], e[1] - point[1]);
        s2 += p * (dx * dx + dy * dy);
    }
    let s = libm::sqrtf(s2);
    [scales[0] * s, scales[1] * s]
}

/// Reduces the `tts_samples` samples of a model with test-time sampling to `k` centres.
pub fn tts_reduce(c: &RefConfig, samples: &[[f32; 2]], k: usize) -> Result<Vec<[f32; 2]>> {
    if k > samples.len() {
        bail!(
            "k = {k} exceeds the model's {} test-time samples",
            samples.len()
        );
    }
    let init = if c.tts_init == 1 {
        crate::tts::TtsInit::Farthest
    } else {
        crate::tts::TtsInit::First
    };
    crate::tts::kmeans(samples, k, u32::from(c.tts_iters), init)
}

/// K predicted samples for one window (caller's units).
#[derive(Clone, Debug, PartialEq)]
pub struct RefPrediction {
    /// The K endpoints.
    pub endpoints: Vec<[f32; 2]>,
    /// The K trajectories (`future_len` points each, last = endpoint), if asked for.
    pub trajectories: Vec<Vec<[f32; 2]>>,
}

impl RefModel {
    /// The model's endpoint set (the blob's protocol, `gpecnet_core::sampling`): the first `k`
    /// samples, or the k-means reduction ([`crate::tts::kmeans`], written independently of
    /// the core) of the first `tts_samples` samples.
    pub fn predict_set(
        &self,
        past: &[[f32; 2]],
        seed: u64,
        k: usize,
        kind: SineKind,
    ) -> Result<Vec<[f32; 2]>> {
        let c = &self.config;
        if c.tts_samples == 0 {
            return Ok(self.predict(past, seed, k, kind, false).endpoints);
        }
        let samples = self
            .predict(past, seed, c.tts_samples, kind, false)
            .endpoints;
        tts_reduce(c, &samples, k)
    }

    /// The network input `x` of `past` in frame `fr` (shared by the encoder and the point head).
    fn input(&self, fr: &RefFrame, past: &[[f32; 2]]) -> Vec<f32> {
        let ds = self.config.data_scale;
        past.iter().flat_map(|p| fr.input(*p, ds)).collect()
    }

    /// The frame of `past` and the encoder's features `f` (step 2 of the computation).
    pub fn features(&self, past: &[[f32; 2]], kind: SineKind) -> (RefFrame, Vec<f32>) {
        let fr = self.frame(past);
        let x = self.input(&fr, past);
        let f = run(&self.nets.encoder_past, &x, kind);
        (fr, f)
    }

    /// The proposal's hidden activations `h` for the features `f` (every layer but the last).
    pub fn proposal_hidden(&self, f: &[f32], kind: SineKind) -> Vec<f32> {
        let n = self.nets.proposal.len().saturating_sub(1);
        run(&self.nets.proposal[..n], f, kind)
    }

    /// The probabilities of the first `k` endpoints of a model with endpoint probabilities:
    /// the proposal's logit rows (after the `K·zdim` latent rows) on the features, softmax
    /// over the first `k` ([`softmax`]); `None` for a model without them or `k` above K.
    pub fn probabilities(&self, past: &[[f32; 2]], k: usize, kind: SineKind) -> Option<Vec<f32>> {
        let latents = self.proposal_latents();
        if !self.is_scored() || k == 0 || k > latents {
            return None;
        }
        let (_, f) = self.features(past, kind);
        let out = run(&self.nets.proposal, &f, kind);
        let first = latents * self.config.zdim;
        softmax(out.get(first..first + k)?)
    }

    /// The deterministic point forecast of the point head (`future_len` points, caller's
    /// units), or `None` without a head.
    pub fn predict_point(&self, past: &[[f32; 2]], kind: SineKind) -> Option<Vec<[f32; 2]>> {
        if self.nets.point_head.is_empty() {
            return None;
        }
        let c = &self.config;
        let fr = self.frame(past);
        let x = self.input(&fr, past);
        let q = run(&self.nets.point_head, &x, kind);
        Some(
            q.chunks(2)
                .map(|p| fr.output([p[0], p[1]], c.data_scale))
                .collect(),
        )
    }

    /// The documented computation (see `gpecnet_core::predictor`), naively:
    /// a full decoder pass per sample (the core caches the feature columns;
    /// the two must agree bit for bit).
    pub fn predict(
        &self,
        past: &[[f32; 2]],
        seed: u64,
        k: usize,
        kind: SineKind,
        trajectories: bool,
    ) -> RefPrediction {
        let c = &self.config;
        let fr = self.frame(past);
        let x = self.input(&fr, past);
        let f = run(&self.nets.encoder_past, &x, kind);
        let mut normals = Normals::new(seed);
        let last = fr.predictor_position(past[past.len() - 1]);
        let mut out = RefPrediction {
            endpoints: Vec::with_capacity(k),
            trajectories: Vec::new(),
        };
        let mut input = f.clone();
        let proposed = (!self.nets.proposal.is_empty()).then(|| run(&self.nets.proposal, &f, kind));
        let latents = self.proposal_latents();
        for i in 0..k {
            input.truncate(c.fdim);
            if let Some(p) = &proposed {
                let Some(z) = p.get(i * c.zdim..(i + 1) * c.zdim).filter(|_| i < latents) else {
                    break;
                };
                input.extend(z.iter().map(|&v| clamp_latent(v, c.latent_bound)));
            } else {
                for _ in 0..c.zdim {
                    input.push(c.sigma * normals.next_normal());
                }
            }
            let d = run(&self.nets.decoder, &input, kind);
            let e = fr.output([d[0], d[1]], c.data_scale);
            out.endpoints.push(e);
            if trajectories && !self.nets.predictor.is_empty() {
                let g = run(&self.nets.encoder_dest, &d, kind);
                let mut pin = f.clone();
                pin.extend_from_slice(&g);
                pin.push(last[0] / c.initial_pos_divisor);
                pin.push(last[1] / c.initial_pos_divisor);
                let q = run(&self.nets.predictor, &pin, kind);
                let mut t: Vec<[f32; 2]> = q
                    .chunks(2)
                    .map(|p| fr.output([p[0], p[1]], c.data_scale))
                    .collect();
                t.push(e);
                out.trajectories.push(t);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prng_reference_values() {
        // Seed 42 outputs from the specification in gpecnet_core::prng.
        let mut x = Xoshiro::new(42);
        assert_eq!(x.0, [0x2feb6e95, 0xbdd73226, 0xb266f103, 0x28efe333]);
        assert_eq!(x.next(), 2643743425);
        let mut x = Xoshiro([1, 2, 3, 4]);
        assert_eq!((x.next(), x.next()), (641, 1573767));
    }

    #[test]
    fn sines_agree_with_f64() {
        for i in 0..10_000 {
            let x = i as f32 * 0.04 - 200.0;
            let want = (x as f64).sin();
            assert!((sine(SineKind::Fast, x) as f64 - want).abs() < 4e-7);
            assert!((sine(SineKind::Libm, x) as f64 - want).abs() < 1e-7);
        }
    }

    #[test]
    fn accumulate_order_is_sequential() {
        // 5 rows (4 + remainder) against a plain loop, bit for bit.
        let w: Vec<f32> = (0..35)
            .map(|i| ((i * 37 % 11) as f32 - 5.0) * 0.37)
            .collect();
        let x: Vec<f32> = (0..7).map(|i| (i as f32 - 3.0) * 1.3e-3 + 1e5).collect();
        let mut acc = vec![0.1f32; 5];
        accumulate(&w, 7, 0, &x, &mut acc);
        for j in 0..5 {
            let mut s = 0.1f32;
            for i in 0..7 {
                s += w[j * 7 + i] * x[i];
            }
            assert_eq!(s.to_bits(), acc[j].to_bits());
        }
    }
}
