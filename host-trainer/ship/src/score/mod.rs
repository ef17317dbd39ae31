//! `gpecnet score`: endpoint probabilities and point-forecast radii for a **frozen**
//! learned-proposal model (format version 6, `gpecnet_core::planner`).
//!
//! A proposal gives each of its K latents a fixed slot, so a slot's endpoint has an
//! identity from window to window, and a probability per slot can be learned the way
//! mode-probability heads are (MultiPath, TUTR, MTR): K logit rows read the proposal's
//! hidden activations (the blob appends them to the proposal's last layer, after the
//! `K·zdim` latent rows), trained by multinomial logistic regression to name the endpoint
//! closest to the truth. The endpoints are untouched: the latent rows, the encoder and the
//! decoder stay as they are.
//!
//! Everything is chosen on the validation windows, never on test: the L2 weight (a grid,
//! by validation cross-entropy), a temperature (one number, by validation cross-entropy,
//! folded into the rows), and the two radius multipliers `c50`, `c90` — the percentiles
//! of `d / s` on validation, `d` the distance of the truth to the point forecast and `s`
//! the probability-weighted spread of the endpoints around it — so that `r = c·s` covers
//! the truth in half and in nine tenths of the validation windows.
//!
//! The fit is convex and starts from equal probabilities, so it is deterministic; seeds
//! matter only through the proposal and CVAE it is fitted to. The output is one file,
//! `score.json`, that `gpecnet export --score` attaches to the very model it was fitted
//! for (a fingerprint of the encoder, decoder and proposal).
//!
//! Files: `fit.rs` (the windows' table, the fit, the temperature, the radii), `file.rs`
//! (`score.json`, the fingerprint, the card's record), this file (the command line).

mod fit;

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};

use crate::data::{self, DatasetSpec};
use crate::reference::RefModel;
use crate::score_file::{scored_fingerprint, GridRow, ScoreFile};
pub use fit::{fit, inverse_temperature, metrics, radius_scales, scored, Logits, Table};

/// Most L2 weights `--l2` may try (each is one full fit).
pub const MAX_L2: usize = 64;
/// Most Adam iterations of one fit (`--iters`).
pub const MAX_ITERS: usize = 1_000_000;

/// `gpecnet score`'s options.
#[derive(clap::Args, Debug)]
pub struct ScoreArgs {
    /// The frozen f32 blob with a learned proposal (`gpecnet export --proposal`), or its
    /// CVAE without one when --proposal names the proposal.
    #[arg(long, value_name = "FILE")]
    pub blob: PathBuf,
    /// A `gpecnet propose` result to use instead of the blob's proposal (the blob must be
    /// the model it was trained for).
    #[arg(long, value_name = "FILE")]
    pub proposal: Option<PathBuf>,
    /// Training and validation data (`sdd-m`, `sdd`, `eth_ucy:<scene>`, a folder); the test
    /// split is never read.
    #[arg(long, value_name = "SPEC", default_value = "sdd-m")]
    pub dataset: String,
    /// Data root holding sdd/ and eth_ucy/.
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    pub data: PathBuf,
    /// Output folder for score.json (created; refused when it already holds one).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// L2 weights tried (the one with the lowest validation cross-entropy is kept).
    #[arg(long, value_delimiter = ',', default_value = "0,0.0001,0.001,0.01")]
    pub l2: Vec<f64>,
    /// Full-batch Adam iterations.
    #[arg(long, default_value_t = 400)]
    pub iters: usize,
    /// Adam learning rate.
    #[arg(long, default_value_t = 0.05)]
    pub lr: f64,
    /// No mirrored (y → −y) copies of the training windows.
    #[arg(long)]
    pub no_mirror: bool,
    /// Fit on the windows of a fixed FRACTION of the training split's tracks, as
    /// `gpecnet train --train-fraction` (the same tracks); validation is never reduced.
    #[arg(long, value_name = "FRACTION", default_value_t = 1.0)]
    pub train_fraction: f32,
}

