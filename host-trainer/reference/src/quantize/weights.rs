//! Exponents from the calibration and the int16 weights / int32 biases / shifts of every layer.

use anyhow::{bail, Result};

use super::{Calibration, QLayer, QModel, MARGIN};
use crate::network::{Act, Layer, Networks, QScale};
use crate::reference::RefModel;

const MIN_EXP: i32 = -8;
const MAX_EXP: i32 = 30;

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
            // Its output must hold ±bound (then saturation only ever meets values the
            // clamp would cut to the bound anyway; the core checks it).
            proposal: quantize_net(
                &model.nets.proposal,
                &cal.proposal,
                e_f,
                exp_for(cal.proposal.last().copied().unwrap_or(0.0)).min(
                    ((32767.0 / f64::from(model.config.latent_bound.max(1e-30)))
                        .log2()
                        .floor() as i32)
                        .clamp(MIN_EXP, MAX_EXP),
                ),
            ),
        },
    })
}
