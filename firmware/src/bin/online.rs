//! The online loop's streamed scene in an image of its own
//! ([`gpecnet_firmware::golden_run::online`]): for an MCU class whose golden
//! image has no room for the loop beside every golden case (the Cortex-M0).
//! Built with `GPECNET_MODELS=sdd-m-lp-qe`, the scene's one model, by
//! `cargo xtask qemu`.
#![no_std]
#![no_main]

use gpecnet_firmware::boot::Supervision;
use gpecnet_firmware::{firmware_main, golden_run};

firmware_main!(Supervision::On, |_spawner| golden_run::online());