impl ScoreArgs {
    /// Runs the command: fits, writes `score.json`, returns it.
    pub fn run(&self) -> Result<ScoreFile> {
        if self.l2.is_empty()
            || self.l2.len() > MAX_L2
            || self.l2.iter().any(|v| !(v.is_finite() && *v >= 0.0))
        {
            bail!("--l2 needs 1..={MAX_L2} finite values >= 0");
        }
        if self.iters == 0 || self.iters > MAX_ITERS {
            bail!(
                "--iters {} is out of range: allowed 1..={MAX_ITERS}",
                self.iters
            );
        }
        if !(self.lr.is_finite() && self.lr > 0.0 && self.lr <= 1.0) {
            bail!(
                "--lr {} is out of range: allowed a finite number in (0, 1]",
                self.lr
            );
        }
        let target = self.out.join("score.json");
        // Never over the blob, its sidecars or the proposal, never among the data.
        let sidecars = crate::outpath::blob_and_sidecars(&self.blob);
        let mut inputs: Vec<&Path> = sidecars.iter().map(PathBuf::as_path).collect();
        inputs.push(&self.blob);
        inputs.extend(self.proposal.as_deref());
        let data_dirs = crate::outpath::data_input_dirs(&self.data);
        let dirs: Vec<&Path> = data_dirs.iter().map(PathBuf::as_path).collect();
        crate::outpath::check_output("--out", &target, &inputs, &dirs)?;
        // One writer per folder: the lock is held until score.json is in place, and the
        // existence check runs under it (a second run into the folder is refused at once).
        std::fs::create_dir_all(&self.out)
            .with_context(|| format!("creating {}", self.out.display()))?;
        let _lock =
            crate::rundir::RunLock::acquire_file(&self.out.join(".score.lock"), |other, path| {
                format!(
                    "another gpecnet score is writing into {} ({other}; lock file {}); a fit is \
                     never written over. If no such command is running, delete the lock file",
                    self.out.display(),
                    path.display()
                )
            })?;
        if std::fs::symlink_metadata(&target).is_ok() {
            bail!(
                "{} exists: choose another --out (a fit is never written over)",
                target.display()
            );
        }
        let bytes = crate::inpath::read_limited(&self.blob, crate::inpath::FileKind::Blob)?;
        let mut model = crate::export::read_blob(&bytes)
            .with_context(|| format!("reading {}", self.blob.display()))?;
        let spec = DatasetSpec::parse(&self.dataset).map_err(anyhow::Error::msg)?;
        {
            // The data must be in the blob's unit and at its clock.
            let core = gpecnet_core::Model::from_blob(&bytes)
                .map_err(|e| anyhow::anyhow!("{}: {e}", self.blob.display()))?;
            let meta = gpecnet_core::blob::Meta::of_blob(&bytes)
                .map_err(|e| anyhow::anyhow!("{}: {e}", self.blob.display()))?;
            crate::units::check_unit(&core, &meta, &spec, None)
                .with_context(|| format!("scoring {}", self.blob.display()))?;
        }
        if let Some(path) = &self.proposal {
            let p = crate::proposal_file::ProposalFile::read(path)?;
            p.join(&mut model).map_err(|e| {
                anyhow::anyhow!("{} with {}: {e}", path.display(), self.blob.display())
            })?;
            model.validate()?;
        }
        if model.is_scored() {
            bail!(
                "{} already has endpoint probabilities: score its unscored source",
                self.blob.display()
            );
        }
        if model.nets.point_head.is_empty() {
            bail!("the radii are around the point forecast: the model needs a point head");
        }
        let k = model.proposal_latents();
        let val_scenes = data::default_sdd_val_scenes();
        if !(self.train_fraction.is_finite()
            && self.train_fraction > 0.0
            && self.train_fraction <= 1.0)
        {
            bail!(
                "--train-fraction {} is out of range: allowed a finite number in (0, 1]",
                self.train_fraction
            );
        }
        let mut train = data::track_fraction(
            data::load(&self.data, &spec, data::Split::Train, &val_scenes)?.windows,
            self.train_fraction,
        );
        if !self.no_mirror {
            let mir: Vec<_> = train.iter().map(data::mirrored).collect();
            train.extend(mir);
        }
        let val = data::load(&self.data, &spec, data::Split::Val, &val_scenes)?.windows;
        let bar = ProgressBar::new((self.l2.len() + 3) as u64).with_style(
            ProgressStyle::with_template("{msg:>24} {bar:30} {pos}/{len} [{elapsed}]")?,
        );
        bar.set_message("encoding windows");
        let (t_train, t_val) = (Table::of(&model, &train)?, Table::of(&model, &val)?);
        if t_train.is_empty() || t_val.is_empty() {
            bail!("no training or validation windows");
        }
        bar.inc(1);
        let mut grid = Vec::new();
        let mut best: Option<(f64, Logits)> = None;
        for &l2 in &self.l2 {
            bar.set_message(format!("fitting, L2 {l2}"));
            let l = fit(&t_train, k, l2, self.iters, self.lr);
            let ce = l.cross_entropy(&t_val);
            grid.push(GridRow {
                l2,
                val_cross_entropy: ce,
            });
            if best.as_ref().is_none_or(|(b, _)| ce < *b) {
                best = Some((ce, l));
            }
            bar.inc(1);
        }
        let (_, logits) = best.context("no fit")?;
        let l2 = grid
            .iter()
            .min_by(|a, b| a.val_cross_entropy.total_cmp(&b.val_cross_entropy))
            .map_or(0.0, |g| g.l2);
        bar.set_message("temperature");
        let s = inverse_temperature(&logits, &t_val);
        let logits = logits.scaled(s);
        bar.inc(1);
        bar.set_message("radii on validation");
        let unit_scaled = scored(&model, &logits, [1.0, 1.0])?;
        let scales = radius_scales(&unit_scaled, &val)?;
        let m = scored(&model, &logits, scales)?;
        let val_metrics = metrics(&m, &val)?;
        bar.inc(1);
        bar.finish_and_clear();
        let (w, b) = logits.rows();
        let file = ScoreFile {
            source: self.blob.display().to_string(),
            proposal: self.proposal.as_ref().map(|p| p.display().to_string()),
            fingerprint: scored_fingerprint(&model),
            dataset: self.dataset.clone(),
            val_scenes,
            k,
            width: t_train.width,
            mirror: !self.no_mirror,
            iters: self.iters,
            lr: self.lr,
            grid,
            l2,
            inverse_temperature: s,
            w,
            b,
            radius_scales: scales,
            val: val_metrics,
        };
        if std::fs::symlink_metadata(&target).is_ok() {
            bail!(
                "{} exists: choose another --out (a fit is never written over)",
                target.display()
            );
        }
        crate::rundir::write_atomic(&target, serde_json::to_string_pretty(&file)?.as_bytes())?;
        Ok(file)
    }
}

/// The probabilities of `path` attached to `m` (refused when fitted for another model or
/// another K).
pub fn attach(m: &mut RefModel, path: &Path) -> Result<ScoreFile> {
    let s = ScoreFile::read(path)?;
    if s.fingerprint != scored_fingerprint(m) {
        bail!(
            "{}: these probabilities were fitted for other weights (encoder, decoder, proposal or point head)",
            path.display()
        );
    }
    if s.k != m.proposal_latents() || s.w.len() != s.k * s.width || s.b.len() != s.k {
        bail!(
            "{}: {} logit rows of width {} do not fit this proposal's {} latents",
            path.display(),
            s.k,
            s.width,
            m.proposal_latents()
        );
    }
    let logits = fit::Logits {
        w: s.w.iter().map(|&v| f64::from(v)).collect(),
        b: s.b.iter().map(|&v| f64::from(v)).collect(),
    };
    *m = fit::scored(m, &logits, s.radius_scales)?;
    Ok(s)
}
