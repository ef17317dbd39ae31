//! Profiling: one K = 20 prediction per embedded model between the bench
//! markers, counted by the QEMU plugin (`cargo xtask profile`, `cargo xtask
//! qemu --all-targets`); the QEMU supervisor stays off so no interrupt lands
//! in the measured window.
#![no_std]
#![no_main]

use gpecnet_firmware::boot::{self, Supervision};
use gpecnet_firmware::profile;

#[cortex_m_rt::entry]
fn main() -> ! {
    boot::start(tasks)
}

extern "C" fn tasks() -> ! {
    boot::executor(Supervision::BoardOnly, |s| s.spawn(supervisor().unwrap()))
}

#[embassy_executor::task]
async fn supervisor() {
    boot::banner();
    boot::finish(profile::run())
}
