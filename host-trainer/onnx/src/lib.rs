//! ONNX export of an f32 blob's networks (`gpecnet onnx`), for companion computers that run
//! onnxruntime or TensorRT instead of `gpecnet-core`.
//!
//! # The graph
//!
//! Opset 17, IR version 8, one graph, batch dimensions named `n` (windows) and `k` (latent
//! samples per window). Every dense layer is `MatMul(input, Wᵀ) + b` followed by `Sin` or
//! `Relu` (none on the last layer); the initializer `<net>.<i>.weight` holds `Wᵀ`, shape
//! `[in_dim, out_dim]`, and `<net>.<i>.bias` holds `b`, shape `[out_dim]`, the blob's f32 values
//! unchanged (the SIREN `w0` is already folded into the blob's sine layers).
//!
//! Inputs:
//!
//! * `x`, float `[n, 2·past_len]`: what `gpecnet-core` feeds `encoder_past` (step 1 of
//!   `gpecnet_core::engine`): `x[2t + c] = (p_t[c] − p_0[c]) · data_scale`, rotated into the
//!   heading frame first when the blob's `heading_steps > 0`
//!   (`gpecnet_core::frame::Frame::inputs`).
//! * `z`, float `[n, k, zdim]`: the latent samples, already multiplied by `sigma` (the core draws
//!   them from `gpecnet_core::prng::Gaussian` seeded with the caller's seed). Not with a
//!   learned latent proposal (format version 5 and later): the graph computes its `K` latents
//!   itself (below), and `k` = `K`.
//! * `pos`, float `[n, 2]`, only when the blob has a trajectory predictor: the last observed point
//!   as the predictor sees it, `Frame::predictor_position(p_last) / initial_pos_divisor`.
//!
//! Outputs (all in the network's normalised frame; a point `d` maps to the caller's units as
//! `Frame::output(d, data_scale)`: divide by `data_scale`, rotate back, add `p_0`):
//!
//! * `d`, float `[n, k, 2]`: the endpoint of every latent sample (step 4).
//! * `point`, float `[n, 2·future_len]`, only with a point-forecast head: the point forecast.
//! * `traj`, float `[n, k, 2·(future_len − 1)]`, only with a trajectory predictor: the
//!   intermediate points of every sample (step 6; the last point of a trajectory is `d`).
//! * `prob`, float `[n, K]`, only with endpoint probabilities (format version 6): each
//!   endpoint's probability, `Softmax` of the proposal's logit rows.
//! * `radii`, float `[n, 2]`, with probabilities and a point head: `r50`, `r90` around the
//!   point forecast's endpoint `q` in the blob's unit (not the normalised frame):
//!   `[c50, c90] · sqrt(Σ_i prob_i · |d_i − q|²) / data_scale` (the frame only rotates and
//!   shifts, so a distance in it is the caller's times `data_scale`).
//!
//! # The learned latent proposal
//!
//! A proposal model (the shipped defaults `sdd-m-lp`, `sdd-m-lp-host`) runs the proposal's
//! hidden layers on `f = encoder_past(x)` once per window (`proposal.h`), then the last
//! layer's `K·zdim` latent rows (`proposal.<last>.weight.z`, `[hidden, K·zdim]`), reshaped to
//! `[n, K, zdim]` and clamped to `±latent_bound` (`Clip`): the decoder's `z`. With
//! probabilities, the last layer's `K` logit rows (`proposal.<last>.weight.logits`) give
//! `prob`. The whole forecast the core's `Predictor::predict_forecast` returns (20
//! endpoints, probabilities, point forecast, radii) is then one call of the graph with a
//! batch dimension.
//!
//! The first layer of the decoder (`[f, z]`) and of the predictor (`[f, g, pos]`) is split by
//! input columns, `W [f, z] = W_f f + W_z z`, so that the feature part is computed once per
//! window and broadcast over `k` (what the core does too). Its initializers are
//! `<net>.0.weight.<part>`, e.g. `decoder.0.weight.f` `[fdim, out]` and `decoder.0.weight.z`
//! `[zdim, out]`; the bias is added once.
//!
//! The blob's settings ride along as metadata properties (`data_scale`, `sigma`, `zdim`, ...).
//!
//! # Fixed-point blobs are refused
//!
//! An `Int16Q15` blob computes with integer activations, per-channel shifts and an integer sine;
//! an ONNX float graph of its dequantised weights would not be that model (it would differ from
//! the core's fixed-point outputs by the quantisation error, not by rounding). Export the f32
//! blob it was quantised from instead (e.g. `sdd-small.gpec` for `sdd-small-q.gpec`).
//!
//! # Agreement with the core
//!
//! onnxruntime sums in its own order, with fused multiply-adds, and has its own `sin`, so it
//! agrees with the core within rounding, not bit for bit: `scripts/peers/check.py` measures the
//! difference on the whole SDD test set (`docs/peers.md`): at most 1.6e-3 px for the shipped
//! f32 blobs (sdd-paper; 5e-4 px for sdd-small), checked against a tolerance of 0.01 px. The
//! unit tests here run the decoded graph in f64 against the core (within 0.01 px).

