//! The fit of the endpoint probabilities and the radii: the frozen model's view of each
//! window, multinomial logistic regression on the proposal's hidden activations (the
//! logit rows), temperature scaling and the radius multipliers, all chosen on validation.

use anyhow::{bail, Context, Result};

use crate::core_eval::{planner_metrics, PlannerOut};
use crate::data::{Window, FUTURE, PAST};
use crate::network::Layer;
use crate::planner_metrics::{closest, PlannerMetrics};
use crate::reference::{radii, RefModel, SineKind};

/// The frozen model's view of a set of windows.
pub struct Table {
    /// Hidden width of the proposal (the logits' inputs).
    pub width: usize,
    /// `[n · width]`: the proposal's hidden activations of each window.
    pub hidden: Vec<f32>,
    /// The index of the endpoint closest to the truth, per window.
    pub closest: Vec<usize>,
}

impl Table {
    /// Windows.
    pub fn len(&self) -> usize {
        self.closest.len()
    }

    /// Whether there are no windows.
    pub fn is_empty(&self) -> bool {
        self.closest.is_empty()
    }

    /// The table of `windows` under `model` (f32 reference arithmetic, libm sine), with the
    /// model's K endpoints.
    pub fn of(model: &RefModel, windows: &[Window]) -> Result<Self> {
        let k = model.proposal_latents();
        if k == 0 || model.nets.proposal.len() < 2 {
            bail!("endpoint probabilities need a learned proposal with a hidden layer");
        }
        let width = model.nets.proposal[model.nets.proposal.len() - 1].in_dim;
        let (mut hidden, mut close) = (Vec::new(), Vec::new());
        for w in windows {
            let past = &w.pos[..PAST];
            let (_, f) = model.features(past, SineKind::Libm);
            hidden.extend(model.proposal_hidden(&f, SineKind::Libm));
            let ends = model.predict(past, 0, k, SineKind::Libm, false).endpoints;
            close.push(closest(&ends, w.pos[PAST + FUTURE - 1]));
        }
        Ok(Self {
            width,
            hidden,
            closest: close,
        })
    }
}

/// Logit rows: `l_k = b_k + Σ_i w[k·width + i] h_i`.
#[derive(Clone, Debug, PartialEq)]
pub struct Logits {
    /// Rows `[K · width]`.
    pub w: Vec<f64>,
    /// Biases `[K]`.
    pub b: Vec<f64>,
}

impl Logits {
    fn zeros(k: usize, width: usize) -> Self {
        Self {
            w: vec![0.0; k * width],
            b: vec![0.0; k],
        }
    }

    /// Scales every row by `s` (temperature `1/s`).
    pub fn scaled(&self, s: f64) -> Self {
        Self {
            w: self.w.iter().map(|v| v * s).collect(),
            b: self.b.iter().map(|v| v * s).collect(),
        }
    }

    /// Probabilities of one window, f64.
    fn probs(&self, h: &[f32], out: &mut [f64]) {
        let width = h.len();
        for (k, o) in out.iter_mut().enumerate() {
            let row = &self.w[k * width..][..width];
            *o = self.b[k]
                + row
                    .iter()
                    .zip(h)
                    .map(|(w, &x)| w * f64::from(x))
                    .sum::<f64>();
        }
        let m = out.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut s = 0.0;
        for o in out.iter_mut() {
            *o = (*o - m).exp();
            s += *o;
        }
        for o in out.iter_mut() {
            *o /= s;
        }
    }

    /// Mean cross-entropy of the closest endpoint over `t` (nats).
    pub fn cross_entropy(&self, t: &Table) -> f64 {
        let k = self.b.len();
        let mut p = vec![0.0; k];
        let mut ce = 0.0;
        for (n, &j) in t.closest.iter().enumerate() {
            self.probs(&t.hidden[n * t.width..][..t.width], &mut p);
            ce -= p[j].max(1e-300).ln();
        }
        ce / t.len().max(1) as f64
    }

