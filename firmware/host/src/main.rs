//! `golden-host [WEIGHTS_DIR]`: the firmware's golden verification on the
//! host (stable toolchain), same code (`firmware/src/golden.rs`), same lines.
//! `cargo xtask qemu` compares its `golden`/`xcheck` lines with the firmware's.
//! `golden-host --macs FILE.gpec K`: the blob's MAC count for K endpoints.
use gpecnet_replay::{verify_all, EmbeddedModel, Line};

/// The firmware's scratch width on the M4F/M7 (`gpecnet_firmware::SCRATCH`).
const SCRATCH: usize = 128;
use std::path::PathBuf;
use std::process::exit;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--macs") {
        let blob = std::fs::read(&args[1]).unwrap_or_else(|e| {
            eprintln!("golden-host: {}: {e}", args[1]);
            exit(2)
        });
        let k: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(20);
        match gpecnet_core::Model::from_blob(&blob) {
            Ok(m) => {
                println!(
                    "macs {} k={k} total={} encoder_past={} params={} max_width={}",
                    m.name(),
                    m.endpoint_macs(k),
                    m.encoder_past().macs(),
                    m.parameter_count(),
                    m.max_width()
                );
                exit(0)
            }
            Err(e) => {
                eprintln!("golden-host: {}: {e}", args[1]);
                exit(1)
            }
        }
    }
    let dir = args
        .first()
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../weights"));
    let only: Option<Vec<String>> = std::env::var("GPECNET_MODELS")
        .ok()
        .filter(|s| !s.is_empty())
        .map(|s| s.split(',').map(|x| x.trim().to_string()).collect());
    // Same selection and order as firmware/build.rs.
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .filter_map(|e| {
                    let p = e.path();
                    (p.extension()? == "gpec").then(|| p.file_stem()?.to_str().map(String::from))?
                })
                .filter(|n| dir.join(format!("{n}.golden")).is_file())
                .filter(|n| only.as_ref().map_or(true, |o| o.contains(n)))
                // Host-only models do not go into the image (firmware/build.rs MAX_MCU_BLOB).
                .filter(|n| {
                    std::fs::metadata(dir.join(format!("{n}.gpec")))
                        .is_ok_and(|m| m.len() <= 512 * 1024)
                })
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    if names.is_empty() {
        eprintln!(
            "golden-host: no model in {} (need <name>.gpec + <name>.golden)",
            dir.display()
        );
        exit(3);
    }
    let models: Vec<EmbeddedModel> = names
        .iter()
        .map(|n| EmbeddedModel {
            name: Box::leak(n.clone().into_boxed_str()),
            blob: Box::leak(
                std::fs::read(dir.join(format!("{n}.gpec")))
                    .unwrap()
                    .into_boxed_slice(),
            ),
            golden: Box::leak(
                std::fs::read(dir.join(format!("{n}.golden")))
                    .unwrap()
                    .into_boxed_slice(),
            ),
        })
        .collect();
    let s = verify_all::<SCRATCH>(&models, true, &mut |l| {
        match l {
        Line::Model {
            model,
            numeric,
            sine,
            cases,
        } => println!("model {model} {numeric} {sine} {cases}"),
        Line::Golden {
            model,
            case,
            hash,
            ok,
        } => {
            println!("golden {model} {case} {hash:08x}");
            if !ok {
                eprintln!("MISMATCH {model} case {case}");
            }
        }
        Line::Xcheck {
            model,
            sine,
            case,
            hash,
        } => println!("xcheck {model} {sine} {case} {hash:08x}"),
        Line::Error { model, what } => eprintln!("golden {model}: {what}"),
        Line::TooWide {
            model,
            needed,
            capacity,
        } => eprintln!(
            "golden {model}: model needs scratch width {needed} > SCRATCH {capacity} (firmware/src/lib.rs)"
        ),
    }
    });
    println!(
        "golden summary: models={} cases={} mismatches={} errors={} xchecks={}",
        s.models, s.cases, s.mismatches, s.errors, s.xchecks
    );
    exit(if s.ok() { 0 } else { 1 })
}