// The lower crates' modules under the names the code uses (`crate::export::read_blob`).
use gpecnet_files::{inpath, outpath, rundir};
use gpecnet_reference::{export, network, reference};

use std::path::Path;

use anyhow::{bail, Context, Result};
use prost::Message;

use crate::network::{Act, Layer};
use crate::reference::RefModel;

pub mod proto;

use proto::*;

/// IR version written (ONNX 1.13+, onnxruntime 1.14+).
pub const IR_VERSION: i64 = 8;
/// Default-domain opset written.
pub const OPSET: i64 = 17;

/// One dimension of a graph input or output.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Dim {
    /// A fixed size.
    Fixed(usize),
    /// A symbolic size (`n`, `k`).
    Named(&'static str),
}

/// A graph input or output: name, shape, meaning (what `--help` and the docs list).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Port {
    /// Tensor name.
    pub name: &'static str,
    /// Shape.
    pub shape: Vec<Dim>,
    /// What it holds.
    pub doc: &'static str,
}

/// What [`export_onnx`] wrote.
#[derive(Clone, Debug)]
pub struct OnnxSummary {
    /// The blob's model name.
    pub name: String,
    /// Graph inputs.
    pub inputs: Vec<Port>,
    /// Graph outputs.
    pub outputs: Vec<Port>,
    /// Parameters (weights and biases) in the initializers.
    pub parameters: usize,
    /// Bytes of the ONNX file.
    pub bytes: usize,
}

fn value_info(p: &Port) -> ValueInfoProto {
    let dim = p
        .shape
        .iter()
        .map(|d| Dimension {
            value: Some(match d {
                Dim::Fixed(v) => DimValue::DimValue(*v as i64),
                Dim::Named(s) => DimValue::DimParam((*s).to_string()),
            }),
        })
        .collect();
    ValueInfoProto {
        name: p.name.to_string(),
        r#type: Some(TypeProto {
            tensor_type: Some(TensorTypeProto {
                elem_type: FLOAT,
                shape: Some(TensorShapeProto { dim }),
            }),
        }),
        doc_string: p.doc.to_string(),
    }
}

/// Builds the node list and initializers.
#[derive(Default)]
struct Builder {
    nodes: Vec<NodeProto>,
    init: Vec<TensorProto>,
    parameters: usize,
}

impl Builder {
    fn node(&mut self, op: &str, inputs: &[&str], output: &str) -> String {
        let name = format!("{op}_{}", self.nodes.len());
        self.nodes.push(NodeProto {
            input: inputs.iter().map(|s| s.to_string()).collect(),
            output: vec![output.to_string()],
            name,
            op_type: op.to_string(),
            domain: String::new(),
        });
        output.to_string()
    }

    fn f32_tensor(&mut self, name: &str, dims: &[usize], data: impl Iterator<Item = f32>) {
        let raw: Vec<u8> = data.flat_map(f32::to_le_bytes).collect();
        self.parameters += raw.len() / 4;
        self.init.push(TensorProto {
            dims: dims.iter().map(|&d| d as i64).collect(),
            data_type: FLOAT,
            name: name.to_string(),
            raw_data: raw,
        });
    }

