//! `gpecnet stream`: a blob on every recording of a data set's split, streamed frame by
//! frame through the track table, the predictor and the online loop
//! (`gpecnet_metrics::stream`), with the loop off and on; the report per recording and pooled,
//! and a picture of coverage over time.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use serde::Serialize;

use crate::data::{recordings, DatasetSpec, Split, Unit};
use crate::stream::{pool, stream_both, StreamReport, StreamSettings, ROLLING};
use crate::units::check_unit;

/// What to stream and where from.
#[derive(Clone, Debug)]
pub struct StreamTarget {
    /// The blob.
    pub blob: PathBuf,
    /// The data root (`sdd/`, `eth_ucy/`).
    pub data_root: PathBuf,
    /// The data set.
    pub dataset: DatasetSpec,
    /// Its split.
    pub split: Split,
    /// The unit of a blob that states none.
    pub assume_unit: Option<Unit>,
}

/// The report of one data set: per recording and pooled, each with the loop off and on.
#[derive(Clone, Debug, Serialize)]
pub struct StreamSet {
    /// The blob's model name.
    pub model: String,
    /// The data set and split.
    pub dataset: String,
    /// The split streamed.
    pub split: String,
    /// Forecasts awaiting their truth per track (the loop's `P`).
    pub pending: usize,
    /// Detection noise, metres (0: none).
    pub noise_m: f32,
    /// Its seed.
    pub noise_seed: u64,
    /// The Kalman filter's config (metres) when it was on.
    #[serde(serialize_with = "filter_config")]
    pub filter: Option<gpecnet_core::tracks::filter::FilterConfig>,
    /// The simulated drone, when the recordings were seen through one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flight: Option<crate::flight::FlightSettings>,
    /// Per recording: `(off, on)`.
    pub recordings: Vec<[StreamReport; 2]>,
    /// All recordings pooled: `[off, on]`.
    pub pooled: [StreamReport; 2],
}

/// Streams every recording of `t` (module docs); `plot` draws the rolling r90 coverage.
pub fn stream_blob(t: &StreamTarget, s: &StreamSettings, plot: Option<&Path>) -> Result<StreamSet> {
    if let Some(out) = plot {
        let inputs = crate::outpath::blob_and_sidecars(&t.blob);
        let mut refs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
        refs.push(&t.blob);
        let data_dirs = crate::outpath::data_input_dirs(&t.data_root);
        let dirs: Vec<&Path> = data_dirs.iter().map(PathBuf::as_path).collect();
        crate::outpath::check_output("--plot", out, &refs, &dirs)?;
    }
    let blob = crate::inpath::read_limited(&t.blob, crate::inpath::FileKind::Blob)?;
    let model = gpecnet_core::Model::from_blob(&blob)
        .map_err(|e| anyhow::anyhow!("{}: {e}", t.blob.display()))?;
    let meta = gpecnet_core::blob::Meta::of_blob(&blob)
        .map_err(|e| anyhow::anyhow!("{}: {e}", t.blob.display()))?;
    check_unit(&model, &meta, &t.dataset, t.assume_unit)
        .with_context(|| format!("streaming {}", t.blob.display()))?;
    if let Some(period) = model.period_s() {
        if (period - crate::data::PERIOD_S).abs() > 1e-6 {
            bail!(
                "{}: the model's period is {period} s; the recordings are resampled onto 0.4 s \
                 grids by the data sets' clocks, so only a 0.4 s model can be streamed",
                t.blob.display()
            );
        }
    }
    let val = if t.dataset.is_sdd() {
        crate::data::default_sdd_val_scenes()
    } else {
        Vec::new()
    };
    let recs = recordings(&t.data_root, &t.dataset, t.split, &val).with_context(|| {
        format!(
            "reading the {} recordings of {}",
            t.split.dir_name(),
            t.dataset
        )
    })?;
    if recs.is_empty() {
        bail!("{} has no {} recording", t.dataset, t.split.dir_name());
    }
    let mut per = Vec::with_capacity(recs.len());
    for r in &recs {
        let (off, on) =
            stream_both(&blob, r, s).with_context(|| format!("streaming {}", r.path.display()))?;
        per.push([off, on]);
    }
    let name = format!("{} ({})", t.dataset, t.split.dir_name());
    let offs: Vec<StreamReport> = per.iter().map(|p| p[0].clone()).collect();
    let ons: Vec<StreamReport> = per.iter().map(|p| p[1].clone()).collect();
    let set = StreamSet {
        model: model.name().to_string(),
        dataset: t.dataset.to_string(),
        split: t.split.dir_name().to_string(),
        pending: s.pending,
        noise_m: s.noise_m,
        noise_seed: s.noise_seed,
        filter: s.filter,
        flight: s.flight,
        pooled: [pool(&name, &offs), pool(&name, &ons)],
        recordings: per,
    };
    if let Some(out) = plot {
        crate::rundir::write_atomic(out, coverage_svg(&set).as_bytes())
            .with_context(|| format!("writing {}", out.display()))?;
    }
    Ok(set)
}

