//! PECNet / G-PECNet (conditional VAE over the endpoint) on candle, CPU, with PECNet's
//! optional non-local social pooling ([`crate::social`], off by default, host only).
//!
//! Networks (PECNet names and order):
//! * `encoder_past`: `2 * past_length` (x0, y0, x1, y1, ...) -> `fdim`
//! * `encoder_dest`: 2 -> `fdim`
//! * `encoder_latent`: `2 * fdim` -> `2 * zdim` (mu, logvar); training only
//! * `decoder`: `fdim + zdim` -> 2 (the endpoint)
//! * `predictor`: `2 * fdim + 2` (features, encoded endpoint, initial_pos) ->
//!   `2 * (future_length - 1)` (the 11 intermediate points, x/y interleaved)
//! * only with `social_pooling`: `non_local_theta`, `non_local_phi`, `non_local_g`, applied
//!   `nonlocal_pools` times to the predictor's input features (masked by social groups). They
//!   are initialised and stored after all other networks, so configs without pooling keep
//!   their exact initialisation and checkpoint layout.
//!
//! Every MLP is `Linear -> act -> ... -> Linear` (activation after every layer but the last),
//! with `act = sin(w0 * .)` (SIREN, G-PECNet) or ReLU (PECNet). All weights are initialised
//! from the crate's seeded [`Rng`]; no candle randomness is used.
//!
//! The layers, activations and their fused ops are `gpecnet_nn`'s ([`Mlp`], `gpecnet_nn::ops`).

use candle_core::{DType, Device, Tensor, Var};

use crate::config::TrainConfig;
use crate::data::{Sample, FUTURE, PAST};
use crate::network::Networks;
use crate::social::SocialPooling;
use gpecnet_nn::mlp::Mlp;
use gpecnet_nn::rng::Rng;

/// A minibatch in model space (see [`crate::data::normalize`]).
#[derive(Clone, Debug)]
pub struct Batch {
    /// `[B, 2 * PAST]`, x/y interleaved.
    pub obs: Tensor,
    /// `[B, 2]`: the endpoint (future step 12).
    pub dest: Tensor,
    /// `[B, 2 * (FUTURE - 1)]`: future steps 1..=11, x/y interleaved.
    pub future: Tensor,
    /// `[B, 2]`: raw last observed position / 1000.
    pub initial_pos: Tensor,
}

impl Batch {
    /// Stack samples into tensors.
    pub fn from_samples<'a, I>(samples: I) -> candle_core::Result<Self>
    where
        I: IntoIterator<Item = &'a Sample>,
    {
        let (mut obs, mut dest, mut fut, mut init): (Vec<f32>, Vec<f32>, Vec<f32>, Vec<f32>) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut n = 0;
        for s in samples {
            obs.extend(s.obs.iter().flatten());
            dest.extend(s.future[FUTURE - 1]);
            fut.extend(s.future[..FUTURE - 1].iter().flatten());
            init.extend(s.initial_pos);
            n += 1;
        }
        let dev = Device::Cpu;
        Ok(Self {
            obs: Tensor::from_vec(obs, (n, 2 * PAST), &dev)?,
            dest: Tensor::from_vec(dest, (n, 2), &dev)?,
            future: Tensor::from_vec(fut, (n, 2 * (FUTURE - 1)), &dev)?,
            initial_pos: Tensor::from_vec(init, (n, 2), &dev)?,
        })
    }

    /// Batch size.
    pub fn len(&self) -> usize {
        self.obs.dims()[0]
    }