    /// `Wᵀ` restricted to input columns `cols`, shape `[cols.len(), out_dim]`.
    fn weight_t(&mut self, name: &str, l: &Layer, cols: std::ops::Range<usize>) -> String {
        let (n_in, n_out) = (l.in_dim, l.out_dim);
        let data = cols
            .clone()
            .flat_map(move |i| (0..n_out).map(move |j| (j, i)))
            .map(|(j, i)| l.w.get(j * n_in + i).copied().unwrap_or(0.0));
        self.f32_tensor(name, &[cols.len(), n_out], data);
        name.to_string()
    }

    fn bias(&mut self, name: &str, l: &Layer) -> String {
        self.f32_tensor(name, &[l.out_dim], l.b.iter().copied());
        name.to_string()
    }

    fn activation(&mut self, act: Act, pre: &str, out: &str) -> String {
        match act {
            Act::Linear => self.node("Identity", &[pre], out),
            Act::Sine => self.node("Sin", &[pre], out),
            Act::Relu => self.node("Relu", &[pre], out),
        }
    }

    /// Rows `rows` of the layer `l` named `layer` (`<net>.<i>`) as their own dense layer
    /// `act(input · W_rowsᵀ + b_rows)`: initializers `<layer>.weight.<part>` `[in_dim,
    /// rows.len()]` and `<layer>.bias.<part>`.
    fn dense_rows(
        &mut self,
        layer: &str,
        l: &Layer,
        rows: std::ops::Range<usize>,
        part: &str,
        input: &str,
        out: &str,
    ) -> String {
        let n_in = l.in_dim;
        let name = format!("{layer}.weight.{part}");
        let data = (0..n_in)
            .flat_map(|c| rows.clone().map(move |j| (j, c)))
            .map(|(j, c)| l.w.get(j * n_in + c).copied().unwrap_or(0.0));
        self.f32_tensor(&name, &[n_in, rows.len()], data);
        let b = format!("{layer}.bias.{part}");
        self.f32_tensor(
            &b,
            &[rows.len()],
            rows.clone().map(|j| l.b.get(j).copied().unwrap_or(0.0)),
        );
        let mm = self.node("MatMul", &[input, &name], &format!("{layer}.mm.{part}"));
        let pre = self.node("Add", &[&mm, &b], &format!("{layer}.pre.{part}"));
        self.activation(l.act, &pre, out)
    }

    /// A constant int64 tensor `name` of shape `[values.len()]`.
    fn i64s(&mut self, name: &str, values: &[i64]) -> String {
        self.init.push(TensorProto {
            dims: vec![values.len() as i64],
            data_type: INT64,
            name: name.to_string(),
            raw_data: values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        });
        name.to_string()
    }

    /// A constant f32 tensor `name` of shape `dims` (a setting of the blob, not a
    /// parameter: it is not counted in [`OnnxSummary::parameters`]); `dims` empty: a scalar.
    fn f32_const(&mut self, name: &str, dims: &[usize], values: &[f32]) -> String {
        self.init.push(TensorProto {
            dims: dims.iter().map(|&d| d as i64).collect(),
            data_type: FLOAT,
            name: name.to_string(),
            raw_data: values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        });
        name.to_string()
    }

    /// One whole dense layer `act(input · Wᵀ + b)`.
    fn dense(&mut self, net: &str, i: usize, l: &Layer, input: &str, out: &str) -> String {
        let w = self.weight_t(&format!("{net}.{i}.weight"), l, 0..l.in_dim);
        let b = self.bias(&format!("{net}.{i}.bias"), l);
        let mm = self.node("MatMul", &[input, &w], &format!("{net}.{i}.mm"));
        let pre = self.node("Add", &[&mm, &b], &format!("{net}.{i}.pre"));
        self.activation(l.act, &pre, out)
    }

