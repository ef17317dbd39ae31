//! The commands that start from a blob or a run and write shipped artefacts: `gpecnet export`,
//! `quantize`, `eval` and `onnx`.
// Doc comments here are the CLI --help text, where <name> placeholders are plain text.
#![allow(rustdoc::invalid_html_tags)]

use std::path::PathBuf;

use anyhow::Result;
use gpecnet_trainer::data;

#[derive(clap::Args, Debug)]
pub(crate) struct OnnxArgs {
    /// The f32 blob to export.
    #[arg(long, value_name = "FILE")]
    blob: PathBuf,
    /// The ONNX file to write.
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
    /// Only the endpoint path: inputs x, z; output d (no point head, no trajectory predictor).
    #[arg(long)]
    endpoint_only: bool,
}

pub(crate) fn cmd_onnx(a: OnnxArgs) -> Result<()> {
    use std::io::Write;
    let s = gpecnet_trainer::onnx::export_onnx(&a.blob, &a.out, a.endpoint_only)?;
    let mut o = std::io::stdout().lock();
    writeln!(
        o,
        "wrote {} ({} bytes, {} parameters, opset {}) from model {}",
        a.out.display(),
        s.bytes,
        s.parameters,
        gpecnet_trainer::onnx::OPSET,
        s.name
    )?;
    writeln!(o, "inputs:\n{}", gpecnet_trainer::onnx::describe(&s.inputs))?;
    writeln!(
        o,
        "outputs:\n{}",
        gpecnet_trainer::onnx::describe(&s.outputs)
    )?;
    Ok(())
}

/// How the test windows are sampled, the same in every command that scores a model on them.
#[derive(clap::Args, Debug)]
pub(crate) struct TestSampling {
    /// Samples per window (best-of-K).
    #[arg(long, default_value_t = 20)]
    pub(crate) k: usize,
    /// Latent seed of test window i is SEED + i.
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u64,
}

#[derive(clap::Args, Debug)]
pub(crate) struct QuantizeArgs {
    /// The f32 source blob.
    #[arg(long, value_name = "FILE")]
    blob: PathBuf,
    /// The fixed-point blob to write (its stem is the model name).
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
    /// Data root holding sdd/ and eth_ucy/ (see shared/data/README.md).
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    /// The data set to calibrate on (its training split) and evaluate on (its test split):
    /// default the source card's `dataset`, else `sdd`. Must be in the blob's unit.
    #[arg(long, value_name = "SPEC", value_parser = parse_dataset)]
    dataset: Option<data::DatasetSpec>,
    #[command(flatten)]
    sampling: TestSampling,
    /// Calibrate on every N-th training window.
    #[arg(long, default_value_t = 4)]
    cal_stride: usize,
    /// Leave encoder_dest and predictor out (endpoint prediction only, about half the size).
    #[arg(long)]
    endpoint_only: bool,
    /// Replace existing artefacts of the same name, and write a fixed-point model whose test
    /// minFDE is further from its f32 source's than the tolerance (0.5 px / 0.02 m).
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    signing: SignOptions,
}

/// Signing a blob as it is written.
#[derive(clap::Args, Debug)]
pub(crate) struct SignOptions {
    /// Write the blob signed with this private key (gpecnet keygen); needs --sign-version.
    #[arg(long, value_name = "KEY", requires = "sign_version")]
    sign_key: Option<PathBuf>,
    /// The model version to sign with (monotonic per product); needs --sign-key.
    #[arg(long, value_name = "N", requires = "sign_key")]
    sign_version: Option<u32>,
}

impl SignOptions {
    fn spec(&self) -> Result<Option<gpecnet_trainer::signing::SignSpec>> {
        match (&self.sign_key, self.sign_version) {
            (Some(k), Some(v)) => Ok(Some(gpecnet_trainer::signing::SignSpec::load(k, v)?)),
            _ => Ok(None),
        }
    }
}

pub(crate) fn cmd_quantize(a: QuantizeArgs) -> Result<()> {
    let c = gpecnet_trainer::quantize_blob::quantize_blob_with(
        &a.blob,
        &a.out,
        &a.data,
        a.sampling.k,
        a.sampling.seed,
        a.cal_stride,
        8,
        a.endpoint_only,
        a.dataset.as_ref(),
        a.force,
        a.signing.spec()?.as_ref(),
    )?;
    let (f, x) = (&c.test_f32, &c.test_fixed);
    let ds = c.dataset.as_deref().unwrap_or("sdd");
    let u = data::DatasetSpec::parse(ds).map_or("px", |s| s.unit().suffix());
    println!(
        "{}: {} bytes; {ds} test K={}: minADE/minFDE f32 {:.3}/{:.3} {u}, fixed {:.3}/{:.3} {u}",
        c.name, c.blob_bytes, c.k, f.min_ade, f.min_fde, x.min_ade, x.min_fde
    );
    println!(
        "K=1: FDE f32 {:.3} {u}, fixed {:.3} {u}",
        f.fde_k1, x.fde_k1
    );
    Ok(())
}

