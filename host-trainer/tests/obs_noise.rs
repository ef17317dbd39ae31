//! Training on noisy pasts (`obs_noise`, `gpecnet train --obs-noise`, `gpecnet propose
//! --obs-noise`): the noise lands on the observed positions only, every offset the networks
//! see is taken from the noisy observations, a noisy run is reproducible and resumes bit for
//! bit, and `obs_noise = 0` is the training without the option.
//!
//! That `obs_noise = 0` gives the very weights of the trainer before the option existed was
//! checked once across binaries (docs/camera.md, "Noise-aware training"); here the run with the
//! key written as 0 must equal the run without it, bit for bit, and write the same config.

use crate::common;

use std::path::{Path, PathBuf};

use common::{line_window, run, s, temp_dir, tiny_train_config};
use gpecnet_trainer::checkpoint;
use gpecnet_trainer::config::TrainConfig;
use gpecnet_trainer::data::{self, normalize, PAST};
use gpecnet_trainer::frame::canonical_window;
use gpecnet_trainer::proposal_file::{ProposalCard, ProposalFile};
use gpecnet_trainer::rng::Rng;
use gpecnet_trainer::train::{
    noisy_samples, prepare_data, train_new, train_resume, with_obs_noise, TrainOptions,
};

fn opts(dir: &Path, stop_after: Option<usize>) -> TrainOptions {
    TrainOptions {
        data_root: data::default_data_root(),
        run_dir: dir.to_path_buf(),
        epochs: Some(2),
        quiet: true,
        stop_after,
        force: false,
    }
}

/// The run's weights (wall-clock times aside, a checkpoint is its weights, optimiser, RNG
/// and history).
fn weights(dir: &Path) -> Vec<Vec<f32>> {
    checkpoint::load(dir).unwrap().weights
}

