//! What the examples share: the shipped MCU model, linked in and read in place.

/// 8-byte aligned storage: a format-3 blob's tensors start at multiples of 4
/// from its first byte, so at an aligned address the Cortex-M4/M7 kernels can
/// use word loads (`include_bytes!` alone has alignment 1; any address works,
/// only slower).
#[repr(C, align(8))]
pub struct Aligned<T>(pub T);

/// The blob's bytes in aligned storage.
static ALIGNED: Aligned<[u8; include_bytes!("../../../weights/sdd-tiny-v2-qe.gpec").len()]> =
    Aligned(*include_bytes!("../../../weights/sdd-tiny-v2-qe.gpec"));

/// The shipped MCU model (`weights/sdd-tiny-v2-qe.gpec`); on a microcontroller it stays in
/// flash.
pub static BLOB: &[u8] = &ALIGNED.0;
