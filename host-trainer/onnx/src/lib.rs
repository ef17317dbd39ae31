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
//!   them from `gpecnet_core::prng::Gaussian` seeded with the caller's seed).
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

/// The subset of `onnx.proto` (ONNX 1.x, the `onnx` package's `onnx/onnx.proto`) that the
/// export writes, as prost messages with the upstream field numbers; anything else a reader
/// finds is skipped by prost as an unknown field.
pub mod proto {
    /// `TensorProto.DataType.FLOAT`.
    pub const FLOAT: i32 = 1;
    /// `TensorProto.DataType.INT64`.
    pub const INT64: i32 = 7;

    /// `ModelProto`: the file.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct ModelProto {
        /// IR version of the file format.
        #[prost(int64, tag = "1")]
        pub ir_version: i64,
        /// Operator sets the graph uses.
        #[prost(message, repeated, tag = "8")]
        pub opset_import: Vec<OperatorSetIdProto>,
        /// Producer (`gpecnet`).
        #[prost(string, tag = "2")]
        pub producer_name: String,
        /// Producer version.
        #[prost(string, tag = "3")]
        pub producer_version: String,
        /// Model domain.
        #[prost(string, tag = "4")]
        pub domain: String,
        /// Model version.
        #[prost(int64, tag = "5")]
        pub model_version: i64,
        /// Human-readable description.
        #[prost(string, tag = "6")]
        pub doc_string: String,
        /// The graph.
        #[prost(message, optional, tag = "7")]
        pub graph: Option<GraphProto>,
        /// Key/value metadata.
        #[prost(message, repeated, tag = "14")]
        pub metadata_props: Vec<StringStringEntryProto>,
    }

    /// `OperatorSetIdProto`.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct OperatorSetIdProto {
        /// Domain ("" = the default ONNX operators).
        #[prost(string, tag = "1")]
        pub domain: String,
        /// Opset version.
        #[prost(int64, tag = "2")]
        pub version: i64,
    }

    /// `StringStringEntryProto`.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct StringStringEntryProto {
        /// Key.
        #[prost(string, tag = "1")]
        pub key: String,
        /// Value.
        #[prost(string, tag = "2")]
        pub value: String,
    }

    /// `GraphProto`.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct GraphProto {
        /// Nodes in topological order.
        #[prost(message, repeated, tag = "1")]
        pub node: Vec<NodeProto>,
        /// Graph name.
        #[prost(string, tag = "2")]
        pub name: String,
        /// Constant tensors (weights).
        #[prost(message, repeated, tag = "5")]
        pub initializer: Vec<TensorProto>,
        /// Description.
        #[prost(string, tag = "10")]
        pub doc_string: String,
        /// Graph inputs.
        #[prost(message, repeated, tag = "11")]
        pub input: Vec<ValueInfoProto>,
        /// Graph outputs.
        #[prost(message, repeated, tag = "12")]
        pub output: Vec<ValueInfoProto>,
    }

    /// `NodeProto`.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct NodeProto {
        /// Input tensor names.
        #[prost(string, repeated, tag = "1")]
        pub input: Vec<String>,
        /// Output tensor names.
        #[prost(string, repeated, tag = "2")]
        pub output: Vec<String>,
        /// Node name.
        #[prost(string, tag = "3")]
        pub name: String,
        /// Operator.
        #[prost(string, tag = "4")]
        pub op_type: String,
        /// Operator domain ("" = default).
        #[prost(string, tag = "7")]
        pub domain: String,
    }

    /// `TensorProto` (dense, raw little-endian data).
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct TensorProto {
        /// Shape.
        #[prost(int64, repeated, tag = "1")]
        pub dims: Vec<i64>,
        /// Element type ([`FLOAT`], [`INT64`]).
        #[prost(int32, tag = "2")]
        pub data_type: i32,
        /// Name.
        #[prost(string, tag = "8")]
        pub name: String,
        /// Elements, little-endian, row-major.
        #[prost(bytes = "vec", tag = "9")]
        pub raw_data: Vec<u8>,
    }

    /// `ValueInfoProto`.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct ValueInfoProto {
        /// Tensor name.
        #[prost(string, tag = "1")]
        pub name: String,
        /// Its type.
        #[prost(message, optional, tag = "2")]
        pub r#type: Option<TypeProto>,
        /// What it means.
        #[prost(string, tag = "3")]
        pub doc_string: String,
    }

    /// `TypeProto` (tensor types only).
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct TypeProto {
        /// The tensor type (`TypeProto.tensor_type`, field 1 of the `value` oneof).
        #[prost(message, optional, tag = "1")]
        pub tensor_type: Option<TensorTypeProto>,
    }

    /// `TypeProto.Tensor`.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct TensorTypeProto {
        /// Element type.
        #[prost(int32, tag = "1")]
        pub elem_type: i32,
        /// Shape.
        #[prost(message, optional, tag = "2")]
        pub shape: Option<TensorShapeProto>,
    }

    /// `TensorShapeProto`.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct TensorShapeProto {
        /// Dimensions.
        #[prost(message, repeated, tag = "1")]
        pub dim: Vec<Dimension>,
    }

    /// `TensorShapeProto.Dimension`: a fixed size or a symbolic name.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct Dimension {
        /// Fixed size (`dim_value`) or symbolic name (`dim_param`).
        #[prost(oneof = "DimValue", tags = "1, 2")]
        pub value: Option<DimValue>,
    }

    /// The `value` oneof of [`Dimension`].
    #[derive(Clone, PartialEq, prost::Oneof)]
    pub enum DimValue {
        /// A fixed size.
        #[prost(int64, tag = "1")]
        DimValue(i64),
        /// A symbolic size.
        #[prost(string, tag = "2")]
        DimParam(String),
    }
}

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
    let (nn, kk) = (Dim::Named("n"), Dim::Named("k"));
    let mut inputs = vec![
        Port {
            name: "x",
            shape: vec![nn.clone(), Dim::Fixed(in_x)],
            doc: "observed past as the core's frame input: x[2t+c] = (p_t[c] - p_0[c]) * data_scale (rotated into the heading frame when heading_steps > 0)",
        },
        Port {
            name: "z",
            shape: vec![nn.clone(), kk.clone(), Dim::Fixed(c.zdim)],
            doc: "latent samples, already multiplied by sigma",
        },
    ];
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
    let single = n.decoder.len() == 1;
    let h = b.split_first(
        "decoder",
        &n.decoder[0],
        &[("f", fdim, &f, false), ("z", c.zdim, "z", true)],
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
        "G-PECNet model {} exported by gpecnet onnx from an f32 blob (CRC-32 {blob_crc:08x}); inputs and outputs: see host-trainer/src/onnx.rs",
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
    if m.has_proposal() {
        bail!(
            "{} computes its latents with a learned proposal (format version 5), which this ONNX graph (latents as the input z) does not carry; export the blob without it (e.g. weights/sdd-m-tiny.gpec for sdd-m-lp)",
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
mod tests {
    use super::*;
    use gpecnet_core::frame::Frame;
    use gpecnet_core::prng::Gaussian;
    use gpecnet_core::{LibmSine, Predictor};
    use std::collections::HashMap;

    fn blob(name: &str) -> Vec<u8> {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../weights/{name}.gpec"));
        std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
    }

    fn decode(name: &str) -> (ModelProto, RefModel) {
        let b = blob(name);
        let (bytes, summary) = blob_to_onnx(&b, false).unwrap();
        assert_eq!(summary.bytes, bytes.len());
        (
            ModelProto::decode(bytes.as_slice()).unwrap(),
            crate::export::read_blob(&b).unwrap(),
        )
    }

    fn dims(v: &ValueInfoProto) -> Vec<String> {
        let t = v.r#type.as_ref().unwrap().tensor_type.as_ref().unwrap();
        assert_eq!(t.elem_type, FLOAT);
        t.shape
            .as_ref()
            .unwrap()
            .dim
            .iter()
            .map(|d| match d.value.as_ref().unwrap() {
                DimValue::DimValue(v) => v.to_string(),
                DimValue::DimParam(s) => s.clone(),
            })
            .collect()
    }

    fn f32s(t: &TensorProto) -> Vec<f32> {
        t.raw_data
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    }

    #[test]
    fn shipped_blobs_export_well_formed_models() {
        for name in ["sdd-small", "sdd-tiny-v2", "sdd-tiny"] {
            let (m, r) = decode(name);
            assert_eq!(
                (m.ir_version, m.opset_import[0].version),
                (IR_VERSION, OPSET)
            );
            let g = m.graph.as_ref().unwrap();
            let c = &r.config;
            let io = |v: &[ValueInfoProto]| -> Vec<(String, Vec<String>)> {
                v.iter().map(|p| (p.name.clone(), dims(p))).collect()
            };
            let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
            let (px, zd) = ((2 * c.past_len).to_string(), c.zdim.to_string());
            let mut want_in = vec![
                ("x".to_string(), s(&["n", &px])),
                ("z".to_string(), s(&["n", "k", &zd])),
            ];
            let mut want_out = vec![("d".to_string(), s(&["n", "k", "2"]))];
            if !r.nets.point_head.is_empty() {
                let w = (2 * c.future_len).to_string();
                want_out.push(("point".into(), s(&["n", &w])));
            }
            if !r.nets.predictor.is_empty() {
                want_in.push(("pos".into(), s(&["n", "2"])));
                let w = (2 * (c.future_len - 1)).to_string();
                want_out.push(("traj".into(), s(&["n", "k", &w])));
            }
            assert_eq!(io(&g.input), want_in, "{name}");
            assert_eq!(io(&g.output), want_out, "{name}");
            // Every weight and bias of the blob, transposed, split where documented.
            let init: HashMap<&str, &TensorProto> =
                g.initializer.iter().map(|t| (t.name.as_str(), t)).collect();
            let fdim = c.fdim;
            let ddim = r.nets.encoder_dest.last().map_or(0, |l| l.out_dim);
            let mut params = 0;
            for (net, layers) in crate::network::NETWORK_NAMES
                .iter()
                .zip(r.nets.in_blob_order())
            {
                for (i, l) in layers.iter().enumerate() {
                    let parts: Vec<(String, std::ops::Range<usize>)> = match (*net, i) {
                        ("decoder", 0) => vec![
                            ("decoder.0.weight.f".into(), 0..fdim),
                            ("decoder.0.weight.z".into(), fdim..l.in_dim),
                        ],
                        ("predictor", 0) => vec![
                            ("predictor.0.weight.f".into(), 0..fdim),
                            ("predictor.0.weight.g".into(), fdim..fdim + ddim),
                            ("predictor.0.weight.pos".into(), fdim + ddim..l.in_dim),
                        ],
                        _ => vec![(format!("{net}.{i}.weight"), 0..l.in_dim)],
                    };
                    for (pname, cols) in parts {
                        let t = init[pname.as_str()];
                        assert_eq!(t.dims, vec![cols.len() as i64, l.out_dim as i64], "{pname}");
                        let want: Vec<f32> = cols
                            .clone()
                            .flat_map(|ci| (0..l.out_dim).map(move |j| l.w[j * l.in_dim + ci]))
                            .collect();
                        assert_eq!(f32s(t), want, "{pname}");
                    }
                    let b = init[format!("{net}.{i}.bias").as_str()];
                    assert_eq!(b.dims, vec![l.out_dim as i64]);
                    assert_eq!(f32s(b), l.b);
                    params += l.w.len() + l.b.len();
                }
            }
            let counted: usize = g
                .initializer
                .iter()
                .filter(|t| t.data_type == FLOAT)
                .map(|t| t.raw_data.len() / 4)
                .sum();
            assert_eq!(counted, params, "{name}");
            // Every node input is a graph input, an initializer or an earlier output.
            let mut known: std::collections::HashSet<String> =
                g.input.iter().map(|i| i.name.clone()).collect();
            known.extend(g.initializer.iter().map(|t| t.name.clone()));
            for n in &g.node {
                for i in &n.input {
                    assert!(known.contains(i), "{name}: {} reads unknown {i}", n.name);
                }
                known.extend(n.output.iter().cloned());
            }
            for o in &g.output {
                assert!(known.contains(&o.name));
            }
        }
    }

    #[test]
    fn endpoint_only_has_x_z_and_d() {
        let (bytes, s) = blob_to_onnx(&blob("sdd-tiny-v2"), true).unwrap();
        let g = ModelProto::decode(bytes.as_slice()).unwrap().graph.unwrap();
        let names = |v: &[ValueInfoProto]| v.iter().map(|p| p.name.clone()).collect::<Vec<_>>();
        assert_eq!(names(&g.input), ["x", "z"]);
        assert_eq!(names(&g.output), ["d"]);
        assert_eq!(s.inputs.len(), 2);
        assert!(g
            .initializer
            .iter()
            .all(|t| t.name.starts_with("encoder_past.") || t.name.starts_with("decoder.")));
    }

    #[test]
    fn refuses_fixed_point_and_garbage_without_panicking() {
        let e = blob_to_onnx(&blob("sdd-small-q"), false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("fixed-point"), "{e}");
        assert!(blob_to_onnx(b"not a blob", false).is_err());
        let mut b = blob("sdd-tiny");
        let n = b.len();
        b[n / 2] ^= 0x40;
        assert!(blob_to_onnx(&b, false).is_err());
        assert!(blob_to_onnx(&[], true).is_err());
        let dir = tempfile::tempdir().unwrap();
        assert!(export_onnx(
            &dir.path().join("missing.gpec"),
            &dir.path().join("m.onnx"),
            false
        )
        .is_err());
    }

    /// A tensor of the tiny interpreter below: shape and row-major f64 values.
    type T = (Vec<usize>, Vec<f64>);

    fn broadcast_add(a: &T, b: &T) -> T {
        let r = a.0.len().max(b.0.len());
        let pad = |s: &[usize]| {
            let mut v = vec![1; r - s.len()];
            v.extend_from_slice(s);
            v
        };
        let (sa, sb) = (pad(&a.0), pad(&b.0));
        let shape: Vec<usize> = sa.iter().zip(&sb).map(|(x, y)| *x.max(y)).collect();
        let n: usize = shape.iter().product();
        let index = |s: &[usize], mut flat: usize| {
            let (mut idx, mut stride) = (0, 1);
            for d in (0..r).rev() {
                let i = flat % shape[d];
                flat /= shape[d];
                if s[d] != 1 {
                    idx += i * stride;
                }
                stride *= s[d];
            }
            idx
        };
        let v = (0..n)
            .map(|f| a.1[index(&sa, f)] + b.1[index(&sb, f)])
            .collect();
        (shape, v)
    }

    fn matmul(a: &T, b: &T) -> T {
        let (m, n) = (b.0[0], b.0[1]);
        let rows = a.1.len() / m;
        let mut v = vec![0.0; rows * n];
        for r in 0..rows {
            for j in 0..n {
                v[r * n + j] = (0..m).map(|i| a.1[r * m + i] * b.1[i * n + j]).sum();
            }
        }
        let mut shape = a.0.clone();
        *shape.last_mut().unwrap() = n;
        (shape, v)
    }

    /// Runs the exported graph (the ops it uses) in f64.
    fn run(g: &GraphProto, feeds: Vec<(&str, T)>) -> HashMap<String, T> {
        let mut env: HashMap<String, T> = feeds.into_iter().map(|(k, v)| (k.into(), v)).collect();
        for t in &g.initializer {
            let shape = t.dims.iter().map(|&d| d as usize).collect();
            let v = if t.data_type == INT64 {
                t.raw_data
                    .chunks_exact(8)
                    .map(|c| i64::from_le_bytes(c.try_into().unwrap()) as f64)
                    .collect()
            } else {
                f32s(t).into_iter().map(f64::from).collect()
            };
            env.insert(t.name.clone(), (shape, v));
        }
        for n in &g.node {
            let a = &env[&n.input[0]];
            let out = match n.op_type.as_str() {
                "MatMul" => matmul(a, &env[&n.input[1]]),
                "Add" => broadcast_add(a, &env[&n.input[1]]),
                "Sin" => (a.0.clone(), a.1.iter().map(|v| v.sin()).collect()),
                "Relu" => (a.0.clone(), a.1.iter().map(|v| v.max(0.0)).collect()),
                "Identity" => a.clone(),
                "Unsqueeze" => {
                    let ax = env[&n.input[1]].1[0] as usize;
                    let mut s = a.0.clone();
                    s.insert(ax, 1);
                    (s, a.1.clone())
                }
                op => panic!("unexpected op {op}"),
            };
            env.insert(n.output[0].clone(), out);
        }
        env
    }

    #[test]
    fn graph_computes_what_the_core_computes() {
        for name in ["sdd-small", "sdd-tiny-v2"] {
            let b = blob(name);
            let (m, r) = decode(name);
            let g = m.graph.unwrap();
            let model = gpecnet_core::Model::from_blob(&b).unwrap();
            let c = *model.config();
            let mut p = Box::new(Predictor::<LibmSine, 256>::new(model).unwrap());
            let (k, zdim) = (5, c.zdim as usize);
            for w in 0..3u64 {
                let past: Vec<[f32; 2]> = (0..c.past_len as usize)
                    .map(|t| {
                        let t = t as f32;
                        [100.0 + 3.5 * t + w as f32 * t * t * 0.3, 200.0 - 2.0 * t]
                    })
                    .collect();
                let (frame, pts) = Frame::inputs(&past, &model).unwrap();
                let x: Vec<f64> = pts[..past.len()]
                    .iter()
                    .flatten()
                    .map(|&v| f64::from(v))
                    .collect();
                let mut gs = Gaussian::new(w);
                let z: Vec<f64> = (0..k * zdim)
                    .map(|_| f64::from(c.sigma * gs.next()))
                    .collect();
                let q = frame.predictor_position(past[past.len() - 1]);
                let pos = vec![
                    f64::from(q[0] / c.initial_pos_divisor),
                    f64::from(q[1] / c.initial_pos_divisor),
                ];
                let env = run(
                    &g,
                    vec![
                        ("x", (vec![1, x.len()], x)),
                        ("z", (vec![1, k, zdim], z)),
                        ("pos", (vec![1, 2], pos)),
                    ],
                );
                let mut ends = vec![[0.0f32; 2]; k];
                p.predict_samples(&past, w, &mut ends).unwrap();
                let d = &env["d"];
                assert_eq!(d.0, vec![1, k, 2]);
                for (s, e) in ends.iter().enumerate() {
                    let got =
                        frame.output([d.1[2 * s] as f32, d.1[2 * s + 1] as f32], c.data_scale);
                    for ci in 0..2 {
                        assert!((got[ci] - e[ci]).abs() < 1e-2, "{name}: {got:?} vs {e:?}");
                    }
                }
                if !r.nets.point_head.is_empty() {
                    let want = p.predict_point(&past).unwrap();
                    let q = &env["point"].1;
                    for (t, e) in want.iter().enumerate() {
                        let got =
                            frame.output([q[2 * t] as f32, q[2 * t + 1] as f32], c.data_scale);
                        assert!((got[0] - e[0]).abs() < 1e-2 && (got[1] - e[1]).abs() < 1e-2);
                    }
                }
            }
        }
    }
}