fn dir(name: &str) -> PathBuf {
    let d = temp_dir(name);
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn the_noise_lands_on_the_observed_positions_only() {
    let w = line_window("scene", 1.0, [3.0, -2.0], [0.5, 0.25]);
    let mut rng = Rng::with_stream(5, 9);
    let (mut sum, mut sum2, mut n) = (0.0f64, 0.0f64, 0usize);
    for _ in 0..2000 {
        let noisy = with_obs_noise(&w, 0.2, &mut rng);
        assert_eq!(noisy.pos[PAST..], w.pos[PAST..], "the future is left clean");
        assert_eq!((noisy.scene.as_str(), noisy.frames), ("scene", w.frames));
        assert_ne!(noisy.pos[..PAST], w.pos[..PAST]);
        for (a, b) in noisy.pos[..PAST].iter().zip(&w.pos[..PAST]) {
            for c in 0..2 {
                let d = f64::from(a[c] - b[c]);
                (sum, sum2, n) = (sum + d, sum2 + d * d, n + 1);
            }
        }
    }
    let mean = sum / n as f64;
    let std = (sum2 / n as f64 - mean * mean).sqrt();
    assert!(
        mean.abs() < 0.005 && (std - 0.2).abs() < 0.005,
        "{mean} {std}"
    );
}

#[test]
fn every_offset_is_taken_from_the_noisy_observations() {
    let windows = vec![
        line_window("a", 1.0, [3.0, -2.0], [0.5, 0.25]),
        line_window("b", 2.0, [-1.0, 4.0], [-0.3, 0.4]),
    ];
    for heading_steps in [0, 1] {
        let cfg = TrainConfig {
            obs_noise: 0.1,
            data_scale: 2.0,
            heading_steps,
            ..TrainConfig::default()
        };
        let samples = noisy_samples(&cfg, &windows, &mut Rng::with_stream(3, 4));
        // The same draws, window by window, then the frame and the normalisation of the
        // noisy window: the future relative to the noisy first point (and, with the heading
        // frame, turned by the noisy heading), as the core computes it at inference.
        let mut rng = Rng::with_stream(3, 4);
        for (w, got) in windows.iter().zip(&samples) {
            let noisy = with_obs_noise(w, 0.1, &mut rng);
            let framed = if heading_steps == 0 {
                noisy.clone()
            } else {
                canonical_window(&noisy, heading_steps).0
            };
            let want = normalize(&framed, 2.0);
            assert_eq!(got.obs, want.obs);
            assert_eq!(got.future, want.future);
            assert_eq!(got.initial_pos, want.initial_pos);
            let clean = normalize(w, 2.0);
            assert_ne!(
                got.future, clean.future,
                "offsets from the noisy observations"
            );
            if heading_steps == 0 {
                let p0 = noisy.pos[0];
                for (f, p) in got.future.iter().zip(&w.pos[PAST..]) {
                    assert_eq!(*f, [(p[0] - p0[0]) * 2.0, (p[1] - p0[1]) * 2.0]);
                }
            }
        }
    }
}

#[test]
fn obs_noise_is_checked_and_written_only_when_set() {
    let base = TrainConfig::default().to_toml_string().unwrap();
    assert!(!base.contains("obs_noise"), "{base}");
    let zero = TrainConfig::from_toml_str("obs_noise = 0\ndata_scale = 1.86").unwrap();
    assert_eq!(zero, TrainConfig::default());
    let c = TrainConfig::from_toml_str("obs_noise = 0.1").unwrap();
    assert!(c.to_toml_string().unwrap().contains("obs_noise = 0.1"));
    for bad in ["-0.1", "nan", "inf", "1001"] {
        let e = TrainConfig::from_toml_str(&format!("obs_noise = {bad}"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("obs_noise"), "{bad}: {e}");
    }
}

#[test]
fn obs_noise_zero_trains_as_without_the_option() {
    let without = dir("noise-without");
    train_new(tiny_train_config(), &opts(&without, None)).unwrap();
    let zero = dir("noise-zero");
    let cfg = TrainConfig::from_toml_str(&format!(
        "{}obs_noise = 0\n",
        tiny_train_config().to_toml_string().unwrap()
    ))
    .unwrap();
    train_new(cfg.clone(), &opts(&zero, None)).unwrap();
    assert_eq!(weights(&without), weights(&zero));
    let text = |d: &Path| std::fs::read_to_string(d.join("config.toml")).unwrap();
    assert_eq!(text(&without), text(&zero));
    // Without noise the loop keeps no second copy of the training windows.
    let data = prepare_data(&cfg, &data::default_data_root()).unwrap();
    assert!(data.train_windows.is_empty() && !data.train.is_empty());
    for d in [without, zero] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn a_noisy_run_is_reproducible_and_resumes_bit_exactly() {
    // SDD is in pixels: 2 px of noise.
    let cfg = TrainConfig {
        obs_noise: 2.0,
        ..tiny_train_config()
    };
    let straight = dir("noise-straight");
    train_new(cfg.clone(), &opts(&straight, None)).unwrap();
    let killed = dir("noise-killed");
    train_new(cfg.clone(), &opts(&killed, Some(1))).unwrap();
    train_resume(&opts(&killed, None)).unwrap();
    assert_eq!(weights(&straight), weights(&killed));
    let a = checkpoint::load(&straight).unwrap();
    let b = checkpoint::load(&killed).unwrap();
    assert_eq!(a.adam, b.adam);
    assert_eq!(a.rng, b.rng);
    let clean = dir("noise-clean");
    train_new(tiny_train_config(), &opts(&clean, None)).unwrap();
    assert_ne!(
        weights(&straight),
        weights(&clean),
        "the noise changes training"
    );
    let toml = std::fs::read_to_string(straight.join("config.toml")).unwrap();
    assert!(toml.contains("obs_noise = 2.0"), "{toml}");
    for d in [straight, killed, clean] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn propose_records_its_noise_and_refuses_to_mix_noise_levels() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let blob = root.join("weights/sdd-m-tiny.gpec");
    let d = temp_dir("propose-noise");
    let out = d.join("run");
    let args = |noise: &'static str| {
        vec![
            "propose".to_string(),
            "--blob".into(),
            s(&blob).into(),
            "--dataset".into(),
            "sdd-m".into(),
            "--epochs".into(),
            "1".into(),
            "--hidden".into(),
            "8".into(),
            "--obs-noise".into(),
            noise.into(),
            "--out".into(),
            s(&out).into(),
        ]
    };
    let call = |a: Vec<String>| run(&a.iter().map(String::as_str).collect::<Vec<_>>());
    let (ok, text) = call(args("0.1"));
    assert!(ok, "{text}");
    let p = ProposalFile::read(&out.join("proposal.json")).unwrap();
    assert_eq!(p.settings.obs_noise, 0.1);
    let card = ProposalCard::of(&p, &out.join("proposal.json"));
    assert!(
        card.command.contains(" --obs-noise 0.1 "),
        "{}",
        card.command
    );
    let mut resume = args("0.05");
    resume.push("--resume".into());
    let (ok, text) = call(resume);
    assert!(!ok && text.contains("other settings"), "{text}");
    let (ok, text) = call(args("nan"));
    assert!(!ok && text.contains("--obs-noise"), "{text}");
    let _ = std::fs::remove_dir_all(d);
}
