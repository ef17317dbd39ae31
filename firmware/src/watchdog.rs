//! Catching a hung task (a deadlock, a runaway loop): [`start`] once, then
//! [`feed`] from the work loop (each demo frame, golden line, profiled model).
//!
//! * Real board (`--features board`): the chip's independent watchdog resets
//!   the MCU about [`TIMEOUT_MS`] after the last feed, instead of leaving the
//!   outputs in their last state.
//! * QEMU (default): the machines do not model these watchdogs, so a
//!   timer-driven supervisor stands in: SysTick interrupts every 10 ms of
//!   emulated time, and when [`QEMU_TIMEOUT_MS`] pass without a feed its
//!   handler logs `watchdog: no feed ... a task hung` and ends the run in the
//!   defined fatal state (exit 1). `cargo xtask fw-faults` proves it with
//!   an injected `hang` (`fault-injection`). The `profile` binary leaves SysTick off, so no
//!   interrupt lands in the measured instruction window.
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

/// Timeout of the QEMU supervisor: generous, because emulated time runs at
/// the host's pace and a busy CI machine slows the guest down.
#[cfg(not(feature = "board"))]
pub const QEMU_TIMEOUT_MS: u32 = 10_000;

/// Core clock the QEMU machine gives SysTick (its processor clock source).
#[cfg(all(not(feature = "board"), feature = "chip-nrf51"))]
const CPU_HZ: u32 = 16_000_000;
#[cfg(all(not(feature = "board"), feature = "chip-mps2-an500"))]
const CPU_HZ: u32 = 25_000_000;
#[cfg(all(
    not(feature = "board"),
    not(any(feature = "chip-nrf51", feature = "chip-mps2-an500"))
))]
const CPU_HZ: u32 = 168_000_000;

/// SysTick periods (10 ms) since [`start`], counted by the handler only.
#[cfg(not(feature = "board"))]
static TICKS: core::sync::atomic::AtomicU32 = core::sync::atomic::AtomicU32::new(0);
/// [`TICKS`] at the last [`feed`].
#[cfg(not(feature = "board"))]
static FED_AT: core::sync::atomic::AtomicU32 = core::sync::atomic::AtomicU32::new(0);

/// The QEMU supervisor: counts 10 ms periods and ends the run when the work
/// loop has not fed for [`QEMU_TIMEOUT_MS`]. Load/store only (no
/// read-modify-write atomics, which the Cortex-M0 lacks): only this handler
/// writes `TICKS`, only `feed` writes `FED_AT`.
#[cfg(not(feature = "board"))]
#[cortex_m_rt::exception]
fn SysTick() {
    use core::sync::atomic::Ordering::Relaxed;
    let now = TICKS.load(Relaxed).wrapping_add(1);
    TICKS.store(now, Relaxed);
    let idle = now.wrapping_sub(FED_AT.load(Relaxed));
    if idle.saturating_mul(10) >= QEMU_TIMEOUT_MS {
        defmt::error!(
            "watchdog: no feed for {=u32} ms: a task hung",
            idle.saturating_mul(10)
        );
        crate::fatal::exit(1);
    }
}

/// Starts the watchdog (cannot be stopped again until reset). `supervise`:
/// also the QEMU supervisor (not in the profile binary: an interrupt inside
/// the measured window would add its instructions to the count; the
/// runner's timeout bounds that run).
pub fn start(supervise: bool) {
    #[cfg(not(feature = "board"))]
    if supervise {
        // SAFETY: the SysTick registers are owned by this module alone (nothing
        // else in the firmware uses SysTick, embassy-time is not linked); they are
        // programmed once, here, before the executor starts.
        let mut syst = unsafe { cortex_m::Peripherals::steal() }.SYST;
        syst.set_clock_source(cortex_m::peripheral::syst::SystClkSource::Core);
        syst.set_reload(CPU_HZ / 100 - 1);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
    }
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
    #[cfg(not(feature = "board"))]
    FED_AT.store(
        TICKS.load(core::sync::atomic::Ordering::Relaxed),
        core::sync::atomic::Ordering::Relaxed,
    );
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
