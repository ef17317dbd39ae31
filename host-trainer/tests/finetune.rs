//! Fine-tuning and training on your own amount of data (`gpecnet train --init`,
//! `--train-fraction`, `--data-scale auto`): a shipped blob goes back into the training model
//! as it was exported, a run started from it begins where the shipped model ends, the
//! architecture of the source is kept (a `--config` that changes it is refused, naming the
//! keys), a fraction of a split keeps whole tracks, the same for every seed, and a data scale
//! left to the data follows the documented rule.

use crate::common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use common::{run, s, temp_dir, weights};
use gpecnet_trainer::config::{data_scale_rule, TrainConfig};
use gpecnet_trainer::data::{self, track_fraction, DatasetSpec, Split};
use gpecnet_trainer::model::Model;
use gpecnet_trainer::rng::Rng;
use gpecnet_trainer::train::auto_data_scale;
use gpecnet_trainer::train::init::{apply_init, init_config, load_init, InitWeights};

fn dir(name: &str) -> PathBuf {
    let d = temp_dir(name);
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn train(out: &Path, extra: &[&str]) -> (bool, String) {
    run(&[&["train", "--quiet", "--out", s(out)], extra].concat())
}

/// Validation minFDE of each epoch of a run (metrics.jsonl).
fn val_min_fde(run: &Path) -> Vec<f64> {
    std::fs::read_to_string(run.join("metrics.jsonl"))
        .unwrap()
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            v["val"]["min_fde"].as_f64().unwrap()
        })
        .collect()
}

fn config_of(run: &Path) -> TrainConfig {
    TrainConfig::from_file(&run.join("config.toml")).unwrap()
}

#[test]
fn a_shipped_blob_goes_back_into_the_training_model_as_it_was_exported() {
    let blob = weights("sdd-m-lp.gpec");
    let src = load_init(&blob).unwrap();
    let cfg = init_config(&src, None).unwrap();
    assert_eq!(cfg.init.as_deref(), Some(s(&blob)));
    assert_eq!((cfg.data_scale, cfg.coord_scale), (49.0, 100.0));
    let InitWeights::Blob(nets) = &src.weights else {
        panic!("a blob loads as a blob");
    };
    let model = Model::new(&cfg, &mut Rng::new(1)).unwrap();
    apply_init(&model, &src).unwrap();
    let back = model.export_networks().unwrap();
    let pairs = [
        (&back.encoder_past, &nets.encoder_past),
        (&back.encoder_dest, &nets.encoder_dest),
        (&back.decoder, &nets.decoder),
        (&back.predictor, &nets.predictor),
        (&back.point_head, &nets.point_head),
    ];
    let mut compared = 0;
    for (a, b) in pairs {
        assert_eq!(a.len(), b.len());
        for (la, lb) in a.iter().zip(b.iter()) {
            assert_eq!(
                (la.in_dim, la.out_dim, la.act),
                (lb.in_dim, lb.out_dim, lb.act)
            );
            for (x, y) in la.w.iter().chain(&la.b).zip(lb.w.iter().chain(&lb.b)) {
                // Import divides by the scale that export multiplies by: one rounding each way.
                assert!((x - y).abs() <= 2.0 * f32::EPSILON * y.abs(), "{x} vs {y}");
                compared += 1;
            }
        }
    }
    assert!(compared > 15_000, "{compared} parameters compared");
}