    /// The rows as the proposal's extra output rows (f32).
    pub fn rows(&self) -> (Vec<f32>, Vec<f32>) {
        (
            self.w.iter().map(|&v| v as f32).collect(),
            self.b.iter().map(|&v| v as f32).collect(),
        )
    }
}

/// Fits the logit rows to `t` by full-batch Adam on the mean cross-entropy of the closest
/// endpoint plus `l2 · ‖w‖²` (on standardised inputs, folded back into the rows), from
/// zero (equal probabilities): convex, deterministic.
pub fn fit(t: &Table, k: usize, l2: f64, iters: usize, lr: f64) -> Logits {
    let (n, width) = (t.len(), t.width);
    let mut mean = vec![0.0f64; width];
    let mut var = vec![0.0f64; width];
    for r in t.hidden.chunks_exact(width) {
        for (m, &x) in mean.iter_mut().zip(r) {
            *m += f64::from(x);
        }
    }
    mean.iter_mut().for_each(|m| *m /= n.max(1) as f64);
    for r in t.hidden.chunks_exact(width) {
        for ((v, &x), m) in var.iter_mut().zip(r).zip(&mean) {
            *v += (f64::from(x) - m).powi(2);
        }
    }
    let sd: Vec<f64> = var
        .iter()
        .map(|v| (v / n.max(1) as f64).sqrt().max(1e-6))
        .collect();
    let x: Vec<f64> = t
        .hidden
        .chunks_exact(width)
        .flat_map(|r| {
            r.iter()
                .zip(&mean)
                .zip(&sd)
                .map(|((&v, m), s)| (f64::from(v) - m) / s)
        })
        .collect();
    let mut th = Logits::zeros(k, width);
    let np = k * width + k;
    let (mut m1, mut m2) = (vec![0.0f64; np], vec![0.0f64; np]);
    let (b1, b2, eps) = (0.9f64, 0.999f64, 1e-8);
    let mut p = vec![0.0f64; k];
    let mut grad = vec![0.0f64; np];
    for it in 1..=iters {
        grad.iter_mut().for_each(|g| *g = 0.0);
        for (row, &j) in x.chunks_exact(width).zip(&t.closest) {
            for (kk, o) in p.iter_mut().enumerate() {
                *o = th.b[kk]
                    + th.w[kk * width..][..width]
                        .iter()
                        .zip(row)
                        .map(|(w, x)| w * x)
                        .sum::<f64>();
            }
            let mx = p.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let mut s = 0.0;
            for o in p.iter_mut() {
                *o = (*o - mx).exp();
                s += *o;
            }
            for (kk, o) in p.iter().enumerate() {
                let g = o / s - f64::from(u8::from(kk == j));
                for (gi, xi) in grad[kk * width..][..width].iter_mut().zip(row) {
                    *gi += g * xi;
                }
                grad[k * width + kk] += g;
            }
        }
        let inv = 1.0 / n.max(1) as f64;
        for (i, g) in grad.iter_mut().enumerate() {
            *g *= inv;
            if i < k * width {
                *g += 2.0 * l2 * th.w[i];
            }
        }
        let (c1, c2) = (1.0 - b1.powi(it as i32), 1.0 - b2.powi(it as i32));
        for i in 0..np {
            m1[i] = b1 * m1[i] + (1.0 - b1) * grad[i];
            m2[i] = b2 * m2[i] + (1.0 - b2) * grad[i] * grad[i];
            let step = lr * (m1[i] / c1) / ((m2[i] / c2).sqrt() + eps);
            if i < k * width {
                th.w[i] -= step;
            } else {
                th.b[i - k * width] -= step;
            }
        }
    }
    // Fold the standardisation: w' = w / sd, b' = b − Σ w μ / sd.
    let mut out = Logits::zeros(k, width);
    for kk in 0..k {
        let mut b = th.b[kk];
        for i in 0..width {
            let w = th.w[kk * width + i] / sd[i];
            out.w[kk * width + i] = w;
            b -= w * mean[i];
        }
        out.b[kk] = b;
    }
    out
}

