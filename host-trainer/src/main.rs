//! `gpecnet`: the G-PECNet host command line.
//!
//! One `Command` variant and one small `cmd_*` function per subcommand; the work lives in the
//! library modules so subcommands can be appended without touching each other.
// Doc comments here are the CLI --help text, where <name> placeholders are plain text.
#![allow(rustdoc::invalid_html_tags)]

use std::path::PathBuf;

use anyhow::Result;
use clap::{Parser, Subcommand};
use gpecnet_trainer::{config::TrainConfig, data, train};

/// G-PECNet (PECNet with SIREN sine MLPs) host tools: training, evaluation and export.
#[derive(Parser, Debug)]
#[command(name = "gpecnet", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Train a model (new run, or continue one with --resume).
    ///
    /// Writes checkpoint.bin (after every epoch, atomically; the one before is kept as
    /// checkpoint.prev.bin), metrics.csv, metrics.jsonl, curves.svg, config.toml and
    /// data-fingerprint.json into the run directory. The best epoch is chosen on the
    /// validation scenes (never the test set).
    ///
    /// Run-folder safety: a run holds the lock file <out>/.gpecnet.lock (pid, host, start
    /// time) while it runs, so a second run into the same folder is refused; a lock left by a
    /// killed run is taken over automatically only when its pid is provably dead (same host,
    /// no /proc/<pid>), otherwise delete it by hand. A new run refuses a folder that already
    /// holds files (unless --force) or a checkpoint (use --resume). --resume refuses a
    /// different config or different data (window fingerprint) and falls back to
    /// checkpoint.prev.bin, with a warning, when checkpoint.bin is corrupt. Temp files of
    /// interrupted writes (.checkpoint.bin.tmp.<pid>) are deleted at start.
    Train(TrainArgs),
    /// Export a run's best-validation model to weights/: blob, golden vectors, model card.
    ///
    /// Evaluates the exported blob on the SDD test set through gpecnet-core (and checks the
    /// trainer's reference path gives the same bits) and writes <name>.gpec, <name>.golden,
    /// <name>.json and <name>.md.
    Export(ExportArgs),
    /// Choose inference settings (latent sigma, test-time samples N) on the run's VALIDATION
    /// windows through gpecnet-core; prints a table (the test set is never read).
    Select(SelectArgs),
    /// Evaluate a shipped blob on the SDD test set through gpecnet-core; print ADE/FDE and draw.
    ///
    /// This is what runs on the drone, on the real test set: best-of-K and K = 1 errors in
    /// pixels, the constant-velocity baseline, whether the model card is reproduced exactly,
    /// and an SVG of predicted vs. true trajectories.
    Eval(EvalArgs),
    /// Quantize an f32 blob to the fixed-point kind (Int16Q15); writes <out>.gpec, .golden,
    /// .json and .md with f32 vs fixed ADE/FDE on the SDD test set through gpecnet-core.
    Quantize(QuantizeArgs),
    /// AbScore (and areal-scaled AbScore) statistics, per-trajectory CSV and distribution plots
    /// for SDD train and test; with --max-abscore, the outlier filter's effect.
    Abscore(AbscoreArgs),
    /// Classify SDD train/test trajectories into the paper's 7 types; unique-points histogram.
    Classify(ClassifyArgs),
    /// Build the fixed-order synthetic pool (Newtonian + HMM + policy-gradient agents) with SDD
    /// train's type shares; the first k % of it is the augmentation.
    Synth(SynthArgs),
    /// Train the policy-gradient agent in the HMM playground; learning curve and episodes SVG.
    RlTrain(RlTrainArgs),
    /// The augmentation sweep: one training run per --pcts value (0 = no augmentation) with the
    /// same config, each best-validation model evaluated on the SDD test set through
    /// gpecnet-core; writes <out>/aug-<K>/ runs and <out>/sweep.md, sweep.csv.
    Sweep(SweepArgs),
    /// Export an f32 blob's networks to ONNX (opset 17) for onnxruntime / TensorRT.
    ///
    /// Inputs (n = windows, k = latent samples per window):
    ///   x [n, 2*past_len]: the observed past as gpecnet-core's frame input,
    ///     x(2t+c) = (p_t(c) - p_0(c)) * data_scale, rotated into the heading frame first when
    ///     the blob has heading_steps > 0 (gpecnet_core::frame::Frame::inputs);
    ///   z [n, k, zdim]: the latent samples, already multiplied by sigma (the core draws them
    ///     from gpecnet_core::prng::Gaussian);
    ///   pos [n, 2] (only with a trajectory predictor): the last observed point as the
    ///     predictor sees it (rotated in the heading frame), divided by initial_pos_divisor.
    /// Outputs, in the normalised frame (caller units: divide by data_scale, rotate back, add
    /// p_0; gpecnet_core::frame::Frame::output):
    ///   d [n, k, 2]: each sample's endpoint (encoder_past, then the decoder on [f, z]);
    ///   point [n, 2*future_len] (only with a point-forecast head): the point forecast;
    ///   traj [n, k, 2*(future_len-1)] (only with a trajectory predictor): each sample's
    ///     intermediate points (its last point is d).
    /// Blob settings (data_scale, sigma, zdim, heading_steps, ...) are metadata properties.
    ///
    /// Fixed-point (Int16Q15) blobs are refused: their integer arithmetic has no ONNX float
    /// equivalent; export the f32 blob they were quantised from. onnxruntime agrees with the
    /// core within rounding, not bit for bit: at most 1.6e-3 px on the SDD test set for the
    /// shipped f32 blobs (scripts/peers/check.py, tolerance 0.01 px; docs/peers.md).
    #[command(verbatim_doc_comment)]
    Onnx(OnnxArgs),
    /// Make an Ed25519 key pair for signing blobs: DIR/gpecnet-signing.key (the private
    /// seed, hex, mode 0600, never printed) and DIR/gpecnet-signing.pub (the public key,
    /// hex). Never overwrites a key. Keep the private file off the drone and out of
    /// version control; compile the public one into the firmware.
    Keygen(KeygenArgs),
    /// Sign a blob: writes --out = the blob, then an 82-byte trailer (key id, --version,
    /// Ed25519 signature; weights/FORMAT.md). Predictions are unchanged (the blob's bytes
    /// and CRC are kept). Never writes over the blob or the key; the output is verified
    /// before it is in place.
    Sign(SignArgs),
    /// Verify a signed blob against a public key (and a minimum version): prints the
    /// model, key id and version, or why it is refused (unsigned, unknown key, bad
    /// signature, rolled back, invalid blob) and exits 1.
    Verify(VerifyArgs),
    /// Train a learned latent proposal (K latents from the past, DLow-like, or a fixed code
    /// book) for a frozen f32 blob, selected on validation; writes <out>/proposal.json.
    ///
    /// The blob's networks stay frozen; the proposal is trained against the soft minimum of
    /// the K endpoint errors and selected on the validation scenes (the test set is never
    /// read). The run folder holds checkpoint.json (after every epoch, atomically),
    /// metrics.csv and, at the end, proposal.json with the selected proposal's validation
    /// numbers through gpecnet-core (minFDE, KDE NLL, hit rates). --resume continues a run
    /// (the settings must be the same); a folder holding a run is refused without it. Attach
    /// the result with `gpecnet export --proposal <out>/proposal.json --tts 0`. The shipped
    /// metric MCU model's proposal (about 2 minutes on one core):
    /// gpecnet propose --blob weights/sdd-m-tiny.gpec --hidden 8 --seed 1 --out runs/latents/h8-s1
    Propose(gpecnet_trainer::propose::ProposeArgs),
    /// Fit endpoint probabilities and point-forecast radii for a frozen learned-proposal
    /// blob (with a point head); writes <out>/score.json.
    ///
    /// K logit rows on the proposal's hidden activations learn which endpoint is closest to
    /// the truth (multinomial logistic regression; the endpoints themselves do not change).
    /// The L2 weight, a temperature and the radius multipliers c50 / c90 (r = c · the
    /// probability-weighted spread of the endpoints around the point forecast) are chosen
    /// on the validation scenes; the test set is never read. Prints the validation numbers.
    /// Attach with `gpecnet export --proposal P --score <out>/score.json` (format version 6).
    /// The shipped metric MCU model's (under a minute on one core):
    /// gpecnet score --blob weights/sdd-m-lp.gpec --out runs/score/lp
    Score(gpecnet_trainer::score::ScoreArgs),
}

