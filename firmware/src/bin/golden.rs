//! Golden verification: every golden case of every embedded model, bit for
//! bit against its sidecar (what `cargo xtask qemu` runs and compares with
//! the host).
#![no_std]
#![no_main]

use gpecnet_firmware::boot::Supervision;
use gpecnet_firmware::{firmware_main, golden_run};

firmware_main!(Supervision::On, |_spawner| golden_run::run());
