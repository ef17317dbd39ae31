//! Stack high-water mark: paint the free stack with a pattern at boot, find
//! the lowest overwritten word at the end.
//!
//! The tasks' stack is the process stack of [`crate::guard`]: from just
//! above the guard region (which sits on `__sheap`, the end of .data/.bss) up
//! to `_stack_start − HANDLER_STACK`; the top of RAM above it is the
//! exception handlers' main stack.
const PATTERN: u32 = 0xC0DE_5AA5;

fn bottom() -> usize {
    crate::guard::task_stack().0
}

fn top() -> usize {
    crate::guard::task_stack().1
}

/// The stack pointer in use (PSP once `guard::run_guarded` switched to it).
fn sp() -> usize {
    if cortex_m::register::control::read().spsel() == cortex_m::register::control::Spsel::Psp {
        cortex_m::register::psp::read() as usize
    } else {
        cortex_m::register::msp::read() as usize
    }
}

/// Stack region size (bytes): top of RAM down to the end of static data.
pub fn size() -> usize {
    top() - bottom()
}

/// Paint from the bottom of the stack region up to just below the current
/// stack pointer. Call first thing in `main`.
#[inline(never)]
pub fn paint() {
    let sp = sp();
    let end = (sp - 64) & !3; // margin for this function's own frame
    let mut p = bottom();
    while p < end {
        unsafe { core::ptr::write_volatile(p as *mut u32, PATTERN) };
        p += 4;
    }
}

/// Bytes of stack used so far (maximum depth since `paint`).
pub fn high_water() -> usize {
    let mut p = bottom();
    let t = top();
    while p < t && unsafe { core::ptr::read_volatile(p as *const u32) } == PATTERN {
        p += 4;
    }
    t - p
}

/// Re-paint the unused stack below the caller, returning the depth in use
/// now (bytes from the top), so `high_water() - base` is what the code run
/// after this call added.
#[inline(never)]
#[allow(dead_code)]
pub fn repaint() -> usize {
    let sp = sp();
    let end = (sp - 64) & !3;
    let mut p = bottom();
    while p < end {
        unsafe { core::ptr::write_volatile(p as *mut u32, PATTERN) };
        p += 4;
    }
    top() - sp
}
