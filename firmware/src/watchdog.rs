//! Independent watchdog for the real-board build (`--features board`): a hung
//! task (a deadlock, a runaway loop) resets the MCU after about
//! [`TIMEOUT_MS`] instead of leaving the outputs in their last state.
//! Without `board` both functions do nothing: the QEMU machines do not model
//! these watchdogs, and the QEMU runs are bounded by the runner's timeout.
//!
//! Untested on hardware (no board in CI). Per chip:
//! * STM32F405 / STM32F767 (`chip-stm32f405`, `chip-stm32f767`): the IWDG at
//!   0x4000_3000 (RM0090 §21, RM0410 §33; same registers on both). It runs
//!   from the ~32 kHz LSI; prescaler /64 (PR = 4) gives 2 ms per tick, reload
//!   1000 gives ~2 s (LSI tolerance 17–47 kHz: 1.4–3.8 s).
//! * nRF51822 (`chip-nrf51`): the WDT at 0x4001_0000 (nRF51 reference manual
//!   §25), counting the 32.768 kHz low-frequency clock it starts itself;
//!   CRV = 2 s × 32 768, reload register RR[0] only.
//! * MPS2 AN500 (`chip-mps2-an500`, QEMU only): none.

/// Nominal watchdog timeout.
#[cfg_attr(not(feature = "board"), allow(dead_code))]
pub const TIMEOUT_MS: u32 = 2000;

#[cfg(all(
    feature = "board",
    any(feature = "chip-stm32f405", feature = "chip-stm32f767")
))]
const IWDG: usize = 0x4000_3000;
#[cfg(all(feature = "board", feature = "chip-nrf51"))]
const WDT: usize = 0x4001_0000;
/// The value that reloads the nRF51 WDT when written to RR[n].
#[cfg(all(feature = "board", feature = "chip-nrf51"))]
const WDT_RELOAD: u32 = 0x6E52_4635;

/// Starts the watchdog (cannot be stopped again until reset).
pub fn start() {
    #[cfg(all(
        feature = "board",
        any(feature = "chip-stm32f405", feature = "chip-stm32f767")
    ))]
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
    #[cfg(all(feature = "board", feature = "chip-nrf51"))]
    // SAFETY: the documented WDT registers: CRV (+0x504, reload value in
    // 32.768 kHz ticks), RREN (+0x508, bit 0 enables RR[0]) are written while
    // the WDT is stopped (they are locked once it runs); TASKS_START (+0)
    // starts it.
    unsafe {
        let reg = |off: usize| (WDT + off) as *mut u32;
        core::ptr::write_volatile(reg(0x504), TIMEOUT_MS * 32_768 / 1000);
        core::ptr::write_volatile(reg(0x508), 1);
        core::ptr::write_volatile(reg(0), 1);
    }
}

/// Reloads the watchdog: call at least every [`TIMEOUT_MS`] from the main loop.
#[inline]
pub fn feed() {
    #[cfg(all(
        feature = "board",
        any(feature = "chip-stm32f405", feature = "chip-stm32f767")
    ))]
    // SAFETY: writing 0xAAAA to IWDG_KR reloads the counter; no other effect.
    unsafe {
        core::ptr::write_volatile(IWDG as *mut u32, 0xAAAA);
    }
    #[cfg(all(feature = "board", feature = "chip-nrf51"))]
    // SAFETY: writing the reload value to RR[0] (+0x600) reloads the counter.
    unsafe {
        core::ptr::write_volatile((WDT + 0x600) as *mut u32, WDT_RELOAD);
    }
}
