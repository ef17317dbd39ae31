//! `gpecnet stream`: recordings streamed through the track table, the predictor and the online
//! loop, as a drone runs them; argument parsing and printing only.
// Doc comments here are the CLI --help text, where <name> placeholders are plain text.
#![allow(rustdoc::invalid_html_tags)]

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use gpecnet_trainer::data;
use gpecnet_trainer::stream::{StreamReport, StreamSettings};
use gpecnet_trainer::stream_eval::{stream_blob, StreamSet, StreamTarget};

use crate::cmd_blob::{parse_dataset, UnitArg};

/// Which split's recordings to stream.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub(crate) enum SplitArg {
    /// The test split (touch once per shipped model).
    Test,
    /// The validation split (choose the loop's settings here).
    Val,
}

#[derive(clap::Args, Debug)]
pub(crate) struct StreamArgs {
    /// The blob to stream (its unit must be the data set's).
    #[arg(long, value_name = "FILE", default_value = "weights/sdd-m-lp-qe.gpec")]
    blob: PathBuf,
    /// Data root holding sdd/ and eth_ucy/ (see shared/data/README.md).
    #[arg(long, value_name = "DIR", default_value_os_t = data::default_data_root())]
    data: PathBuf,
    /// The data set whose recordings are streamed, one recording per file: `sdd-m` (SDD in
    /// metres), `sdd` (pixels), `eth_ucy:<eth|hotel|univ|zara1|zara2>` (metres), or your own
    /// data-set folder (a path with a '/', docs/own-data.md).
    #[arg(long, value_name = "SPEC", default_value = "eth_ucy:zara1", value_parser = parse_dataset)]
    dataset: data::DatasetSpec,
    /// The split whose files are streamed.
    #[arg(long, value_enum, default_value = "test")]
    split: SplitArg,
    /// The unit of a blob that does not state one (format version < 4).
    #[arg(long, value_enum, value_name = "UNIT")]
    assume_unit: Option<UnitArg>,
    /// Forecasts per track kept for scoring: 2 (the device default: 496 B per track, one
    /// forecast in six scored) or 12 (every forecast scored).
    #[arg(long, default_value_t = 2, value_parser = parse_pending)]
    pending: usize,
    /// Step of the radius multipliers' logarithm per update (0 < γ <= 1).
    #[arg(long, default_value_t = 0.2)]
    gamma: f32,
    /// Learning rate of the expert weights, per metre of discounted endpoint error.
    #[arg(long, default_value_t = 2.0)]
    eta: f32,
    /// Forgetting factor of the expert losses per update (0 < λ < 1).
    #[arg(long, default_value_t = 0.999)]
    forgetting: f32,
    /// The constant-velocity experts' initial discounted loss at the endpoint horizon, in
    /// metres (the point head's is 0): how much evidence it takes to move weight off the head.
    #[arg(long, default_value_t = 0.5)]
    expert_prior: f32,
    /// One calibration per motion state (standing, slow, walking, fast) instead of one for
    /// all (did worse on validation: docs/online.md).
    #[arg(long)]
    motion_bins: bool,
    /// Longest gap between two detections of a track that is bridged (milliseconds).
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u32).range(1..=60_000))]
    max_gap_ms: u32,
    /// Add i.i.d. Gaussian noise of SIGMA metres to each coordinate of every detection (a
    /// seeded PRNG: runs reproduce); forecasts are still scored against the clean positions.
    #[arg(long, value_name = "SIGMA", default_value_t = 0.0)]
    noise_m: f32,
    /// Seed of the detection noise.
    #[arg(long, default_value_t = 1)]
    noise_seed: u64,
    /// Put the core's per-track Kalman filter (gpecnet_core::tracks::filter) in front of the
    /// track table (docs/camera.md, "Noise and filtering").
    #[arg(long)]
    filter: bool,
    /// The filter's white-acceleration process noise, m/s² (default: the core's).
    #[arg(long, value_name = "M_PER_S2", requires = "filter")]
    filter_accel: Option<f32>,
    /// The filter's measurement noise σ per detection, metres (default: the core's).
    #[arg(long, value_name = "METRES", requires = "filter")]
    filter_sigma: Option<f32>,
    /// See every recording through a simulated drone (docs/camera.md, "Synthetic flight"):
    /// orbiting the scene 30 m ± 5 m up with a gimballed camera and yawing 90° in 2 s every
    /// 30 s; each pedestrian is projected into its 1920 x 1080 image, detected with pixel
    /// noise and misses, and mapped back to the ground through a pose with attitude error, by
    /// the core's camera module. With --filter, each detection's σ is the measurement model's.
    /// Metre data only; scored against the clean positions.
    #[arg(long)]
    flight: bool,
    /// The flight's mean altitude, metres.
    #[arg(
        long,
        value_name = "METRES",
        default_value_t = 30.0,
        requires = "flight"
    )]
    flight_altitude: f32,
    /// The detector's noise on each pixel coordinate, pixels.
    #[arg(long, value_name = "PX", default_value_t = 2.0, requires = "flight")]
    pixel_noise: f32,
    /// The orientation's noise about each world axis, degrees.
    #[arg(long, value_name = "DEG", default_value_t = 0.5, requires = "flight")]
    attitude_noise_deg: f32,
    /// Correlation time of the orientation noise, seconds (0: drawn afresh every frame; τ > 0:
    /// a Gauss-Markov drift of the same σ, as an attitude estimator's error).
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 0.0,
        requires = "flight"
    )]
    attitude_correlation_s: f32,
    /// Probability that the detector misses a pedestrian in a frame.
    #[arg(long, value_name = "P", default_value_t = 0.05, requires = "flight")]
    miss_rate: f32,
    /// Seed of the flight's draws.
    #[arg(long, default_value_t = 1, requires = "flight")]
    flight_seed: u64,
    /// Write an SVG of the rolling r90 coverage over time (loop off and on) to FILE.
    #[arg(long, value_name = "FILE")]
    plot: Option<PathBuf>,
    /// Print exactly one JSON object on stdout (model, dataset, split, pending, recordings:
    /// [[off, on], ...], pooled: [off, on]; each report with endpoint, per_horizon, by_motion,
    /// starters coverage, mean_r50, mean_r90, oracle_r90, fde, burn_in, rolling_r90,
    /// final_multipliers) instead of the tables.
    #[arg(long)]
    json: bool,
}