    /// Layers `from..` of `net` on `input`; the last output is named `out`.
    fn chain(
        &mut self,
        net: &str,
        layers: &[Layer],
        from: usize,
        input: &str,
        out: &str,
    ) -> String {
        let mut cur = input.to_string();
        for (i, l) in layers.iter().enumerate().skip(from) {
            let name = if i + 1 == layers.len() {
                out.to_string()
            } else {
                format!("{net}.{i}.out")
            };
            cur = self.dense(net, i, l, &cur, &name);
        }
        cur
    }

    /// The first layer of `net` over the concatenation of `parts` (name, width, tensor, and
    /// whether it has the `k` axis): per-window parts are summed with the bias and unsqueezed
    /// to `[n, 1, out]`, then added to the per-sample parts `[n, k, out]`.
    fn split_first(
        &mut self,
        net: &str,
        l: &Layer,
        parts: &[(&str, usize, &str, bool)],
        out: &str,
    ) -> Result<String> {
        let total: usize = parts.iter().map(|p| p.1).sum();
        if total != l.in_dim {
            bail!(
                "{net}: first layer has {} inputs, expected {total} ({})",
                l.in_dim,
                parts
                    .iter()
                    .map(|p| format!("{} {}", p.0, p.1))
                    .collect::<Vec<_>>()
                    .join(" + ")
            );
        }
        let b = self.bias(&format!("{net}.0.bias"), l);
        let (mut window, mut sample): (String, Option<String>) = (b, None);
        let mut col = 0;
        for &(part, width, tensor, per_sample) in parts {
            let w = self.weight_t(&format!("{net}.0.weight.{part}"), l, col..col + width);
            col += width;
            let mm = self.node("MatMul", &[tensor, &w], &format!("{net}.0.mm.{part}"));
            if per_sample {
                sample = Some(match sample {
                    None => mm,
                    Some(s) => self.node("Add", &[&s, &mm], &format!("{net}.0.sum.{part}")),
                });
            } else {
                window = self.node("Add", &[&mm, &window], &format!("{net}.0.sum.{part}"));
            }
        }
        let axes = format!("{net}.0.axes");
        self.init.push(TensorProto {
            dims: vec![1],
            data_type: INT64,
            name: axes.clone(),
            raw_data: 1i64.to_le_bytes().to_vec(),
        });
        let wu = self.node(
            "Unsqueeze",
            &[&window, &axes],
            &format!("{net}.0.window_part"),
        );
        let pre = match sample {
            Some(s) => self.node("Add", &[&s, &wu], &format!("{net}.0.pre")),
            None => bail!("{net}: no per-sample input"),
        };
        let name = if out.is_empty() {
            format!("{net}.0.out")
        } else {
            out.to_string()
        };
        Ok(self.activation(l.act, &pre, &name))
    }
}

/// The radii of a model with probabilities and a point head (`weights/FORMAT.md`, "Format
/// version 6"), from the graph's `d`, `prob` and `point`: the point forecast's last point
/// `q` (`point[:, 2F−2 .. 2F]`), `s² = Σ_i prob_i · |d_i − q|²` over the K endpoints, `radii =
/// [c50, c90] · sqrt(s²) / data_scale`. In the network's frame distances are the caller's
/// times `data_scale` (the frame only rotates and shifts), hence the division.
fn radii_nodes(b: &mut Builder, c: &network::RefConfig, point_head: &[Layer]) -> Result<()> {
    let w = point_head.last().map_or(0, |l| l.out_dim) as i64;
    if w < 2 {
        bail!("the point head gives {w} values, expected 2·future_len");
    }
    let starts = b.i64s("radii.q_start", &[w - 2]);
    let ends = b.i64s("radii.q_end", &[w]);
    let axes = b.i64s("radii.q_axis", &[1]);
    let q = b.node("Slice", &["point", &starts, &ends, &axes], "radii.q");
    let one = b.i64s("radii.k_axis", &[1]);
    let qk = b.node("Unsqueeze", &[&q, &one], "radii.q_k");
    let diff = b.node("Sub", &["d", &qk], "radii.diff");
    let sq = b.node("Mul", &[&diff, &diff], "radii.sq");
    let last = b.i64s("radii.xy_axis", &[2]);
    // ReduceSum keeps the reduced axes (keepdims = 1, the default): [n, K, 1].
    let d2 = b.node("ReduceSum", &[&sq, &last], "radii.d2");
    let pk = b.node("Unsqueeze", &["prob", &last], "radii.prob_k");
    let wd = b.node("Mul", &[&pk, &d2], "radii.weighted");
    let s2 = b.node("ReduceSum", &[&wd, &one], "radii.s2");
    let s = b.node("Sqrt", &[&s2], "radii.s_net");
    let scale = b.f32_const("radii.data_scale", &[], &[c.data_scale]);
    let su = b.node("Div", &[&s, &scale], "radii.s");
    let mult = b.f32_const("radii.scales", &[2], &c.radius_scales);
    let r = b.node("Mul", &[&su, &mult], "radii.r");
    let shape = b.i64s("radii.shape", &[0, 2]);
    b.node("Reshape", &[&r, &shape], "radii");
    Ok(())
}

