//! The limits a [`TrainConfig`] must hold ([`TrainConfig::validate`]) and the parameter
//! counts they are checked with.

use anyhow::{bail, Result};

use crate::data::DatasetSpec;
use crate::network::Act;

use super::{
    mlp_params, TrainConfig, MAX_BATCH, MAX_HIDDEN_LAYERS, MAX_K, MAX_NONLOCAL_POOLS,
    MAX_OBS_NOISE, MAX_PARAMETERS, MAX_THREADS, MAX_TRAIN_ACTIVATION_BYTES,
    MAX_VAL_ACTIVATION_BYTES, MAX_WIDTH, VAL_CHUNK,
};

impl TrainConfig {
    /// Check every value's range and the internal consistency, before any work (called by
    /// [`TrainConfig::from_toml_str`], hence at load time). Each error names the key and the
    /// allowed range.
    ///
    /// Bounds and why: `k` in `1..=`[`MAX_K`] (the most samples a blob's predictor can draw,
    /// `gpecnet_core::blob::MAX_TTS_SAMPLES`; validation also holds
    /// `VAL_CHUNK · k · widest layer` f32 activations, which must stay within
    /// [`MAX_VAL_ACTIVATION_BYTES`]); layer widths, `fdim`, `zdim` in `1..=`[`MAX_WIDTH`] and at
    /// most [`MAX_HIDDEN_LAYERS`] hidden layers per network (the blob holds at most 8 layers
    /// per network); `num_epochs`, `batch_size`, `eval_every` at least 1 (`num_epochs`,
    /// `eval_every` and `seed` at most `i64::MAX`, a TOML integer); `learning_rate`
    /// finite in `(0, 1]`; `data_scale` finite and `> 0`, or [`super::AUTO_DATA_SCALE`] (a new
    /// run computes it); `train_fraction` finite in `(0, 1]`; `coord_scale`, `w0`,
    /// `point_reg` finite and `> 0`;
    /// `sigma`, `kld_reg`, `adl_reg` finite and `>= 0`; `obs_noise` finite in
    /// `[0, `[`MAX_OBS_NOISE`]`]`; `threads` in `0..=`[`MAX_THREADS`].
    ///
    /// Every floating-point value must be finite (NaN and infinities are refused, naming the
    /// key); `nonlocal_pools` is at most [`MAX_NONLOCAL_POOLS`], `non_local_dim` at most
    /// [`MAX_WIDTH`]; all networks together have at most [`MAX_PARAMETERS`] parameters
    /// ([`TrainConfig::total_param_count`]), and `batch_size · widest layer` f32 training
    /// activations stay within [`MAX_TRAIN_ACTIVATION_BYTES`].
    pub fn validate(&self) -> Result<()> {
        if self.past_length != crate::data::PAST || self.future_length != crate::data::FUTURE {
            bail!(
                "past_length/future_length must be {}/{} (the data windows are fixed)",
                crate::data::PAST,
                crate::data::FUTURE
            );
        }
        let in_range = |key: &str, v: usize, lo: usize, hi: usize, why: &str| -> Result<()> {
            if v < lo || v > hi {
                bail!("{key} = {v} is out of range: allowed {lo}..={hi}{why}");
            }
            Ok(())
        };
        in_range("fdim", self.fdim, 1, MAX_WIDTH, "")?;
        in_range("zdim", self.zdim, 1, MAX_WIDTH, "")?;
        in_range(
            "k",
            self.k,
            1,
            MAX_K,
            " (the most samples a blob's predictor draws per window)",
        )?;
        // config.toml holds every value as a TOML integer, whose largest value is i64::MAX.
        let toml_max = i64::MAX as usize;
        let toml_int = " (config.toml holds it as a TOML integer)";
        in_range("num_epochs", self.num_epochs, 1, toml_max, toml_int)?;
        in_range("batch_size", self.batch_size, 1, MAX_BATCH, "")?;
        in_range("eval_every", self.eval_every, 1, toml_max, toml_int)?;
        if self.seed > i64::MAX as u64 {
            bail!(
                "seed = {} is out of range: allowed 0..={}{toml_int}",
                self.seed,
                i64::MAX
            );
        }
        in_range("threads", self.threads, 0, MAX_THREADS, " (0 = all cores)")?;
        in_range(
            "nonlocal_pools",
            self.nonlocal_pools,
            0,
            MAX_NONLOCAL_POOLS,
            " (each round keeps its activations for the backward pass)",
        )?;
        in_range("non_local_dim", self.non_local_dim, 0, MAX_WIDTH, "")?;
        let positive = |key: &str, v: f64| -> Result<()> {
            if !(v.is_finite() && v > 0.0) {
                bail!("{key} = {v} is out of range: allowed a finite number > 0");
            }
            Ok(())
        };
        let non_negative = |key: &str, v: f64| -> Result<()> {
            if !(v.is_finite() && v >= 0.0) {
                bail!("{key} = {v} is out of range: allowed a finite number >= 0");
            }
            Ok(())
        };
        if !(self.learning_rate.is_finite()
            && self.learning_rate > 0.0
            && self.learning_rate <= 1.0)
        {
            bail!(
                "learning_rate = {} is out of range: allowed a finite number in (0, 1]",
                self.learning_rate
            );
        }
        if self.data_scale != super::AUTO_DATA_SCALE {
            positive("data_scale", f64::from(self.data_scale))?;
        }
        if !(self.train_fraction.is_finite()
            && self.train_fraction > 0.0
            && self.train_fraction <= 1.0)
        {
            bail!(
                "train_fraction = {} is out of range: allowed a finite number in (0, 1]",
                self.train_fraction
            );
        }
        positive("coord_scale", f64::from(self.coord_scale))?;
        positive("point_reg", f64::from(self.point_reg))?;
        if self.activation == Act::Linear {
            bail!(
                "activation = \"linear\" is not a hidden activation: allowed \"sine\" or \"relu\""
            );
        }
        if self.activation == Act::Sine {
            positive("w0", f64::from(self.w0))?;
        } else {
            non_negative("w0", f64::from(self.w0))?;
        }
        non_negative("sigma", f64::from(self.sigma))?;
        non_negative("kld_reg", f64::from(self.kld_reg))?;
        non_negative("adl_reg", f64::from(self.adl_reg))?;
        let mut widest = self.fdim.max(self.zdim);
        for (name, v, may_be_empty) in [
            ("enc_past_size", &self.enc_past_size, false),
            ("enc_dest_size", &self.enc_dest_size, false),
            ("enc_latent_size", &self.enc_latent_size, false),
            ("dec_size", &self.dec_size, false),
            ("predictor_hidden_size", &self.predictor_hidden_size, false),
            ("non_local_theta_size", &self.non_local_theta_size, true),
            ("non_local_phi_size", &self.non_local_phi_size, true),
            ("non_local_g_size", &self.non_local_g_size, true),
            ("point_head_size", &self.point_head_size, true),
        ] {
            let lo = usize::from(!may_be_empty);
            if v.len() < lo || v.len() > MAX_HIDDEN_LAYERS {
                bail!(
                    "{name} has {} hidden layers: allowed {lo}..={MAX_HIDDEN_LAYERS} (a blob holds at most {} layers per network)",
                    v.len(),
                    MAX_HIDDEN_LAYERS + 1
                );
            }
            if let Some(&w) = v.iter().find(|&&w| w == 0 || w > MAX_WIDTH) {
                bail!("{name} has a layer of width {w}: allowed widths 1..={MAX_WIDTH}");
            }
            widest = widest.max(v.iter().copied().max().unwrap_or(0));
        }
        let params = self.total_param_count();
        if params > u128::from(MAX_PARAMETERS) {
            let (key, n) = self.largest_network();
            bail!(
                "the networks have {params} parameters, over the limit of {MAX_PARAMETERS} \
                 (training holds weights, gradients and two Adam moments of each); the largest \
                 network is {key} with {n} parameters: make its layers smaller"
            );
        }
        let train_bytes = (self.batch_size as u128) * (widest as u128) * 4;
        if train_bytes > u128::from(MAX_TRAIN_ACTIVATION_BYTES) {
            bail!(
                "batch_size = {} is out of range for layers {widest} wide: allowed 1..={} \
                 (a batch holds batch_size x {widest} f32 activations per layer, at most {} GiB)",
                self.batch_size,
                (MAX_TRAIN_ACTIVATION_BYTES as usize / (widest * 4)).max(1),
                MAX_TRAIN_ACTIVATION_BYTES >> 30
            );
        }
        let val_bytes = (VAL_CHUNK as u128) * (self.k as u128) * (widest as u128) * 4;
        if val_bytes > u128::from(MAX_VAL_ACTIVATION_BYTES) {
            let max_k = MAX_VAL_ACTIVATION_BYTES as usize / (VAL_CHUNK * widest * 4);
            bail!(
                "k = {} is out of range for layers {widest} wide: allowed 1..={} (validation holds {} windows x k samples x {widest} f32 activations per layer, at most {} GiB)",
                self.k,
                max_k.max(1),
                VAL_CHUNK,
                MAX_VAL_ACTIVATION_BYTES >> 30
            );
        }
        let spec = self.dataset_spec()?;
        if self.social_pooling
            && (self.nonlocal_pools == 0
                || self.non_local_dim == 0
                || self.time_thresh < 0
                || !(self.dist_thresh.is_finite() && self.dist_thresh >= 0.0))
        {
            bail!("social pooling needs nonlocal_pools > 0, non_local_dim > 0, time_thresh >= 0 and a finite dist_thresh >= 0");
        }
        if self.heading_steps >= self.past_length {
            bail!(
                "heading_steps must be 0 (off) or in 1..{}, got {}",
                self.past_length,
                self.heading_steps
            );
        }
        if let Some(s) = self
            .speed_scales
            .iter()
            .find(|s| !(s.is_finite() && super::SPEED_SCALE_RANGE.contains(*s)))
        {
            bail!("speed_scales: every factor must be a number in [0.25, 4], got {s}");
        }
        if !self.speed_scales.is_empty() && self.social_pooling {
            bail!("speed_scales and social_pooling cannot be combined (scaled copies have no social groups)");
        }
        if self.mirror && self.social_pooling {
            bail!("mirror and social_pooling cannot be combined (mirrored copies have no social groups)");
        }
        if self.heading_steps > 0 && self.social_pooling {
            bail!("heading_steps and social_pooling cannot be combined (each pedestrian would be rotated into its own frame before pooling)");
        }
        if !(self.obs_noise.is_finite() && (0.0..=MAX_OBS_NOISE).contains(&self.obs_noise)) {
            bail!(
                "obs_noise = {} is out of range: allowed a finite number in [0, {MAX_OBS_NOISE}] (the data's unit)",
                self.obs_noise
            );
        }
        if !(self.augment_pct.is_finite() && (0.0..=100.0).contains(&self.augment_pct)) {
            bail!("augment_pct must be in [0, 100], got {}", self.augment_pct);
        }
        if self.include_train_extra && spec != DatasetSpec::Sdd {
            bail!(
                "include_train_extra needs dataset = \"sdd\" (train_extra is one SDD pixel scene)"
            );
        }
        let mpp = self.synthetic_metres_per_pixel;
        if !(mpp.is_finite() && mpp >= 0.0) {
            bail!("synthetic_metres_per_pixel must be a finite number >= 0, got {mpp}");
        }
        if mpp > 0.0 && spec.unit() == crate::data::Unit::Pixels {
            bail!(
                "synthetic_metres_per_pixel is set but dataset {spec} is in pixels, like the pool"
            );
        }
        if self.augment_pct > 0.0 {
            if spec.unit() == crate::data::Unit::Metres && mpp == 0.0 {
                bail!(
                    "dataset {spec} is in metres but the synthetic pool is in SDD pixels: \
                     set synthetic_metres_per_pixel (0.0377 = 7.84 m / 208.2 px, the RMS window spans of sdd-m and sdd)"
                );
            }
            if self
                .synthetic_pool
                .as_deref()
                .is_none_or(|p| p.trim().is_empty())
            {
                bail!("augment_pct = {} needs synthetic_pool = \"<pool.csv>\" (written by `gpecnet synth`)", self.augment_pct);
            }
        }
        // Every other float key (those with a range of their own were checked above).
        if let Some(key) = non_finite_key(&toml::Value::try_from(self)?, "") {
            bail!("{key} is not a finite number: NaN and infinities are refused");
        }
        Ok(())
    }

