//! Calibration: the f32 model's largest activation magnitudes on training windows.

use crate::data::{Window, PAST};
use crate::network::{Act, Layer};
use crate::reference::{Normals, RefModel};

/// Largest magnitudes seen while running the f32 model (f64 arithmetic).
#[derive(Clone, Debug, Default)]
pub struct Calibration {
    /// encoder_past input.
    pub input: f64,
    /// Per network (enc, dec, dest, pred, point head), per layer: max |output|.
    pub layers: [Vec<f64>; 5],
    /// The latent proposal, per layer: max |output| (empty without one).
    pub proposal: Vec<f64>,
    /// The latent (`sigma · N(0, 1)`, or a proposal's clamped latents and its bound).
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

/// Runs `model` on `windows` with `k` latent samples each (window `i` uses seed `i`), or all
/// of a proposal model's latents.
pub fn calibrate(model: &RefModel, windows: &[Window], k: usize) -> Calibration {
    let c = &model.config;
    let nets = model.nets.in_blob_order();
    let mut cal = Calibration {
        layers: nets.map(|n| vec![0.0; n.len()]),
        proposal: vec![0.0; model.nets.proposal.len()],
        ..Default::default()
    };
    if !model.nets.proposal.is_empty() {
        // The clamp makes the bound the largest latent the decoder can see.
        cal.z = f64::from(c.latent_bound);
    }
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
        let proposed = (!model.nets.proposal.is_empty())
            .then(|| run_f64(&model.nets.proposal, &f, &mut cal.proposal));
        // A proposal's latents are all calibrated (they are what the decoder will see).
        let n = proposed.as_ref().map_or(k, |_| model.proposal_latents());
        for i in 0..n {
            let mut input = f.clone();
            if let Some(p) = &proposed {
                let Some(z) = p.get(i * c.zdim..(i + 1) * c.zdim) else {
                    break;
                };
                let b = f64::from(c.latent_bound);
                input.extend(z.iter().map(|v| v.clamp(-b, b)));
            } else {
                for _ in 0..c.zdim {
                    let z = c.sigma * normals.next_normal();
                    cal.z = cal.z.max(z.abs() as f64);
                    input.push(z as f64);
                }
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
