//! `gpecnet`: the G-PECNet host command line.
//!
//! One `Command` variant per subcommand and one small `cmd_*` function for it in a `cmd_*.rs`
//! module by command family; the work lives in the trainer's crates, so subcommands can be
//! appended without touching each other.
// Doc comments here are the CLI --help text, where <name> placeholders are plain text.
#![allow(rustdoc::invalid_html_tags)]

use anyhow::Result;
use clap::{Parser, Subcommand};
mod cmd_blob;
mod cmd_data;
mod cmd_sign;
mod cmd_stream;
mod cmd_synth;
mod cmd_train;

use cmd_blob::{
    cmd_eval, cmd_export, cmd_onnx, cmd_quantize, EvalArgs, ExportArgs, OnnxArgs, QuantizeArgs,
};
use cmd_sign::{cmd_keygen, cmd_sign, cmd_verify, KeygenArgs, SignArgs, VerifyArgs};
use cmd_stream::{cmd_stream, StreamArgs};
use cmd_synth::{
    cmd_abscore, cmd_classify, cmd_rl_train, cmd_sweep, cmd_synth, AbscoreArgs, ClassifyArgs,
    RlTrainArgs, SweepArgs, SynthArgs,
};
use cmd_train::{cmd_select, cmd_train, SelectArgs, TrainArgs};

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
    /// Evaluate a blob on a data set's test split through gpecnet-core; print ADE/FDE.
    ///
    /// This is what runs on the drone, on the real test set: best-of-K and K = 1 errors in
    /// the data's unit, the constant-velocity baseline, hit rates at the unit's radii, the
    /// same per scene, whether the model card is reproduced exactly, and (with --draw) an
    /// SVG of predicted vs. true trajectories. Writes no file unless asked. With no options:
    /// the shipped default model (weights/sdd-m-lp-qe.gpec) on its own data set, SDD in
    /// metres (`sdd-m`), with the pixel equivalents and what a planner gets.
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
    ///     from gpecnet_core::prng::Gaussian); not for a model with a learned latent proposal
    ///     (the shipped defaults sdd-m-lp, sdd-m-lp-host), whose graph computes its K latents
    ///     from x (k = K);
    ///   pos [n, 2] (only with a trajectory predictor): the last observed point as the
    ///     predictor sees it (rotated in the heading frame), divided by initial_pos_divisor.
    /// Outputs, in the normalised frame (caller units: divide by data_scale, rotate back, add
    /// p_0; gpecnet_core::frame::Frame::output):
    ///   d [n, k, 2]: each sample's endpoint (encoder_past, then the decoder on [f, z]);
    ///   point [n, 2*future_len] (only with a point-forecast head): the point forecast;
    ///   traj [n, k, 2*(future_len-1)] (only with a trajectory predictor): each sample's
    ///     intermediate points (its last point is d);
    ///   prob [n, K] (only with endpoint probabilities): each endpoint's probability;
    ///   radii [n, 2] (with probabilities and a point head): r50, r90 around the point
    ///     forecast's endpoint, in the blob's unit (not the normalised frame).
    /// Blob settings (data_scale, sigma, zdim, heading_steps, ...) are metadata properties.
    ///
    /// Fixed-point (Int16Q15) blobs are refused: their integer arithmetic has no ONNX float
    /// equivalent; export the f32 blob they were quantised from (sdd-m-lp for sdd-m-lp-qe).
    /// onnxruntime agrees with the core within rounding, not bit for bit: at most 1.6e-3 px
    /// on the SDD test set for the older f32 blobs (scripts/peers/check.py), at most 1e-5 m
    /// on every sdd-m test window for sdd-m-lp's whole forecast (scripts/peers/forecast.py;
    /// docs/peers.md).
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
    /// Stream a data set's recordings frame by frame through the timed track table, the
    /// predictor and the online loop, as a drone runs them, with the loop off and on.
    ///
    /// Every file of the split is one recording (all its pedestrians, in time order). Each
    /// forecast is scored against the track's grid positions 0.4 s … 4.8 s later: r50 / r90
    /// coverage at the endpoint and per horizon, by motion state and for starters (standing
    /// when forecast, > 1 m away at the endpoint), the mean r90 against an oracle multiplier
    /// fitted on the recording itself, the endpoint error of the point head, of constant
    /// velocity over 1, 2 and 4 steps and of the issued point, and the burn-in. Distances in
    /// metres. docs/online.md explains every number; for example:
    /// gpecnet stream --blob weights/sdd-m-lp-qe.gpec --dataset eth_ucy:hotel --plot hotel.svg
    Stream(StreamArgs),
    /// A data-set folder as a model will see it (gpecnet data check DIR).
    #[command(subcommand)]
    Data(cmd_data::DataCommand),
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
        Command::Stream(a) => cmd_stream(a),
        Command::Data(c) => cmd_data::cmd_data(c),
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
