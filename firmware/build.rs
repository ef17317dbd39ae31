//! Build script: memory map + linker scripts + the table of embedded model blobs.
use std::{env, fs, path::PathBuf};

use gpecnet_mcu_models::{blob_path, golden_path, MAX_MCU_BLOB};

/// One supported chip (a `chip-*` cargo feature).
struct Chip {
    /// The feature without `chip-`.
    feature: &'static str,
    /// The only target it builds for.
    target: &'static str,
    /// Memory map: `memory.x` (repository root) or a file in firmware/memory/.
    memory: &'static str,
    /// Whether the core has an MPU for the stack guard (firmware/src/guard.rs).
    mpu: bool,
    /// For the boot line.
    describe: &'static str,
}

/// Every chip the firmware supports; keep in step with xtask/src/mcu.rs.
const CHIPS: &[Chip] = &[
    Chip {
        feature: "stm32f405",
        target: "thumbv7em-none-eabihf",
        memory: "memory.x",
        mpu: true,
        describe: "STM32F405 (Cortex-M4F)",
    },
    Chip {
        feature: "nrf51",
        target: "thumbv6m-none-eabi",
        memory: "nrf51.x",
        mpu: false,
        describe: "nRF51822 (Cortex-M0)",
    },
    Chip {
        feature: "mps2-an500",
        target: "thumbv7em-none-eabihf",
        memory: "mps2-an500.x",
        mpu: true,
        describe: "MPS2 AN500 (Cortex-M7)",
    },
    Chip {
        feature: "stm32f767",
        target: "thumbv7em-none-eabihf",
        memory: "stm32f767.x",
        mpu: true,
        describe: "STM32F767 (Cortex-M7)",
    },
];

/// The chip selected by exactly one `chip-*` feature.
fn chip() -> &'static Chip {
    let on: Vec<&Chip> = CHIPS
        .iter()
        .filter(|c| {
            let var = format!(
                "CARGO_FEATURE_CHIP_{}",
                c.feature.to_uppercase().replace('-', "_")
            );
            env::var_os(var).is_some()
        })
        .collect();
    match on.as_slice() {
        [one] => one,
        [] => panic!("no chip selected: enable one of the features chip-stm32f405 (default), chip-nrf51, chip-mps2-an500, chip-stm32f767"),
        _ => panic!("more than one chip-* feature enabled: pick one (use --no-default-features to drop chip-stm32f405)"),
    }
}

