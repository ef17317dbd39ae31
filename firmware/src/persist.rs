//! The minimum model version the firmware accepts, kept where it survives a
//! reset, and raised only after a model with a higher version verified
//! (rollback protection for signed weights).
//!
//! Here it lives in RAM the runtime never zeroes (cortex-m-rt's `.uninit`
//! section), behind a magic word: it survives a warm reset (watchdog, fault)
//! but not a power cycle, and QEMU starts every run with zeroed RAM, so in
//! the emulator it is the simulated store the fault proofs need. On a board,
//! put it in a backup register (RTC backup domain, kept on VBAT) or a flash
//! page written only by [`raise_min_version`]; nothing else changes.
use core::mem::MaybeUninit;
use core::ptr::{addr_of, addr_of_mut};

/// "GPMV": the store holds a version.
const MAGIC: u32 = 0x564d_5047;

#[link_section = ".uninit.gpecnet_min_version"]
static mut STORE: MaybeUninit<[u32; 2]> = MaybeUninit::uninit();

/// The lowest model version this firmware accepts: the stored one (0 when
/// none is stored), at least the build's floor (`force-rollback` proofs).
pub fn min_version() -> u32 {
    // SAFETY: a volatile read of two words of this static (single core, no
    // concurrent writer: only the boot sequence calls into this module); an
    // uninitialised value is caught by the magic word.
    let [magic, v] = unsafe { addr_of!(STORE).cast::<[u32; 2]>().read_volatile() };
    let stored = if magic == MAGIC { v } else { 0 };
    stored.max(crate::models::MIN_VERSION_FLOOR)
}

/// Stores `version` as the minimum when it is higher than the stored one.
/// Call only after a model of that version verified.
pub fn raise_min_version(version: u32) {
    if version > min_version() {
        // SAFETY: as in `min_version`; a volatile write of this static's two words.
        unsafe {
            addr_of_mut!(STORE)
                .cast::<[u32; 2]>()
                .write_volatile([MAGIC, version])
        };
    }
}
