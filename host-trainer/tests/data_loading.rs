//! Data loading on the real benchmark files (shared/data): counts, windows, splits,
//! normalisation. Malformed files are `data_errors.rs`.

use crate::common;

use std::fs;
use std::path::PathBuf;

use gpecnet_trainer::data::*;

fn root() -> PathBuf {
    let r = default_data_root();
    assert!(
        r.join("README.md").is_file(),
        "benchmark data not found at {}",
        r.display()
    );
    r
}

#[test]
fn sdd_train_counts() {
    let ds = load_sdd(&root(), SddSplit::Train).unwrap();
    assert_eq!(ds.unit, Unit::Pixels);
    assert_eq!(ds.name, "sdd/train");
    assert_eq!(ds.len(), 8494);
    let per = ds.windows_per_scene();
    assert_eq!(per.len(), 30);
    assert_eq!(per["bookstore_0"], 805);
    assert_eq!(per["hyang_9"], 1);
    assert_eq!(per["nexus_9"], 326);
    // Sorted file-name order.
    let scenes = ds.scenes();
    assert_eq!(scenes.len(), 30);
    let mut sorted = scenes.clone();
    sorted.sort();
    assert_eq!(scenes, sorted);
    assert_eq!(scenes[0], "bookstore_0");
}

#[test]
fn sdd_test_and_extra_counts() {
    let ds = load_sdd(&root(), SddSplit::Test).unwrap();
    assert_eq!(ds.len(), 2829);
    assert_eq!(ds.scenes().len(), 17);
    assert_eq!(ds.windows_per_scene()["hyang_0"], 630);
    let extra = load_sdd(&root(), SddSplit::TrainExtra).unwrap();
    assert_eq!(extra.len(), 491);
    assert_eq!(extra.scenes(), vec!["nexus_2".to_string()]);
}

#[test]
fn sdd_first_window_equals_first_20_lines() {
    let r = root();
    let text = fs::read_to_string(r.join("sdd/train/bookstore_0.txt")).unwrap();
    let ds = load_sdd(&r, SddSplit::Train).unwrap();
    let w = &ds.windows[0];
    assert_eq!(w.scene, "bookstore_0");
    assert_eq!(w.ped_id, 100.0);
    for (t, line) in text.lines().take(WINDOW).enumerate() {
        let c: Vec<&str> = line.split(' ').collect();
        assert_eq!(w.frames[t], c[0].parse::<i64>().unwrap());
        assert_eq!(w.ped_id, c[1].parse::<f64>().unwrap());
        assert_eq!(w.pos[t][0], c[2].parse::<f32>().unwrap());
        assert_eq!(w.pos[t][1], c[3].parse::<f32>().unwrap());
    }
    assert_eq!(w.frames[0], 0);
    assert_eq!(w.pos[0], [757.0, 918.5]);
    assert_eq!(w.frames[19], 228);
    assert_eq!(w.endpoint(), w.pos[19]);
    assert_eq!(w.obs()[..], w.pos[..PAST]);
    assert_eq!(w.future()[..], w.pos[PAST..]);
}

/// The whole test split equals Y-Net's `test_trajnet.csv`, row for row and in order.
#[test]
fn sdd_test_matches_ynet_csv() {
    let r = root();
    let ds = load_sdd(&r, SddSplit::Test).unwrap();
    let csv = fs::read_to_string(r.join("sdd/ynet/test_trajnet.csv")).unwrap();
    let mut n = 0usize;
    for (i, line) in csv.lines().skip(1).enumerate() {
        let c: Vec<&str> = line.split(',').collect();
        let meta: usize = c[5].parse().unwrap();
        assert_eq!(meta, i / WINDOW);
        let w = &ds.windows[meta];
        let t = i % WINDOW;
        assert_eq!(w.scene, c[4]);
        assert_eq!(w.ped_id, c[1].parse::<f64>().unwrap());
        assert_eq!(w.frames[t], c[0].parse::<i64>().unwrap());
        assert_eq!(w.pos[t][0], c[2].parse::<f32>().unwrap(), "row {i}");
        assert_eq!(w.pos[t][1], c[3].parse::<f32>().unwrap(), "row {i}");
        n += 1;
    }
    assert_eq!(n, 56_580);
}

