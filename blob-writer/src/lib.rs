//! The one writer of gpecnet's binary files (`weights/FORMAT.md`): weight blobs ([`blob_bytes`])
//! and golden-vector sidecars ([`golden_bytes`]). The trainer's exporters (`gpecnet export`,
//! `gpecnet quantize`), the workspace tests and the firmware host tool `make-test-blob` all
//! write through here, and every file is read back through `gpecnet-core`'s validating reader
//! before it is returned, so nothing is written that the embedded side would refuse.
//!
//! The crate is deliberately small (`gpecnet-core`, `postcard`, `serde`): the firmware host
//! tools, a workspace of their own, depend on it by path.

#![deny(missing_docs)]

use std::fmt;

pub use gpecnet_core::blob::{
    Activation, Extensions, Meta, ModelConfig, NumericKind, PositionUnit,
};
use gpecnet_core::blob::{
    ModelInfo, Preamble, ALIGNED_FORMAT_VERSION, CRC32, MAGIC, META_FORMAT_VERSION,
    PROPOSAL_FORMAT_VERSION, SCORE_FORMAT_VERSION, TENSOR_ALIGN,
};
pub use gpecnet_core::golden::GoldenInfo;
use gpecnet_core::golden::{
    GoldenCaseWire, GoldenCaseWireV2, GoldenPreamble, GOLDEN_MAGIC, GOLDEN_VERSION,
    GOLDEN_VERSION_POINT,
};

/// Why a blob or golden file could not be written.
#[derive(Debug)]
pub enum WriteError {
    /// A width or count does not fit its field in the format.
    TooLarge {
        /// Which value.
        what: &'static str,
        /// The value.
        value: usize,
    },
    /// A layer or case does not fit the file it is written into.
    Shape(String),
    /// postcard could not encode a record.
    Encode(postcard::Error),
    /// `gpecnet-core`'s reader refused the written file.
    Rejected {
        /// What was written ("f32 blob", "fixed-point blob", "golden file").
        what: &'static str,
        /// The reader's error.
        reason: String,
    },
}

impl fmt::Display for WriteError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            WriteError::TooLarge { what, value } => {
                write!(f, "{what} = {value} does not fit the file format")
            }
            WriteError::Shape(msg) => f.write_str(msg),
            WriteError::Encode(e) => write!(f, "postcard encoding: {e}"),
            WriteError::Rejected { what, reason } => {
                write!(f, "{what} rejected by gpecnet-core: {reason}")
            }
        }
    }
}

impl std::error::Error for WriteError {}

fn narrow<T: TryFrom<usize>>(what: &'static str, value: usize) -> Result<T, WriteError> {
    T::try_from(value).map_err(|_| WriteError::TooLarge { what, value })
}

fn push<T: serde::Serialize>(out: &mut Vec<u8>, v: &T) -> Result<(), WriteError> {
    out.extend(postcard::to_allocvec(v).map_err(WriteError::Encode)?);
    Ok(())
}

/// Length of `n` as a postcard (LEB128) varint.
fn varint_len(mut n: usize) -> usize {
    let mut len = 1;
    while n >= 0x80 {
        n >>= 7;
        len += 1;
    }
    len
}

/// A format-version-3 tensor (`weights/FORMAT.md`): the padding byte string
/// (0–3 zero bytes, its length prefix one byte) that puts the tensor's first
/// byte at a multiple of [`TENSOR_ALIGN`] from the blob's start (`out` is the
/// blob so far), then the tensor as a postcard byte string.
fn push_aligned(out: &mut Vec<u8>, tensor: &[u8]) -> Result<(), WriteError> {
    let data_at = out.len() + 1 + varint_len(tensor.len());
    let pad = vec![0u8; (TENSOR_ALIGN - data_at % TENSOR_ALIGN) % TENSOR_ALIGN];
    push(out, &pad.as_slice())?;
    debug_assert_eq!((out.len() + varint_len(tensor.len())) % TENSOR_ALIGN, 0);
    push(out, &tensor)
}

fn seal(mut out: Vec<u8>) -> Vec<u8> {
    let crc = CRC32.checksum(&out);
    out.extend(crc.to_le_bytes());
    out
}