/// The inverse temperature `s` (rows times `s`) that minimises the cross-entropy on `val`:
/// golden-section search of `ln s` over `[ln 0.2, ln 5]`.
pub fn inverse_temperature(l: &Logits, val: &Table) -> f64 {
    let f = |ls: f64| l.scaled(ls.exp()).cross_entropy(val);
    let (mut a, mut b) = (0.2f64.ln(), 5.0f64.ln());
    let g = (5.0f64.sqrt() - 1.0) / 2.0;
    for _ in 0..40 {
        let (c, d) = (b - g * (b - a), a + g * (b - a));
        if f(c) < f(d) {
            b = d;
        } else {
            a = c;
        }
    }
    ((a + b) / 2.0).exp()
}

/// `model` with `logits` appended to its proposal's last layer and `scales` as its radius
/// multipliers (the scored model the blob will hold).
pub fn scored(model: &RefModel, logits: &Logits, scales: [f32; 2]) -> Result<RefModel> {
    let mut m = model.clone();
    let last = m.nets.proposal.last_mut().context("no proposal")?;
    let (w, b) = logits.rows();
    let (mut lw, mut lb) = (last.w.clone(), last.b.clone());
    lw.extend(w);
    lb.extend(b);
    *last = Layer::new(
        last.in_dim,
        last.out_dim + lb.len() - last.b.len(),
        last.act,
        lw,
        lb,
    );
    m.config.radius_scales = scales;
    m.validate()?;
    Ok(m)
}

/// One window under the scored `model`: its K endpoints, their probabilities, the point
/// forecast's endpoint and the radii with the model's multipliers (f32 reference
/// arithmetic, libm sine).
fn outputs(model: &RefModel, w: &Window) -> Result<PlannerOut> {
    let k = model.proposal_latents();
    let past = &w.pos[..PAST];
    let endpoints = model.predict(past, 0, k, SineKind::Libm, false).endpoints;
    let probs = model
        .probabilities(past, k, SineKind::Libm)
        .context("no probabilities")?;
    let point = model
        .predict_point(past, SineKind::Libm)
        .and_then(|p| p.last().copied());
    let radii = point.map(|pt| radii(pt, &endpoints, &probs, model.config.radius_scales));
    Ok(PlannerOut {
        endpoints,
        probs,
        point,
        radii,
    })
}

/// The multipliers `[c50, c90]`: the 50th and 90th percentiles (the smallest values that
/// cover half and nine tenths of the windows) of `d / s` on `windows`, `d` the distance of
/// the truth to the point forecast and `s` the probability-weighted spread of the endpoints
/// around it (the radius with unit multipliers), under `model` scored with multipliers
/// `[1, 1]`.
pub fn radius_scales(unit_scored: &RefModel, windows: &[Window]) -> Result<[f32; 2]> {
    let mut ratios = Vec::with_capacity(windows.len());
    for w in windows {
        let o = outputs(unit_scored, w)?;
        let (pt, [s, _]) = o
            .point
            .zip(o.radii)
            .context("the radii need a point-forecast head")?;
        let t = w.pos[PAST + FUTURE - 1];
        let d = (f64::from(t[0] - pt[0]).powi(2) + f64::from(t[1] - pt[1]).powi(2)).sqrt();
        if s > 0.0 && s.is_finite() {
            ratios.push(d / f64::from(s));
        }
    }
    if ratios.is_empty() {
        bail!("no window with a positive spread to calibrate the radii on");
    }
    ratios.sort_by(f64::total_cmp);
    let q = |p: f64| ratios[((p * ratios.len() as f64).ceil() as usize).clamp(1, ratios.len()) - 1];
    Ok([q(0.5) as f32, q(0.9) as f32])
}

/// The planner metrics of the scored `model` on `windows` (the data set's unit).
pub fn metrics(model: &RefModel, windows: &[Window]) -> Result<PlannerMetrics> {
    let outs = windows
        .iter()
        .map(|w| outputs(model, w))
        .collect::<Result<Vec<_>>>()?;
    planner_metrics(windows, &outs, |_| Ok(1.0))
}