#[test]
fn eth_ucy_counts() {
    let r = root();
    let cases = [
        ("eth", EthUcySplit::Test, 181),
        ("zara1", EthUcySplit::Test, 2253),
        ("hotel", EthUcySplit::Test, 1053),
        ("zara2", EthUcySplit::Test, 5833),
        ("univ", EthUcySplit::Test, 24334),
        ("eth", EthUcySplit::Train, 29809),
        ("zara1", EthUcySplit::Val, 5118),
    ];
    for (scene, split, n) in cases {
        let ds = load_eth_ucy(&r, scene, split).unwrap();
        assert_eq!(ds.unit, Unit::Metres);
        assert_eq!(ds.len(), n, "{scene} {split:?}");
    }
}

#[test]
fn eth_ucy_windows_are_consistent() {
    let ds = load_eth_ucy(&root(), "eth", EthUcySplit::Test).unwrap();
    assert_eq!(ds.scenes(), vec!["biwi_eth".to_string()]);
    for w in &ds.windows {
        for t in 1..WINDOW {
            assert!(w.frames[t] > w.frames[t - 1]);
        }
        assert!(w.pos.iter().flatten().all(|v| v.is_finite()));
    }
}

#[test]
fn eth_ucy_sliding_window_rule_on_small_file() {
    // Three peds: 1 and 2 present in frames 0..=20 (21 unique frames -> 2 windows), ped 3 only
    // in frames 0..=18 (never complete). A lone ped 4 in frames 100..=119 alone -> dropped.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("eth_ucy/eth/test");
    fs::create_dir_all(&d).unwrap();
    let mut s = String::new();
    for f in 0..=20 {
        for p in 1..=3 {
            if p == 3 && f > 18 {
                continue;
            }
            s.push_str(&format!("{}\t{p}.0\t{}.5\t{}\n", f * 10, f, p));
        }
    }
    for f in 21..41 {
        s.push_str(&format!("{}\t4.0\t1.0\t1.0\n", f * 10));
    }
    fs::write(d.join("a.txt"), s).unwrap();
    let ds = load_eth_ucy(dir.path(), "eth", EthUcySplit::Test).unwrap();
    // windows start at unique-frame index 0 and 1 (peds 1,2), later starts lack two peds.
    assert_eq!(ds.len(), 4);
    assert_eq!(ds.windows[0].ped_id, 1.0);
    assert_eq!(ds.windows[1].ped_id, 2.0);
    assert_eq!(ds.windows[2].frames[0], 10);
    assert_eq!(ds.windows[2].pos[0], [1.5, 1.0]);
}

#[test]
fn val_split_by_scene() {
    let ds = load_sdd(&root(), SddSplit::Train).unwrap();
    let val_scenes = default_sdd_val_scenes();
    assert_eq!(val_scenes.len(), 5);
    let (train, val) = split_by_scene(ds, &val_scenes);
    assert_eq!(val.len(), 846);
    assert_eq!(train.len(), 8494 - 846);
    let frac = val.len() as f64 / 8494.0;
    assert!((0.09..0.11).contains(&frac), "{frac}");
    assert_eq!(val.scenes().len(), 5);
    assert_eq!(train.scenes().len(), 25);
    assert!(train.windows.iter().all(|w| !val_scenes.contains(&w.scene)));
    assert!(val.windows.iter().all(|w| val_scenes.contains(&w.scene)));
}

fn hand_window() -> Window {
    common::line_window("hand", 7.0, [100.0, 50.0], [2.0, -1.0])
}

#[test]
fn normalize_hand_computed() {
    let w = hand_window();
    let s = normalize(&w, 1.86);
    assert_eq!(s.obs[0], [0.0, 0.0]);
    assert_eq!(s.obs[1], [2.0f32 * 1.86, -1.86]);
    assert!((s.obs[7][0] - 26.04).abs() < 1e-5);
    assert!((s.obs[7][1] + 13.02).abs() < 1e-5);
    assert!((s.future[11][0] - 70.68).abs() < 1e-4); // (138-100)*1.86
    assert!((s.future[11][1] + 35.34).abs() < 1e-4); // (31-50)*1.86
    assert_eq!(s.initial_pos, [114.0 / 1000.0, 43.0 / 1000.0]);
    // Exact f32 op order: (p - p0) * scale; future[3] is step 11, x = 100 + 22.
    assert_eq!(s.future[3][0], (122.0f32 - 100.0f32) * 1.86f32);
    // Round trip.
    let back = denormalize_point(s.future[11], w.pos[0], 1.86);
    assert!((back[0] - 138.0).abs() < 1e-4 && (back[1] - 31.0).abs() < 1e-4);
}

