//! Stack high-water mark: paint the free stack with a pattern at boot, find
//! the lowest overwritten word at the end.
//!
//! cortex-m-rt places the stack at `_stack_start` (top of RAM, see memory.x)
//! growing down towards `__sheap` (the end of .bss/.uninit). Everything
//! between is stack headroom.
const PATTERN: u32 = 0xC0DE_5AA5;

extern "C" {
    static mut __sheap: u32;
    static mut _stack_start: u32;
}

fn bottom() -> usize {
    (core::ptr::addr_of!(__sheap) as usize + 3) & !3
}

fn top() -> usize {
    core::ptr::addr_of!(_stack_start) as usize
}

/// Stack region size (bytes): top of RAM down to the end of static data.
pub fn size() -> usize {
    top() - bottom()
}

/// Paint from the bottom of the stack region up to just below the current
/// stack pointer. Call first thing in `main`.
#[inline(never)]
pub fn paint() {
    let sp = cortex_m::register::msp::read() as usize;
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
    let sp = cortex_m::register::msp::read() as usize;
    let end = (sp - 64) & !3;
    let mut p = bottom();
    while p < end {
        unsafe { core::ptr::write_volatile(p as *mut u32, PATTERN) };
        p += 4;
    }
    top() - sp
}
