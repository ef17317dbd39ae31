//! Golden verification: every golden case of every embedded model, bit for
//! bit against its sidecar (what `cargo xtask qemu` runs and compares with
//! the host).
#![no_std]
#![no_main]

use gpecnet_firmware::boot::{self, Supervision};
use gpecnet_firmware::golden_run;

#[cortex_m_rt::entry]
fn main() -> ! {
    boot::start(tasks)
}

extern "C" fn tasks() -> ! {
    boot::executor(Supervision::On, |s| s.spawn(supervisor().unwrap()))
}

#[embassy_executor::task]
async fn supervisor() {
    boot::banner();
    boot::finish(golden_run::run())
}