    /// `true` for an empty batch.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The training loss and its parts (parts as plain numbers, for logging).
#[derive(Debug)]
pub struct Loss {
    /// `rcl + kld_reg * kld + adl_reg * adl` (differentiable scalar).
    pub total: Tensor,
    /// Endpoint reconstruction MSE (mean over elements).
    pub rcl: f32,
    /// KL divergence, summed over the batch (PECNet's convention).
    pub kld: f32,
    /// Intermediate-points MSE (mean over elements).
    pub adl: f32,
    /// Point head: mean Euclidean displacement over the 12 steps plus the endpoint's
    /// (model units; 0 without a head).
    pub point: f32,
}

/// Outputs of the training-mode forward pass.
#[derive(Debug)]
pub struct TrainForward {
    /// `[B, 2]`.
    pub dest_recon: Tensor,
    /// `[B, zdim]`.
    pub mu: Tensor,
    /// `[B, zdim]`.
    pub logvar: Tensor,
    /// `[B, 2 * (FUTURE - 1)]`.
    pub pred_future: Tensor,
}

/// PECNet, with sine or ReLU MLPs and optional social pooling.
#[derive(Clone, Debug)]
pub struct Model {
    /// Past-trajectory encoder.
    pub encoder_past: Mlp,
    /// Endpoint encoder.
    pub encoder_dest: Mlp,
    /// Latent encoder (training only).
    pub encoder_latent: Mlp,
    /// Endpoint decoder.
    pub decoder: Mlp,
    /// Intermediate-points predictor.
    pub predictor: Mlp,
    /// Non-local social pooling (only with `social_pooling = true`).
    pub social: Option<SocialPooling>,
    /// The point-forecast head (only with a non-empty `point_head_size`).
    pub point_head: Option<Mlp>,
    zdim: usize,
    point_reg: f32,
    kld_reg: f32,
    adl_reg: f32,
}

impl Model {
    /// Build and initialise from `rng` (networks in PECNet's constructor order).
    pub fn new(cfg: &TrainConfig, rng: &mut Rng) -> candle_core::Result<Self> {
        let (a, w0) = (cfg.activation, cfg.w0);
        let cs = cfg.coord_scale;
        let encoder_past =
            Mlp::new(2 * PAST, &cfg.enc_past_size, cfg.fdim, a, w0, rng)?.with_scales(cs, 1.0);
        let encoder_dest =
            Mlp::new(2, &cfg.enc_dest_size, cfg.fdim, a, w0, rng)?.with_scales(cs, 1.0);
        let encoder_latent =
            Mlp::new(2 * cfg.fdim, &cfg.enc_latent_size, 2 * cfg.zdim, a, w0, rng)?;
        let decoder =
            Mlp::new(cfg.fdim + cfg.zdim, &cfg.dec_size, 2, a, w0, rng)?.with_scales(1.0, cs);
        let predictor = Mlp::new(
            2 * cfg.fdim + 2,
            &cfg.predictor_hidden_size,
            2 * (FUTURE - 1),
            a,
            w0,
            rng,
        )?
        .with_scales(1.0, cs);
        // Drawn after everything else: configs without pooling keep their initialisation.
        let social = if cfg.social_pooling {
            Some(SocialPooling::new(cfg, rng)?)
        } else {
            None
        };
        // Drawn last: configs without a head keep their initialisation.
        let point_head = if cfg.point_head_size.is_empty() {
            None
        } else {
            Some(
                Mlp::new(2 * PAST, &cfg.point_head_size, 2 * FUTURE, a, w0, rng)?
                    .with_scales(cs, cs),
            )
        };
        Ok(Self {
            encoder_past,
            encoder_dest,
            encoder_latent,
            decoder,
            predictor,
            social,
            point_head,
            point_reg: cfg.point_reg,
            zdim: cfg.zdim,
            kld_reg: cfg.kld_reg,
            adl_reg: cfg.adl_reg,
        })
    }

    /// Latent dimension.
    pub fn zdim(&self) -> usize {
        self.zdim
    }

    /// All trainable parameters, in a fixed order (the checkpoint / optimizer order).
    pub fn vars(&self) -> Vec<Var> {
        [
            &self.encoder_past,
            &self.encoder_dest,
            &self.encoder_latent,
            &self.decoder,
            &self.predictor,
        ]
        .iter()
        .flat_map(|m| m.vars())
        .chain(self.social.iter().flat_map(|s| s.vars()))
        .chain(self.point_head.iter().flat_map(|h| h.vars()))
        .collect()
    }

    /// Number of tensors of the point head at the end of [`Model::vars`] (0 without one).
    pub fn point_head_tensors(&self) -> usize {
        self.point_head.as_ref().map_or(0, |h| h.vars().len())
    }

