//! Golden verification: every golden case of every embedded model, bit for
//! bit against its sidecar (what `cargo xtask qemu` runs and compares with
//! the host).
#![no_std]
#![no_main]

use embassy_executor::Spawner;
use gpecnet_firmware::boot::{self, Supervision};
use gpecnet_firmware::{firmware_main, golden_run};

firmware_main!(Supervision::On, supervisor);

#[embassy_executor::task]
async fn supervisor(_spawner: Spawner) {
    boot::banner();
    boot::finish(golden_run::run())
}