/// Little-endian bytes of every value (the format's tensor encoding).
fn le<const N: usize, T: Copy>(v: &[T], bytes: impl Fn(T) -> [u8; N]) -> Vec<u8> {
    v.iter().flat_map(|&x| bytes(x)).collect()
}

/// The fixed-point scaling of one layer (`NumericKind::Int16Q15`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FixedScale {
    /// The input vector holds `x_i · 2^in_exp`.
    pub in_exp: i8,
    /// The output vector holds `y_j · 2^out_exp` (15 for sine layers).
    pub out_exp: i8,
    /// Per-output-channel requantisation shifts.
    pub shifts: Vec<i8>,
}

/// One dense layer as a blob stores it: shape, activation and little-endian tensors.
#[derive(Clone, Debug, PartialEq)]
pub struct WireLayer {
    /// Input width.
    pub in_dim: usize,
    /// Output width.
    pub out_dim: usize,
    /// Activation after the affine map.
    pub activation: Activation,
    /// `out_dim × in_dim` weights, row-major, little endian (f32 or i16).
    pub weights: Vec<u8>,
    /// `out_dim` biases, little endian (f32, or i32 in accumulator units).
    pub bias: Vec<u8>,
    /// The fixed-point scaling; `None` for an f32 layer.
    pub fixed: Option<FixedScale>,
}

impl WireLayer {
    /// An f32 layer (`w` row-major `[out][in]`).
    pub fn f32(
        in_dim: usize,
        out_dim: usize,
        activation: Activation,
        w: &[f32],
        b: &[f32],
    ) -> Self {
        Self {
            in_dim,
            out_dim,
            activation,
            weights: le(w, f32::to_le_bytes),
            bias: le(b, f32::to_le_bytes),
            fixed: None,
        }
    }

    /// A fixed-point layer: int16 weights (row-major), int32 biases, its scaling.
    pub fn q15(
        in_dim: usize,
        out_dim: usize,
        activation: Activation,
        w: &[i16],
        b: &[i32],
        scale: FixedScale,
    ) -> Self {
        Self {
            in_dim,
            out_dim,
            activation,
            weights: le(w, i16::to_le_bytes),
            bias: le(b, i32::to_le_bytes),
            fixed: Some(scale),
        }
    }

    fn push(&self, out: &mut Vec<u8>, numeric: NumericKind) -> Result<(), WriteError> {
        let (in_dim, out_dim): (u16, u16) = (
            narrow("in_dim", self.in_dim)?,
            narrow("out_dim", self.out_dim)?,
        );
        match (numeric, &self.fixed) {
            (NumericKind::F32, None) => {
                push(out, &in_dim)?;
                push(out, &out_dim)?;
                push(out, &self.activation)?;
                push_aligned(out, &self.weights)?;
                push_aligned(out, &self.bias)
            }
            (NumericKind::Int16Q15, Some(s)) => {
                let shifts: Vec<u8> = s.shifts.iter().map(|&v| v as u8).collect();
                push(out, &in_dim)?;
                push(out, &out_dim)?;
                push(out, &self.activation)?;
                push(out, &s.in_exp)?;
                push(out, &s.out_exp)?;
                push_aligned(out, &self.weights)?;
                push_aligned(out, &self.bias)?;
                push(out, &shifts.as_slice())
            }
            _ => Err(WriteError::Shape(format!(
                "a {} layer in a {numeric:?} blob",
                if self.fixed.is_some() {
                    "fixed-point"
                } else {
                    "f32"
                }
            ))),
        }
    }
}

/// Everything of a blob before its networks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlobHead<'a> {
    /// The blob's numeric kind (every layer must be of it).
    pub numeric: NumericKind,
    /// The model's name.
    pub name: &'a str,
    /// Hyper-parameters.
    pub config: ModelConfig,
    /// The version-2 settings (heading frame, test-time sampling); `None` is all zeros
    /// (raw orientation, plain sampling). Versions 3 and 4 store them either way.
    pub extensions: Option<Extensions>,
    /// The version-4 description (unit, period, training data, licence). `Some` writes
    /// format version 4 ([`META_FORMAT_VERSION`]); `None` writes version 3
    /// ([`ALIGNED_FORMAT_VERSION`]), byte for byte what this writer gave before version 4
    /// existed (so re-exporting an old model reproduces its shipped bytes).
    pub meta: Option<Meta<'a>>,
}