    /// The point forecast `[B, FUTURE, 2]` in model space from `obs` `[B, 2 * PAST]`, or
    /// `None` without a head.
    pub fn point_forecast(&self, obs: &Tensor) -> candle_core::Result<Option<Tensor>> {
        match &self.point_head {
            Some(h) => {
                let b = obs.dims()[0];
                Ok(Some(h.forward(obs)?.reshape((b, FUTURE, 2))?))
            }
            None => Ok(None),
        }
    }

    /// `true` when the model has social pooling (its forward passes need a group mask).
    pub fn has_social(&self) -> bool {
        self.social.is_some()
    }

    /// Number of scalar parameters.
    pub fn param_count(&self) -> usize {
        self.vars().iter().map(|v| v.elem_count()).sum()
    }

    /// Copy of every parameter, flattened, in [`Model::vars`] order.
    pub fn weights(&self) -> candle_core::Result<Vec<Vec<f32>>> {
        self.vars()
            .iter()
            .map(|v| v.as_tensor().flatten_all()?.to_vec1::<f32>())
            .collect()
    }

    /// Overwrite every parameter (inverse of [`Model::weights`]).
    pub fn set_weights(&self, weights: &[Vec<f32>]) -> candle_core::Result<()> {
        let vars = self.vars();
        if vars.len() != weights.len() {
            candle_core::bail!(
                "weight count mismatch: model has {} tensors, got {}",
                vars.len(),
                weights.len()
            );
        }
        for (v, w) in vars.iter().zip(weights) {
            if v.elem_count() != w.len() {
                candle_core::bail!(
                    "weight shape mismatch: {:?} vs {} values",
                    v.shape(),
                    w.len()
                );
            }
            v.set(&Tensor::from_slice(w, v.shape(), &Device::Cpu)?)?;
        }
        Ok(())
    }

    /// Training forward pass; `eps ~ N(0, 1)` of shape `[B, zdim]` (from the caller's RNG);
    /// `mask` is the social mask `[B, B]` of the batch (required when the model has social
    /// pooling, ignored otherwise).
    pub fn forward_train(
        &self,
        batch: &Batch,
        eps: &Tensor,
        mask: Option<&Tensor>,
    ) -> candle_core::Result<TrainForward> {
        let features = self.encoder_past.forward(&batch.obs)?;
        let dest_features = self.encoder_dest.forward(&batch.dest)?;
        let latent = self
            .encoder_latent
            .forward(&Tensor::cat(&[&features, &dest_features], 1)?)?;
        let mu = latent.narrow(1, 0, self.zdim)?;
        let logvar = latent.narrow(1, self.zdim, self.zdim)?;
        let std = logvar.affine(0.5, 0.0)?.exp()?;
        let z = (&mu + std.mul(eps)?)?;
        let dest_recon = self.decoder.forward(&Tensor::cat(&[&features, &z], 1)?)?;
        let pred_future = self.predict_future(&features, &dest_recon, &batch.initial_pos, mask)?;
        Ok(TrainForward {
            dest_recon,
            mu,
            logvar,
            pred_future,
        })
    }

    /// PECNet's loss: `MSE(dest, dest_recon) + kld_reg * KLD + adl_reg * MSE(future, pred)`,
    /// with the batch's social mask (see [`Model::forward_train`]).
    pub fn loss(
        &self,
        batch: &Batch,
        eps: &Tensor,
        mask: Option<&Tensor>,
    ) -> candle_core::Result<Loss> {
        let f = self.forward_train(batch, eps, mask)?;
        let rcl = (&batch.dest - &f.dest_recon)?.sqr()?.mean_all()?;
        let adl = (&batch.future - &f.pred_future)?.sqr()?.mean_all()?;
        // -0.5 * sum(1 + logvar - mu^2 - exp(logvar))
        let kld_terms = ((f.logvar.affine(1.0, 1.0)? - f.mu.sqr()?)? - f.logvar.exp()?)?;
        let kld = kld_terms.sum_all()?.affine(-0.5, 0.0)?;
        let mut total = ((&rcl + kld.affine(f64::from(self.kld_reg), 0.0)?)?
            + adl.affine(f64::from(self.adl_reg), 0.0)?)?;
        let mut point = 0.0;
        if let Some(pred) = self.point_forecast(&batch.obs)? {
            let b = batch.len();
            let truth = Tensor::cat(&[&batch.future, &batch.dest], 1)?.reshape((b, FUTURE, 2))?;
            // Euclidean distance per step; the tiny offset keeps the gradient finite at 0.
            let dist = (&pred - &truth)?
                .sqr()?
                .sum(2)?
                .affine(1.0, POINT_LOSS_EPS)?
                .sqrt()?;
            let last = dist.narrow(1, FUTURE - 1, 1)?;
            let l = (dist.mean_all()? + last.mean_all()?)?;
            point = l.to_scalar::<f32>()?;
            total = (total + l.affine(f64::from(self.point_reg), 0.0)?)?;
        }
        Ok(Loss {
            total,
            rcl: rcl.to_scalar::<f32>()?,
            kld: kld.to_scalar::<f32>()?,
            adl: adl.to_scalar::<f32>()?,
            point,
        })
    }

