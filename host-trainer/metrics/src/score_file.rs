//! `score.json`: the fitted logit rows and radius multipliers, the settings and
//! validation numbers that chose them, the fingerprint of the model they belong to, and
//! the model card's record of them.

use std::path::Path;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

use crate::planner_metrics::PlannerMetrics;
use crate::reference::RefModel;

/// One L2 weight tried.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GridRow {
    /// The weight.
    pub l2: f64,
    /// Mean validation cross-entropy of the closest endpoint (nats).
    pub val_cross_entropy: f64,
}

/// The output of `gpecnet score`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScoreFile {
    /// The frozen blob's path as given.
    pub source: String,
    /// The `gpecnet propose` result used instead of the blob's proposal, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub proposal: Option<String>,
    /// [`scored_fingerprint`] of the model it was fitted for.
    pub fingerprint: u32,
    /// Data set name.
    pub dataset: String,
    /// SDD validation scenes.
    pub val_scenes: Vec<String>,
    /// Endpoints (logits).
    pub k: usize,
    /// Inputs per logit row (the proposal's hidden width).
    pub width: usize,
    /// Mirrored copies of the training windows.
    pub mirror: bool,
    /// Adam iterations.
    pub iters: usize,
    /// Adam learning rate.
    pub lr: f64,
    /// The L2 grid with its validation cross-entropies.
    pub grid: Vec<GridRow>,
    /// The chosen L2 weight.
    pub l2: f64,
    /// The validation-chosen inverse temperature, already folded into `w` and `b`.
    pub inverse_temperature: f64,
    /// Logit rows `[k · width]`.
    pub w: Vec<f32>,
    /// Logit biases `[k]`.
    pub b: Vec<f32>,
    /// `[c50, c90]`.
    pub radius_scales: [f32; 2],
    /// The scored model's planner metrics on validation (f32 reference arithmetic).
    pub val: PlannerMetrics,
}

impl ScoreFile {
    /// Reads `score.json`.
    pub fn read(path: &Path) -> Result<Self> {
        let text = crate::inpath::read_text_limited(path, crate::inpath::FileKind::Text)?;
        serde_json::from_str(&text).with_context(|| format!("reading {}", path.display()))
    }

    /// The `gpecnet score` command that reproduces this file in `dir`.
    pub fn command(&self, dir: &Path) -> String {
        format!(
            "gpecnet score --blob {}{} --dataset {} --l2 {} --iters {} --lr {}{} --out {}",
            self.source,
            self.proposal
                .as_ref()
                .map_or(String::new(), |p| format!(" --proposal {p}")),
            self.dataset,
            self.grid
                .iter()
                .map(|g| g.l2.to_string())
                .collect::<Vec<_>>()
                .join(","),
            self.iters,
            self.lr,
            if self.mirror { "" } else { " --no-mirror" },
            dir.display()
        )
    }
}

/// CRC-32 of the f32 bytes of the networks the probabilities depend on (`encoder_past`,
/// `decoder`, `proposal`, `point_head`: each layer's weights, then biases) and of
/// `data_scale` and the heading frame.
pub fn scored_fingerprint(m: &RefModel) -> u32 {
    let mut d = gpecnet_core::blob::CRC32.digest();
    let n = &m.nets;
    for l in n
        .encoder_past
        .iter()
        .chain(&n.decoder)
        .chain(&n.proposal)
        .chain(&n.point_head)
    {
        for v in l.w.iter().chain(&l.b) {
            d.update(&v.to_le_bytes());
        }
    }
    d.update(&m.config.data_scale.to_le_bytes());
    d.update(&(m.config.heading_steps as u64).to_le_bytes());
    d.finalize()
}

/// The probabilities' provenance in a model card.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScoreCard {
    /// The `score.json` the export read.
    pub file: String,
    /// `[c50, c90]`.
    pub radius_scales: [f32; 2],
    /// The chosen L2 weight and inverse temperature.
    pub l2: f64,
    /// Inverse temperature.
    pub inverse_temperature: f64,
    /// Validation metrics.
    pub val: PlannerMetrics,
    /// The `gpecnet score` command.
    pub command: String,
}

impl ScoreCard {
    /// The card of `s`, read from `path`.
    pub fn of(s: &ScoreFile, path: &Path) -> Self {
        Self {
            file: path.display().to_string(),
            radius_scales: s.radius_scales,
            l2: s.l2,
            inverse_temperature: s.inverse_temperature,
            val: s.val,
            command: s.command(path.parent().unwrap_or(Path::new("."))),
        }
    }
}