    /// The networks this config trains (key of their sizes, parameters), in u128 so that no
    /// config overflows: the encoders, decoder, predictor, the point head when present and
    /// the social networks when `social_pooling` is on.
    fn networks(&self) -> Vec<(&'static str, u128)> {
        let p = |input: usize, hidden: &[usize], output: usize| -> u128 {
            let mut n: u128 = 0;
            let mut prev = input as u128;
            for &h in hidden.iter().chain(std::iter::once(&output)) {
                n += prev * h as u128 + h as u128;
                prev = h as u128;
            }
            n
        };
        let p2 = 2 * self.past_length;
        let d = 2 * self.fdim + 2;
        let mut v = vec![
            ("enc_past_size", p(p2, &self.enc_past_size, self.fdim)),
            ("enc_dest_size", p(2, &self.enc_dest_size, self.fdim)),
            (
                "enc_latent_size",
                p(2 * self.fdim, &self.enc_latent_size, 2 * self.zdim),
            ),
            ("dec_size", p(self.fdim + self.zdim, &self.dec_size, 2)),
            (
                "predictor_hidden_size",
                p(
                    d,
                    &self.predictor_hidden_size,
                    2 * self.future_length.saturating_sub(1),
                ),
            ),
        ];
        if !self.point_head_size.is_empty() {
            v.push((
                "point_head_size",
                p(p2, &self.point_head_size, 2 * self.future_length),
            ));
        }
        if self.social_pooling {
            v.push((
                "non_local_theta_size",
                p(d, &self.non_local_theta_size, self.non_local_dim),
            ));
            v.push((
                "non_local_phi_size",
                p(d, &self.non_local_phi_size, self.non_local_dim),
            ));
            v.push(("non_local_g_size", p(d, &self.non_local_g_size, d)));
        }
        v
    }

