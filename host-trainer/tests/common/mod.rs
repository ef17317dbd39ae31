//! Tiny SDD-shaped data sets, tiny configs and a runner for the `gpecnet` binary.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh empty temp directory (removed by the caller or left in the OS temp dir).
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "gpecnet-it-{}-{name}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos())
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// One SDD file: `peds` trajectories of 20 rows, frame step 12, smooth walks.
pub fn sdd_file(peds: usize, salt: f32) -> String {
    let mut s = String::new();
    for p in 0..peds {
        let (x0, y0) = (100.0 + 37.0 * p as f32 + salt, 200.0 + 11.0 * p as f32);
        let (vx, vy) = (3.0 + (p % 5) as f32, -2.0 + (p % 3) as f32 + 0.1 * salt);
        for t in 0..20 {
            let frame = 12 * t + 240 * p;
            let x = x0 + vx * t as f32 + 0.3 * ((t * p) % 7) as f32;
            let y = y0 + vy * t as f32;
            s += &format!("{frame} {p}.0 {x} {y}\n");
        }
    }
    s
}

/// `root/sdd/<split>/<scene>.txt` for each `(scene, peds)`.
pub fn write_sdd(root: &Path, split: &str, scenes: &[(&str, usize)]) {
    let dir = root.join("sdd").join(split);
    std::fs::create_dir_all(&dir).unwrap();
    for (i, (scene, peds)) in scenes.iter().enumerate() {
        std::fs::write(dir.join(format!("{scene}.txt")), sdd_file(*peds, i as f32)).unwrap();
    }
}

/// A data root with training scenes `a`, `b`, `c` (validation: `v`).
pub fn tiny_data(root: &Path) {
    write_sdd(root, "train", &[("a", 12), ("b", 10), ("c", 8), ("v", 6)]);
}

/// A tiny config TOML (validation scene `v`), `extra` appended.
pub fn tiny_config(extra: &str) -> String {
    format!(
        "enc_past_size = [8]\nenc_dest_size = [8]\nenc_latent_size = [8]\ndec_size = [8]\n\
         predictor_hidden_size = [8]\nfdim = 4\nzdim = 2\nnum_epochs = 2\nbatch_size = 16\n\
         learning_rate = 1e-3\nk = 3\nseed = 5\nthreads = 1\nval_scenes = [\"v\"]\ndata_scale = 1.86\n{extra}"
    )
}

/// Write `tiny_config(extra)` to `dir/cfg.toml` and return its path.
pub fn write_config(dir: &Path, extra: &str) -> PathBuf {
    let p = dir.join("cfg.toml");
    std::fs::write(&p, tiny_config(extra)).unwrap();
    p
}

/// A temp folder with [`tiny_data`], [`write_config`]`(dir, "")` and the run folder
/// `dir/run` (not created); the folder is removed on drop.
pub struct TinyRun {
    /// The temp folder (the data root).
    pub dir: PathBuf,
    /// The tiny config file.
    pub cfg: PathBuf,
    /// The run folder.
    pub out: PathBuf,
}

impl TinyRun {
    /// A fresh one named `name`.
    pub fn new(name: &str) -> Self {
        let dir = temp_dir(name);
        tiny_data(&dir);
        let cfg = write_config(&dir, "");
        let out = dir.join("run");
        Self { dir, cfg, out }
    }

    /// A fresh one named `name`, trained for `epochs` (which must succeed).
    pub fn trained(name: &str, epochs: u32) -> Self {
        let run = Self::new(name);
        let (ok, text) = run.train(&["--epochs", &epochs.to_string()]);
        assert!(ok, "{text}");
        run
    }

    /// `gpecnet train --quiet --data <dir> --out <out> --resume ...`.
    pub fn resume(&self, extra: &[&str]) -> (bool, String) {
        train(&self.dir, &self.out, &[&["--resume"], extra].concat())
    }

    /// `gpecnet train --quiet --data <dir> --out <out> --config <cfg> ...`.
    pub fn train(&self, extra: &[&str]) -> (bool, String) {
        train(
            &self.dir,
            &self.out,
            &[&["--config", s(&self.cfg)], extra].concat(),
        )
    }
}

