//! `cargo xtask fw-faults`: the firmware's failure paths, proven in QEMU on the
//! STM32F405 (Cortex-M4F). Injected faults (a panic, a HardFault, a stack
//! overflow, a hung task) and a corrupted blob must each end the run with exit
//! 1 and their own log line; a model in the wrong unit is refused with its
//! typed error; the signed-weight attacks (a forged copy, an untrusted key, a
//! rollback) each end in their defined state.

use crate::elf::fill_symbol;
use crate::firmware::{
    build_and_start, build_image, finish, fw_cargo, require_models, run_image, weights_dir, Opts,
    DEMO_MODEL,
};
use crate::mcu;
use crate::replay::model_pack_with;
use crate::toolchain::require;
use crate::{die, root};

/// Builds and runs every proof; 0 when each ended as it must, else 1.
pub(crate) fn fw_faults(o: &Opts) -> i32 {
    require(true);
    let dir = weights_dir(o);
    let models = require_models(&dir);
    let first = models[0].as_str();
    let unitless = "sdd-tiny-v2-qe";
    let have_unitless = models.iter().any(|m| m == unitless);
    let out_dir = root().join("target/fw-faults");
    // The injected faults run on one image: the golden binary linked with
    // `fault-injection` and an empty model-pack area the size of the first model's
    // pack. Each proof writes the pack and its fault's name (GPECNET_FAULT) into a
    // copy; the corrupted-blob proof writes no fault and a pack whose blob has one byte
    // in the middle flipped, as a flash bit error would leave it.
    let batch = [first.to_string()];
    let budget = mcu::M4F.image_data_budget;
    let packs = model_pack_with(&dir, &batch, budget, |_| {}).and_then(|plain| {
        let flip = |blob: &mut Vec<u8>| {
            let mid = blob.len() / 2;
            blob[mid] ^= 0x10;
        };
        Ok((plain, model_pack_with(&dir, &batch, budget, flip)?))
    });
    let (plain, corrupt) = match packs {
        Ok(p) => p,
        Err(e) => die(&format!("xtask: fw-faults: the model pack of {first}: {e}")),
    };
    // Every image is built first, one after the other (one target directory); each runs
    // in QEMU as soon as it is built, while the next one builds. The verdicts follow in order.
    std::thread::scope(|s| {
        let image = |name: &str, only: &str, demo_model: Option<&str>, bin: &str, f: &[&str]| {
            let mut c = fw_cargo(o);
            c.env(gpecnet_mcu_models::ONLY_VAR, only);
            if let Some(d) = demo_model {
                c.env("GPECNET_DEMO_MODEL", d);
            }
            let copy = out_dir.join(format!("{name}.elf"));
            build_and_start(s, c, &mcu::M4F, bin, f, &[], copy)
        };
        // Each injected failure must end the run with exit 1 and its own log line
        // (no lockup, no silent corruption, no outer timeout).
        let linked = out_dir.join("fault-injection.elf");
        let mut c = fw_cargo(o);
        c.env(
            "GPECNET_MODEL_PACK",
            plain.len().next_multiple_of(8).to_string(),
        );
        let built = build_image(c, &mcu::M4F, "golden", &["fault-injection"], &[], &linked)
            .and_then(|()| {
                std::fs::read(&linked).map_err(|e| (1, format!("{}: {e}", linked.display())))
            });
        let injected: Vec<_> = [
            ("panic", "panic"),
            ("hardfault", "HardFault"),
            ("stack-overflow", "stack overflow"),
            ("hang", "a task hung"),
            ("corrupt-blob", "blob rejected"),
        ]
        .into_iter()
        .map(|(f, want)| {
            let copy = out_dir.join(format!("{f}.elf"));
            let image = built.clone().and_then(|mut image| {
                let (pack, fault) = match f {
                    "corrupt-blob" => (&corrupt, &b""[..]),
                    _ => (&plain, f.as_bytes()),
                };
                fill_symbol(&mut image, "GPECNET_MODEL_PACK", pack)
                    .and_then(|()| fill_symbol(&mut image, "GPECNET_FAULT", fault))
                    .and_then(|()| {
                        std::fs::write(&copy, &image)
                            .map_err(|e| format!("{}: {e}", copy.display()))
                    })
                    .map_err(|e| (1, format!("xtask: fw-faults image {f}: {e}")))
            });
            let run = s.spawn(move || match image {
                Ok(()) => run_image(&mcu::M4F, &copy),
                Err((rc, err)) => (rc, String::new(), err),
            });
            (f, want, run)
        })
        .collect();
        // A model in the wrong unit: the metric demo given a blob that does not
        // record its unit must refuse it with the typed unit error and exit 1.
        let unit =
            have_unitless.then(|| image("unit-mismatch", unitless, Some(unitless), "demo", &[]));
        // Signed weights: each attack ends in its defined state, named in the log. A forged
        // copy (valid CRC, broken signature) is refused and the demo runs the last good model
        // (exit 0); with only an untrusted key, or a stored minimum version above the model's,
        // nothing is run (exit 1).
        let attacks: Vec<_> = [
            (
                "force-forged-blob",
                0,
                &[
                    "refused: BadSignature",
                    "falling back to the last good model",
                ][..],
            ),
            (
                "force-untrusted-key",
                1,
                &["refused: UnknownKey", "no trusted model"][..],
            ),
            (
                "force-rollback",
                1,
                &["refused: RolledBack", "no trusted model"][..],
            ),
        ]
        .into_iter()
        .map(|(f, want_rc, wants)| (f, want_rc, wants, image(f, DEMO_MODEL, None, "demo", &[f])))
        .collect();

        let mut bad = 0;
        for (f, want, run) in injected {
            let (rc, out, _) = finish(run);
            let last = out.lines().rev().find(|l| l.contains(want)).unwrap_or("");
            let ok = rc == 1 && !last.is_empty();
            println!(
                "fw-faults {:<22} exit {rc} (want 1), log {:?} {}",
                format!("inject {f}"),
                last.trim(),
                if ok { "ok" } else { "FAILED" }
            );
            bad += (!ok) as i32;
        }
        if let Some(run) = unit {
            let (rc, out, _) = finish(run);
            let want = "refused for positions in metres";
            let last = out.lines().rev().find(|l| l.contains(want)).unwrap_or("");
            let ok = rc == 1 && last.contains("UnknownModelUnit");
            println!(
                "fw-faults {:<22} exit {rc} (want 1), log {:?} {}",
                "unit-mismatch",
                last.trim(),
                if ok { "ok" } else { "FAILED" }
            );
            bad += (!ok) as i32;
        } else {
            println!("fw-faults unit-mismatch          FAILED: weights/{unitless}.gpec missing");
            bad += 1;
        }
        for (f, want_rc, wants, run) in attacks {
            let (rc, out, _) = finish(run);
            let found: Vec<&str> = wants
                .iter()
                .filter_map(|w| out.lines().find(|l| l.contains(w)))
                .collect();
            let ok = rc == want_rc && found.len() == wants.len();
            println!(
                "fw-faults {f:<22} exit {rc} (want {want_rc}), log {:?} {}",
                found.iter().map(|l| l.trim()).collect::<Vec<_>>(),
                if ok { "ok" } else { "FAILED" }
            );
            bad += (!ok) as i32;
        }
        (bad != 0) as i32
    })
}
