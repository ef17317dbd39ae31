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

pub use gpecnet_core::blob::{Activation, Extensions, ModelConfig, NumericKind};
use gpecnet_core::blob::{
    LayerWire, LayerWireQ, ModelInfo, Preamble, CRC32, FORMAT_VERSION, MAGIC, MIN_FORMAT_VERSION,
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
        let (in_dim, out_dim) = (
            narrow("in_dim", self.in_dim)?,
            narrow("out_dim", self.out_dim)?,
        );
        match (numeric, &self.fixed) {
            (NumericKind::F32, None) => push(
                out,
                &LayerWire {
                    in_dim,
                    out_dim,
                    activation: self.activation,
                    weights: &self.weights,
                    bias: &self.bias,
                },
            ),
            (NumericKind::Int16Q15, Some(s)) => {
                let shifts: Vec<u8> = s.shifts.iter().map(|&v| v as u8).collect();
                push(
                    out,
                    &LayerWireQ {
                        in_dim,
                        out_dim,
                        activation: self.activation,
                        in_exp: s.in_exp,
                        out_exp: s.out_exp,
                        weights: &self.weights,
                        bias: &self.bias,
                        shifts: &shifts,
                    },
                )
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
    /// The version-2 settings: `Some` writes format version 2 (with the point head),
    /// `None` version 1, so models without the new features keep their bytes.
    pub extensions: Option<Extensions>,
}

/// Serialises a blob: preamble, model info, (extensions,) the networks in the blob's order
/// (`encoder_past`, `decoder`, `encoder_dest`, `predictor`, `point_head`; a version-1 blob has
/// no point head) and the CRC-32; checked by `gpecnet-core`'s reader.
pub fn blob_bytes(head: &BlobHead<'_>, networks: [&[WireLayer]; 5]) -> Result<Vec<u8>, WriteError> {
    let v2 = head.extensions.is_some();
    if !v2 && !networks[4].is_empty() {
        return Err(WriteError::Shape(
            "a point head needs format version 2 (extensions)".into(),
        ));
    }
    let mut out = Vec::new();
    push(
        &mut out,
        &Preamble {
            magic: MAGIC,
            version: if v2 {
                FORMAT_VERSION
            } else {
                MIN_FORMAT_VERSION
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
    if let Some(x) = &head.extensions {
        push(&mut out, x)?;
    }
    for net in networks.into_iter().take(if v2 { 5 } else { 4 }) {
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
                    point: &q,
                    ..v1.into()
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
