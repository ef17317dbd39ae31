//! Independent watchdog (IWDG) of the STM32F405, for the real-board build
//! (`--features board`): a hung task (a deadlock, a runaway loop) resets the
//! MCU after [`TIMEOUT_MS`] instead of leaving the outputs in their last state.
//! Without `board` both functions do nothing: QEMU's `netduinoplus2` does not
//! model the IWDG, and the QEMU runs are bounded by the runner's timeout.
//!
//! Untested on hardware (no board in CI); register values from RM0090 §21:
//! the IWDG runs from the ~32 kHz LSI; prescaler /64 (PR = 4) gives 2 ms per
//! tick, reload 1000 gives ~2 s (LSI tolerance 17–47 kHz: 1.4–3.8 s).

/// Nominal watchdog timeout (LSI at 32 kHz).
pub const TIMEOUT_MS: u32 = 2000;

#[cfg(feature = "board")]
const IWDG: usize = 0x4000_3000;

/// Starts the watchdog (cannot be stopped again until reset).
pub fn start() {
    #[cfg(feature = "board")]
    // SAFETY: IWDG_KR (+0), IWDG_PR (+4) and IWDG_RLR (+8) are the documented
    // IWDG registers; 0xCCCC starts it, 0x5555 unlocks PR/RLR, 0xAAAA reloads.
    unsafe {
        let reg = |off: usize| (IWDG + off) as *mut u32;
        core::ptr::write_volatile(reg(0), 0xCCCC);
        core::ptr::write_volatile(reg(0), 0x5555);
        core::ptr::write_volatile(reg(4), 4);
        core::ptr::write_volatile(reg(8), TIMEOUT_MS / 2);
        core::ptr::write_volatile(reg(0), 0xAAAA);
    }
}

/// Reloads the watchdog: call at least every [`TIMEOUT_MS`] from the main loop.
#[inline]
pub fn feed() {
    #[cfg(feature = "board")]
    // SAFETY: writing 0xAAAA to IWDG_KR reloads the counter; no other effect.
    unsafe {
        core::ptr::write_volatile(IWDG as *mut u32, 0xAAAA);
    }
}
