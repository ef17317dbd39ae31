//! The streaming evaluation (`gpecnet stream`) on real recordings: every pedestrian of a
//! recording reaches the track table (the data's manifest counts), every full 20-step window is
//! scored, the loop off reproduces the static forecast, the loop on calibrates a scene the
//! static radii over-cover, and the command's output and refusals.
use crate::common::{run, s, temp_dir};

use gpecnet_trainer::data::{default_data_root, recordings, DatasetSpec, Split};
use gpecnet_trainer::stream::StreamSettings;
use gpecnet_trainer::stream_eval::{stream_blob, StreamTarget};

const BLOB: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../weights/sdd-m-lp-qe.gpec");

fn hotel() -> StreamTarget {
    StreamTarget {
        blob: BLOB.into(),
        data_root: default_data_root(),
        dataset: DatasetSpec::parse("eth_ucy:hotel").unwrap(),
        split: Split::Test,
        assume_unit: None,
    }
}

#[test]
fn a_recording_holds_every_pedestrian_in_time_order() {
    let recs = recordings(
        &default_data_root(),
        &DatasetSpec::parse("eth_ucy:hotel").unwrap(),
        Split::Test,
        &[],
    )
    .unwrap();
    assert_eq!(recs.len(), 1);
    let r = &recs[0];
    // shared/data/MANIFEST.tsv: biwi_hotel.txt, 6,543 rows, 389 pedestrians.
    assert_eq!((r.detections(), r.pedestrians()), (6_543, 389));
    assert!(r.frames.windows(2).all(|w| w[0].t_ms < w[1].t_ms));
    // 10 frames of 25 fps are one 0.4 s step.
    assert!(r
        .frames
        .windows(2)
        .all(|w| (w[1].t_ms - w[0].t_ms) % 400 == 0));
}

#[test]
fn hotel_streamed_scores_every_window_and_the_loop_calibrates_it() {
    let settings = StreamSettings {
        pending: 12,
        ..StreamSettings::default()
    };
    let set = stream_blob(&hotel(), &settings, None).unwrap();
    let [off, on] = &set.recordings[0];
    // MANIFEST.tsv: 1,197 twenty-step windows, lone walkers included.
    assert_eq!((off.scored, on.scored), (1_197, 1_197));
    // The loop off issues the head's point forecast and the blob's radii.
    assert_eq!(off.fde.point, off.fde.head.unwrap());
    assert!(off.per_horizon.len() == 12 && off.endpoint == off.per_horizon[11]);
    // The static radii over-cover HOTEL; the loop brings them to about 90 % and narrower.
    assert!(off.endpoint.r90 > 0.95, "{:?}", off.endpoint);
    assert!(
        (0.85..=0.95).contains(&on.endpoint.r90),
        "{:?}",
        on.endpoint
    );
    assert!(on.mean_r90 < 0.8 * off.mean_r90);
    for c in &on.per_horizon {
        assert!((0.85..=0.96).contains(&c.r90), "{c:?}");
    }
    // And its point forecast is closer to the best expert than the head alone.
    let best = on
        .fde
        .cv
        .iter()
        .copied()
        .fold(on.fde.head.unwrap(), f64::min);
    assert!(on.fde.point < off.fde.point && on.fde.point < 1.02 * best);
}