impl Drop for TinyRun {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The tiny model the in-process training tests use (two threads, seed 11): 3 epochs of
/// batches of 1024; override fields with struct update syntax.
pub fn tiny_train_config() -> gpecnet_trainer::config::TrainConfig {
    gpecnet_trainer::config::TrainConfig {
        enc_past_size: vec![16, 8],
        enc_dest_size: vec![8, 16],
        enc_latent_size: vec![8, 16],
        dec_size: vec![16, 8],
        predictor_hidden_size: vec![16, 8],
        fdim: 8,
        zdim: 4,
        num_epochs: 3,
        batch_size: 1024,
        learning_rate: 1e-3,
        k: 5,
        seed: 11,
        threads: 2,
        ..Default::default()
    }
}

/// A window of pedestrian `ped_id` in `scene` walking a straight line: position
/// `start + t · step` at frame `12 t`.
pub fn line_window(
    scene: &str,
    ped_id: f64,
    start: [f32; 2],
    step: [f32; 2],
) -> gpecnet_trainer::data::Window {
    gpecnet_trainer::data::Window {
        scene: scene.into(),
        ped_id,
        frames: std::array::from_fn(|t| 12 * t as i64),
        pos: std::array::from_fn(|t| {
            [start[0] + step[0] * t as f32, start[1] + step[1] * t as f32]
        }),
    }
}

/// The `gpecnet` binary.
pub fn gpecnet() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gpecnet"))
}

/// Run `gpecnet` with `args`; (success, stdout + stderr).
pub fn run(args: &[&str]) -> (bool, String) {
    let o: Output = gpecnet().args(args).output().unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o.status.success(), text)
}

/// `p` as UTF-8 (test paths are).
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Run `gpecnet` with `args`, then `extra`; (success, stdout + stderr).
pub fn run_with(args: &[&str], extra: &[&str]) -> (bool, String) {
    run(&[args, extra].concat())
}

/// `gpecnet train --quiet --data <data> --out <out> ...`.
pub fn train(data: &Path, out: &Path, extra: &[&str]) -> (bool, String) {
    run_with(
        &["train", "--quiet", "--data", s(data), "--out", s(out)],
        extra,
    )
}

/// `gpecnet quantize --blob <blob> --out <out> ...`.
pub fn quantize(blob: &Path, out: &Path, extra: &[&str]) -> (bool, String) {
    run_with(&["quantize", "--blob", s(blob), "--out", s(out)], extra)
}

/// The shipped file `weights/<name>`.
pub fn weights(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../weights")
        .join(name)
}

/// Copies the shipped set `name` (blob, golden file, cards) into `dir`; returns the blob.
pub fn copy_set(dir: &Path, name: &str) -> PathBuf {
    for ext in ["gpec", "golden", "json", "md"] {
        let file = format!("{name}.{ext}");
        std::fs::copy(weights(&file), dir.join(&file)).unwrap();
    }
    dir.join(format!("{name}.gpec"))
}

/// The refusal `DatasetSpec::parse` gives for an own data folder whose `dataset.toml` is
/// `toml`, beside empty `train`, `val` and `test` folders (a fresh temp folder `name`,
/// removed afterwards); panics when the folder is accepted.
pub fn own_data_refusal(name: &str, toml: &str) -> String {
    let dir = temp_dir(name);
    std::fs::write(dir.join("dataset.toml"), toml).unwrap();
    for split in ["train", "val", "test"] {
        std::fs::create_dir_all(dir.join(split)).unwrap();
    }
    let e = gpecnet_trainer::data::DatasetSpec::parse(&format!("{}/", dir.display())).unwrap_err();
    let _ = std::fs::remove_dir_all(&dir);
    e
}

/// The pid of a process that has exited (and been reaped): provably dead.
pub fn dead_pid() -> u32 {
    let mut c = Command::new("true").spawn().unwrap();
    let pid = c.id();
    c.wait().unwrap();
    pid
}

/// A valid 20-row trajectory for ped `id` starting at frame `f0`.
pub fn good_rows(id: &str, f0: i64) -> Vec<String> {
    (0..20)
        .map(|t| format!("{} {id} {}.0 5.5", f0 + 12 * t, 10 + t))
        .collect()
}
