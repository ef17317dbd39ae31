//! Writes weight blobs (`weights/FORMAT.md`) and golden-vector sidecars
//! (`gpecnet_core::golden`) from a [`RefModel`], and reads blobs back into one.

use anyhow::{bail, Context, Result};
use gpecnet_core::blob::{
    Activation, Extensions, LayerWire, ModelConfig, ModelInfo, NumericKind, Preamble, CRC32,
    FORMAT_VERSION, MAGIC, MIN_FORMAT_VERSION,
};
use gpecnet_core::golden::{
    GoldenCaseWire, GoldenCaseWireV2, GoldenInfo, GoldenPreamble, GOLDEN_MAGIC, GOLDEN_VERSION,
    GOLDEN_VERSION_POINT,
};

use crate::reference::{Act, RefConfig, RefLayer, RefModel, SineKind};

pub(crate) fn act_to_wire(a: Act) -> Activation {
    match a {
        Act::Linear => Activation::Linear,
        Act::Relu => Activation::Relu,
        Act::Sine => Activation::Sine,
    }
}

fn act_from_wire(a: Activation) -> Act {
    match a {
        Activation::Linear => Act::Linear,
        Activation::Relu => Act::Relu,
        Activation::Sine => Act::Sine,
    }
}

fn le_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

pub(crate) fn push<T: serde::Serialize>(out: &mut Vec<u8>, v: &T) -> Result<()> {
    out.extend(postcard::to_stdvec(v).context("postcard encoding")?);
    Ok(())
}

/// The blob's `ModelConfig` for a model's hyper-parameters (shared by the f32
/// and fixed-point exporters).
pub(crate) fn wire_config(c: &RefConfig) -> Result<ModelConfig> {
    Ok(ModelConfig {
        past_len: u8::try_from(c.past_len)?,
        future_len: u8::try_from(c.future_len)?,
        fdim: u16::try_from(c.fdim)?,
        zdim: u16::try_from(c.zdim)?,
        data_scale: c.data_scale,
        sigma: c.sigma,
        initial_pos_divisor: c.initial_pos_divisor,
        w0: c.w0,
        hidden_activation: act_to_wire(c.hidden_act),
    })
}

/// The version-2 settings of a model's config.
pub(crate) fn wire_extensions(c: &RefConfig) -> Result<Extensions> {
    Ok(Extensions {
        heading_steps: u8::try_from(c.heading_steps)?,
        tts_samples: u16::try_from(c.tts_samples)?,
        tts_iters: c.tts_iters,
        tts_init: c.tts_init,
    })
}

/// The head of every blob (shared by the f32 and fixed-point exporters): preamble, model info
/// and, for a model that uses a version-2 setting, the extensions. Returns the version
/// written: 1 whenever possible, so models without the new features keep their bytes.
pub(crate) fn push_head(
    out: &mut Vec<u8>,
    numeric: NumericKind,
    name: &str,
    c: &RefConfig,
    v2: bool,
) -> Result<u16> {
    let version = if v2 {
        FORMAT_VERSION
    } else {
        MIN_FORMAT_VERSION
    };
    push(
        out,
        &Preamble {
            magic: MAGIC,
            version,
        },
    )?;
    push(
        out,
        &ModelInfo {
            numeric,
            name,
            config: wire_config(c)?,
        },
    )?;
    if v2 {
        push(out, &wire_extensions(c)?)?;
    }
    Ok(version)
}

/// Serialises `model` as an f32 blob (format version 1, or 2 when it uses the heading frame,
/// test-time sampling or a point head), CRC included.
pub fn blob_bytes(model: &RefModel) -> Result<Vec<u8>> {
    model.validate()?;
    let mut out = Vec::new();
    let v2 = model.needs_v2();
    push_head(&mut out, NumericKind::F32, &model.name, &model.config, v2)?;
    let nets = [
        &model.encoder_past,
        &model.decoder,
        &model.encoder_dest,
        &model.predictor,
        &model.point_head,
    ];
    for net in nets.into_iter().take(if v2 { 5 } else { 4 }) {
        push(&mut out, &u8::try_from(net.len())?)?;
        for l in net {
            let (w, b) = (le_bytes(&l.w), le_bytes(&l.b));
            let wire = LayerWire {
                in_dim: u16::try_from(l.in_dim)?,
                out_dim: u16::try_from(l.out_dim)?,
                activation: act_to_wire(l.act),
                weights: &w,
                bias: &b,
            };
            push(&mut out, &wire)?;
        }
    }
    let crc = CRC32.checksum(&out);
    out.extend(crc.to_le_bytes());
    // The embedded reader must accept what we write.
    gpecnet_core::Model::from_blob(&out)
        .map_err(|e| anyhow::anyhow!("exported blob rejected by gpecnet-core: {e}"))?;
    Ok(out)
}