#[derive(clap::Args, Debug)]
struct KeygenArgs {
    /// Folder for the two key files (created if missing).
    #[arg(long)]
    out: PathBuf,
}

#[derive(clap::Args, Debug)]
struct SignArgs {
    /// The unsigned blob.
    #[arg(long)]
    blob: PathBuf,
    /// The private key file (gpecnet keygen).
    #[arg(long)]
    key: PathBuf,
    /// The model's release number: firmware refuses versions below the last it accepted.
    #[arg(long)]
    version: u32,
    /// The signed blob to write (a new file or a regular file; never the input).
    #[arg(long)]
    out: PathBuf,
}

#[derive(clap::Args, Debug)]
struct VerifyArgs {
    /// The signed blob.
    #[arg(long)]
    blob: PathBuf,
    /// The public key file (gpecnet keygen).
    #[arg(long)]
    pubkey: PathBuf,
    /// Refuse versions below this one.
    #[arg(long, default_value_t = 0)]
    min_version: u32,
}

fn cmd_keygen(a: KeygenArgs) -> Result<()> {
    use gpecnet_trainer::signing;
    let (sk, pk, id) = signing::keygen(&a.out)?;
    println!("private key: {} (mode 0600; keep it secret)", sk.display());
    println!("public key:  {}", pk.display());
    println!("key id:      {}", signing::key_id_hex(&id));
    Ok(())
}

