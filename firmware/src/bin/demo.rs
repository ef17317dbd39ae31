//! The tracker demo: `ingest` -> track table -> `predict` -> `report` over a
//! scripted 24-frame scene (see `gpecnet_firmware::demo`).
#![no_std]
#![no_main]

use gpecnet_firmware::boot::Supervision;
use gpecnet_firmware::{demo, firmware_main};

firmware_main!(Supervision::On, |spawner| demo::run(spawner).await);