#[derive(clap::Args, Debug)]
pub(crate) struct ExportArgs {
    /// Run directory (or checkpoint file) written by `gpecnet train`.
    #[arg(long, value_name = "DIR")]
    run: PathBuf,
    /// Model name: the file stem in weights/ (letters, digits, '-', '_').
    #[arg(long)]
    name: String,
    /// Output folder.
    #[arg(long, value_name = "DIR", default_value = "weights")]
    out: PathBuf,
    /// Data root holding sdd/ (see shared/data/README.md).
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    /// Sine of the reported numbers and golden vectors (the device must use the same).
    #[arg(long, value_enum, default_value = "libm")]
    sine: gpecnet_trainer::reference::SineKind,
    #[command(flatten)]
    sampling: TestSampling,
    /// Latent sigma written into the blob (default: the training config's). Choose it on
    /// validation with `gpecnet select`.
    #[arg(long)]
    sigma: Option<f32>,
    /// Test-time sampling written into the blob: N latent samples reduced to K by k-means
    /// (3 Lloyd iterations, first-K init); 0 = plain sampling. Choose it with `gpecnet select`.
    #[arg(long, value_name = "N")]
    tts: Option<usize>,
    /// A learned latent proposal for this run's encoder and decoder (`gpecnet propose`'s
    /// proposal.json): the blob (format version 5) computes its K latents from the past
    /// instead of drawing them. Needs --tts 0.
    #[arg(long, value_name = "FILE")]
    proposal: Option<PathBuf>,
    /// Endpoint probabilities and point-forecast radii (`gpecnet score`'s score.json) fitted
    /// for this run with this --proposal: the blob (format version 6) returns them beside the
    /// endpoints, and the card reports the planner metrics on test.
    #[arg(long, value_name = "FILE")]
    score: Option<PathBuf>,
    /// Replace existing artefacts of the same name in --out (never done without it).
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    signing: SignOptions,
}

#[derive(clap::Args, Debug)]
pub(crate) struct EvalArgs {
    /// The blob to evaluate: by default the shipped default model, the one the firmware
    /// embeds (SDD in metres, learned endpoint probabilities and radii, fixed point).
    #[arg(long, value_name = "FILE", default_value = gpecnet_trainer::blob_eval::DEFAULT_BLOB)]
    blob: PathBuf,
    /// Where the BENCHMARK data lives: the root holding sdd/ and eth_ucy/ (shared/data/README.md).
    /// Only the built-in data sets read it; your own folder goes in --dataset, not here.
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    /// WHICH data set's test split is evaluated: `sdd` (pixels), `sdd-m` (SDD in metres
    /// through the per-scene scales; also prints the pixel-equivalent numbers),
    /// `eth_ucy:<eth|hotel|univ|zara1|zara2>` (metres), or your own data-set folder with a '/'
    /// in its path (`./mydrone`: dataset.toml and test/; docs/own-data.md). Default: the
    /// blob's own data set, the one its model card names (<blob>.json), else the one its unit
    /// and recorded training data say (SDD in metres: `sdd-m`; the default model's is
    /// `sdd-m`). A folder without val/ is evaluated zero-shot, the constant-velocity window
    /// fixed at 2 steps (the report says so). A blob whose unit differs from the data set's
    /// is refused before anything runs.
    #[arg(long, value_name = "SPEC", value_parser = parse_dataset)]
    dataset: Option<data::DatasetSpec>,
    /// The unit of a blob that does not state one (format version < 4). Without it such a
    /// blob is taken as SDD pixels (what every shipped blob of those versions is) and
    /// refused on metre data.
    #[arg(long, value_enum, value_name = "UNIT")]
    assume_unit: Option<UnitArg>,
    /// Sine to run (default: the one the blob's golden file names, else libm).
    #[arg(long, value_enum)]
    sine: Option<gpecnet_trainer::reference::SineKind>,
    #[command(flatten)]
    sampling: TestSampling,
    /// Draw predictions to this SVG file (nothing is written without it).
    #[arg(long, value_name = "FILE")]
    draw: Option<PathBuf>,
    /// Number of test windows to draw.
    #[arg(long, default_value_t = 16)]
    n_draw: usize,
    /// Also draw the reliability diagram of the endpoint probabilities (SVG; a model with
    /// probabilities only: format version 6, `gpecnet score`).
    #[arg(long, value_name = "FILE")]
    reliability: Option<PathBuf>,
    /// Print exactly one JSON object on stdout (name, n, k, min_ade, min_fde, ade_k1, fde_k1,
    /// mean_ade, mean_fde, point_ade, point_fde, cv_n, cv_n_chosen_on, cv_ade, cv_fde,
    /// cv_last_ade, cv_last_fde, kde_nll, the hit rates at the unit's radii: hit_0.5m and
    /// hit_1m, or hit_20px and hit_40px, scenes: the same per scene, speeds: per observed
    /// speed (standing, slow, walking, fast; metres only), changes: starters and stoppers
    /// (metres only), matches_card,
    /// probabilities, planner: the planner metrics of a model with endpoint probabilities,
    /// ...) instead of the table.
    #[arg(long)]
    json: bool,
    /// Add the distribution metrics (kde_nll, hit20, hit40) to the blob's existing model card
    /// (.json and .md) if it lacks them; nothing else in the card, the blob or the golden file
    /// changes. The card's ADE/FDE must be reproduced first. SDD pixel cards only (the data
    /// set `sdd`).
    #[arg(long)]
    update_card: bool,
}

