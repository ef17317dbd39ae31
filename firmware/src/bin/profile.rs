//! Profiling: one K = 20 prediction per embedded model between the bench
//! markers, counted by the QEMU plugin (`cargo xtask profile`, `cargo xtask
//! qemu --all-targets`); the QEMU supervisor stays off so no interrupt lands
//! in the measured window.
#![no_std]
#![no_main]

use gpecnet_firmware::boot::Supervision;
use gpecnet_firmware::{firmware_main, profile};

firmware_main!(Supervision::BoardOnly, |_spawner| profile::run());