/// The graph of `model` (an f32 model read from a blob): see the module docs. With
/// `endpoint_only`, only `x`, `z` → `d` (no point head, no trajectory predictor).
pub fn model_proto(
    model: &RefModel,
    blob_crc: u32,
    endpoint_only: bool,
) -> Result<(ModelProto, OnnxSummary)> {
    let c = &model.config;
    let n = &model.nets;
    if n.encoder_past.is_empty() || n.decoder.is_empty() {
        bail!(
            "{}: the blob has no encoder_past or decoder; nothing to export",
            model.name
        );
    }
    let in_x = 2 * c.past_len;
    if n.encoder_past[0].in_dim != in_x {
        bail!(
            "{}: encoder_past takes {} inputs, expected 2·past_len = {in_x}",
            model.name,
            n.encoder_past[0].in_dim
        );
    }
    // A proposal model computes its K latents from the past: no `z` input, `k` = K.
    let latents = model.proposal_latents();
    let proposal = !n.proposal.is_empty();
    if proposal && latents == 0 {
        bail!("{}: a proposal with no latent rows", model.name);
    }
    let nn = Dim::Named("n");
    let kk = if proposal {
        Dim::Fixed(latents)
    } else {
        Dim::Named("k")
    };
    let mut inputs = vec![Port {
        name: "x",
        shape: vec![nn.clone(), Dim::Fixed(in_x)],
        doc: "observed past as the core's frame input: x[2t+c] = (p_t[c] - p_0[c]) * data_scale (rotated into the heading frame when heading_steps > 0)",
    }];
    if !proposal {
        inputs.push(Port {
            name: "z",
            shape: vec![nn.clone(), kk.clone(), Dim::Fixed(c.zdim)],
            doc: "latent samples, already multiplied by sigma",
        });
    }
    let dec_out = n.decoder.last().map_or(0, |l| l.out_dim);
    if dec_out != 2 {
        bail!("{}: decoder gives {dec_out} values, expected 2", model.name);
    }
    let mut outputs = vec![Port {
        name: "d",
        shape: vec![nn.clone(), kk.clone(), Dim::Fixed(2)],
        doc: "endpoint of each sample in the normalised frame (caller units: d / data_scale, rotated back, + p_0)",
    }];
    let mut b = Builder::default();
    let f = b.chain("encoder_past", &n.encoder_past, 0, "x", "f");
    let fdim = n.encoder_past.last().map_or(0, |l| l.out_dim);
    if fdim != c.fdim {
        bail!(
            "{}: encoder_past gives {fdim} features, the config says fdim = {}",
            model.name,
            c.fdim
        );
    }
    // The proposal: its hidden layers on f once per window, then the last layer's latent
    // rows (reshaped to [n, K, zdim], clamped to ±latent_bound) and, with probabilities,
    // its K logit rows.
    let mut logits = None;
    let z = if proposal {
        let last = n.proposal.len() - 1;
        let lz = &n.proposal[last];
        if n.proposal[0].in_dim != fdim {
            bail!(
                "{}: the proposal takes {} inputs, expected fdim = {fdim}",
                model.name,
                n.proposal[0].in_dim
            );
        }
        let h = if last == 0 {
            f.clone()
        } else {
            b.chain("proposal", &n.proposal[..last], 0, &f, "proposal.h")
        };
        let rows = latents * c.zdim;
        let layer = format!("proposal.{last}");
        let flat = b.dense_rows(&layer, lz, 0..rows, "z", &h, "proposal.z_flat");
        let shape = b.i64s("proposal.z_shape", &[0, latents as i64, c.zdim as i64]);
        let zk = b.node("Reshape", &[&flat, &shape], "proposal.z_raw");
        let lo = b.f32_const("proposal.bound_lo", &[], &[-c.latent_bound]);
        let hi = b.f32_const("proposal.bound_hi", &[], &[c.latent_bound]);
        if model.is_scored() {
            logits = Some(b.dense_rows(&layer, lz, rows..rows + latents, "logits", &h, "logits"));
        }
        b.node("Clip", &[&zk, &lo, &hi], "z")
    } else {
        "z".to_string()
    };
    let single = n.decoder.len() == 1;
    let h = b.split_first(
        "decoder",
        &n.decoder[0],
        &[("f", fdim, &f, false), ("z", c.zdim, &z, true)],
        if single { "d" } else { "" },
    )?;
    if !single {
        b.chain("decoder", &n.decoder, 1, &h, "d");
    }
    if !n.point_head.is_empty() && !endpoint_only {
        let w = n.point_head.last().map_or(0, |l| l.out_dim);
        outputs.push(Port {
            name: "point",
            shape: vec![nn.clone(), Dim::Fixed(w)],
            doc: "point forecast (future_len points, normalised frame, mapped like d)",
        });
        if n.point_head[0].in_dim != in_x {
            bail!("{}: point_head does not take x", model.name);
        }
        b.chain("point_head", &n.point_head, 0, "x", "point");
    }
    if let Some(logits) = logits.filter(|_| !endpoint_only) {
        outputs.push(Port {
            name: "prob",
            shape: vec![nn.clone(), kk.clone()],
            doc: "probability of each endpoint: the softmax of the proposal's logit rows",
        });
        b.node("Softmax", &[&logits], "prob");
        if !n.point_head.is_empty() {
            outputs.push(Port {
                name: "radii",
                shape: vec![nn.clone(), Dim::Fixed(2)],
                doc: "r50, r90 around the point forecast's endpoint, in the blob's unit: [c50, c90] * sqrt(sum_i prob_i * |d_i - point_end|^2) / data_scale",
            });
            radii_nodes(&mut b, c, &n.point_head)?;
        }
    }
    if !n.predictor.is_empty() && !endpoint_only {
        if n.encoder_dest.is_empty() {
            bail!("{}: predictor without encoder_dest", model.name);
        }
        inputs.push(Port {
            name: "pos",
            shape: vec![nn.clone(), Dim::Fixed(2)],
            doc: "last observed point as the predictor sees it (rotated in the heading frame) / initial_pos_divisor",
        });
        let w = n.predictor.last().map_or(0, |l| l.out_dim);
        outputs.push(Port {
            name: "traj",
            shape: vec![nn.clone(), kk.clone(), Dim::Fixed(w)],
            doc: "intermediate points of each sample's trajectory (future_len - 1 points, normalised frame, mapped like d; the last point is d)",
        });
        let g = b.chain("encoder_dest", &n.encoder_dest, 0, "d", "g");
        let ddim = n.encoder_dest.last().map_or(0, |l| l.out_dim);
        let single = n.predictor.len() == 1;
        let h = b.split_first(
            "predictor",
            &n.predictor[0],
            &[
                ("f", fdim, &f, false),
                ("g", ddim, &g, true),
                ("pos", 2, "pos", false),
            ],
            if single { "traj" } else { "" },
        )?;
        if !single {
            b.chain("predictor", &n.predictor, 1, &h, "traj");
        }
    }
    let meta = [
        ("gpecnet.name", model.name.clone()),
        ("gpecnet.blob_crc32", format!("{blob_crc:08x}")),
        ("past_len", c.past_len.to_string()),
        ("future_len", c.future_len.to_string()),
        ("fdim", c.fdim.to_string()),
        ("zdim", c.zdim.to_string()),
        ("data_scale", format!("{:?}", c.data_scale)),
        ("sigma", format!("{:?}", c.sigma)),
        (
            "initial_pos_divisor",
            format!("{:?}", c.initial_pos_divisor),
        ),
        ("heading_steps", c.heading_steps.to_string()),
        ("tts_samples", c.tts_samples.to_string()),
    ];
    let doc = format!(
        "G-PECNet model {} exported by gpecnet onnx from an f32 blob (CRC-32 {blob_crc:08x}); inputs and outputs: see host-trainer/onnx/src/lib.rs",
        model.name
    );
    let graph = GraphProto {
        node: b.nodes,
        name: model.name.clone(),
        initializer: b.init,
        doc_string: doc.clone(),
        input: inputs.iter().map(value_info).collect(),
        output: outputs.iter().map(value_info).collect(),
    };
    let proto = ModelProto {
        ir_version: IR_VERSION,
        opset_import: vec![OperatorSetIdProto {
            domain: String::new(),
            version: OPSET,
        }],
        producer_name: "gpecnet".into(),
        producer_version: env!("CARGO_PKG_VERSION").into(),
        domain: String::new(),
        model_version: 1,
        doc_string: doc,
        graph: Some(graph),
        metadata_props: meta
            .into_iter()
            .map(|(k, v)| StringStringEntryProto {
                key: k.into(),
                value: v,
            })
            .collect(),
    };
    let summary = OnnxSummary {
        name: model.name.clone(),
        inputs,
        outputs,
        parameters: b.parameters,
        bytes: proto.encoded_len(),
    };
    Ok((proto, summary))
}