    /// Past features `[B, fdim]` from `obs` `[B, 2 * PAST]`.
    pub fn encode_past(&self, obs: &Tensor) -> candle_core::Result<Tensor> {
        self.encoder_past.forward(obs)
    }

    /// Endpoint `[B, 2]` from past features and a latent `z` `[B, zdim]`.
    pub fn decode_dest(&self, features: &Tensor, z: &Tensor) -> candle_core::Result<Tensor> {
        self.decoder.forward(&Tensor::cat(&[features, z], 1)?)
    }

    /// The 11 intermediate points `[B, 22]` given features, an endpoint and `initial_pos`,
    /// with social pooling of the predictor's input features over `mask` `[B, B]` when the
    /// model has it (then `mask` is required; ignored otherwise).
    pub fn predict_future(
        &self,
        features: &Tensor,
        dest: &Tensor,
        initial_pos: &Tensor,
        mask: Option<&Tensor>,
    ) -> candle_core::Result<Tensor> {
        let dest_features = self.encoder_dest.forward(dest)?;
        let mut feat = Tensor::cat(&[features, &dest_features, initial_pos], 1)?;
        if let Some(social) = &self.social {
            let Some(mask) = mask else {
                candle_core::bail!(
                    "this model has social pooling: its forward pass needs the batch's group mask"
                );
            };
            feat = social.pool(&feat, mask)?;
        }
        self.predictor.forward(&feat)
    }

    /// Inference: full 12-step futures in model space, `[B, FUTURE, 2]`, for latents `z`
    /// `[B, zdim]` (PECNet draws `z ~ N(0, sigma^2)`): 11 predicted points + the endpoint;
    /// `mask` is the social mask `[B, B]` of the rows (see [`Model::predict_future`]).
    pub fn sample_future(
        &self,
        obs: &Tensor,
        initial_pos: &Tensor,
        z: &Tensor,
        mask: Option<&Tensor>,
    ) -> candle_core::Result<Tensor> {
        let features = self.encode_past(obs)?;
        let dest = self.decode_dest(&features, z)?;
        let inter = self.predict_future(&features, &dest, initial_pos, mask)?;
        let b = obs.dims()[0];
        Tensor::cat(&[&inter, &dest], 1)?.reshape((b, FUTURE, 2))
    }