pub(crate) fn cmd_export(a: ExportArgs) -> Result<()> {
    let settings = gpecnet_trainer::run_export::ExportSettings {
        sine: a.sine,
        k: a.sampling.k,
        base_seed: a.sampling.seed,
        sigma: a.sigma,
        tts: a.tts,
        proposal: a.proposal.clone(),
        score: a.score.clone(),
    };
    let sign = a.signing.spec()?;
    let card = gpecnet_trainer::run_export::ship_with(
        &a.run,
        &a.name,
        &a.out,
        &a.data,
        settings,
        a.force,
        sign.as_ref(),
    )?;
    let m = card.test;
    println!(
        "exported {} (epoch {}, {} parameters, {} bytes) to {}",
        card.name,
        card.epoch,
        card.parameters,
        card.blob_bytes,
        a.out.display()
    );
    let spec = card.dataset_spec()?;
    let u = spec.unit().suffix();
    println!("{spec} test through gpecnet-core: minADE {:.3} {u}  minFDE {:.3} {u} (K={})  ADE/FDE K=1 {:.3}/{:.3} {u}", m.min_ade, m.min_fde, m.k, m.ade_k1, m.fde_k1);
    if let Some(p) = card.test_point {
        println!(
            "point forecast: ADE {:.3} {u}  FDE {:.3} {u}",
            p.ade_k1, p.fde_k1
        );
    }
    Ok(())
}

/// A unit on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub(crate) enum UnitArg {
    /// Image pixels.
    Px,
    /// Metres.
    M,
}

impl From<UnitArg> for data::Unit {
    fn from(u: UnitArg) -> Self {
        match u {
            UnitArg::Px => data::Unit::Pixels,
            UnitArg::M => data::Unit::Metres,
        }
    }
}

pub(crate) fn parse_dataset(s: &str) -> std::result::Result<data::DatasetSpec, String> {
    data::DatasetSpec::parse(s)
}

pub(crate) fn cmd_eval(a: EvalArgs) -> Result<()> {
    let dataset = match &a.dataset {
        Some(d) => d.clone(),
        None => gpecnet_trainer::blob_eval::own_dataset(&a.blob)?,
    };
    let target = gpecnet_trainer::blob_eval::EvalTarget {
        dataset: dataset.clone(),
        assume_unit: a.assume_unit.map(Into::into),
    };
    // A data-set folder given as the benchmark root would be read as sdd/ and eth_ucy/.
    if a.data.join(data::DATASET_TOML).is_file() {
        anyhow::bail!(
            "--data {} is a data-set folder (it holds {}): --data is the benchmark data \
             root; evaluate your folder with --dataset {}",
            a.data.display(),
            data::DATASET_TOML,
            a.data.display()
        );
    }
    if a.update_card && dataset != data::DatasetSpec::Sdd {
        anyhow::bail!("--update-card applies to the SDD pixel cards only");
    }
    let mut r = gpecnet_trainer::blob_eval::eval_blob(
        &a.blob,
        &a.data,
        &target,
        a.sine,
        a.sampling.k,
        a.sampling.seed,
        a.draw.as_deref(),
        a.n_draw,
        a.reliability.as_deref(),
    )?;
    let update = if a.update_card {
        let u = gpecnet_trainer::blob_eval::update_card_dist(
            &a.blob,
            &a.data,
            &r,
            a.sampling.k,
            a.sampling.seed,
        )?;
        // update_card_dist checked the card's ADE/FDE and wrote (or checked) the rest.
        r.matches_card = Some(true);
        Some(u)
    } else {
        None
    };
    let m = &r.metrics;
    let numbers = [
        m.min_ade, m.min_fde, m.ade_k1, m.fde_k1, m.mean_ade, m.mean_fde,
    ];
    if m.n == 0 || numbers.iter().any(|v| !v.is_finite()) {
        anyhow::bail!(
            "evaluation of {} on {} windows gave undefined ADE/FDE (an empty or absurd test set?)",
            a.blob.display(),
            m.n
        );
    }
    if a.json {
        println!("{}", gpecnet_trainer::eval_report::json(&r, &a.blob));
    } else {
        print!("{}", gpecnet_trainer::eval_report::table(&r));
    }
    if let Some(u) = update {
        eprintln!("{u}");
    }
    if r.matches_card == Some(false)
        && a.sampling.k == 20
        && a.sampling.seed == 0
        && a.sine.is_none()
        && !a.update_card
    {
        anyhow::bail!("the shipped numbers were not reproduced");
    }
    Ok(())
}
