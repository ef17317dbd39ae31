//! A drone's whole pipeline on a real recording, drawn: the simulated drone of
//! `gpecnet_trainer::flight` (the one `gpecnet stream --flight` uses) films one ETH/UCY test
//! recording; each frame's detections go back to the ground through the core's camera module,
//! through the per-track Kalman filter with the measurement model's σ, into the online
//! forecaster of `weights/sdd-m-lp-qe.gpec`. The picture shows the first 60 s: the
//! pedestrians' true tracks, the drone's path (orange where it yaws), and the point forecasts
//! with their r90 circle issued every 12 s.
//!
//! ```text
//! cargo run --release -p gpecnet-trainer --example synthetic_flight -- \
//!     [--scene zara1] [--data ../shared/data] [--out docs/flight-zara1.svg]
//! ```

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{anyhow, bail, Result};
use gpecnet_core::online::{Config, Forecaster};
use gpecnet_core::tracks::filter::{FilterConfig, TrackFilter};
use gpecnet_core::tracks::Observation;
use gpecnet_core::units::CallerUnit;
use gpecnet_core::{LibmSine, Model, Predictor};
use gpecnet_trainer::data::{self, DatasetSpec, Split};
use gpecnet_trainer::draw::svg::{header, Panel};
use gpecnet_trainer::flight::{Flight, FlightSettings};

/// Seconds of the recording drawn.
const SPAN_S: f32 = 60.0;
/// Seconds between two drawn sets of forecasts.
const EVERY_S: u32 = 12;

fn main() -> Result<()> {
    let mut scene = "zara1".to_string();
    let mut root = data::default_data_root();
    let mut out = PathBuf::from("target/flight/flight-zara1.svg");
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or_else(|| anyhow!("{a} needs a value"));
        match a.as_str() {
            "--scene" => scene = value()?,
            "--data" => root = PathBuf::from(value()?),
            "--out" => out = PathBuf::from(value()?),
            _ => bail!("unknown argument {a} (--scene NAME, --data DIR, --out FILE)"),
        }
    }
    let spec = DatasetSpec::parse(&format!("eth_ucy:{scene}")).map_err(anyhow::Error::msg)?;
    let recs = data::recordings(&root, &spec, Split::Test, &[])?;
    let rec = recs.first().ok_or_else(|| anyhow!("no test recording"))?;
    let blob = std::fs::read("weights/sdd-m-lp-qe.gpec")?;
    let model = Model::from_blob(&blob).map_err(|e| anyhow!("{e}"))?;
    let mut p: Predictor<'_, LibmSine, 1024> =
        Predictor::with_units(model, CallerUnit::ModelUnit).map_err(|e| anyhow!("{e}"))?;
    let mut forecaster: Box<Forecaster<128, 2>> =
        Box::new(Forecaster::new(&model, Config::metres(), 1_000).map_err(|e| anyhow!("{e}"))?);
    let mut filter: Box<TrackFilter<128>> =
        Box::new(TrackFilter::new(FilterConfig::metres()).map_err(|e| anyhow!("{e:?}"))?);
    let mut flight = Flight::over(FlightSettings::default(), rec).map_err(anyhow::Error::msg)?;
    let t0 = rec.frames.first().map_or(0, |f| f.t_ms);
    let (mut tracks, mut drone, mut forecasts) = (
        std::collections::BTreeMap::<u32, Vec<[f32; 2]>>::new(),
        Vec::new(),
        Vec::new(),
    );
    let mut seen = Vec::new();
    for frame in &rec.frames {
        let t = frame.t_ms.wrapping_sub(t0);
        if t as f32 / 1000.0 > SPAN_S {
            break;
        }
        for (id, pos) in &frame.detections {
            tracks.entry(*id).or_default().push(*pos);
        }
        let st = flight.states(frame.t_ms);
        drone.push(([st.truth.position[0], st.truth.position[1]], st.yawing));
        seen.clear();
        flight
            .detect(frame.t_ms, &frame.detections, &mut seen)
            .map_err(|e| anyhow!("{e}"))?;
        let mut obs: Vec<Observation> = seen
            .iter()
            .map(|&(id, pos, _)| Observation { id, pos })
            .collect();
        filter.update_with(frame.t_ms, &mut obs, |i, _| {
            seen.get(i).map_or(f32::NAN, |d| d.2)
        });
        let draw = t % (EVERY_S * 1000) < 400 && t >= 4_000;
        forecaster.frame::<LibmSine, 1024, 20>(&mut p, frame.t_ms, &obs, |fc| {
            if draw {
                let mut path = vec![fc.anchor];
                path.extend_from_slice(&fc.point);
                forecasts.push((path, fc.radii[11].r90));
            }
        });
    }
    // Screen: x = east, y = −north (north up).
    let screen = |q: [f32; 2]| [q[1], -q[0]];
    let mut all: Vec<[f32; 2]> = tracks.values().flatten().map(|&q| screen(q)).collect();
    all.extend(drone.iter().map(|(q, _)| screen(*q)));
    let panel = Panel::fit((0.0, 24.0), 760.0, &all, (20.0, 20.0, 40.0), 10.0);
    let mut s = String::new();
    header(
        &mut s,
        760.0,
        790.0,
        &format!("Synthetic flight over eth_ucy:{scene} (test split, first {SPAN_S:.0} s)"),
    );
    panel.border(&mut s);
    for t in tracks.values() {
        let pts: Vec<[f32; 2]> = t.iter().map(|&q| screen(q)).collect();
        panel.polyline(&mut s, &pts, r##"stroke="#999" stroke-width="1""##);
    }
    for w in drone.windows(2) {
        let colour = if w[1].1 { "#e67e00" } else { "#1f5fbf" };
        let pts = [screen(w[0].0), screen(w[1].0)];
        panel.polyline(
            &mut s,
            &pts,
            &format!(r#"stroke="{colour}" stroke-width="2""#),
        );
    }
    for (path, r90) in &forecasts {
        let pts: Vec<[f32; 2]> = path.iter().map(|&q| screen(q)).collect();
        panel.polyline(&mut s, &pts, r##"stroke="#c0392b" stroke-width="1.2""##);
        if let Some(&end) = pts.last() {
            let (x, y) = panel.map(end);
            let _ = writeln!(
                s,
                r##"<circle cx="{x:.1}" cy="{y:.1}" r="{:.1}" fill="none" stroke="#c0392b" stroke-opacity="0.35"/>"##,
                r90 * panel.scale()
            );
        }
    }
    panel.scale_bar(&mut s, "m");
    panel.caption(
        &mut s,
        &format!(
            "grey: true tracks; blue: the drone (orange while it yaws 90°); red: point forecasts issued every {EVERY_S} s, circle: r90 at 4.8 s"
        ),
    );
    s.push_str("</svg>\n");
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir)?;
    }
    gpecnet_trainer::rundir::write_atomic(&out, s.as_bytes())?;
    let stats = flight.stats();
    println!(
        "{} forecasts drawn from {} tracks; ground error RMS {:.3} m ({:.3} m while yawing); wrote {}",
        forecasts.len(),
        tracks.len(),
        stats.rms_error_m,
        stats.rms_error_yawing_m,
        out.display()
    );
    Ok(())
}
