//! Stack-overflow guard: a stack overflow faults with a working handler
//! instead of running the stack pointer down through static data.
//!
//! Layout (RAM, cortex-m-rt conventions; `_stack_start` = top of RAM):
//!
//! ```text
//! _stack_start ┬ main stack (MSP): exception handlers only, HANDLER_STACK bytes
//!              ├ task stack (PSP): `main` after `run_guarded`, the executor, every task
//! guard + 32   ┤
//!              ├ guard: 32 bytes, MPU region 0, no access (aligned up from __sheap)
//! __sheap      ┴ end of .data/.bss
//! ```
//!
//! Thread mode runs on the process stack (PSP). When it overflows, the first
//! store into the guard raises a MemManage fault (data access violation, or a
//! stacking error when the exception entry itself cannot push); the handler
//! runs on the main stack (MSP), which is intact, logs `stack overflow`, parks
//! the outputs and ends the run with exit 1 (`fatal`). Without the guard the
//! same overflow would silently corrupt .bss and end in a lockup.
//!
//! Chips without an MPU (`cfg(not(has_mpu))`, the Cortex-M0 nRF51) run
//! everything on the main stack, unguarded; see [`task_stack`].
//!
//! `unsafe` here: MPU/SCB register writes and the switch of stack pointers,
//! each with its SAFETY note.

#[cfg(has_mpu)]
use core::arch::asm;

/// Bytes of the main stack kept for exception handlers.
#[cfg(has_mpu)]
pub const HANDLER_STACK: usize = 2048;
/// Size of the guard region (the MPU's smallest region; without an MPU, the
/// alignment of the stack's bottom).
pub const GUARD: usize = 32;

extern "C" {
    static mut __sheap: u32;
    static mut _stack_start: u32;
}

/// The guard region's base: `__sheap` rounded up to [`GUARD`].
pub fn guard_base() -> usize {
    (core::ptr::addr_of!(__sheap) as usize + GUARD - 1) & !(GUARD - 1)
}

/// The task stack: `(lowest usable address, top)`.
#[cfg(has_mpu)]
pub fn task_stack() -> (usize, usize) {
    let top = (core::ptr::addr_of!(_stack_start) as usize - HANDLER_STACK) & !7;
    (guard_base() + GUARD, top)
}

/// The stack without an MPU (Cortex-M0, feature `chip-nrf51`): everything
/// from the end of static data to the top of RAM, one stack for tasks and
/// handlers, no guard. An overflow there runs into .bss unnoticed; the
/// high-water mark of every run (`stack::high_water`) shows the margin.
#[cfg(not(has_mpu))]
pub fn task_stack() -> (usize, usize) {
    let top = core::ptr::addr_of!(_stack_start) as usize & !7;
    (guard_base(), top)
}

/// Without an MPU there is nothing to arm: runs `f` on the main stack.
#[cfg(not(has_mpu))]
pub fn run_guarded(f: extern "C" fn() -> !) -> ! {
    f()
}

/// Arms the guard and continues in `f` on the task stack; never returns.
#[cfg(has_mpu)]
/// Call first thing in `main` (after painting the stack), while nothing on
/// the main stack needs to survive.
pub fn run_guarded(f: extern "C" fn() -> !) -> ! {
    let base = guard_base() as u32;
    let (_, top) = task_stack();
    // SAFETY: the MPU and SCB registers are written once, at boot, before any
    // task runs and with interrupts not yet using the region. Region 0 covers
    // [base, base + 32): base is 32-byte aligned (RBAR needs a size-aligned
    // base), RASR = XN | AP 000 (no access) | SIZE 4 (2^(4+1) = 32 bytes) |
    // ENABLE. CTRL = ENABLE | PRIVDEFENA keeps the default memory map for
    // everything else (the firmware runs privileged). SHCSR.MEMFAULTENA (bit
    // 16) makes the fault a MemManage instead of escalating to HardFault.
    unsafe {
        let mpu = &*cortex_m::peripheral::MPU::PTR;
        mpu.rnr.write(0);
        mpu.rbar.write(base);
        mpu.rasr.write((1 << 28) | (4 << 1) | 1);
        mpu.ctrl.write(0b101);
        let scb = &*cortex_m::peripheral::SCB::PTR;
        scb.shcsr.modify(|v| v | (1 << 16));
    }
    cortex_m::asm::dsb();
    cortex_m::asm::isb();
    // SAFETY: sets PSP to the top of the task stack (8-byte aligned, inside
    // RAM, above the guard), selects it for thread mode (CONTROL.SPSEL = 1,
    // privileged, FP context inactive) and branches to `f`, which never
    // returns. Nothing on the main stack is used afterwards except by
    // exception handlers, which always run on MSP.
    unsafe {
        asm!(
            "msr psp, {top}",
            "msr control, {two}",
            "isb",
            "bx {f}",
            top = in(reg) top,
            two = in(reg) 2u32,
            f = in(reg) f,
            options(noreturn)
        );
    }
}