fn main() {
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").unwrap());
    let root = manifest.parent().unwrap().to_path_buf();
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap());

    // The chip: exactly one `chip-*` feature, which picks the memory map, the
    // target it needs and the cfgs the code branches on (`has_mpu`: the stack
    // guard of guard.rs; `armv6m`: no CFSR/HFSR, no DWT cycle counter).
    let chip = chip();
    let target = env::var("TARGET").unwrap_or_default();
    if target != chip.target {
        panic!(
            "feature chip-{} builds for --target {}, not {target} (cargo xtask qemu --mcu ... picks both)",
            chip.feature, chip.target
        );
    }
    println!("cargo::rustc-check-cfg=cfg(has_mpu)");
    println!("cargo::rustc-check-cfg=cfg(armv6m)");
    if chip.mpu {
        println!("cargo:rustc-cfg=has_mpu");
    }
    if target.starts_with("thumbv6m") {
        println!("cargo:rustc-cfg=armv6m");
    }
    println!("cargo:rustc-env=GPECNET_CHIP={}", chip.describe);
    // The STM32F405's memory map lives at the repository root (one source of
    // truth, also used by the core's embassy example); the others in
    // firmware/memory/. cortex-m-rt's link.x does `INCLUDE memory.x`, found in OUT_DIR.
    let memx = match chip.memory {
        "memory.x" => root.join("memory.x"),
        other => manifest.join("memory").join(other),
    };
    fs::copy(&memx, out.join("memory.x"))
        .unwrap_or_else(|e| panic!("copy {} into OUT_DIR: {e}", memx.display()));
    println!("cargo:rustc-link-search={}", out.display());
    // Linker scripts from here rather than [target] rustflags: an exported
    // RUSTFLAGS (CI!) replaces config rustflags but not these.
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    println!("cargo:rerun-if-changed={}", memx.display());
    println!("cargo:rerun-if-changed=build.rs");

    // Embedded models: every weights/<name>.gpec that has a weights/<name>.golden
    // sidecar and fits the MCU (gpecnet-mcu-models, the rule golden-host and xtask
    // use too). GPECNET_MODELS=a,b restricts the set (profiling builds one at a
    // time). GPECNET_WEIGHTS_DIR overrides the directory (tests with scratch blobs).
    println!("cargo:rerun-if-env-changed=GPECNET_WEIGHTS_DIR");
    let weights = env::var_os("GPECNET_WEIGHTS_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("weights"));
    println!("cargo:rerun-if-changed={}", weights.display());
    println!(
        "cargo:rerun-if-env-changed={}",
        gpecnet_mcu_models::ONLY_VAR
    );
    // GPECNET_MODEL_PACK=<bytes> (`cargo xtask qemu`): the golden image embeds no model
    // but an area of that many bytes for a model pack (gpecnet_replay::pack), which xtask
    // writes into copies of the linked image, one per batch of models.
    println!("cargo:rerun-if-env-changed=GPECNET_MODEL_PACK");
    let pack_len = env::var("GPECNET_MODEL_PACK").ok().map(|v| {
        v.parse::<usize>()
            .unwrap_or_else(|_| panic!("GPECNET_MODEL_PACK={v:?}: not a size in bytes"))
    });
    let only = if pack_len.is_some() {
        Some(Vec::new())
    } else {
        gpecnet_mcu_models::only_from_env()
    };
    let selection = gpecnet_mcu_models::select(&weights, only.as_deref());
    for (n, len) in &selection.host_only {
        println!("cargo:warning=skipping {n}.gpec ({len} bytes > {MAX_MCU_BLOB}): host-only model");
    }
    let names = selection.names;
    // Two tables: the profile build references only BLOBS, so the linker
    // drops the golden sidecars from its image.
    let mut src = String::from("// @generated by build.rs from weights/*.gpec + *.golden\n");
    // Each blob in its own 8-byte aligned static (`AlignedBlob`): a format-3 blob's
    // tensors start at multiples of 4 from its first byte, so they are word aligned in
    // flash and the Cortex-M4/M7 kernels can use LDRD/VLDM (include_bytes! alone has
    // alignment 1).
    for (i, n) in names.iter().enumerate() {
        let blob = blob_path(&weights, n);
        let len = fs::metadata(&blob)
            .unwrap_or_else(|e| panic!("{}: {e}", blob.display()))
            .len();
        src += &format!(
            "static BLOB_{i}: AlignedBlob<{len}> = AlignedBlob(*include_bytes!({:?}));\n",
            blob.display().to_string()
        );
    }
    src += "pub static MODELS: &[EmbeddedModel] = &[\n";
    for (i, n) in names.iter().enumerate() {
        let gold = golden_path(&weights, n);
        println!(
            "cargo:rerun-if-changed={}",
            blob_path(&weights, n).display()
        );
        println!("cargo:rerun-if-changed={}", gold.display());
        src += &format!(
            "    EmbeddedModel {{ name: {n:?}, blob: &BLOB_{i}.0, golden: include_bytes!({:?}) }},\n",
            gold.display().to_string()
        );
    }
    src += "];\npub static BLOBS: &[(&str, &[u8])] = &[\n";
    for (i, n) in names.iter().enumerate() {
        src += &format!("    ({n:?}, &BLOB_{i}.0),\n");
    }
    // The demo tracker's model: GPECNET_DEMO_MODEL=<name>; unset = the metric MCU model
    // (sdd-m-lp-qe) when embedded, else the first metric one (the demo picks it).
    println!("cargo:rerun-if-env-changed=GPECNET_DEMO_MODEL");
    let mut forged_static = String::new();
    let mut demo = env::var("GPECNET_DEMO_MODEL").unwrap_or_else(|_| {
        let default = "sdd-m-lp-qe";
        if names.iter().any(|n| n == default) {
            default.to_string()
        } else {
            String::new()
        }
    });
    // `force-forged-blob` (fault proof): a copy of the demo model with one weight byte
    // changed and its CRC recomputed (valid for the unsigned reader, the signature kept),
    // embedded as the demo model; the genuine one stays embedded as the last good model.
    if env::var_os("CARGO_FEATURE_FORCE_FORGED_BLOB").is_some() && !demo.is_empty() {
        let src_blob = blob_path(&weights, &demo);
        let mut bytes =
            fs::read(&src_blob).unwrap_or_else(|e| panic!("{}: {e}", src_blob.display()));
        let inner = match bytes.len().checked_sub(82) {
            Some(i) if bytes[i..i + 4] == *b"GSIG" => i,
            _ => bytes.len(),
        };
        let body = inner - 4;
        bytes[body - 100] ^= 0x01;
        let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&bytes[..body]);
        bytes[body..inner].copy_from_slice(&crc.to_le_bytes());
        let forged = format!("{demo}-forged");
        let dst = out.join(format!("{forged}.gpec"));
        fs::write(&dst, &bytes).unwrap_or_else(|e| panic!("{}: {e}", dst.display()));
        src += &format!("    ({forged:?}, &BLOB_FORGED.0),\n");
        forged_static = format!(
            "static BLOB_FORGED: AlignedBlob<{}> = AlignedBlob(*include_bytes!({:?}));\n",
            bytes.len(),
            dst.display().to_string()
        );
        demo = forged;
    }
    src += "];\n";
    src += &forged_static;
    src += &format!("pub static DEMO_MODEL: &str = {:?};\n", demo.trim());
    // The keys the firmware trusts: weights/test-signing-key.pub (hex; GPECNET_TRUSTED_KEY
    // names another file), or with `force-untrusted-key` RFC 8032's first test key only.
    println!("cargo:rerun-if-env-changed=GPECNET_TRUSTED_KEY");
    let key_file = env::var_os("GPECNET_TRUSTED_KEY")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("weights/test-signing-key.pub"));
    println!("cargo:rerun-if-changed={}", key_file.display());
    let hex = if env::var_os("CARGO_FEATURE_FORCE_UNTRUSTED_KEY").is_some() {
        "d75a980182b10ab7d54bfed3c964073a0ee172f3daa62325af021a68f707511a".to_string()
    } else {
        fs::read_to_string(&key_file)
            .unwrap_or_else(|e| panic!("{}: {e}", key_file.display()))
            .trim()
            .to_string()
    };
    assert!(
        hex.len() == 64 && hex.bytes().all(|b| b.is_ascii_hexdigit()),
        "{}: not a public key (64 hex digits)",
        key_file.display()
    );
    let key: Vec<String> = (0..32)
        .map(|i| format!("0x{}", &hex[2 * i..2 * i + 2]))
        .collect();
    src += &format!(
        "pub static TRUSTED_KEYS: &[gpecnet_core::blob::signed::TrustedKey] = &[gpecnet_core::blob::signed::TrustedKey::new([{}])];\n",
        key.join(", ")
    );
    // `force-rollback`: the stored minimum version starts above any shipped model's
    // (the signed ones are at 1 and 2), so the demo model is refused as rolled back.
    let floor = if env::var_os("CARGO_FEATURE_FORCE_ROLLBACK").is_some() {
        u32::MAX
    } else {
        0
    };
    src += &format!("pub static MIN_VERSION_FLOOR: u32 = {floor};\n");
    // The profile build's extra windows (timed track table, signature verification):
    // GPECNET_PROFILE_EXTRAS=1 (`cargo xtask profile`), off in the MCU x model table;
    // GPECNET_PROFILE_EXTRAS=online: the online forecaster's window after the models'.
    println!("cargo:rerun-if-env-changed=GPECNET_PROFILE_EXTRAS");
    println!("cargo::rustc-check-cfg=cfg(prof_extras)");
    println!("cargo::rustc-check-cfg=cfg(prof_online)");
    match env::var("GPECNET_PROFILE_EXTRAS").as_deref() {
        Ok("1") => println!("cargo:rustc-cfg=prof_extras"),
        // The online forecaster's window, in an image of its own: linked beside the
        // models' windows it would change how the compiler lays out their code.
        Ok("online") => println!("cargo:rustc-cfg=prof_online"),
        _ => {}
    }
    // Numeric path of the profile build (one sine per image, so flash/RAM are per path).
    println!("cargo:rerun-if-env-changed=GPECNET_SINE");
    println!(
        "cargo::rustc-check-cfg=cfg(prof_sine, values(\"libm\", \"fast-f32\", \"micromath\", \"q15-table\"))"
    );
    let sine = env::var("GPECNET_SINE").unwrap_or_else(|_| "libm".into());
    println!("cargo:rustc-cfg=prof_sine=\"{sine}\"");
    println!("cargo::rustc-check-cfg=cfg(model_pack)");
    match pack_len {
        Some(n) => {
            println!("cargo:rustc-cfg=model_pack");
            src += &format!(
                "/// The model pack's area, filled in by `cargo xtask qemu` after linking.\n\
                 #[no_mangle]\n\
                 #[link_section = \".rodata.gpecnet_model_pack\"]\n\
                 pub static GPECNET_MODEL_PACK: AlignedBlob<{n}> = AlignedBlob([0; {n}]);\n\
                 pub fn pack() -> Option<&'static [u8]> {{\n    \
                 // Opaque: the linked area holds zeros, the image that runs holds the pack.\n    \
                 Some(core::hint::black_box(&GPECNET_MODEL_PACK.0[..]))\n}}\n"
            );
        }
        None => src += "pub fn pack() -> Option<&'static [u8]> {\n    None\n}\n",
    }
    fs::write(out.join("models.rs"), src).unwrap();
    if names.is_empty() && pack_len.is_none() {
        println!("cargo:warning=no model blob in weights/ (weights/<name>.gpec + <name>.golden): golden mode will report 'no model' and fail");
    }
}
