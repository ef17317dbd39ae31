//! The tracker demo: `ingest` -> track table -> `predict` -> `report` over a
//! scripted 24-frame scene (see `gpecnet_firmware::demo`).
#![no_std]
#![no_main]

use embassy_executor::Spawner;
use gpecnet_firmware::boot::{self, Supervision};
use gpecnet_firmware::{demo, firmware_main};

firmware_main!(Supervision::On, supervisor);

#[embassy_executor::task]
async fn supervisor(spawner: Spawner) {
    boot::banner();
    boot::finish(demo::run(spawner).await)
}
