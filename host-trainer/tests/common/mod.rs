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
         learning_rate = 1e-3\nk = 3\nseed = 5\nthreads = 1\nval_scenes = [\"v\"]\n{extra}"
    )
}

/// Write `tiny_config(extra)` to `dir/cfg.toml` and return its path.
pub fn write_config(dir: &Path, extra: &str) -> PathBuf {
    let p = dir.join("cfg.toml");
    std::fs::write(&p, tiny_config(extra)).unwrap();
    p
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

/// `gpecnet train --quiet --data <data> --out <out> ...`.
pub fn train(data: &Path, out: &Path, extra: &[&str]) -> (bool, String) {
    let mut args = vec![
        "train",
        "--quiet",
        "--data",
        data.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    run(&args)
}

/// The pid of a process that has exited (and been reaped): provably dead.
pub fn dead_pid() -> u32 {
    let mut c = Command::new("true").spawn().unwrap();
    let pid = c.id();
    c.wait().unwrap();
    pid
}
