//! `gpec-rewrite DIR`: re-writes every `DIR/<name>.gpec` in the newest blob format
//! (`weights/FORMAT.md`, version 3: aligned tensors) with identical weights, and its
//! `DIR/<name>.golden` (if any) with the same cases and the new blob CRC, both through
//! `gpecnet-blob-writer`; then the model cards (`DIR/*.json`, `DIR/*.md`) that state a
//! re-written blob's CRC-32 and size (`blob_crc`/`blob_bytes`, `source_crc`/`source_bytes`,
//! "`N bytes` … CRC-32 `0x…`") get the new values. Rerunnable: a second run changes nothing.
//!
//! ```sh
//! cargo run -p gpecnet-blob-writer --bin gpec-rewrite -- weights
//! ```

use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let Some(dir) = std::env::args_os().nth(1).map(PathBuf::from) else {
        eprintln!("usage: gpec-rewrite DIR");
        return ExitCode::from(2);
    };
    match run(&dir) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("gpec-rewrite: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(dir: &std::path::Path) -> Result<(), Box<dyn std::error::Error>> {
    let mut names: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "gpec"))
        .collect();
    names.sort();
    let mut changed = Vec::new();
    for blob_path in names {
        let old = std::fs::read(&blob_path)?;
        let old_crc = gpecnet_core::Model::from_blob(&old)
            .map_err(|e| format!("{}: {e}", blob_path.display()))?
            .crc();
        let new = gpecnet_blob_writer::rewrite_blob(&old)
            .map_err(|e| format!("{}: {e}", blob_path.display()))?;
        let new_crc = gpecnet_core::Model::from_blob(&new)?.crc();
        std::fs::write(&blob_path, &new)?;
        let golden_path = blob_path.with_extension("golden");
        let golden = match std::fs::read(&golden_path) {
            Ok(g) => {
                let g2 = gpecnet_blob_writer::rewrite_golden(&g, old_crc, new_crc)
                    .map_err(|e| format!("{}: {e}", golden_path.display()))?;
                std::fs::write(&golden_path, &g2)?;
                format!(", {} re-sealed", golden_path.display())
            }
            Err(_) => String::new(),
        };
        changed.push((old_crc, old.len(), new_crc, new.len()));
        println!(
            "{}: {} -> {} B, crc {old_crc:#010x} -> {new_crc:#010x}{golden}",
            blob_path.display(),
            old.len(),
            new.len()
        );
    }
    update_cards(dir, &changed)
}

/// Model cards: the CRC and size of every re-written blob, wherever a card names that CRC.
fn update_cards(
    dir: &std::path::Path,
    changed: &[(u32, usize, u32, usize)],
) -> Result<(), Box<dyn std::error::Error>> {
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        let ext = path.extension().and_then(|x| x.to_str()).unwrap_or("");
        if ext != "json" && ext != "md" || path.file_name().is_some_and(|n| n == "FORMAT.md") {
            continue;
        }
        let text = std::fs::read_to_string(&path)?;
        let mut out = text.clone();
        for &(c, n, c2, n2) in changed.iter().filter(|x| x.0 != x.2) {
            if ext == "json" {
                for key in ["blob", "source"] {
                    let old_crc = format!("\"{key}_crc\": {c}");
                    if out.contains(&old_crc) {
                        out = out.replace(&old_crc, &format!("\"{key}_crc\": {c2}"));
                        out = out.replace(
                            &format!("\"{key}_bytes\": {n},"),
                            &format!("\"{key}_bytes\": {n2},"),
                        );
                        out = out.replace(
                            &format!("\"{key}_bytes\": {n}\n"),
                            &format!("\"{key}_bytes\": {n2}\n"),
                        );
                    }
                }
            } else if out.contains(&format!("`{c:#010x}`")) {
                out = out.replace(&format!("`{c:#010x}`"), &format!("`{c2:#010x}`"));
                out = out.replace(&format!(" {n} bytes"), &format!(" {n2} bytes"));
            }
        }
        if out != text {
            std::fs::write(&path, out)?;
            println!("{}: CRC/size updated", path.display());
        }
    }
    Ok(())
}
