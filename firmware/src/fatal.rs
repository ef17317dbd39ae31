//! Defined end states: normal exit, panic, HardFault.
//!
//! * QEMU (default): log with defmt, then semihosting `exit(code)`; QEMU quits
//!   with that status (0 = pass, 1 = fail/panic/fault).
//! * Real board (`--features board`): no semihosting (a semihosting call
//!   without a debugger attached would itself fault). Outputs are parked in a
//!   safe state (`park_outputs`, adapt to your board: motors/servos off,
//!   status LED on), then the MCU is reset via SYSRESETREQ after a fatal
//!   error, or sleeps forever (`wfi`) after a normal end.
use cortex_m_rt::{exception, ExceptionFrame};

/// Put actuators into a safe state. The reference design drives nothing;
/// on a real drone payload board set the GPIOs/PWM you own to their safe level
/// here with raw register writes (no allocation, no locks: this runs from the
/// panic and HardFault handlers).
#[inline(always)]
fn park_outputs() {}

pub fn exit(code: i32) -> ! {
    park_outputs();
    #[cfg(not(feature = "board"))]
    {
        use cortex_m_semihosting::debug;
        debug::exit(if code == 0 {
            debug::EXIT_SUCCESS
        } else {
            debug::EXIT_FAILURE
        });
    }
    #[cfg(feature = "board")]
    if code != 0 {
        cortex_m::peripheral::SCB::sys_reset();
    }
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(info));
    exit(1)
}

#[defmt::panic_handler]
fn defmt_panic() -> ! {
    exit(1)
}

#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    defmt::error!(
        "HardFault: pc={=u32:#010x} lr={=u32:#010x} hfsr={=u32:#010x} cfsr={=u32:#010x}",
        ef.pc(),
        ef.lr(),
        unsafe { core::ptr::read_volatile(0xE000_ED2C as *const u32) },
        unsafe { core::ptr::read_volatile(0xE000_ED28 as *const u32) }
    );
    exit(1)
}

/// `force-panic` / `force-hardfault`: prove the failure paths end in exit 1.
pub fn self_tests() {
    if cfg!(feature = "force-hardfault") {
        defmt::println!("force-hardfault: executing udf");
        // UsageFault (disabled) escalates to HardFault.
        cortex_m::asm::udf();
    }
    if cfg!(feature = "force-panic") {
        let v = core::hint::black_box(7u32);
        panic!("forced panic (v = {})", v);
    }
}
