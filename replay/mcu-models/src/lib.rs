//! Model discovery for the firmware: which models of a weights directory go
//! into an MCU image. A model is a `<name>.gpec` weight blob with its
//! `<name>.golden` sidecar; blobs over [`MAX_MCU_BLOB`] are host-only
//! (paper size) and are left out; `GPECNET_MODELS=a,b` ([`ONLY_VAR`])
//! restricts the set. One rule for the three places that need it:
//! `firmware/build.rs` (what it embeds), `firmware/host`'s `golden-host`
//! (the same models on the host) and `xtask` (what it builds, runs and
//! reports). `std` only, no dependencies.
#![deny(missing_docs)]

use std::path::{Path, PathBuf};

/// Largest blob linked into the firmware: the STM32F405 has 1 MiB of flash,
/// and code, golden files and the other models need room too. Bigger
/// (host-only, e.g. paper-size) models are skipped.
pub const MAX_MCU_BLOB: u64 = 512 * 1024;

/// The environment variable that restricts the set: `a,b` (model names,
/// comma separated); unset or empty means every model.
pub const ONLY_VAR: &str = "GPECNET_MODELS";

/// `dir/<name>.gpec`: a model's weight blob.
pub fn blob_path(dir: &Path, name: &str) -> PathBuf {
    dir.join(format!("{name}.gpec"))
}

/// `dir/<name>.golden`: a model's golden-vector sidecar.
pub fn golden_path(dir: &Path, name: &str) -> PathBuf {
    dir.join(format!("{name}.golden"))
}

/// The model names of an [`ONLY_VAR`] value (trimmed); `None` (every model)
/// when it is empty.
pub fn parse_only(value: &str) -> Option<Vec<String>> {
    (!value.is_empty()).then(|| value.split(',').map(|x| x.trim().to_string()).collect())
}

/// The restriction [`ONLY_VAR`] sets in this process's environment.
pub fn only_from_env() -> Option<Vec<String>> {
    std::env::var(ONLY_VAR).ok().as_deref().and_then(parse_only)
}

/// The models of one weights directory, sorted by name.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct Selection {
    /// The models an MCU image embeds: blob and sidecar present, the blob at
    /// most [`MAX_MCU_BLOB`] bytes, and named in the restriction (if any).
    pub names: Vec<String>,
    /// Models left out for their size alone: `(name, blob bytes)`.
    pub host_only: Vec<(String, u64)>,
}

/// The models in `dir` (none when it cannot be read), restricted to `only`
/// when given.
pub fn select(dir: &Path, only: Option<&[String]>) -> Selection {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|x| x == "gpec"))
                .filter_map(|p| p.file_stem().and_then(|s| s.to_str()).map(String::from))
                .filter(|n| golden_path(dir, n).is_file())
                .filter(|n| only.is_none_or(|o| o.contains(n)))
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    let mut s = Selection::default();
    for n in names {
        let len = std::fs::metadata(blob_path(dir, &n)).map_or(0, |m| m.len());
        if len <= MAX_MCU_BLOB {
            s.names.push(n);
        } else {
            s.host_only.push((n, len));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_only_small_enough_and_restricted() {
        let dir = std::env::temp_dir().join(format!("gpecnet-mcu-models-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (name, len, golden) in [
            ("b", 10, true),
            ("a", 10, true),
            ("no-sidecar", 10, false),
            ("big", MAX_MCU_BLOB + 1, true),
        ] {
            std::fs::write(blob_path(&dir, name), vec![0u8; len as usize]).unwrap();
            if golden {
                std::fs::write(golden_path(&dir, name), b"g").unwrap();
            }
        }
        let all = select(&dir, None);
        assert_eq!(all.names, ["a", "b"]);
        assert_eq!(all.host_only, [("big".to_string(), MAX_MCU_BLOB + 1)]);
        let only = parse_only("b, big").unwrap();
        let some = select(&dir, Some(&only));
        assert_eq!(some.names, ["b"]);
        assert_eq!(some.host_only.len(), 1);
        assert_eq!(parse_only(""), None);
        assert!(select(&dir.join("missing"), None).names.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