/// Serialises a blob in format version 4 (with [`BlobHead::meta`]) or 3 (without):
/// preamble, model info, extensions, the meta record (version 4), the networks in the
/// blob's order (`encoder_past`, `decoder`,
/// `encoder_dest`, `predictor`, `point_head`), each weight and bias tensor after the
/// padding that aligns it to [`TENSOR_ALIGN`] bytes from the blob's start, and the
/// CRC-32; checked by `gpecnet-core`'s reader.
pub fn blob_bytes(head: &BlobHead<'_>, networks: [&[WireLayer]; 5]) -> Result<Vec<u8>, WriteError> {
    blob_bytes_with_proposal(head, networks, None)
}

/// A learned latent proposal for [`blob_bytes_with_proposal`]: the network
/// (`fdim → K·zdim`, last layer linear) and the clamp `±bound` of every latent
/// component.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProposalWire<'a> {
    /// The layers.
    pub layers: &'a [WireLayer],
    /// The latent bound (finite, > 0).
    pub bound: f32,
    /// The radius multipliers `[r50, r90]` of a model with endpoint probabilities (its
    /// last layer then also has `K` logit rows after the `K·zdim` latent rows): format
    /// version 6 ([`SCORE_FORMAT_VERSION`]). `[0.0; 2]` for none (version 5).
    pub radius_scales: [f32; 2],
}

/// [`blob_bytes`], and with `Some` proposal format version 5
/// ([`PROPOSAL_FORMAT_VERSION`]): the meta record (required), then the
/// latent bound (f32), the five networks and the proposal as a sixth; version 6
/// ([`SCORE_FORMAT_VERSION`]) when the proposal has radius multipliers, written after
/// the bound.
pub fn blob_bytes_with_proposal(
    head: &BlobHead<'_>,
    networks: [&[WireLayer]; 5],
    proposal: Option<ProposalWire<'_>>,
) -> Result<Vec<u8>, WriteError> {
    if proposal.is_some() && head.meta.is_none() {
        return Err(WriteError::Shape(
            "a blob with a latent proposal (format version 5) must state its unit and clock".into(),
        ));
    }
    let mut out = Vec::new();
    push(
        &mut out,
        &Preamble {
            magic: MAGIC,
            version: if proposal.is_some_and(|p| p.radius_scales != [0.0; 2]) {
                SCORE_FORMAT_VERSION
            } else if proposal.is_some() {
                PROPOSAL_FORMAT_VERSION
            } else if head.meta.is_some() {
                META_FORMAT_VERSION
            } else {
                ALIGNED_FORMAT_VERSION
            },
        },
    )?;
    push(
        &mut out,
        &ModelInfo {
            numeric: head.numeric,
            name: head.name,
            config: head.config,
        },
    )?;
    push(&mut out, &head.extensions.unwrap_or_default())?;
    if let Some(meta) = &head.meta {
        push(&mut out, meta)?;
    }
    if let Some(p) = &proposal {
        push(&mut out, &p.bound)?;
        if p.radius_scales != [0.0; 2] {
            push(&mut out, &p.radius_scales)?;
        }
    }
    let sixth = proposal.map(|p| p.layers);
    for net in networks.into_iter().chain(sixth) {
        push(&mut out, &narrow::<u8>("layers in a network", net.len())?)?;
        for l in net {
            l.push(&mut out, head.numeric)?;
        }
    }
    let out = seal(out);
    gpecnet_core::Model::from_blob(&out).map_err(|e| WriteError::Rejected {
        what: match head.numeric {
            NumericKind::F32 => "f32 blob",
            NumericKind::Int16Q15 => "fixed-point blob",
        },
        reason: e.to_string(),
    })?;
    Ok(out)
}

/// One golden case: inputs and the outputs a reference computed for them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GoldenCase {
    /// Observed positions.
    pub past: Vec<[f32; 2]>,
    /// Latent seed.
    pub seed: u64,
    /// K endpoints.
    pub endpoints: Vec<[f32; 2]>,
    /// Sample 0's trajectory (empty for endpoint-only models).
    pub trajectory0: Vec<[f32; 2]>,
    /// The point forecast (empty for models without a point head).
    pub point: Vec<[f32; 2]>,
}