    /// The embedded networks with `w0` folded in (see [`crate::network::Layer`]). Refuses a model
    /// with social pooling: it needs the other pedestrians at inference, which the embedded
    /// core does not support (such models exist to reproduce PECNet on the host).
    pub fn export_networks(&self) -> candle_core::Result<Networks> {
        if self.has_social() {
            candle_core::bail!(
                "this model uses social pooling (social_pooling = true), which needs the other \
                 pedestrians of the scene at inference; the embedded core does not support it, \
                 so it cannot be exported (it is for reproducing PECNet on the host)"
            );
        }
        Ok(Networks {
            encoder_past: self.encoder_past.export()?,
            decoder: self.decoder.export()?,
            encoder_dest: self.encoder_dest.export()?,
            predictor: self.predictor.export()?,
            point_head: match &self.point_head {
                Some(h) => h.export()?,
                None => Vec::new(),
            },
            proposal: Vec::new(),
        })
    }
}

impl Model {
    /// Overwrite the networks a blob ships with `nets` (the inverse of
    /// [`Model::export_networks`], for fine-tuning from a blob): the past and destination
    /// encoders, the decoder, the predictor and, when both have one, the point head. The
    /// latent encoder (training only, never exported) keeps its weights, and a proposal in
    /// `nets` is ignored (it is refitted with `gpecnet propose`). Errors name the network whose
    /// shape differs.
    pub fn import_networks(&self, nets: &Networks) -> candle_core::Result<()> {
        if self.has_social() {
            candle_core::bail!("a model with social pooling cannot start from a blob (no blob holds its pooling networks)");
        }
        let named = [
            ("encoder_past", &self.encoder_past, &nets.encoder_past),
            ("encoder_dest", &self.encoder_dest, &nets.encoder_dest),
            ("decoder", &self.decoder, &nets.decoder),
            ("predictor", &self.predictor, &nets.predictor),
        ];
        for (name, mlp, layers) in named {
            mlp.import(layers)
                .map_err(|e| candle_core::Error::Msg(format!("{name}: {e}")))?;
        }
        match (&self.point_head, nets.point_head.is_empty()) {
            (Some(h), false) => h
                .import(&nets.point_head)
                .map_err(|e| candle_core::Error::Msg(format!("point_head: {e}")))?,
            (None, true) => {}
            (Some(_), true) => candle_core::bail!(
                "the config has a point head (point_head_size) and the blob has none"
            ),
            (None, false) => candle_core::bail!(
                "the blob has a point head and the config none (set point_head_size)"
            ),
        }
        Ok(())
    }
}

/// Added under the square root of the point head's per-step squared distance (model units²),
/// so the loss stays differentiable at zero error.
pub const POINT_LOSS_EPS: f64 = 1e-4;

/// `DType` of every tensor in the model.
pub const DTYPE: DType = DType::F32;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::Act;

    fn tiny() -> TrainConfig {
        TrainConfig {
            enc_past_size: vec![8],
            enc_dest_size: vec![4],
            enc_latent_size: vec![8],
            dec_size: vec![8],
            predictor_hidden_size: vec![8],
            fdim: 4,
            zdim: 3,
            ..TrainConfig::default()
        }
    }

    #[test]
    fn export_folds_w0_and_matches_forward() {
        let cfg = tiny();
        let m = Model::new(&cfg, &mut Rng::new(3)).unwrap();
        let ex = m.export_networks().unwrap();
        assert_eq!(ex.encoder_past[0].act, Act::Sine);
        assert_eq!(ex.encoder_past.last().unwrap().act, Act::Linear);
        let x: Vec<f32> = (0..16).map(|i| i as f32 * 0.37 - 2.0).collect();
        // Reference forward of the exported layers in f64.
        let mut h: Vec<f64> = x.iter().map(|&v| v as f64).collect();
        for l in &ex.encoder_past {
            let mut y = vec![0.0f64; l.out_dim];
            for (o, yo) in y.iter_mut().enumerate() {
                let mut s = l.b[o] as f64;
                for (i, hi) in h.iter().enumerate() {
                    s += l.w[o * l.in_dim + i] as f64 * hi;
                }
                *yo = match l.act {
                    Act::Sine => s.sin(),
                    Act::Relu => s.max(0.0),
                    Act::Linear => s,
                };
            }
            h = y;
        }
        let t = Tensor::from_vec(x, (1, 16), &Device::Cpu).unwrap();
        let got = m
            .encode_past(&t)
            .unwrap()
            .flatten_all()
            .unwrap()
            .to_vec1::<f32>()
            .unwrap();
        for (a, b) in got.iter().zip(&h) {
            assert!((*a as f64 - b).abs() < 1e-3, "{a} vs {b}");
        }
    }
    #[test]
    fn init_is_seeded() {
        let cfg = tiny();
        let a = Model::new(&cfg, &mut Rng::new(5))
            .unwrap()
            .weights()
            .unwrap();
        let b = Model::new(&cfg, &mut Rng::new(5))
            .unwrap()
            .weights()
            .unwrap();
        let c = Model::new(&cfg, &mut Rng::new(6))
            .unwrap()
            .weights()
            .unwrap();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }
}