/// The rolling r90 endpoint coverage of every recording over its scored forecasts (blocks of
/// [`ROLLING`]), loop off dashed and on solid, with the 0.87–0.93 band.
pub fn coverage_svg(set: &StreamSet) -> String {
    const W: f64 = 760.0;
    const H: f64 = 360.0;
    const L: f64 = 60.0;
    const R: f64 = 170.0;
    const T: f64 = 40.0;
    const B: f64 = 40.0;
    let blocks = set
        .recordings
        .iter()
        .map(|p| p[1].rolling_r90.len())
        .max()
        .unwrap_or(0)
        .max(2);
    let x = |i: usize| L + (W - L - R) * i as f64 / (blocks - 1) as f64;
    let (lo, hi) = (0.5, 1.0);
    let y = |c: f64| T + (H - T - B) * (hi - c.clamp(lo, hi)) / (hi - lo);
    let colours = [
        "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf",
    ];
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{H}\" \
         font-family=\"sans-serif\" font-size=\"11\">\n\
         <rect width=\"{W}\" height=\"{H}\" fill=\"white\"/>\n\
         <text x=\"{L}\" y=\"20\" font-size=\"13\">{} on {} ({}): r90 endpoint coverage per {ROLLING} \
         forecasts (dashed: loop off, solid: on)</text>\n",
        escape(&set.model),
        escape(&set.dataset),
        set.split
    );
    s += &format!(
        "<rect x=\"{L}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"#eeeeee\"/>\n",
        y(0.93),
        W - L - R,
        y(0.87) - y(0.93)
    );
    for c in [0.5, 0.6, 0.7, 0.8, 0.9, 1.0] {
        s += &format!(
            "<line x1=\"{L}\" x2=\"{:.1}\" y1=\"{:.1}\" y2=\"{:.1}\" stroke=\"#cccccc\"/>\
             <text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{c:.1}</text>\n",
            W - R,
            y(c),
            y(c),
            L - 4.0,
            y(c) + 4.0
        );
    }
    s += &format!(
        "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">forecasts, in time order (blocks of \
         {ROLLING})</text>\n",
        (L + W - R) / 2.0,
        H - 10.0
    );
    let mut legend = 0;
    for (i, p) in set.recordings.iter().enumerate() {
        let colour = colours[i % colours.len()];
        for (mode, dash) in [(0, "stroke-dasharray=\"4 3\""), (1, "")] {
            let pts: Vec<String> = p[mode]
                .rolling_r90
                .iter()
                .enumerate()
                .map(|(k, &c)| format!("{:.1},{:.1}", x(k), y(c)))
                .collect();
            if pts.len() >= 2 {
                s += &format!(
                    "<polyline points=\"{}\" fill=\"none\" stroke=\"{colour}\" {dash}/>\n",
                    pts.join(" ")
                );
            }
        }
        if !p[1].rolling_r90.is_empty() {
            s += &format!(
                "<text x=\"{:.1}\" y=\"{:.1}\" fill=\"{colour}\">{}</text>\n",
                W - R + 10.0,
                T + 14.0 * legend as f64,
                escape(&p[1].scene)
            );
            legend += 1;
        }
    }
    s += "</svg>\n";
    s
}

/// The filter's config as `{accel, sigma, init_speed, reset, max_gap_ms}` (the core's type
/// has no serde).
fn filter_config<S: serde::Serializer>(
    c: &Option<gpecnet_core::tracks::filter::FilterConfig>,
    s: S,
) -> std::result::Result<S::Ok, S::Error> {
    use serde::ser::SerializeStruct;
    match c {
        None => s.serialize_none(),
        Some(c) => {
            let mut m = s.serialize_struct("FilterConfig", 5)?;
            m.serialize_field("accel", &c.accel)?;
            m.serialize_field("sigma", &c.sigma)?;
            m.serialize_field("init_speed", &c.init_speed)?;
            m.serialize_field("reset", &c.reset)?;
            m.serialize_field("max_gap_ms", &c.max_gap_ms)?;
            m.end()
        }
    }
}

fn escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
