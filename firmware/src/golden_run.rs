//! The golden mode: [`crate::golden::verify_all`] over every embedded model
//! (or [`crate::golden::verify_pack`] over the image's model pack),
//! each result printed as one defmt line (the lines `cargo xtask qemu`
//! compares with the host's `golden-host` run), then the totals.
//!
//! The text is [`crate::golden::Line::print`]'s (what the host prints), here
//! with typed defmt arguments instead of `core::fmt`: the Cortex-M0's golden
//! run peaks within about 600 B of its 16 KiB, and `core::fmt` in the
//! per-case callback overflows it.

/// Golden verification of every embedded model, one defmt line per model
/// and case (the lines `cargo xtask qemu` compares with the host's); `true`
/// when every case matched.
pub fn run() -> bool {
    let mut out = |l: crate::golden::Line<'_>| {
        crate::watchdog::feed();
        print(l)
    };
    let s = match crate::models::pack() {
        // An image linked for a model pack (`cargo xtask qemu`): the models xtask wrote into it.
        Some(pack) => crate::golden::verify_pack::<{ crate::SCRATCH }, { crate::ONLINE_SCENE }>(
            pack, true, &mut out,
        ),
        None if crate::models::MODELS.is_empty() => {
            defmt::error!("golden: no model embedded (weights/<name>.gpec + weights/<name>.golden missing at build time)");
            return false;
        }
        None => crate::golden::verify_all::<{ crate::SCRATCH }, { crate::ONLINE_SCENE }>(
            crate::models::MODELS,
            true,
            &mut out,
        ),
    };
    crate::golden::resample_scene(&mut print);
    // The synthetic flight's camera stage, where the golden image has room for it (the
    // Cortex-M0 plays it in the online loop's image, `online`).
    if crate::ONLINE_SCENE {
        crate::golden::flight_scene(&mut print);
    }
    defmt::println!(
        "golden summary: models={=u32} cases={=u32} mismatches={=u32} errors={=u32} xchecks={=u32}",
        s.models,
        s.cases,
        s.mismatches,
        s.errors,
        s.xchecks
    );
    s.ok()
}

/// The online loop's streamed scene alone ([`crate::golden::online_scene`]
/// on [`crate::golden::ONLINE_MODEL`], one defmt line per camera frame, the
/// lines `cargo xtask qemu` compares with the host's), after the synthetic
/// flight's camera stage ([`crate::golden::flight_scene`]): the image of a
/// class whose golden image leaves both out ([`crate::ONLINE_SCENE`]). It
/// embeds the scene's model alone, without its golden file, so the loop's
/// code fits the Cortex-M0's flash; `true` when the scene ran to its end.
pub fn online() -> bool {
    let model = crate::golden::ONLINE_MODEL;
    let Some(&(name, blob)) = crate::models::BLOBS.iter().find(|(n, _)| *n == model) else {
        defmt::error!(
            "online: model {=str} not embedded (build with GPECNET_MODELS={=str})",
            model,
            model
        );
        return false;
    };
    let mut out = |l: crate::golden::Line<'_>| {
        crate::watchdog::feed();
        print(l)
    };
    // The synthetic flight's camera stage first: the golden image of this class has no
    // flash for the camera module beside its models.
    crate::golden::flight_scene(&mut print);
    match crate::golden::online_scene::<{ crate::SCRATCH }>(name, blob, &mut out) {
        Ok(()) => {
            defmt::println!(
                "scene: online loop, {=u32} frames",
                crate::golden::ONLINE_FRAMES
            );
            true
        }
        Err(what) => {
            defmt::error!("golden {=str}: {=str}", name, what);
            false
        }
    }
}

/// One result line as defmt text (the same text as the host's `Line::print`).
/// The variants' fields are named again here, not shared with the host's
/// printer: defmt's format strings take typed arguments at the call, and the
/// host's `format_args!` text would pull `core::fmt` onto the Cortex-M0's stack.
fn print(l: crate::golden::Line<'_>) {
    use crate::golden::Line;
    match l {
        Line::Model {
            model,
            numeric,
            sine,
            cases,
        } => defmt::println!(
            "model {=str} {=str} {=str} {=u32}",
            model,
            numeric,
            sine,
            cases
        ),
        Line::Golden {
            model,
            case,
            hash,
            ok,
        } => {
            defmt::println!("golden {=str} {=u32} {=u32:08x}", model, case, hash);
            if !ok {
                defmt::error!("MISMATCH {=str} case {=u32}", model, case);
            }
        }
        Line::Xcheck {
            model,
            sine,
            case,
            hash,
        } => {
            defmt::println!(
                "xcheck {=str} {=str} {=u32} {=u32:08x}",
                model,
                sine,
                case,
                hash
            )
        }
        Line::Resample {
            frames,
            points,
            hash,
        } => defmt::println!("resample {=u32} {=u32} {=u32:08x}", frames, points, hash),
        Line::Flight {
            frames,
            detections,
            points,
            hash,
        } => defmt::println!(
            "flight {=u32} {=u32} {=u32} {=u32:08x}",
            frames,
            detections,
            points,
            hash
        ),
        Line::Online {
            model,
            frame,
            t_ms,
            forecasts,
            feedback,
            hash,
        } => defmt::println!(
            "online {=str} {=u32} {=u32} {=u32} {=u32} {=u32:08x}",
            model,
            frame,
            t_ms,
            forecasts,
            feedback,
            hash
        ),
        Line::Error { model, what } => defmt::error!("golden {=str}: {=str}", model, what),
        Line::TooWide {
            model,
            needed,
            capacity,
        } => defmt::error!(
            "golden {=str}: model needs scratch width {=u32} > SCRATCH {=u32} (firmware/src/lib.rs)",
            model,
            needed,
            capacity
        ),
    }
}