#[test]
fn time_reversal() {
    let w = hand_window();
    let r = time_reversed(&w);
    assert_eq!(r.pos[0], w.pos[19]);
    assert_eq!(r.frames[19], w.frames[0]);
    assert_ne!(r, w);
    assert_eq!(time_reversed(&r), w);
    let ds = Dataset {
        name: "x".into(),
        unit: Unit::Pixels,
        windows: vec![w.clone()],
    }
    .with_time_reversed();
    assert_eq!(ds.windows, vec![w, r]);
}

#[test]
fn default_root_exists() {
    assert!(default_data_root().join("sdd/train").is_dir());
}

/// SDD in metres: the same windows as `sdd`, each scene times its factor, and constant velocity
/// (linear in the positions) gives the pixel errors times each scene's factor.
#[test]
fn sdd_in_metres_is_sdd_times_the_scene_scale() {
    let r = root();
    let val = default_sdd_val_scenes();
    let scales = sdd_metres_per_pixel(&r).unwrap();
    for split in [Split::Train, Split::Val, Split::Test] {
        let px = load(&r, &DatasetSpec::Sdd, split, &val).unwrap();
        let m = load(&r, &DatasetSpec::SddMetres, split, &val).unwrap();
        assert_eq!((px.unit, m.unit), (Unit::Pixels, Unit::Metres));
        assert_eq!(px.len(), m.len());
        for (a, b) in px.windows.iter().zip(&m.windows) {
            let s = scales[&a.scene] as f32;
            assert_eq!(a.scene, b.scene);
            for (p, q) in a.pos.iter().zip(&b.pos) {
                assert_eq!([p[0] * s, p[1] * s], *q);
            }
        }
    }
    let test_px = load(&r, &DatasetSpec::Sdd, Split::Test, &[]).unwrap();
    let test_m = load(&r, &DatasetSpec::SddMetres, Split::Test, &[]).unwrap();
    let cv = |w: &Window| gpecnet_trainer::baseline::constant_velocity_n(w, 2);
    let mut acc = gpecnet_trainer::eval::MetricsAccumulator::new();
    for w in &test_px.windows {
        let p = gpecnet_trainer::eval::Prediction {
            trajectories: vec![cv(w)],
        };
        acc.add_scaled(w, &p, scales[&w.scene] as f32 as f64)
            .unwrap();
    }
    let via_px = acc.finish();
    let direct = gpecnet_trainer::baseline::evaluate_baseline_with(&test_m, cv);
    assert!((via_px.fde_k1 - direct.fde_k1).abs() < 1e-5 * direct.fde_k1);
    assert!((via_px.ade_k1 - direct.ade_k1).abs() < 1e-5 * direct.ade_k1);
    // A scene without a factor is an error naming it, never a pixel window in a metre set.
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir_all(dir.path().join("sdd/test")).unwrap();
    fs::create_dir_all(dir.path().join("sdd/scales")).unwrap();
    fs::write(
        dir.path().join("sdd/test/nowhere_0.txt"),
        common::good_rows("1", 0).join("\n"),
    )
    .unwrap();
    fs::write(
        dir.path().join("sdd/scales/sdd_meters_per_pixel.csv"),
        "scene,meters_per_pixel\ngates_0,0.04\n",
    )
    .unwrap();
    let e = load(dir.path(), &DatasetSpec::SddMetres, Split::Test, &[]).unwrap_err();
    assert!(e.to_string().contains("nowhere_0"), "{e}");
}

/// Writes a data-set folder: `dataset.toml` and one file per split with `tracks` (frame, id,
/// x, y rows).
fn folder(toml: &str, rows: &[String]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("dataset.toml"), toml).unwrap();
    for split in ["train", "val", "test"] {
        fs::create_dir_all(dir.path().join(split)).unwrap();
        fs::write(
            dir.path().join(split).join("flight_01.txt"),
            rows.join("\n"),
        )
        .unwrap();
    }
    dir
}

