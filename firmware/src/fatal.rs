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

#[cfg(armv6m)]
#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    // ARMv6-M has no fault status registers (CFSR/HFSR) and no MPU guard: the
    // frame is readable unless the stack itself is gone, which this core cannot tell.
    defmt::error!(
        "HardFault: pc={=u32:#010x} lr={=u32:#010x}",
        ef.pc(),
        ef.lr()
    );
    exit(1)
}

#[cfg(not(armv6m))]
#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    // SAFETY: CFSR (0xE000_ED28) and HFSR (0xE000_ED2C) are always-readable
    // System Control Block registers.
    let (cfsr, hfsr) = unsafe {
        (
            core::ptr::read_volatile(0xE000_ED28 as *const u32),
            core::ptr::read_volatile(0xE000_ED2C as *const u32),
        )
    };
    // A stack overflow that escalated here: the exception frame could not be
    // pushed (MSTKERR bit 4, STKERR bit 12) or lies below the task stack (in the
    // guard). Reading it would fault again and lock the core up, so it is not read.
    let frame = ef as *const ExceptionFrame as usize;
    if cfsr & ((1 << 4) | (1 << 12)) != 0 || frame < crate::guard::task_stack().0 {
        defmt::error!(
            "HardFault: stack overflow (frame at {=u32:#010x} below the task stack) hfsr={=u32:#010x} cfsr={=u32:#010x}",
            frame as u32,
            hfsr,
            cfsr
        );
        exit(1)
    }
    defmt::error!(
        "HardFault: pc={=u32:#010x} lr={=u32:#010x} hfsr={=u32:#010x} cfsr={=u32:#010x}",
        ef.pc(),
        ef.lr(),
        hfsr,
        cfsr
    );
    exit(1)
}

/// MemManage: with the guard of [`crate::guard`] armed, a stack overflow ends
/// here (a stacking error, or a data access into the guard region); the
/// handler runs on the main stack, which the overflow cannot reach.
#[cfg(has_mpu)]
#[exception]
unsafe fn MemoryManagement() -> ! {
    // SAFETY: CFSR (0xE000_ED28) and MMFAR (0xE000_ED34) are always-readable
    // System Control Block registers.
    let (cfsr, mmfar) = unsafe {
        (
            core::ptr::read_volatile(0xE000_ED28 as *const u32),
            core::ptr::read_volatile(0xE000_ED34 as *const u32),
        )
    };
    let guard = crate::guard::guard_base() as u32;
    // MSTKERR (bit 4): the exception entry could not push; MMARVALID (bit 7) with
    // MMFAR in the guard: a store into it.
    let in_guard =
        cfsr & (1 << 7) != 0 && (guard..guard + crate::guard::GUARD as u32).contains(&mmfar);
    if cfsr & (1 << 4) != 0 || in_guard {
        defmt::error!(
            "stack overflow: the task stack ran into its guard (cfsr={=u32:#010x} mmfar={=u32:#010x})",
            cfsr,
            mmfar
        );
    } else {
        defmt::error!(
            "MemManage fault: cfsr={=u32:#010x} mmfar={=u32:#010x}",
            cfsr,
            mmfar
        );
    }
    exit(1)
}

/// Uses stack without bound (each frame keeps a 256-byte array alive).
#[inline(never)]
fn recurse(n: u32) -> u32 {
    let buf = core::hint::black_box([n; 64]);
    if n == 0 {
        0
    } else {
        recurse(n - 1).wrapping_add(buf[3])
    }
}

/// The fault a `fault-injection` image injects, by name, zero-padded: `cargo
/// xtask fw-faults` links one such image and writes `panic`, `hardfault`,
/// `stack-overflow` or `hang` into a copy of it per proof (all zeros: none),
/// as the golden replay writes its model pack. A linked-in constant would
/// need one build per fault.
#[cfg(feature = "fault-injection")]
#[no_mangle]
#[used]
pub static GPECNET_FAULT: [u8; 16] = [0; 16];

/// The injected fault's name (empty: none, and always without `fault-injection`).
fn injected_fault() -> &'static [u8] {
    #[cfg(feature = "fault-injection")]
    {
        // Read through `black_box`: the area's bytes are written after linking.
        let area: &'static [u8; 16] = core::hint::black_box(&GPECNET_FAULT);
        let len = area.iter().position(|&b| b == 0).unwrap_or(area.len());
        &area[..len]
    }
    #[cfg(not(feature = "fault-injection"))]
    {
        &[]
    }
}

/// Injects the fault [`GPECNET_FAULT`] names (`fault-injection` images): each
/// proves its failure path ends in exit 1 (a corrupted blob is proven on the
/// same image through its model pack: the golden run rejects it).
pub fn self_tests() {
    let fault = injected_fault();
    match fault {
        b"" => {}
        b"stack-overflow" => {
            defmt::println!("fault-injection stack-overflow: recursing");
            let r = recurse(core::hint::black_box(u32::MAX));
            defmt::error!("fault-injection stack-overflow: returned {=u32}", r);
        }
        b"hardfault" => {
            defmt::println!("fault-injection hardfault: executing udf");
            // UsageFault (disabled) escalates to HardFault.
            cortex_m::asm::udf();
        }
        b"hang" => {
            defmt::println!("fault-injection hang: spinning without feeding the watchdog");
            loop {
                core::hint::spin_loop();
            }
        }
        b"panic" => {
            let v = core::hint::black_box(7u32);
            panic!("forced panic (v = {})", v);
        }
        other => {
            defmt::error!("fault-injection: unknown fault {=[u8]:a}", other);
            exit(1)
        }
    }
}