/// Serialises a golden file: `info` (its `n_cases` must be `cases.len()`), then the cases;
/// version 1, or version 2 when any case records a point forecast. Checked by
/// `gpecnet-core`'s reader.
pub fn golden_bytes(info: &GoldenInfo<'_>, cases: &[GoldenCase]) -> Result<Vec<u8>, WriteError> {
    if narrow::<u32>("golden cases", cases.len())? != info.n_cases {
        return Err(WriteError::Shape(format!(
            "golden file header says {} cases, {} given",
            info.n_cases,
            cases.len()
        )));
    }
    let with_point = cases.iter().any(|c| !c.point.is_empty());
    let mut out = Vec::new();
    push(
        &mut out,
        &GoldenPreamble {
            magic: GOLDEN_MAGIC,
            version: if with_point {
                GOLDEN_VERSION_POINT
            } else {
                GOLDEN_VERSION
            },
        },
    )?;
    push(&mut out, info)?;
    let flat =
        |v: &[[f32; 2]]| -> Vec<u8> { v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect() };
    for case in cases {
        if case.past.len() != usize::from(info.past_len)
            || case.endpoints.len() != usize::from(info.k)
        {
            return Err(WriteError::Shape(
                "golden case shape does not match the model".into(),
            ));
        }
        let (p, e, t, q) = (
            flat(&case.past),
            flat(&case.endpoints),
            flat(&case.trajectory0),
            flat(&case.point),
        );
        let v1 = GoldenCaseWire {
            past: &p,
            seed: case.seed,
            endpoints: &e,
            trajectory0: &t,
        };
        if with_point {
            push(
                &mut out,
                &GoldenCaseWireV2 {
                    case: v1,
                    point: &q,
                },
            )?;
        } else {
            push(&mut out, &v1)?;
        }
    }
    let out = seal(out);
    gpecnet_core::golden::GoldenSet::parse(&out).map_err(|e| WriteError::Rejected {
        what: "golden file",
        reason: e.to_string(),
    })?;
    Ok(out)
}

/// One layer's dims and raw tensors (weights, bias, shifts), for comparing two blobs.
type LayerTensors = (usize, usize, Vec<u8>, Vec<u8>, Vec<u8>);

/// Re-writes any readable blob (format version 1 to 4) in the newest format that holds what it
/// says (version 4 when it states a unit, else 3) with the same name, hyper-parameters,
/// extensions, description and tensors, byte for byte: what `gpec-rewrite` runs over
/// `weights/`. Writing a version-3 or 4 blob again gives the same bytes (the padding is
/// canonical).
pub fn rewrite_blob(blob: &[u8]) -> Result<Vec<u8>, WriteError> {
    let rejected = |e: gpecnet_core::BlobError| WriteError::Rejected {
        what: "blob to rewrite",
        reason: e.to_string(),
    };
    let model = gpecnet_core::Model::from_blob(blob).map_err(rejected)?;
    let meta = Meta::of_blob(blob).map_err(rejected)?;
    let wire = |net: &gpecnet_core::blob::Network<'_>| -> Vec<WireLayer> {
        net.layers()
            .map(|l| {
                let (weights, bias, shifts) = l.tensors_q();
                WireLayer {
                    in_dim: l.in_dim(),
                    out_dim: l.out_dim(),
                    activation: l.activation(),
                    weights: weights.to_vec(),
                    bias: bias.to_vec(),
                    fixed: (model.numeric() == NumericKind::Int16Q15).then(|| FixedScale {
                        in_exp: l.in_exp(),
                        out_exp: l.out_exp(),
                        shifts: shifts.iter().map(|&s| s as i8).collect(),
                    }),
                }
            })
            .collect()
    };
    let nets = [
        wire(model.encoder_past()),
        wire(model.decoder()),
        wire(model.encoder_dest()),
        wire(model.predictor()),
        wire(model.point_head()),
        wire(model.proposal()),
    ];
    let head = BlobHead {
        numeric: model.numeric(),
        name: model.name(),
        config: *model.config(),
        extensions: Some(*model.extensions()),
        meta: Some(meta).filter(|m| m.unit != PositionUnit::Unknown),
    };
    let proposal = model.has_proposal().then(|| ProposalWire {
        layers: &nets[5],
        bound: model.latent_bound(),
        radius_scales: model.radius_scales(),
    });
    let out = blob_bytes_with_proposal(
        &head,
        [&nets[0], &nets[1], &nets[2], &nets[3], &nets[4]],
        proposal,
    )?;
    // The same model, tensor for tensor (only the framing may differ).
    let again = gpecnet_core::Model::from_blob(&out).map_err(|e| WriteError::Rejected {
        what: "rewritten blob",
        reason: e.to_string(),
    })?;
    let tensors = |m: &gpecnet_core::Model<'_>| -> Vec<LayerTensors> {
        [
            m.encoder_past(),
            m.decoder(),
            m.encoder_dest(),
            m.predictor(),
            m.point_head(),
            m.proposal(),
        ]
        .into_iter()
        .flat_map(|n| n.layers())
        .map(|l| {
            let (w, b, s) = l.tensors_q();
            (l.in_dim(), l.out_dim(), w.to_vec(), b.to_vec(), s.to_vec())
        })
        .collect()
    };
    if tensors(&model) != tensors(&again)
        || model.config() != again.config()
        || model.extensions() != again.extensions()
        || model.latent_bound().to_bits() != again.latent_bound().to_bits()
        || model.radius_scales().map(f32::to_bits) != again.radius_scales().map(f32::to_bits)
        || Meta::of_blob(&out).ok() != Some(meta)
    {
        return Err(WriteError::Shape(
            "rewritten blob differs from the original".into(),
        ));
    }
    Ok(out)
}