/// Reads a blob back into memory (through `gpecnet-core`'s validating reader).
pub fn read_blob(bytes: &[u8]) -> Result<RefModel> {
    let m = gpecnet_core::Model::from_blob(bytes).map_err(|e| anyhow::anyhow!("{e}"))?;
    if m.numeric() != gpecnet_core::NumericKind::F32 {
        bail!("{} is a fixed-point blob; this reads f32 blobs", m.name());
    }
    let c = m.config();
    let net = |n: &gpecnet_core::blob::Network<'_>| -> Vec<RefLayer> {
        n.layers()
            .map(|l| RefLayer {
                in_dim: l.in_dim(),
                out_dim: l.out_dim(),
                act: act_from_wire(l.activation()),
                w: (0..l.out_dim())
                    .flat_map(|j| (0..l.in_dim()).map(move |i| (j, i)))
                    .map(|(j, i)| l.weight(j, i))
                    .collect(),
                b: (0..l.out_dim()).map(|j| l.bias(j)).collect(),
            })
            .collect()
    };
    Ok(RefModel {
        name: m.name().to_string(),
        config: RefConfig {
            past_len: c.past_len as usize,
            future_len: c.future_len as usize,
            fdim: c.fdim as usize,
            zdim: c.zdim as usize,
            data_scale: c.data_scale,
            sigma: c.sigma,
            initial_pos_divisor: c.initial_pos_divisor,
            w0: c.w0,
            hidden_act: act_from_wire(c.hidden_activation),
            heading_steps: m.extensions().heading_steps as usize,
            tts_samples: m.extensions().tts_samples as usize,
            tts_iters: m.extensions().tts_iters,
            tts_init: m.extensions().tts_init,
        },
        encoder_past: net(m.encoder_past()),
        decoder: net(m.decoder()),
        encoder_dest: net(m.encoder_dest()),
        predictor: net(m.predictor()),
        point_head: net(m.point_head()),
    })
}

/// One golden case: inputs and the reference path's outputs.
#[derive(Clone, Debug)]
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

/// Computes golden cases with the canonical reference path.
pub fn golden_cases(
    model: &RefModel,
    inputs: &[(Vec<[f32; 2]>, u64)],
    k: usize,
    sine: SineKind,
) -> Result<Vec<GoldenCase>> {
    inputs
        .iter()
        .map(|(past, seed)| {
            let (endpoints, trajectory0) = if model.config.tts_samples > 0 {
                (model.predict_set(past, *seed, k, sine)?, Vec::new())
            } else {
                let p = model.predict(past, *seed, k, sine, !model.predictor.is_empty());
                (
                    p.endpoints,
                    p.trajectories.first().cloned().unwrap_or_default(),
                )
            };
            Ok(GoldenCase {
                past: past.clone(),
                seed: *seed,
                endpoints,
                trajectory0,
                point: model.predict_point(past, sine).unwrap_or_default(),
            })
        })
        .collect()
}

/// Serialises golden cases for the f32 blob whose CRC is `model_crc`.
pub fn golden_bytes(
    model: &RefModel,
    model_crc: u32,
    sine: SineKind,
    k: usize,
    cases: &[GoldenCase],
) -> Result<Vec<u8>> {
    let c = &model.config;
    golden_file_bytes(
        &model.name,
        model_crc,
        sine.core_name(),
        (c.past_len, c.future_len),
        k,
        cases,
    )
}

/// The one golden-file writer (f32 and fixed-point models): version 1, or version 2 when any
/// case records a point forecast. `lens` = `(past_len, future_len)`.
pub fn golden_file_bytes(
    name: &str,
    model_crc: u32,
    sine: &str,
    lens: (usize, usize),
    k: usize,
    cases: &[GoldenCase],
) -> Result<Vec<u8>> {
    let (past_len, future_len) = lens;
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
    let info = GoldenInfo {
        model_name: name,
        model_crc,
        sine,
        past_len: u8::try_from(past_len)?,
        future_len: u8::try_from(future_len)?,
        k: u8::try_from(k)?,
        n_cases: u32::try_from(cases.len())?,
    };
    push(&mut out, &info)?;
    let flat =
        |v: &[[f32; 2]]| -> Vec<u8> { v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect() };
    for case in cases {
        if case.past.len() != past_len || case.endpoints.len() != k {
            bail!("golden case shape does not match the model");
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
    let crc = CRC32.checksum(&out);
    out.extend(crc.to_le_bytes());
    gpecnet_core::golden::GoldenSet::parse(&out)
        .map_err(|e| anyhow::anyhow!("golden file rejected by gpecnet-core: {e}"))?;
    Ok(out)
}