fn parse_pending(s: &str) -> std::result::Result<usize, String> {
    match s {
        "2" => Ok(2),
        "12" => Ok(12),
        _ => Err(format!("{s:?}: expected 2 or 12")),
    }
}

pub(crate) fn cmd_stream(a: StreamArgs) -> Result<()> {
    let mut config = gpecnet_core::online::Config::metres();
    config.gamma = a.gamma;
    config.eta = a.eta;
    config.forgetting = a.forgetting;
    config.expert_prior = a.expert_prior;
    config.motion_bins = a.motion_bins;
    if config.validate().is_err() {
        anyhow::bail!(
            "--gamma {} / --eta {} / --forgetting {} / --expert-prior {}: expected 0 < gamma <= 1, \
             eta > 0, 0 < forgetting < 1 and 0 <= expert-prior <= 10 / (1 - forgetting)",
            a.gamma,
            a.eta,
            a.forgetting,
            a.expert_prior
        );
    }
    if !(a.noise_m.is_finite() && (0.0..=10.0).contains(&a.noise_m)) {
        anyhow::bail!("--noise-m {}: expected 0 <= SIGMA <= 10 metres", a.noise_m);
    }
    let filter = if a.filter {
        let mut c = gpecnet_core::tracks::filter::FilterConfig::metres();
        c.accel = a.filter_accel.unwrap_or(c.accel);
        c.sigma = a.filter_sigma.unwrap_or(c.sigma);
        if c.validate().is_err() {
            anyhow::bail!(
                "--filter-accel {} / --filter-sigma {}: expected finite, positive values",
                c.accel,
                c.sigma
            );
        }
        Some(c)
    } else {
        None
    };
    let flight = if a.flight {
        let f = gpecnet_trainer::flight::FlightSettings {
            altitude_m: a.flight_altitude,
            pixel_noise: a.pixel_noise,
            attitude_noise_deg: a.attitude_noise_deg,
            attitude_correlation_s: a.attitude_correlation_s,
            miss_rate: a.miss_rate,
            seed: a.flight_seed,
            ..Default::default()
        };
        f.validate().map_err(anyhow::Error::msg)?;
        Some(f)
    } else {
        None
    };
    let settings = StreamSettings {
        flight,
        config,
        max_gap_ms: a.max_gap_ms,
        pending: a.pending,
        noise_m: a.noise_m,
        noise_seed: a.noise_seed,
        filter,
    };
    let target = StreamTarget {
        blob: a.blob.clone(),
        data_root: a.data.clone(),
        dataset: a.dataset.clone(),
        split: match a.split {
            SplitArg::Test => data::Split::Test,
            SplitArg::Val => data::Split::Val,
        },
        assume_unit: a.assume_unit.map(Into::into),
    };
    let set = stream_blob(&target, &settings, a.plot.as_deref())?;
    let mut o = std::io::stdout().lock();
    if a.json {
        writeln!(o, "{}", serde_json::to_string(&set)?)?;
        return Ok(());
    }
    print_set(&mut o, &set)?;
    if let Some(p) = &a.plot {
        writeln!(o, "drew {}", p.display())?;
    }
    Ok(())
}

