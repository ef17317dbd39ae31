//! `gpecnet eval` computes each window once and reads each data file once: the one-pass
//! evaluation of a model with endpoint probabilities gives exactly the bits of the three
//! separate passes (samples, point forecasts, planner outputs), for any K; and with no
//! options it evaluates the shipped default model on its own data set.

use std::path::{Path, PathBuf};

use crate::common::{run, s};

use gpecnet_trainer::blob_eval::own_dataset;
use gpecnet_trainer::core_eval::{
    evaluate_core, evaluate_point_core, forecasts_core, planner_core,
};
use gpecnet_trainer::data::{default_data_root, Dataset, DatasetSpec};
use gpecnet_trainer::reference::SineKind;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn weights(name: &str) -> PathBuf {
    repo().join("weights").join(format!("{name}.gpec"))
}

/// Every 7th SDD-in-metres test window (about 400): enough for every code path.
fn some_test_windows() -> Dataset {
    let mut test =
        gpecnet_trainer::card::test_windows(&default_data_root(), &DatasetSpec::SddMetres).unwrap();
    test.windows = test.windows.into_iter().step_by(7).collect();
    test
}

#[test]
fn one_pass_equals_the_three_passes_bit_for_bit() {
    let test = some_test_windows();
    for (name, sine) in [
        ("sdd-m-lp-qe", SineKind::Libm),
        ("sdd-m-lp", SineKind::Libm),
        ("sdd-m-lp", SineKind::Fast),
    ] {
        let blob = std::fs::read(weights(name)).unwrap();
        for (k, seed) in [(20, 0), (7, 3)] {
            let f = forecasts_core(&blob, sine, &test, k, seed)
                .unwrap()
                .unwrap_or_else(|| panic!("{name} has endpoint probabilities"));
            let (_, samples) = evaluate_core(&blob, sine, &test, k, seed).unwrap();
            assert!(f.samples == samples, "{name} K = {k}: samples");
            let points = evaluate_point_core(&blob, sine, &test)
                .unwrap()
                .map(|p| p.1);
            assert!(f.points == points, "{name}: point forecasts");
            let planner = planner_core(&blob, sine, &test, seed).unwrap().unwrap();
            assert!(f.planner == planner, "{name} seed {seed}: planner outputs");
        }
    }
    // A model without probabilities is left to the separate passes.
    let blob = std::fs::read(weights("sdd-m-tiny-qe")).unwrap();
    assert!(forecasts_core(&blob, SineKind::Libm, &test, 20, 0)
        .unwrap()
        .is_none());
}

#[test]
fn the_blobs_own_data_set_is_its_cards_else_what_the_blob_records() {
    for (name, want) in [
        ("sdd-m-lp-qe", "sdd-m"),
        ("ethucy-zara1-qe", "eth_ucy:zara1"),
        ("sdd-small", "sdd"),
    ] {
        let want = DatasetSpec::parse(want).unwrap();
        assert_eq!(
            own_dataset(&weights(name)).unwrap(),
            want,
            "{name} with its card"
        );
        // Without its card: the blob's unit and recorded training data.
        let tmp = tempfile::tempdir().unwrap();
        let copy = tmp.path().join(format!("{name}.gpec"));
        std::fs::copy(weights(name), &copy).unwrap();
        assert_eq!(own_dataset(&copy).unwrap(), want, "{name} without its card");
    }
}

