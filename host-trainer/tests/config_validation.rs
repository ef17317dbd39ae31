//! Config values are range-checked when the config is loaded, before any work:
//! each error names the key and the allowed range, the exit status is not 0 and the run
//! folder is not even created.

use crate::common;

use common::*;
use gpecnet_trainer::config::TrainConfig;

/// (`key = value` lines set over the tiny config, expected words in the error).
const BAD: &[(&str, &[&str])] = &[
    ("k = 1000000", &["k = 1000000", "1..=1024"]),
    ("k = 0", &["k = 0", "1..=1024"]),
    ("num_epochs = 0", &["num_epochs = 0", "1..="]),
    ("batch_size = 0", &["batch_size = 0", "1..="]),
    ("learning_rate = inf", &["learning_rate = inf", "(0, 1]"]),
    ("learning_rate = nan", &["learning_rate = NaN", "(0, 1]"]),
    ("data_scale = inf", &["data_scale = inf", "> 0"]),
    (
        "activation = \"linear\"",
        &["activation = \"linear\"", "\"sine\" or \"relu\""],
    ),
    ("data_scale = 0.0", &["data_scale = 0", "> 0"]),
    (
        "data_scale = \"big\"",
        &["data_scale = \"big\"", "\"auto\""],
    ),
    ("sigma = inf", &["sigma = inf", ">= 0"]),
    ("sigma = -1.0", &["sigma = -1", ">= 0"]),
    ("w0 = 0.0", &["w0 = 0", "> 0"]),
    ("kld_reg = nan", &["kld_reg = NaN", ">= 0"]),
    ("dec_size = []", &["dec_size", "1..=7"]),
    ("dec_size = [8, 0]", &["dec_size", "width 0", "1..=4096"]),
    (
        "dec_size = [8, 8, 8, 8, 8, 8, 8, 8]",
        &["dec_size has 8 hidden layers", "1..=7"],
    ),
    ("fdim = 0", &["fdim = 0", "1..=4096"]),
    ("zdim = 100000", &["zdim = 100000", "1..=4096"]),
    ("threads = 100000", &["threads = 100000", "0..=1024"]),
    (
        "dec_size = [4096]\nk = 1024",
        &["k = 1024", "4096 wide", "1..=512"],
    ),
];

/// The tiny config with `lines` (`key = value` lines) set over it: every line of the tiny
/// config that sets one of their keys is dropped, and `lines` appended.
fn config_with(lines: &str) -> String {
    let key = |l: &str| l.split('=').next().unwrap_or_default().trim().to_string();
    let keys: Vec<String> = lines.lines().map(key).collect();
    let mut s: String = tiny_config("")
        .lines()
        .filter(|l| !keys.contains(&key(l)))
        .map(|l| format!("{l}\n"))
        .collect();
    s.push_str(lines);
    s.push('\n');
    s
}

#[test]
fn out_of_range_values_are_rejected_at_load_time() {
    for (to, words) in BAD {
        let text = config_with(to);
        let e = match TrainConfig::from_toml_str(&text) {
            Ok(_) => panic!("accepted {to:?}"),
            Err(e) => format!("{e:#}"),
        };
        for w in *words {
            assert!(e.contains(w), "{to:?}: {e:?} lacks {w:?}");
        }
    }
    // The boundaries themselves are fine.
    for ok in ["k = 1024", "sigma = 0.0", "num_epochs = 1"].map(config_with) {
        TrainConfig::from_toml_str(&ok).unwrap();
    }
}

#[test]
fn the_binary_refuses_before_any_work() {
    let run = TinyRun::new("cfg");
    for (i, (to, words)) in BAD.iter().enumerate().take(12) {
        let cfg = run.dir.join(format!("bad{i}.toml"));
        std::fs::write(&cfg, config_with(to)).unwrap();
        let out = run.dir.join(format!("run{i}"));
        let (ok, text) = train(&run.dir, &out, &["--config", cfg.to_str().unwrap()]);
        assert!(!ok, "{to:?} accepted: {text}");
        assert!(text.contains(words[0]), "{to:?}: {text}");
        assert!(!out.exists(), "{to:?}: the run folder was created");
    }
    // --epochs 0 on a new run and on a resume.
    let (ok, text) = run.train(&["--epochs", "0"]);
    assert!(!ok && text.contains("num_epochs = 0"), "{text}");
    assert!(!run.out.exists());
    let (ok, text) = run.train(&["--epochs", "1"]);
    assert!(ok, "{text}");
    let (ok, text) = train(&run.dir, &run.out, &["--resume", "--epochs", "0"]);
    assert!(!ok && text.contains("--epochs = 0"), "{text}");
}
