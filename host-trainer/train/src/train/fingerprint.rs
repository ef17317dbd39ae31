//! The fingerprint of a run's windows, checked by `--resume`.

use std::path::Path;

use anyhow::{Context, Result};

use crate::data::Window;

/// What a run was trained on: window counts per scene and a hash of every window, stored
/// beside the checkpoint as `data-fingerprint.json` when a run starts and compared on
/// `--resume` (a missing or changed scene is refused, not silently resumed).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct DataFingerprint {
    /// Real training windows (before time reversal / mirroring).
    pub n_train: usize,
    /// Synthetic (augmentation) windows.
    pub n_synthetic: usize,
    /// Validation windows.
    pub n_val: usize,
    /// Real training windows per scene.
    pub train_scenes: std::collections::BTreeMap<String, usize>,
    /// Validation windows per scene.
    pub val_scenes: std::collections::BTreeMap<String, usize>,
    /// FNV-1a 64 over every window (scene, ped id, frames, position bits) in load order,
    /// training then validation, hex.
    pub hash: String,
}

impl DataFingerprint {
    /// File name inside a run directory.
    pub const FILE: &'static str = "data-fingerprint.json";

    /// Fingerprint of real training, synthetic and validation windows.
    pub fn of(train: &[Window], n_real: usize, val: &[Window]) -> Self {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |bytes: &[u8]| {
            for &b in bytes {
                h ^= u64::from(b);
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        for w in train.iter().chain(val) {
            eat(w.scene.as_bytes());
            eat(&[0xff]);
            eat(&w.ped_id.to_bits().to_le_bytes());
            for f in &w.frames {
                eat(&f.to_le_bytes());
            }
            for p in &w.pos {
                eat(&p[0].to_bits().to_le_bytes());
                eat(&p[1].to_bits().to_le_bytes());
            }
        }
        let count = |ws: &[Window]| {
            let mut m = std::collections::BTreeMap::new();
            for w in ws {
                *m.entry(w.scene.clone()).or_insert(0) += 1;
            }
            m
        };
        let n_real = n_real.min(train.len());
        Self {
            n_train: n_real,
            n_synthetic: train.len() - n_real,
            n_val: val.len(),
            train_scenes: count(&train[..n_real]),
            val_scenes: count(val),
            hash: format!("{h:016x}"),
        }
    }

    /// Read `run_dir/data-fingerprint.json`; `None` when absent.
    pub fn load(run_dir: &Path) -> Result<Option<Self>> {
        let p = run_dir.join(Self::FILE);
        match crate::inpath::read_limited(&p, crate::inpath::FileKind::Text) {
            Ok(b) => {
                Ok(Some(serde_json::from_slice(&b).with_context(|| {
                    format!("cannot parse {}", p.display())
                })?))
            }
            Err(e) if e.is_not_found() => Ok(None),
            Err(e) => Err(e.into()),
        }
    }

    /// Write `run_dir/data-fingerprint.json` (atomically).
    pub fn save(&self, run_dir: &Path) -> Result<()> {
        let p = run_dir.join(Self::FILE);
        crate::rundir::write_atomic(&p, serde_json::to_string_pretty(self)?.as_bytes())
            .with_context(|| format!("cannot write {}", p.display()))
    }

    /// What differs from `now` (empty when the same data), in words.
    pub fn diff(&self, now: &Self) -> Vec<String> {
        let mut out = Vec::new();
        for (what, a, b) in [
            ("training", &self.train_scenes, &now.train_scenes),
            ("validation", &self.val_scenes, &now.val_scenes),
        ] {
            let missing: Vec<&str> = a
                .keys()
                .filter(|k| !b.contains_key(*k))
                .map(|k| k.as_str())
                .collect();
            let added: Vec<&str> = b
                .keys()
                .filter(|k| !a.contains_key(*k))
                .map(|k| k.as_str())
                .collect();
            let changed: Vec<String> = a
                .iter()
                .filter_map(|(k, n)| {
                    b.get(k)
                        .filter(|m| *m != n)
                        .map(|m| format!("{k} {n} -> {m} windows"))
                })
                .collect();
            if !missing.is_empty() {
                out.push(format!("{what} scenes missing now: {}", missing.join(", ")));
            }
            if !added.is_empty() {
                out.push(format!(
                    "{what} scenes not in the run: {}",
                    added.join(", ")
                ));
            }
            if !changed.is_empty() {
                out.push(format!("{what} scenes changed: {}", changed.join(", ")));
            }
        }
        for (what, a, b) in [
            ("training windows", self.n_train, now.n_train),
            ("synthetic windows", self.n_synthetic, now.n_synthetic),
            ("validation windows", self.n_val, now.n_val),
        ] {
            if a != b {
                out.push(format!("{what}: {a} -> {b}"));
            }
        }
        if out.is_empty() && self.hash != now.hash {
            out.push(format!(
                "same scenes and counts but different window contents (hash {} -> {})",
                self.hash, now.hash
            ));
        }
        out
    }
}