/// One pedestrian walking 1.2 m/s along x, sampled at `hz` for `seconds`, starting at frame
/// `f0`, frames numbered at that rate.
fn track(id: u32, hz: f64, seconds: f64, f0: i64) -> Vec<String> {
    let n = (seconds * hz).round() as i64;
    (0..n)
        .map(|i| {
            let t = i as f64 / hz;
            format!("{} {id} {:.4} {:.4}", f0 + i, 1.2 * t, 0.5 + 0.1 * t)
        })
        .collect()
}

#[test]
fn own_data_folder_is_windowed_on_the_model_clock() {
    // 10 Hz, 20 s of one walker: 0.4 s = 4 frames; windows start every 4 frames while 20
    // steps (76 frames) remain: frames 0, 4, ..., 196 - 76 = 120 -> 31 windows.
    let rows = track(7, 10.0, 20.0, 0);
    let dir = folder(
        "unit = \"m\"\nseconds_per_frame = 0.1\nlicence = \"CC0\"\n",
        &rows,
    );
    let spec = DatasetSpec::parse(&format!("{}/", dir.path().display())).unwrap();
    assert_eq!(spec.unit(), Unit::Metres);
    assert_eq!(spec.licence(), "CC0");
    let ds = load(&r_none(), &spec, Split::Train, &[]).unwrap();
    assert_eq!(ds.len(), 31);
    let w = &ds.windows[1];
    assert_eq!(w.frames[0], 4);
    assert_eq!(w.frames[19], 4 + 19 * 4);
    // Position at frame f is 1.2 * f / 10 m.
    assert!((w.pos[19][0] - 1.2 * 8.0).abs() < 1e-4, "{:?}", w.pos[19]);
    // A dropped row within max_gap_s (default 1 s) is interpolated: the walker is straight,
    // so the windows are the same.
    let mut gappy = rows.clone();
    gappy.remove(40);
    let dir = folder("unit = \"m\"\nseconds_per_frame = 0.1\n", &gappy);
    let spec = DatasetSpec::parse(&format!("{}/", dir.path().display())).unwrap();
    let ds = load(&r_none(), &spec, Split::Test, &[]).unwrap();
    assert_eq!(ds.len(), 31);
    assert!((ds.windows[10].pos[0][0] - 1.2 * 4.0).abs() < 1e-4);
    // With max_gap_s of one frame it ends the track: the windows that need frame 40 are
    // gone, and only those (the track resumes on its grid at frame 44).
    let dir = folder(
        "unit = \"m\"\nseconds_per_frame = 0.1\nmax_gap_s = 0.1\n",
        &gappy,
    );
    let spec = DatasetSpec::parse(&format!("{}/", dir.path().display())).unwrap();
    let ds = load(&r_none(), &spec, Split::Test, &[]).unwrap();
    assert_eq!(ds.len(), 31 - 11);
    assert_eq!(ds.windows[0].frames[0], 44);
    // A pixel folder with per-file scales is converted to metres.
    let dir = folder(
        "unit = \"px\"\nseconds_per_frame = 0.4\n[metres_per_pixel]\nflight_01 = 0.05\n",
        &track(3, 2.5, 10.0, 100),
    );
    let spec = DatasetSpec::parse(&format!("{}/", dir.path().display())).unwrap();
    assert_eq!(spec.unit(), Unit::Metres);
    let ds = load(&r_none(), &spec, Split::Val, &[]).unwrap();
    assert_eq!(ds.len(), 25 - 19);
    assert!((ds.windows[0].pos[1][0] - 1.2 * 0.4 * 0.05).abs() < 1e-6);
}

