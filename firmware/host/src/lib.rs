//! The firmware's target-independent modules, compiled for the host with the
//! stable toolchain, so their `#[cfg(test)]` unit tests run with a std test
//! harness (`cargo xtask fw-test`) and the host golden run shares the exact
//! verification code of the firmware (`golden-host`, used by `cargo xtask qemu`).
#![cfg_attr(not(test), no_std)]

#[path = "../../src/golden.rs"]
pub mod golden;
