//! `golden-host [WEIGHTS_DIR]`: the firmware's golden verification on the
//! host (stable toolchain), same code (`gpecnet-replay`, as `firmware/src/golden_run.rs`), same lines.
//! `cargo xtask qemu` compares its `golden`/`xcheck` lines with the firmware's.
//! `golden-host --macs FILE.gpec K`: the blob's MAC count for K endpoints.
use gpecnet_mcu_models::{blob_path, golden_path, only_from_env, select};
use gpecnet_replay::{verify_all, EmbeddedModel};

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
    // The models firmware/build.rs embeds, in the same order.
    let names = select(&dir, only_from_env().as_deref()).names;
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
                std::fs::read(blob_path(&dir, n))
                    .unwrap()
                    .into_boxed_slice(),
            ),
            golden: Box::leak(
                std::fs::read(golden_path(&dir, n))
                    .unwrap()
                    .into_boxed_slice(),
            ),
        })
        .collect();
    let s = verify_all::<SCRATCH, true>(&models, true, &mut |l| {
        l.print(&mut |text, error| {
            if error {
                eprintln!("{text}")
            } else {
                println!("{text}")
            }
        })
    });
    gpecnet_replay::resample_scene(&mut |l| l.print(&mut |text, _| println!("{text}")));
    gpecnet_replay::flight_scene(&mut |l| l.print(&mut |text, _| println!("{text}")));
    println!("{s}");
    exit(if s.ok() { 0 } else { 1 })
}