fn print_set(o: &mut impl Write, set: &StreamSet) -> Result<()> {
    writeln!(
        o,
        "{} on {} ({}), streamed frame by frame; the loop keeps {} forecasts per track for scoring",
        set.model, set.dataset, set.split, set.pending
    )?;
    if set.noise_m > 0.0 || set.filter.is_some() {
        let filter = set.filter.map_or_else(
            || "off".to_string(),
            |c| format!("on (accel {} m/s², σ {} m)", c.accel, c.sigma),
        );
        writeln!(
            o,
            "detection noise σ = {} m (seed {}), scored against the clean positions; filter {filter}",
            set.noise_m, set.noise_seed
        )?;
    }
    if let (Some(f), Some(st)) = (&set.flight, &set.pooled[0].flight) {
        writeln!(
            o,
            "synthetic flight: {:.0}–{:.0} m up, {} px detector noise, {}° orientation noise \
             (correlation time {} s), {:.0} % \
             misses (seed {}): {} of {} positions detected ({} outside the image, {} missed, {} \
             refused); ground error RMS {:.3} m ({:.3} m while yawing, {} detections), max {:.3} m \
             ({:.3} m while yawing); the measurement model's σ RMS {:.3} m per axis against {:.3} m \
             realised",
            st.altitude_range_m[0],
            st.altitude_range_m[1],
            f.pixel_noise,
            f.attitude_noise_deg,
            f.attitude_correlation_s,
            100.0 * f.miss_rate,
            f.seed,
            st.detections,
            st.positions,
            st.outside,
            st.missed,
            st.refused,
            st.rms_error_m,
            st.rms_error_yawing_m,
            st.detections_yawing,
            st.max_error_m,
            st.max_error_yawing_m,
            st.rms_model_sigma_m,
            st.rms_error_m / std::f64::consts::SQRT_2,
        )?;
    }
    let unit = &set.pooled[0].unit;
    writeln!(
        o,
        "\n| recording | loop | forecasts | scored | r50 | r90 | r90 standing (n) | r90 starters (n) | mean r90 / oracle ({unit}) | FDE head | CV1 | CV2 | CV4 | point | minFDE |"
    )?;
    writeln!(
        o,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    )?;
    for pair in set.recordings.iter().chain(std::iter::once(&set.pooled)) {
        for r in pair {
            row(o, r)?;
        }
    }
    writeln!(
        o,
        "\nper-horizon r90 coverage, all recordings pooled (0.4 s … 4.8 s):"
    )?;
    for r in &set.pooled {
        let h: Vec<String> = r
            .per_horizon
            .iter()
            .map(|c| format!("{:.3}", c.r90))
            .collect();
        writeln!(o, "  loop {:3}: {}", on_off(r), h.join(" "))?;
    }
    writeln!(
        o,
        "\nburn-in (r90 coverage of the first N forecasts, loop on):"
    )?;
    for p in &set.recordings {
        let b: Vec<String> = p[1]
            .burn_in
            .iter()
            .map(|(n, c)| format!("{n}: {c:.3}"))
            .collect();
        writeln!(o, "  {}: {}", p[1].scene, b.join(", "))?;
    }
    Ok(())
}

fn on_off(r: &StreamReport) -> &'static str {
    if r.adapt {
        "on"
    } else {
        "off"
    }
}

fn row(o: &mut impl Write, r: &StreamReport) -> Result<()> {
    let standing = r.by_motion.get("standing").copied().unwrap_or_default();
    let head = r
        .fde
        .head
        .map_or_else(|| "–".to_string(), |h| format!("{h:.3}"));
    writeln!(
        o,
        "| {} | {} | {} | {} | {:.3} | {:.3} | {:.3} ({}) | {:.3} ({}) | {:.3} / {:.3} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
        r.scene,
        on_off(r),
        r.forecasts,
        r.scored,
        r.endpoint.r50,
        r.endpoint.r90,
        standing.r90,
        standing.n,
        r.starters.r90,
        r.starters.n,
        r.mean_r90,
        r.oracle_r90,
        head,
        r.fde.cv[0],
        r.fde.cv[1],
        r.fde.cv[2],
        r.fde.point,
        r.fde.min_k
    )?;
    Ok(())
}