    /// Parameters of every network this config trains (what [`MAX_PARAMETERS`] bounds).
    pub fn total_param_count(&self) -> u128 {
        self.networks().iter().map(|(_, n)| n).sum()
    }

    /// The key of the network with the most parameters, and that number.
    fn largest_network(&self) -> (&'static str, u128) {
        self.networks()
            .into_iter()
            .max_by_key(|(_, n)| *n)
            .unwrap_or(("enc_past_size", 0))
    }

    /// Number of f32 parameters of the four networks that ship to the embedded target
    /// (past encoder, decoder, destination encoder, predictor; the latent encoder is
    /// training-only).
    pub fn embedded_param_count(&self) -> usize {
        let p2 = 2 * self.past_length;
        let pred_out = 2 * (self.future_length - 1);
        mlp_params(p2, &self.enc_past_size, self.fdim)
            + mlp_params(self.fdim + self.zdim, &self.dec_size, 2)
            + mlp_params(2, &self.enc_dest_size, self.fdim)
            + mlp_params(2 * self.fdim + 2, &self.predictor_hidden_size, pred_out)
            + if self.point_head_size.is_empty() {
                0
            } else {
                mlp_params(p2, &self.point_head_size, 2 * self.future_length)
            }
    }
}

/// `key = value` of the first float in `v` (recursively: tables by dotted key, arrays by
/// index) that is NaN or infinite; `key` is `v`'s own key ("" at the top).
fn non_finite_key(v: &toml::Value, key: &str) -> Option<String> {
    match v {
        toml::Value::Float(f) if !f.is_finite() => Some(format!("{key} = {f}")),
        toml::Value::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, x)| non_finite_key(x, &format!("{key}[{i}]"))),
        toml::Value::Table(t) => t.iter().find_map(|(k, x)| {
            let sub = if key.is_empty() {
                k.clone()
            } else {
                format!("{key}.{k}")
            };
            non_finite_key(x, &sub)
        }),
        _ => None,
    }
}