#[test]
fn eval_with_no_options_is_the_default_model_on_its_own_data_set() {
    let data = default_data_root();
    let (ok, text) = {
        let o = crate::common::gpecnet()
            .current_dir(repo())
            .args(["eval", "--data", s(&data)])
            .output()
            .unwrap();
        (
            o.status.success(),
            format!(
                "{}{}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            ),
        )
    };
    assert!(ok, "{text}");
    assert!(
        text.starts_with("model sdd-m-lp-qe on the sdd-m test set (2829 windows)"),
        "{text}"
    );
    assert!(text.contains("model card: reproduced exactly"), "{text}");
    // The default data set is the blob's, so a pixel model is evaluated in pixels.
    let (ok, text) = run(&[
        "eval",
        "--blob",
        s(&weights("sdd-tiny-v2-qe")),
        "--data",
        s(&data),
        "--json",
    ]);
    assert!(ok, "{text}");
    let j: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(j["dataset"], "sdd", "{text}");
    // Speeds are grouped in metres only: a pixel set has no per-speed rows.
    assert_eq!(j["speeds"].as_array().map(Vec::len), Some(0), "{text}");
}

/// `gpecnet eval --json` on a metre set: the per-speed rows partition the test windows, their
/// window-weighted best-of-K FDE is the overall one (a pixel set has none: checked above).
#[test]
fn eval_reports_per_observed_speed_rows_that_partition_the_windows() {
    let j = zara1_eval_json();
    let rows = j["speeds"].as_array().unwrap();
    assert!(rows.len() >= 3, "{rows:?}");
    assert!(rows[0]["scene"].as_str().unwrap().starts_with("standing"));
    let n: u64 = rows.iter().map(|r| r["n"].as_u64().unwrap()).sum();
    assert_eq!(n, j["n"].as_u64().unwrap());
    let weighted: f64 = rows
        .iter()
        .map(|r| r["n"].as_f64().unwrap() * r["min_fde"].as_f64().unwrap())
        .sum::<f64>()
        / n as f64;
    let all = j["min_fde"].as_f64().unwrap();
    assert!(
        (weighted - all).abs() < 1e-9 * all.max(1.0),
        "{weighted} vs {all}"
    );
}

/// Starters and stoppers (`motion_change`) on windows built for each case, and `gpecnet eval
/// --json`'s `changes` rows on a metre set: they partition the windows, and the starters of
/// ZARA1 are counted by the same rule here.
#[test]
fn eval_reports_starters_and_stoppers() {
    use gpecnet_trainer::data::{motion_change, DatasetSpec, Split, Window, PAST, WINDOW};
    let window = |pos: &dyn Fn(usize) -> [f32; 2]| Window {
        scene: "s".into(),
        ped_id: 1.0,
        frames: std::array::from_fn(|i| i as i64 * 10),
        pos: std::array::from_fn(pos),
    };
    // Standing for 2.8 s, then walking 1.2 m/s: a starter.
    let starter = window(&|i| {
        [
            if i < PAST {
                0.0
            } else {
                0.48 * (i - PAST + 1) as f32
            },
            0.0,
        ]
    });
    // Walking 1.2 m/s, then standing for the last 1.6 s: a stopper.
    let stopper = window(&|i| [0.48 * i.min(WINDOW - 5) as f32, 0.0]);
    // Walking throughout, and standing throughout: neither.
    let walker = window(&|i| [0.48 * i as f32, 0.0]);
    let still = window(&|_| [3.0, -2.0]);
    assert_eq!(
        [&starter, &stopper, &walker, &still].map(motion_change),
        [0, 1, 2, 2]
    );
    let data = default_data_root();
    let j = zara1_eval_json();
    let rows = j["changes"].as_array().unwrap();
    let n: u64 = rows.iter().map(|r| r["n"].as_u64().unwrap()).sum();
    assert_eq!(n, j["n"].as_u64().unwrap());
    let test = gpecnet_trainer::data::load(
        &data,
        &DatasetSpec::parse("eth_ucy:zara1").unwrap(),
        Split::Test,
        &[],
    )
    .unwrap();
    let starters = test
        .windows
        .iter()
        .filter(|w| motion_change(w) == 0)
        .count() as u64;
    assert!(starters > 10, "ZARA1 has starters: {starters}");
    let row = rows.iter().find(|r| r["scene"] == "starters").unwrap();
    assert_eq!(row["n"].as_u64(), Some(starters));
    // Starting from standstill is the hard case: worse than the rest at best-of-20.
    let rest = rows.iter().find(|r| r["scene"] == "neither").unwrap();
    assert!(row["min_fde"].as_f64() > rest["min_fde"].as_f64());
}

/// `gpecnet eval --json` of the shipped default on ZARA1's test windows.
fn zara1_eval_json() -> serde_json::Value {
    let (ok, text) = run(&[
        "eval",
        "--blob",
        s(&weights("sdd-m-lp-qe")),
        "--dataset",
        "eth_ucy:zara1",
        "--data",
        s(&default_data_root()),
        "--json",
    ]);
    assert!(ok, "{text}");
    serde_json::from_str(&text).unwrap()
}