#[test]
fn a_run_started_from_the_shipped_model_begins_where_it_ends() {
    let root = dir("finetune-begins");
    let (ft, scratch) = (root.join("ft"), root.join("scratch"));
    let blob = weights("sdd-m-lp.gpec");
    let common_args = [
        "--dataset",
        "eth_ucy:hotel",
        "--train-fraction",
        "0.1",
        "--epochs",
        "1",
        "--seed",
        "3",
    ];
    let (ok, text) = train(&ft, &[&["--init", s(&blob)], &common_args[..]].concat());
    assert!(ok, "{text}");
    assert!(text.contains("starting from"), "{text}");
    let cfg = config_of(&ft);
    assert_eq!(cfg.init.as_deref(), Some(s(&blob)));
    assert_eq!((cfg.data_scale, cfg.train_fraction), (49.0, 0.1));
    assert_eq!((cfg.dataset.as_str(), cfg.seed), ("eth_ucy:hotel", 3));
    let recipe = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/sdd-m-tiny.toml");
    let (ok, text) = train(
        &scratch,
        &[&["--config", s(&recipe)], &common_args[..]].concat(),
    );
    assert!(ok, "{text}");
    // One epoch on 10 % of the data: the fine-tuned model is already a walking-pedestrian
    // model, the fresh one is not.
    let (f, r) = (val_min_fde(&ft)[0], val_min_fde(&scratch)[0]);
    assert!(f < 0.7 * r, "fine-tuned {f} m vs from scratch {r} m");
    // A fine-tuning run resumes like any other (its own checkpoint, not the source).
    let (ok, text) = train(&ft, &["--resume", "--epochs", "2"]);
    assert!(ok, "{text}");
    assert_eq!(val_min_fde(&ft).len(), 2);
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn fine_tuning_keeps_the_source_architecture_and_refuses_what_it_cannot_start_from() {
    let root = dir("finetune-refusals");
    std::fs::create_dir_all(&root).unwrap();
    let blob = weights("sdd-m-lp.gpec");
    let out = root.join("run");
    // A --config that changes what the weights depend on is refused, naming the key.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(weights("sdd-m-lp.json")).unwrap()).unwrap();
    let toml = json["config_toml"]
        .as_str()
        .unwrap()
        .replace("dec_size = [48, 32]", "dec_size = [64, 32]");
    let cfg_path = root.join("wider.toml");
    std::fs::write(&cfg_path, toml).unwrap();
    let (ok, text) = train(
        &out,
        &[
            "--init",
            s(&blob),
            "--config",
            s(&cfg_path),
            "--dataset",
            "eth_ucy:hotel",
        ],
    );
    assert!(
        !ok && text.contains("dec_size: [48, 32] -> [64, 32]"),
        "{text}"
    );
    // The data scale of a fine-tuning run is its source's.
    let (ok, text) = train(
        &out,
        &[
            "--init",
            s(&blob),
            "--data-scale",
            "72",
            "--dataset",
            "eth_ucy:hotel",
        ],
    );
    assert!(
        !ok && text.contains("keeps the data scale of --init (49)"),
        "{text}"
    );
    // A fixed-point blob, and a blob without the training config beside it.
    let (ok, text) = train(&out, &["--init", s(&weights("sdd-m-lp-qe.gpec"))]);
    assert!(!ok && text.contains("fixed-point"), "{text}");
    let alone = root.join("alone.gpec");
    std::fs::copy(&blob, &alone).unwrap();
    let (ok, text) = train(&out, &["--init", s(&alone)]);
    assert!(
        !ok && text.contains("alone.json is missing") && text.contains("--config"),
        "{text}"
    );
    // With --config instead, the config must describe the blob (its data scale here).
    let other_scale = root.join("scale72.toml");
    std::fs::write(
        &other_scale,
        json["config_toml"]
            .as_str()
            .unwrap()
            .replace("data_scale = 49.0", "data_scale = 72.0"),
    )
    .unwrap();
    let (ok, text) = train(&out, &["--init", s(&alone), "--config", s(&other_scale)]);
    assert!(!ok && text.contains("data_scale: 72 / 49"), "{text}");
    // A folder that is no run, and --init on a resume.
    let (ok, text) = train(&out, &["--init", s(&root)]);
    assert!(!ok && text.contains("not a training run folder"), "{text}");
    let (ok, text) = train(&out, &["--resume", "--init", s(&blob)]);
    assert!(!ok && text.contains("--init"), "{text}");
    assert!(
        !out.join("config.toml").exists(),
        "a refused run writes nothing"
    );
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn a_fraction_of_a_split_keeps_whole_tracks_and_the_same_ones_every_time() {
    let spec = DatasetSpec::parse("eth_ucy:hotel").unwrap();
    let all = data::load(&data::default_data_root(), &spec, Split::Train, &[])
        .unwrap()
        .windows;
    let per_track = |ws: &[data::Window]| -> BTreeMap<(String, u64), usize> {
        let mut m = BTreeMap::new();
        for w in ws {
            *m.entry((w.scene.clone(), w.ped_id.to_bits())).or_insert(0) += 1;
        }
        m
    };
    let tracks = per_track(&all);
    let tenth = track_fraction(all.clone(), 0.1);
    let kept = per_track(&tenth);
    assert_eq!(kept.len(), (tracks.len() as f64 * 0.1).ceil() as usize);
    for (k, n) in &kept {
        assert_eq!(tracks[k], *n, "every window of a kept track is kept");
    }
    let scenes: BTreeSet<&str> = kept.keys().map(|(s, _)| s.as_str()).collect();
    assert!(
        scenes.len() >= 3,
        "a tenth spread over the scenes: {scenes:?}"
    );
    assert_eq!(track_fraction(all.clone(), 0.1).len(), tenth.len());
    let same: Vec<_> = track_fraction(all.clone(), 0.1)
        .iter()
        .map(|w| (w.scene.clone(), w.frames))
        .collect();
    let first: Vec<_> = tenth.iter().map(|w| (w.scene.clone(), w.frames)).collect();
    assert_eq!(same, first);
    assert_eq!(track_fraction(all.clone(), 1.0).len(), all.len());
    // Larger fractions keep what smaller ones keep.
    let half = per_track(&track_fraction(all, 0.5));
    assert!(kept.keys().all(|k| half.contains_key(k)));
}

#[test]
fn a_data_scale_left_to_the_data_follows_the_documented_rule() {
    // The rule gives the scales the shipped recipes were written with (docs/ethucy.md).
    let root = data::default_data_root();
    let sdd_m = TrainConfig {
        dataset: "sdd-m".into(),
        ..TrainConfig::default()
    };
    let (scale, span, n) = auto_data_scale(&sdd_m, &root).unwrap();
    assert!(
        (span - 7.84).abs() < 0.01,
        "sdd-m span {span} m over {n} windows"
    );
    assert_eq!(scale, 49.4);
    assert_eq!(data_scale_rule(208.2), Some(1.9));
    assert_eq!(data_scale_rule(0.0), None);
    assert_eq!(data_scale_rule(f64::NAN), None);
    // A config without the key leaves it to the data: the run computes it, says so, writes
    // the number, and resumes with that config as given.
    let out = dir("finetune-auto-scale");
    std::fs::create_dir_all(&out).unwrap();
    let recipe = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/sdd-m-tiny.toml"),
    )
    .unwrap();
    assert!(recipe.contains("data_scale = 49.0\n") && recipe.contains("dataset = \"sdd-m\"\n"));
    let cfg_path = out.join("auto.toml");
    std::fs::write(
        &cfg_path,
        recipe.replace("data_scale = 49.0\n", "").replace(
            "dataset = \"sdd-m\"\n",
            "dataset = \"eth_ucy:zara1\"\ntrain_fraction = 0.1\n",
        ),
    )
    .unwrap();
    let run_dir = out.join("run");
    let (ok, text) = train(&run_dir, &["--config", s(&cfg_path), "--epochs", "1"]);
    assert!(ok, "{text}");
    let tenth = TrainConfig {
        dataset: "eth_ucy:zara1".into(),
        train_fraction: 0.1,
        ..TrainConfig::default()
    };
    let (want, _, _) = auto_data_scale(&tenth, &root).unwrap();
    assert!((60.0..90.0).contains(&want), "ETH/UCY metres: {want}");
    assert_eq!(config_of(&run_dir).data_scale, want);
    assert!(
        text.contains(&format!("data_scale = {want} (computed")),
        "{text}"
    );
    let (ok, text) = train(
        &run_dir,
        &["--resume", "--config", s(&cfg_path), "--epochs", "2"],
    );
    assert!(ok, "{text}");
    let (ok, text) = train(&dir("finetune-bad-scale"), &["--data-scale=-1"]);
    assert!(
        !ok && text.contains("neither `auto` nor a finite number > 0"),
        "{text}"
    );
    let _ = std::fs::remove_dir_all(&out);
}