fn cmd_sign(a: SignArgs) -> Result<()> {
    use gpecnet_trainer::signing;
    let id = signing::sign_file(&a.blob, &a.key, a.version, &a.out)?;
    println!(
        "signed {} -> {} (key id {}, version {})",
        a.blob.display(),
        a.out.display(),
        signing::key_id_hex(&id),
        a.version
    );
    Ok(())
}

fn cmd_verify(a: VerifyArgs) -> Result<()> {
    use gpecnet_trainer::signing;
    let v = signing::verify_file(&a.blob, &a.pubkey, a.min_version)?;
    println!(
        "{}: signature ok: model {}, key id {}, version {}",
        a.blob.display(),
        v.name,
        signing::key_id_hex(&v.key_id),
        v.model_version
    );
    Ok(())
}

#[derive(clap::Args, Debug)]
struct OnnxArgs {
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

fn cmd_onnx(a: OnnxArgs) -> Result<()> {
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
struct TestSampling {
    /// Samples per window (best-of-K).
    #[arg(long, default_value_t = 20)]
    k: usize,
    /// Latent seed of test window i is SEED + i.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

#[derive(clap::Args, Debug)]
struct QuantizeArgs {
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
struct SignOptions {
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

fn cmd_quantize(a: QuantizeArgs) -> Result<()> {
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
struct ExportArgs {
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
struct EvalArgs {
    /// The blob to evaluate.
    #[arg(long, value_name = "FILE", default_value = "weights/sdd-small.gpec")]
    blob: PathBuf,
    /// Data root holding sdd/ and eth_ucy/ (see shared/data/README.md).
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    /// The data set whose test split is evaluated: `sdd` (pixels), `sdd-m` (SDD in metres
    /// through the per-scene scales; also prints the pixel-equivalent numbers) or
    /// `eth_ucy:<eth|hotel|univ|zara1|zara2>` (metres). A blob whose unit differs from the data
    /// set's is refused before anything runs.
    #[arg(long, value_name = "SPEC", default_value = "sdd", value_parser = parse_dataset)]
    dataset: data::DatasetSpec,
    /// The unit of a blob that does not state one (format version < 4). Without it such a
    /// blob is taken as SDD pixels (what every shipped one is) and refused on metre data.
    #[arg(long, value_enum, value_name = "UNIT")]
    assume_unit: Option<UnitArg>,
    /// Sine to run (default: the one the blob's golden file names, else libm).
    #[arg(long, value_enum)]
    sine: Option<gpecnet_trainer::reference::SineKind>,
    #[command(flatten)]
    sampling: TestSampling,
    /// Where to draw predictions (SVG).
    #[arg(long, value_name = "FILE", default_value = "out/predictions.svg")]
    draw: PathBuf,
    /// Number of test windows to draw.
    #[arg(long, default_value_t = 16)]
    n_draw: usize,
    /// Also draw the reliability diagram of the endpoint probabilities (SVG; a model with
    /// probabilities only: format version 6, `gpecnet score`).
    #[arg(long, value_name = "FILE")]
    reliability: Option<PathBuf>,
    /// Print exactly one JSON object on stdout (name, n, k, min_ade, min_fde, ade_k1, fde_k1,
    /// mean_ade, mean_fde, point_ade, point_fde, cv_n, cv_ade, cv_fde, cv_last_ade,
    /// cv_last_fde, kde_nll, hit20, hit40, matches_card, probabilities, planner: the planner
    /// metrics of a model with endpoint probabilities, ...) instead of the table.
    #[arg(long)]
    json: bool,
    /// Add the distribution metrics (kde_nll, hit20, hit40) to the blob's existing model card
    /// (.json and .md) if it lacks them; nothing else in the card, the blob or the golden file
    /// changes. The card's ADE/FDE must be reproduced first.
    #[arg(long)]
    update_card: bool,
}

fn cmd_export(a: ExportArgs) -> Result<()> {
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
enum UnitArg {
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

fn parse_dataset(s: &str) -> std::result::Result<data::DatasetSpec, String> {
    data::DatasetSpec::parse(s)
}

fn cmd_eval(a: EvalArgs) -> Result<()> {
    let target = gpecnet_trainer::blob_eval::EvalTarget {
        dataset: a.dataset.clone(),
        assume_unit: a.assume_unit.map(Into::into),
    };
    if a.update_card && a.dataset != data::DatasetSpec::Sdd {
        anyhow::bail!("--update-card applies to the SDD pixel cards only");
    }
    let mut r = gpecnet_trainer::blob_eval::eval_blob(
        &a.blob,
        &a.data,
        &target,
        a.sine,
        a.sampling.k,
        a.sampling.seed,
        Some(&a.draw),
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

#[derive(clap::Args, Debug)]
struct SelectArgs {
    /// Run directory written by `gpecnet train` (its best validation epoch is used).
    #[arg(long, value_name = "DIR")]
    run: PathBuf,
    /// Data root holding sdd/ and eth_ucy/ (see shared/data/README.md).
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    /// Latent standard deviations to try.
    #[arg(long, value_delimiter = ',', default_value = "0.8,1.0,1.3")]
    sigmas: Vec<f32>,
    /// Test-time samples N to try (0 = plain sampling; N >= K reduces N samples to K by k-means).
    #[arg(long, value_delimiter = ',', default_value = "0,60,80,100")]
    tts: Vec<usize>,
    /// Endpoints per window.
    #[arg(long, default_value_t = 20)]
    k: usize,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
}

fn cmd_select(a: SelectArgs) -> Result<()> {
    let (rows, point) = gpecnet_trainer::select::select(
        &a.run,
        &a.data,
        &a.sigmas,
        &a.tts,
        a.k,
        gpecnet_trainer::reference::SineKind::Libm,
    )?;
    if a.json {
        let v = serde_json::json!({ "run": a.run, "rows": rows, "point": point });
        println!("{v}");
        return Ok(());
    }
    print!(
        "{}",
        gpecnet_trainer::select::table(a.k, &rows, point.as_ref())
    );
    Ok(())
}

#[derive(clap::Args, Debug)]
struct TrainArgs {
    /// Training config (TOML; see host-trainer/configs/). Required for a new run; with
    /// --resume the config stored in the checkpoint is used, and a --config given as well
    /// must equal it (num_epochs aside) or the resume is refused, naming the keys that differ.
    #[arg(long, value_name = "TOML")]
    config: Option<PathBuf>,
    /// Data root holding sdd/ and eth_ucy/ (see shared/data/README.md).
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    /// Run directory for checkpoint, metrics and plots (created if missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Continue the run in --out from its checkpoint.bin, bit-exactly.
    #[arg(long)]
    resume: bool,
    /// New runs: train into an --out folder that already holds files (but no checkpoint),
    /// overwriting its config.toml, metrics.csv, metrics.jsonl and curves.svg. Never breaks
    /// another run's lock and never replaces a checkpoint.
    #[arg(long)]
    force: bool,
    /// Override the total number of epochs of the run (also extends a resumed run).
    #[arg(long, value_name = "N")]
    epochs: Option<usize>,
    /// No progress bars and no per-epoch lines (bars are also hidden when stderr is not a
    /// terminal; then one line per epoch is printed instead).
    #[arg(long)]
    quiet: bool,
    /// Augment with the first K % (of the real training windows) of the synthetic pool
    /// (overrides the config's augment_pct; new runs only).
    #[arg(long, value_name = "K")]
    augment: Option<f32>,
    /// The synthetic pool CSV written by `gpecnet synth` (overrides synthetic_pool).
    #[arg(long, value_name = "CSV")]
    pool: Option<PathBuf>,
    /// Override the config's seed (new runs only): one config, several seeds.
    #[arg(long, value_name = "N")]
    seed: Option<u64>,
    /// Override the config's heading_steps (new runs only; 0 = raw orientation).
    #[arg(long, value_name = "M")]
    heading_steps: Option<usize>,
    /// Override the config's dataset (new runs only): `sdd` (pixels), `sdd-m` (SDD in metres),
    /// `eth_ucy:<scene>` (one config for every leave-one-scene-out split), a data-set folder
    /// with a `/` in its path (`./mydrone`: dataset.toml + train/ val/ test/, see
    /// docs/own-data.md), or several joined by `+`.
    #[arg(long, value_name = "SPEC")]
    dataset: Option<String>,
    /// Turn on reflection augmentation (new runs only; see `mirror` in the config).
    #[arg(long)]
    mirror: bool,
    /// Cosine learning-rate decay over the run (new runs only; see `lr_schedule`).
    #[arg(long)]
    cosine: bool,
}

fn cmd_train(a: TrainArgs) -> Result<()> {
    let opts = train::TrainOptions {
        data_root: a.data,
        run_dir: a.out,
        epochs: a.epochs,
        quiet: a.quiet,
        stop_after: None,
        force: a.force,
    };
    let summary = if a.resume {
        if a.force {
            anyhow::bail!("--force applies to new runs; --resume never overwrites anything");
        }
        if a.augment.is_some()
            || a.pool.is_some()
            || a.seed.is_some()
            || a.heading_steps.is_some()
            || a.dataset.is_some()
            || a.mirror
            || a.cosine
        {
            anyhow::bail!(
                "--resume uses the config stored in the checkpoint; drop --augment/--pool/--seed/--heading-steps/--dataset/--mirror/--cosine"
            );
        }
        let expected = a
            .config
            .as_deref()
            .map(TrainConfig::from_file)
            .transpose()?;
        train::train_resume_checked(&opts, expected.as_ref())?
    } else {
        let Some(path) = a.config else {
            anyhow::bail!("a new run needs --config <TOML> (or --resume to continue one)");
        };
        let mut cfg = TrainConfig::from_file(&path)?;
        if let Some(k) = a.augment {
            cfg.augment_pct = k;
        }
        if let Some(p) = a.pool {
            cfg.synthetic_pool = Some(p.to_string_lossy().into_owned());
        }
        if let Some(s) = a.seed {
            cfg.seed = s;
        }
        if let Some(m) = a.heading_steps {
            cfg.heading_steps = m;
        }
        if let Some(d) = a.dataset {
            cfg.dataset = d;
        }
        if a.mirror {
            cfg.mirror = true;
        }
        if a.cosine {
            cfg.lr_schedule = gpecnet_trainer::config::LrSchedule::Cosine;
        }
        train::train_new(cfg, &opts)?
    };
    let u = summary.unit;
    println!(
        "run: {} ({} epochs)",
        summary.run_dir.display(),
        summary.epochs_done
    );
    if let Some(v) = summary.last_val {
        println!(
            "final validation: minADE {:.3} {u}  minFDE {:.3} {u}  (K={}, n={})",
            v.min_ade, v.min_fde, v.k, v.n
        );
    }
    if let Some((epoch, v)) = summary.best {
        println!(
            "best epoch {epoch}: validation minADE {:.3} {u}  minFDE {:.3} {u}",
            v.min_ade, v.min_fde
        );
    }
    Ok(())
}

#[derive(clap::Args, Debug)]
struct AbscoreArgs {
    /// Data root holding sdd/ (see shared/data/README.md).
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    /// Output directory (abscore.md, abscore.csv, abscore_hist.svg, abscore_scaled_hist.svg).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Outlier filter: report how many trajectories have AbScore above this value.
    #[arg(long, value_name = "X")]
    max_abscore: Option<f64>,
    /// Filter on the areal-scaled AbScore instead of the unscaled one.
    #[arg(long)]
    scaled: bool,
}

fn cmd_abscore(a: AbscoreArgs) -> Result<()> {
    use gpecnet_trainer::synth::abscore::Which;
    let which = if a.scaled {
        Which::Scaled
    } else {
        Which::Unscaled
    };
    print!(
        "{}",
        gpecnet_trainer::synth::cli::run_abscore(&a.data, &a.out, a.max_abscore, which)?
    );
    Ok(())
}

#[derive(clap::Args, Debug)]
struct ClassifyArgs {
    /// Data root holding sdd/.
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    /// Output directory (classify.md, types.svg, unique_points.svg, type_examples.svg).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
}

fn cmd_classify(a: ClassifyArgs) -> Result<()> {
    print!(
        "{}",
        gpecnet_trainer::synth::cli::run_classify(&a.data, &a.out)?
    );
    Ok(())
}

#[derive(clap::Args, Debug)]
struct SynthArgs {
    /// Data root holding sdd/ (SDD train's type shares are matched).
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    /// Pool size.
    #[arg(long, default_value_t = 18000)]
    n: usize,
    /// Seed (policy training and pool order).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Episodes for the policy-gradient agents used in the pool.
    #[arg(long, default_value_t = 3200)]
    rl_episodes: usize,
    /// Output CSV (index,type,source,x0,y0,...); pictures and tables go next to it.
    #[arg(long, value_name = "CSV")]
    out: PathBuf,
}

fn cmd_synth(a: SynthArgs) -> Result<()> {
    print!(
        "{}",
        gpecnet_trainer::synth::cli::run_synth(&a.data, a.n, a.seed, a.rl_episodes, &a.out)?
    );
    Ok(())
}

#[derive(clap::Args, Debug)]
struct RlTrainArgs {
    /// Number of training episodes.
    #[arg(long, default_value_t = 3200)]
    episodes: usize,
    /// Episodes per REINFORCE update.
    #[arg(long, default_value_t = 16)]
    batch: usize,
    /// Adam learning rate.
    #[arg(long, default_value_t = 3e-3)]
    lr: f64,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory (rl_train.md, rl_curve.csv, rl_curve_*.svg, rl_episodes.svg, policy.json).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
}

fn cmd_rl_train(a: RlTrainArgs) -> Result<()> {
    print!(
        "{}",
        gpecnet_trainer::synth::cli::run_rl_train(a.episodes, a.batch, a.lr, a.seed, &a.out)?.0
    );
    Ok(())
}

#[derive(clap::Args, Debug)]
struct SweepArgs {
    /// Training config of every point (its augment_pct / synthetic_pool are overridden).
    #[arg(
        long,
        value_name = "TOML",
        default_value = "host-trainer/configs/sdd-small.toml"
    )]
    config: PathBuf,
    /// Augmentation percentages, comma-separated (0 = no augmentation).
    #[arg(long, default_value = "0,1,3,5,6,8,10,13,15,18")]
    pcts: String,
    /// Epochs of every run (default: the config's num_epochs).
    #[arg(long, value_name = "N")]
    epochs: Option<usize>,
    /// Output directory: aug-<K>/ runs, sweep.md, sweep.csv.
    #[arg(long, value_name = "DIR", default_value = "runs/sweep")]
    out: PathBuf,
    /// The synthetic pool CSV; generated there (--pool-n, --pool-seed) if it does not exist.
    #[arg(long, value_name = "CSV", default_value = "runs/pool/pool.csv")]
    pool: PathBuf,
    /// Seed of a generated pool.
    #[arg(long, default_value_t = 1)]
    pool_seed: u64,
    /// Size of a generated pool.
    #[arg(long, default_value_t = 18000)]
    pool_n: usize,
    /// Data root holding sdd/.
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    #[command(flatten)]
    sampling: TestSampling,
    /// No per-epoch lines.
    #[arg(long)]
    quiet: bool,
}

fn cmd_sweep(a: SweepArgs) -> Result<()> {
    use gpecnet_trainer::synth::sweep;
    let command = format!(
        "gpecnet sweep --config {} --pcts {} --epochs {} --out {} --pool {}",
        a.config.display(),
        a.pcts,
        a.epochs.map_or("<config>".into(), |n| n.to_string()),
        a.out.display(),
        a.pool.display()
    );
    let opts = sweep::SweepOptions {
        config: TrainConfig::from_file(&a.config)?,
        epochs: a.epochs,
        pcts: sweep::parse_pcts(&a.pcts)?,
        data_root: a.data,
        pool: a.pool,
        pool_seed: a.pool_seed,
        pool_n: a.pool_n,
        out: a.out,
        k: a.sampling.k,
        base_seed: a.sampling.seed,
        quiet: a.quiet,
        command,
    };
    let rows = sweep::run_sweep(&opts)?;
    print!("{}", sweep::sweep_md(&opts, &rows));
    Ok(())
}

fn main() -> Result<()> {
    match Cli::parse().command {
        Command::Train(a) => cmd_train(a),
        Command::Export(a) => cmd_export(a),
        Command::Eval(a) => cmd_eval(a),
        Command::Select(a) => cmd_select(a),
        Command::Quantize(a) => cmd_quantize(a),
        Command::Abscore(a) => cmd_abscore(a),
        Command::Classify(a) => cmd_classify(a),
        Command::Synth(a) => cmd_synth(a),
        Command::RlTrain(a) => cmd_rl_train(a),
        Command::Sweep(a) => cmd_sweep(a),
        Command::Onnx(a) => cmd_onnx(a),
        Command::Keygen(a) => cmd_keygen(a),
        Command::Sign(a) => cmd_sign(a),
        Command::Verify(a) => cmd_verify(a),
        Command::Propose(a) => {
            let p = a.run()?;
            println!(
                "best epoch {}: validation minFDE {:.4} (K = {}), clamped {:.4} %, mean |z| {:.2}",
                p.epoch,
                p.val.val_min_fde,
                p.settings.k,
                100.0 * p.val.val_clamped,
                p.val.val_z_norm
            );
            Ok(())
        }
        Command::Score(a) => {
            let s = a.run()?;
            let v = &s.val;
            println!(
                "L2 {} (validation cross-entropy {}), inverse temperature {:.3}, radius multipliers {:.3} / {:.3}",
                s.l2,
                s.grid
                    .iter()
                    .map(|g| format!("{}: {:.4}", g.l2, g.val_cross_entropy))
                    .collect::<Vec<_>>()
                    .join(", "),
                s.inverse_temperature,
                s.radius_scales[0],
                s.radius_scales[1]
            );
            println!(
                "validation ({} windows): P(top = closest) {:.3}, top FDE {:.4}, weighted FDE {:.4}, point FDE {:.4}, brier-minFDE {:.4}, ECE {:.4} (top-label {:.4}), mixture NLL {:.3} (equal weights {:.3}), r50 / r90 coverage {:.1} % / {:.1} %",
                v.n,
                v.top_is_closest,
                v.top_fde,
                v.weighted_fde,
                v.point_fde,
                v.brier_min_fde,
                v.ece,
                v.top_ece,
                v.mixture_nll,
                v.uniform_nll,
                100.0 * v.r50_coverage,
                100.0 * v.r90_coverage
            );
            Ok(())
        }
    }
}