#[test]
fn own_data_folder_errors_are_clear() {
    let rows = track(1, 10.0, 10.0, 0);
    let parse = |toml: &str| {
        let dir = folder(toml, &rows);
        DatasetSpec::parse(&format!("{}/", dir.path().display())).map(|_| ())
    };
    // Any clock up to 3.2 s per frame is resampled; a slower one is refused, naming the key
    // and its line.
    assert!(parse("unit = \"m\"\nseconds_per_frame = 0.3\n").is_ok());
    let e = parse("unit = \"m\"\nseconds_per_frame = 5\n").unwrap_err();
    assert!(
        e.contains("dataset.toml:2: seconds_per_frame") && e.contains("3.2"),
        "{e}"
    );
    assert!(parse("unit = \"ft\"\nseconds_per_frame = 0.1\n")
        .unwrap_err()
        .contains("unit"));
    assert!(parse("unit = \"m\"\n")
        .unwrap_err()
        .contains("seconds_per_frame"));
    assert!(parse("unit = \"m\"\nseconds_per_frame = 0.1\ncolour = 1\n").is_err());
    assert!(
        parse("unit = \"m\"\nseconds_per_frame = 0.1\n[metres_per_pixel]\na = 1.0\n")
            .unwrap_err()
            .contains("pixel")
    );
    let none = tempfile::tempdir().unwrap();
    let e = DatasetSpec::parse(&format!("{}/", none.path().display())).unwrap_err();
    assert!(e.contains("dataset.toml"), "{e}");
    // A duplicate frame of one id names the file and line.
    let mut dup = rows.clone();
    dup.push(rows[5].clone());
    let dir = folder("unit = \"m\"\nseconds_per_frame = 0.1\n", &dup);
    let spec = DatasetSpec::parse(&format!("{}/", dir.path().display())).unwrap();
    let e = load(&r_none(), &spec, Split::Train, &[])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("flight_01.txt") && e.contains(&format!("{}", dup.len())),
        "{e}"
    );
    // A pixel file of a converted set without its factor.
    let dir = folder(
        "unit = \"px\"\nseconds_per_frame = 0.1\n[metres_per_pixel]\nother = 0.05\n",
        &rows,
    );
    let spec = DatasetSpec::parse(&format!("{}/", dir.path().display())).unwrap();
    let e = load(&r_none(), &spec, Split::Train, &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("flight_01"), "{e}");
    // Combined sets must share a unit.
    let dir = folder("unit = \"px\"\nseconds_per_frame = 0.1\n", &rows);
    let e = DatasetSpec::parse(&format!("sdd-m+{}/", dir.path().display())).unwrap_err();
    assert!(e.contains("one unit"), "{e}");
    let both = DatasetSpec::parse(&format!("sdd+{}/", dir.path().display())).unwrap();
    assert_eq!(both.unit(), Unit::Pixels);
}

/// A data root that holds nothing (folder data sets do not read it).
fn r_none() -> PathBuf {
    PathBuf::from("/nonexistent-data-root")
}

/// An ETH/UCY-style file on another clock (a 10 Hz log: frames 1 apart) is refused, naming
/// the file, the line and the step, instead of training at 0.1 s per step.
#[test]
fn eth_ucy_file_on_another_clock_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("eth_ucy/eth/test");
    fs::create_dir_all(&d).unwrap();
    let s: String = (0..40)
        .map(|f| format!("{f}\t1.0\t{}.0\t0.0\n{f}\t2.0\t{}.0\t1.0\n", f, f))
        .collect();
    fs::write(d.join("tenhz.txt"), s).unwrap();
    let e = load_eth_ucy(dir.path(), "eth", EthUcySplit::Test).unwrap_err();
    let msg = e.to_string();
    assert!(
        matches!(
            e,
            DataError::FrameStep {
                found: 1,
                expected: 10,
                ..
            }
        ),
        "{msg}"
    );
    assert!(msg.contains("tenhz.txt:3"), "{msg}");
}

#[test]
fn validation_read_by_scene_is_the_training_split_cut_by_scene() {
    // Validation reads only its scenes' files; the windows, their order and the set's name
    // are those of the whole training split cut by scene, in pixels and in metres.
    let r = root();
    let val_scenes = default_sdd_val_scenes();
    let (_, cut) = split_by_scene(load_sdd(&r, SddSplit::Train).unwrap(), &val_scenes);
    let val = load(&r, &DatasetSpec::Sdd, Split::Val, &val_scenes).unwrap();
    assert_eq!(val.name, cut.name);
    assert_eq!(val.len(), 846);
    assert_eq!(val.windows, cut.windows);
    let metres = load(&r, &DatasetSpec::SddMetres, Split::Val, &val_scenes).unwrap();
    let converted = sdd_in_metres(&r, cut).unwrap();
    assert_eq!(metres.name, converted.name);
    assert!(metres
        .windows
        .iter()
        .zip(&converted.windows)
        .all(|(a, b)| a.scene == b.scene
            && a.frames == b.frames
            && a.pos.iter().flatten().map(|v| v.to_bits()).eq(b
                .pos
                .iter()
                .flatten()
                .map(|v| v.to_bits()))));
    assert_eq!(metres.len(), converted.len());
}