/// Re-writes a golden file for the re-written blob whose CRC is `model_crc`: the same cases,
/// bit for bit, through [`golden_bytes`]; only `GoldenInfo::model_crc` (and so the trailing
/// CRC) changes. The file must belong to `old_crc`, the blob it was made with.
pub fn rewrite_golden(golden: &[u8], old_crc: u32, model_crc: u32) -> Result<Vec<u8>, WriteError> {
    let rejected = |what: &'static str| {
        move |e: gpecnet_core::BlobError| WriteError::Rejected {
            what,
            reason: e.to_string(),
        }
    };
    let set = gpecnet_core::golden::GoldenSet::parse(golden).map_err(rejected("golden file"))?;
    let info = *set.info();
    if info.model_crc != old_crc && info.model_crc != model_crc {
        return Err(WriteError::Shape(format!(
            "golden file belongs to blob CRC {:#010x}, not {old_crc:#010x}",
            info.model_crc
        )));
    }
    let pairs = |f: &dyn Fn(usize) -> Option<[u32; 2]>| -> Vec<[f32; 2]> {
        (0..)
            .map_while(f)
            .map(|[x, y]| [f32::from_bits(x), f32::from_bits(y)])
            .collect()
    };
    let cases: Vec<GoldenCase> = set
        .cases()
        .map(|c| GoldenCase {
            past: c.past.to_vec(),
            seed: c.seed,
            endpoints: pairs(&|i| (i < c.k()).then(|| c.endpoint_bits(i))),
            trajectory0: pairs(&|t| c.trajectory0_bits(t)),
            point: pairs(&|t| c.point_bits(t)),
        })
        .collect();
    let out = golden_bytes(&GoldenInfo { model_crc, ..info }, &cases)?;
    // Only the header's CRC field (a varint: its length may change) and the trailing CRC
    // may differ; every case is the same bytes.
    let check =
        gpecnet_core::golden::GoldenSet::parse(&out).map_err(rejected("rewritten golden"))?;
    let same = check.cases().zip(set.cases()).all(|(a, b)| a == b)
        && check.cases().count() == set.cases().count()
        && {
            // The case bytes: after the preamble (6 bytes: magic, 1-byte version) and the info.
            let head = |i: &GoldenInfo<'_>| postcard::to_allocvec(i).map_or(0, |v| v.len()) + 5;
            let (a, b) = (head(&info) + 1, head(check.info()) + 1);
            golden.get(a..golden.len() - 4) == out.get(b..out.len() - 4)
        };
    if !same {
        return Err(WriteError::Shape(
            "rewritten golden file differs from the original".into(),
        ));
    }
    Ok(out)
}
