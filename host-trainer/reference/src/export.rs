//! Writes weight blobs (`weights/FORMAT.md`) and golden-vector sidecars
//! (`gpecnet_core::golden`) of an [`InferenceModel`] of either numeric kind through the one
//! shared writer (`gpecnet-blob-writer`), and reads f32 blobs back into a [`RefModel`].

use anyhow::{bail, Result};
pub use gpecnet_blob_writer::GoldenCase;
use gpecnet_blob_writer::{BlobHead, GoldenInfo, WireLayer};
use gpecnet_core::blob::{Extensions, ModelConfig};

use crate::network::{InferenceModel, Layer, Networks, Numeric};
use crate::network::{ModelMeta, RefConfig};
use crate::reference::{RefModel, SineKind};

/// `v` narrowed to the wire type `T` whose largest value is `max`; an error naming `what`
/// (the setting or option) and the limit otherwise.
fn fit<T: TryFrom<usize>>(what: &str, v: usize, max: u64) -> Result<T> {
    T::try_from(v).map_err(|_| anyhow::anyhow!("{what} = {v} is out of range: at most {max}"))
}

/// The blob's `ModelConfig` for a model's hyper-parameters.
pub fn wire_config(c: &RefConfig) -> Result<ModelConfig> {
    Ok(ModelConfig {
        past_len: fit::<u8>("past_length", c.past_len, u8::MAX.into())?,
        future_len: fit::<u8>("future_length", c.future_len, u8::MAX.into())?,
        fdim: fit::<u16>("fdim", c.fdim, u16::MAX.into())?,
        zdim: fit::<u16>("zdim", c.zdim, u16::MAX.into())?,
        data_scale: c.data_scale,
        sigma: c.sigma,
        initial_pos_divisor: c.initial_pos_divisor,
        w0: c.w0,
        hidden_activation: c.hidden_act.into(),
    })
}

/// The version-2 settings of a model's config.
pub fn wire_extensions(c: &RefConfig) -> Result<Extensions> {
    Ok(Extensions {
        heading_steps: fit::<u8>("heading_steps", c.heading_steps, u8::MAX.into())?,
        tts_samples: fit::<u16>("test-time samples (--tts)", c.tts_samples, u16::MAX.into())?,
        tts_iters: c.tts_iters,
        tts_init: c.tts_init,
    })
}

/// Serialises `model` as a blob of its numeric kind (format version 4 when its config carries
/// a [`ModelMeta`], else 3), CRC included, after checking its shapes; the embedded reader
/// accepts what this returns.
pub fn blob_bytes<K: Numeric>(model: &InferenceModel<K>) -> Result<Vec<u8>> {
    model.validate()?;
    let c = &model.config;
    let head = BlobHead {
        numeric: K::KIND,
        name: &model.name,
        config: wire_config(c)?,
        extensions: if model.needs_v2() {
            Some(wire_extensions(c)?)
        } else {
            None
        },
        meta: c.meta.as_ref().map(ModelMeta::wire),
    };
    let nets: [Vec<WireLayer>; 5] = model
        .nets
        .in_blob_order()
        .map(|n| n.iter().map(Layer::wire).collect());
    let proposal: Vec<WireLayer> = model.nets.proposal.iter().map(Layer::wire).collect();
    Ok(gpecnet_blob_writer::blob_bytes_with_proposal(
        &head,
        nets.each_ref().map(Vec::as_slice),
        (!proposal.is_empty()).then_some(gpecnet_blob_writer::ProposalWire {
            layers: &proposal,
            bound: c.latent_bound,
            radius_scales: c.radius_scales,
        }),
    )?)
}

/// Reads a blob back into memory (through `gpecnet-core`'s validating reader).
pub fn read_blob(bytes: &[u8]) -> Result<RefModel> {
    let m = gpecnet_core::Model::from_blob(bytes).map_err(|e| anyhow::anyhow!("{e}"))?;
    if m.numeric() != gpecnet_core::NumericKind::F32 {
        bail!("{} is a fixed-point blob; this reads f32 blobs", m.name());
    }
    let c = m.config();
    let net = |n: &gpecnet_core::blob::Network<'_>| -> Vec<Layer> {
        n.layers()
            .map(|l| {
                Layer::new(
                    l.in_dim(),
                    l.out_dim(),
                    l.activation().into(),
                    (0..l.out_dim())
                        .flat_map(|j| (0..l.in_dim()).map(move |i| (j, i)))
                        .map(|(j, i)| l.weight(j, i))
                        .collect(),
                    (0..l.out_dim()).map(|j| l.bias(j)).collect(),
                )
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
            hidden_act: c.hidden_activation.into(),
            heading_steps: m.extensions().heading_steps as usize,
            tts_samples: m.extensions().tts_samples as usize,
            tts_iters: m.extensions().tts_iters,
            tts_init: m.extensions().tts_init,
            latent_bound: m.latent_bound(),
            radius_scales: m.radius_scales(),
            meta: ModelMeta::of_blob(bytes),
        },
        nets: Networks {
            encoder_past: net(m.encoder_past()),
            decoder: net(m.decoder()),
            encoder_dest: net(m.encoder_dest()),
            predictor: net(m.predictor()),
            point_head: net(m.point_head()),
            proposal: net(m.proposal()),
        },
    })
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
                let p = model.predict(past, *seed, k, sine, !model.nets.predictor.is_empty());
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

/// Serialises the golden `cases` of `model` (either numeric kind) for its blob with CRC
/// `model_crc`, computed with the sine named `sine` (`gpecnet_core::Sine::NAME`): version 1,
/// or version 2 when any case records a point forecast.
pub fn golden_bytes<K: Numeric>(
    model: &InferenceModel<K>,
    model_crc: u32,
    sine: &str,
    k: usize,
    cases: &[GoldenCase],
) -> Result<Vec<u8>> {
    let c = &model.config;
    let info = GoldenInfo {
        model_name: &model.name,
        model_crc,
        sine,
        past_len: fit::<u8>("past_length", c.past_len, u8::MAX.into())?,
        future_len: fit::<u8>("future_length", c.future_len, u8::MAX.into())?,
        k: fit::<u8>("K (--k)", k, u8::MAX.into())?,
        n_cases: fit::<u32>("golden cases", cases.len(), u32::MAX.into())?,
    };
    Ok(gpecnet_blob_writer::golden_bytes(&info, cases)?)
}

/// The sine a blob's golden sidecar names (the one its numbers were made with), if any.
pub fn sine_of_blob(blob_path: &std::path::Path) -> Option<SineKind> {
    let bytes = crate::inpath::read_limited(
        &blob_path.with_extension("golden"),
        crate::inpath::FileKind::Golden,
    )
    .ok()?;
    let set = gpecnet_core::golden::GoldenSet::parse(&bytes).ok()?;
    match set.info().sine {
        "libm" => Some(SineKind::Libm),
        "fast-f32" => Some(SineKind::Fast),
        _ => None,
    }
}