/// The ONNX bytes of a blob (validated by `gpecnet-core`'s reader; fixed-point blobs are
/// refused, see the module docs); `endpoint_only` as in [`model_proto`].
pub fn blob_to_onnx(blob: &[u8], endpoint_only: bool) -> Result<(Vec<u8>, OnnxSummary)> {
    let m = gpecnet_core::Model::from_blob(blob)
        .map_err(|e| anyhow::anyhow!("not a valid blob: {e}"))?;
    if m.numeric() != gpecnet_core::NumericKind::F32 {
        bail!(
            "{} is a fixed-point (Int16Q15) blob: its integer activations, per-channel shifts and integer sine have no ONNX float equivalent, so it is not exported; export the f32 blob it was quantised from (e.g. weights/sdd-small.gpec for sdd-small-q)",
            m.name()
        );
    }
    let crc = m.crc();
    let model = crate::export::read_blob(blob)?;
    let (proto, summary) = model_proto(&model, crc, endpoint_only)?;
    Ok((proto.encode_to_vec(), summary))
}

/// `gpecnet onnx`: reads the blob at `blob`, writes the ONNX model to `out` (atomically);
/// `endpoint_only` as in [`model_proto`].
pub fn export_onnx(blob: &Path, out: &Path, endpoint_only: bool) -> Result<OnnxSummary> {
    let inputs = crate::outpath::blob_and_sidecars(blob);
    let mut refs: Vec<&Path> = inputs.iter().map(std::path::PathBuf::as_path).collect();
    refs.push(blob);
    crate::outpath::check_output("--out", out, &refs, &[])?;
    let bytes = crate::inpath::read_limited(blob, crate::inpath::FileKind::Blob)?;
    let (onnx, summary) = blob_to_onnx(&bytes, endpoint_only)
        .with_context(|| format!("exporting {}", blob.display()))?;
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    crate::rundir::write_atomic(out, &onnx)?;
    Ok(summary)
}

/// One line per port: `name [shape]: meaning`.
pub fn describe(ports: &[Port]) -> String {
    ports
        .iter()
        .map(|p| {
            let shape = p
                .shape
                .iter()
                .map(|d| match d {
                    Dim::Fixed(v) => v.to_string(),
                    Dim::Named(s) => (*s).to_string(),
                })
                .collect::<Vec<_>>()
                .join(", ");
            format!("  {} [{shape}]: {}", p.name, p.doc)
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[cfg(test)]
mod tests;