#[test]
fn the_command_prints_json_and_refuses_to_draw_over_its_inputs() {
    let (ok, out) = run(&[
        "stream",
        "--blob",
        BLOB,
        "--dataset",
        "eth_ucy:eth",
        "--json",
    ]);
    assert!(ok, "{out}");
    let j: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(j["model"], "sdd-m-lp-qe");
    assert_eq!(j["pooled"][1]["adapt"], true);
    assert_eq!(j["recordings"][0][0]["scored"], 364);

    let golden = BLOB.replace(".gpec", ".golden");
    let (ok, out) = run(&["stream", "--blob", BLOB, "--plot", &golden]);
    assert!(!ok && out.contains("--plot"), "{out}");
    let (ok, out) = run(&["stream", "--blob", BLOB, "--pending", "3"]);
    assert!(!ok && out.contains("expected 2 or 12"), "{out}");
    let (ok, out) = run(&["stream", "--blob", BLOB, "--gamma", "0"]);
    assert!(!ok && out.contains("--gamma"), "{out}");
    // A pixel model on metre data is refused before anything runs.
    let px = BLOB.replace("sdd-m-lp-qe", "sdd-tiny-v2-qe");
    let (ok, out) = run(&["stream", "--blob", &px, "--dataset", "eth_ucy:eth"]);
    assert!(!ok && out.contains("pixel"), "{out}");

    let dir = temp_dir("stream-plot");
    let svg = dir.join("cov.svg");
    let (ok, out) = run(&[
        "stream",
        "--blob",
        BLOB,
        "--dataset",
        "eth_ucy:hotel",
        "--plot",
        s(&svg),
    ]);
    assert!(ok, "{out}");
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg") && text.contains("biwi_hotel"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_own_data_folder_streams_like_the_built_in_scene() {
    // The HOTEL test file as a user's folder: frame numbers at 25 fps, then as a CSV with a
    // header and timestamps in seconds. Both stream to the built-in scene's numbers.
    let src = default_data_root().join("eth_ucy/hotel/test/biwi_hotel.txt");
    let text = std::fs::read_to_string(&src).unwrap();
    let dir = temp_dir("stream-folder");
    let txt = dir.join("txt");
    std::fs::create_dir_all(txt.join("test")).unwrap();
    std::fs::write(txt.join("test/biwi_hotel.txt"), &text).unwrap();
    std::fs::write(
        txt.join("dataset.toml"),
        "unit = \"m\"\nseconds_per_frame = 0.04\n",
    )
    .unwrap();
    let csv = dir.join("csv");
    std::fs::create_dir_all(csv.join("test")).unwrap();
    let mut rows = String::from("id,t_s,x,y,extra\n");
    for l in text.lines().filter(|l| !l.trim().is_empty()) {
        let c: Vec<&str> = l.split_whitespace().collect();
        let t = c[0].parse::<f64>().unwrap() * 0.04;
        rows += &format!("p{},{t:.3},{},{},x\n", c[1], c[2], c[3]);
    }
    std::fs::write(csv.join("test/biwi_hotel.csv"), rows).unwrap();
    std::fs::write(
        csv.join("dataset.toml"),
        "unit = \"m\"\ntime_unit = \"s\"\n[columns]\ntime = \"t_s\"\nid = \"id\"\nx = \"x\"\ny = \"y\"\n",
    )
    .unwrap();
    let built_in = stream_blob(&hotel(), &StreamSettings::default(), None).unwrap();
    for folder in [&txt, &csv] {
        let t = StreamTarget {
            dataset: DatasetSpec::parse(s(folder)).unwrap(),
            ..hotel()
        };
        let set = stream_blob(&t, &StreamSettings::default(), None).unwrap();
        assert_eq!(
            set.recordings[0][1],
            built_in.recordings[0][1],
            "{}",
            folder.display()
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn noisy_detections_are_scored_against_the_clean_truth_and_the_filter_helps() {
    use gpecnet_core::tracks::filter::FilterConfig;
    let clean = stream_blob(&hotel(), &StreamSettings::default(), None).unwrap();
    let noisy_settings = StreamSettings {
        noise_m: 0.1,
        noise_seed: 5,
        ..StreamSettings::default()
    };
    let noisy = stream_blob(&hotel(), &noisy_settings, None).unwrap();
    // Reproducible: the same seed gives the same report.
    let again = stream_blob(&hotel(), &noisy_settings, None).unwrap();
    assert_eq!(noisy.pooled, again.pooled);
    let filtered = stream_blob(
        &hotel(),
        &StreamSettings {
            filter: Some(FilterConfig::metres()),
            ..noisy_settings
        },
        None,
    )
    .unwrap();
    let (c, n, f) = (&clean.pooled[0], &noisy.pooled[0], &filtered.pooled[0]);
    // Noise changes no timing: the same forecasts are issued and scored.
    assert_eq!((n.forecasts, n.scored), (c.forecasts, c.scored));
    assert_eq!((f.forecasts, f.scored), (c.forecasts, c.scored));
    // Scored against the clean positions: the noise costs accuracy, the filter wins some back.
    assert!(
        n.fde.point > 1.5 * c.fde.point,
        "{:?} vs {:?}",
        n.fde,
        c.fde
    );
    assert!(
        f.fde.point < 0.95 * n.fde.point,
        "{:?} vs {:?}",
        f.fde,
        n.fde
    );
    assert!(f.fde.min_k < n.fde.min_k && c.fde.min_k < n.fde.min_k);
    // Best of 20 is never worse than the point.
    assert!(c.fde.min_k < c.fde.point);
}

/// The synthetic flight on HOTEL's test recording: every position is accounted for
/// (detected, outside the image, missed, refused), the draws reproduce, the measurement
/// model's σ matches the realised ground error, a 90° yaw adds no error, the filter with the
/// model's σ wins back accuracy, and pixel noise alone costs less than pixel and attitude
/// noise; a pixel data set and metre noise on top are refused.
#[test]
fn the_synthetic_flight_sees_hotel_through_a_drone_camera() {
    use gpecnet_core::tracks::filter::FilterConfig;
    use gpecnet_trainer::flight::FlightSettings;
    let clean = stream_blob(&hotel(), &StreamSettings::default(), None).unwrap();
    let flown = StreamSettings {
        flight: Some(FlightSettings::default()),
        ..StreamSettings::default()
    };
    let raw = stream_blob(&hotel(), &flown, None).unwrap();
    assert_eq!(
        raw.pooled,
        stream_blob(&hotel(), &flown, None).unwrap().pooled,
        "the same seed, the same flight"
    );
    let st = raw.pooled[0].flight.expect("flight statistics");
    assert_eq!(st.positions, 6_543, "every detection of the recording");
    assert_eq!(
        st.detections + st.outside + st.missed + st.refused,
        st.positions
    );
    let miss = st.missed as f64 / (st.positions - st.outside) as f64;
    assert!((0.04..0.06).contains(&miss), "5 % misses: {miss}");
    assert!(st.altitude_range_m[0] >= 25.0 - 1e-6 && st.altitude_range_m[1] <= 35.0 + 1e-6);
    // First order is enough: the model's σ per axis within 10 % of the realised error.
    let per_axis = st.rms_error_m / 2f64.sqrt();
    assert!(
        (st.rms_model_sigma_m / per_axis - 1.0).abs() < 0.1,
        "{} vs {per_axis}",
        st.rms_model_sigma_m
    );
    // No jump from the drone's yaw: the error while yawing is the error at other times.
    assert!(st.detections_yawing > 100);
    assert!(
        (st.rms_error_yawing_m / st.rms_error_m - 1.0).abs() < 0.15,
        "{st:?}"
    );
    let filtered = stream_blob(
        &hotel(),
        &StreamSettings {
            filter: Some(FilterConfig::metres()),
            ..flown
        },
        None,
    )
    .unwrap();
    let pixels_only = stream_blob(
        &hotel(),
        &StreamSettings {
            filter: Some(FilterConfig::metres()),
            flight: Some(FlightSettings {
                attitude_noise_deg: 0.0,
                ..FlightSettings::default()
            }),
            ..StreamSettings::default()
        },
        None,
    )
    .unwrap();
    let fde = |s: &gpecnet_trainer::stream_eval::StreamSet| s.pooled[0].fde.min_k;
    assert!(fde(&clean) < fde(&pixels_only) && fde(&pixels_only) < fde(&filtered));
    assert!(fde(&filtered) < fde(&raw), "the filter helps");
    let pixel_data = StreamTarget {
        dataset: DatasetSpec::parse("sdd").unwrap(),
        ..hotel()
    };
    let e = stream_blob(&pixel_data, &flown, None).unwrap_err();
    assert!(
        format!("{e:#}").contains("metres") || format!("{e:#}").contains("unit"),
        "{e:#}"
    );
    let e = stream_blob(
        &hotel(),
        &StreamSettings {
            noise_m: 0.1,
            ..flown
        },
        None,
    )
    .unwrap_err();
    assert!(format!("{e:#}").contains("drop --noise-m"), "{e:#}");
}
