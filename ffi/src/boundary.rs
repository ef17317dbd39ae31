//! What every entry point does at the C boundary: run its body so that a
//! panic becomes a status code, refuse NULL pointers, copy points in and out
//! of C memory of any alignment, and cut names into fixed-size C strings.
use core::ffi::c_char;

use crate::status::{GPECNET_E_NULL_POINTER, GPECNET_OK};
// Only the std build catches panics (the docs name the code on every build).
#[cfg(any(feature = "std", doc))]
use crate::status::GPECNET_E_PANIC;

/// Runs the body of an entry point: [`GPECNET_OK`] when `f` succeeds, its status code when
/// it fails, and [`GPECNET_E_PANIC`] for a panic where std can catch it.
#[inline]
pub(crate) fn guard(f: impl FnOnce() -> Result<(), i32>) -> i32 {
    let status = || match f() {
        Ok(()) => GPECNET_OK,
        Err(e) => e,
    };
    #[cfg(feature = "std")]
    {
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(status)).unwrap_or(GPECNET_E_PANIC)
    }
    #[cfg(not(feature = "std"))]
    {
        status()
    }
}

/// [`GPECNET_E_NULL_POINTER`] when `p` is NULL.
#[inline]
pub(crate) fn non_null<T>(p: *const T) -> Result<(), i32> {
    if p.is_null() {
        Err(GPECNET_E_NULL_POINTER)
    } else {
        Ok(())
    }
}

/// Copies `n` points from C memory (any alignment) into a local buffer.
///
/// # Safety
/// `xy` is non-null and valid for reads of `2·n` floats, `n <= N`.
pub(crate) unsafe fn read_points<const N: usize>(xy: *const f32, n: usize) -> [[f32; 2]; N] {
    let mut out = [[0.0f32; 2]; N];
    for (i, o) in out.iter_mut().take(n).enumerate() {
        // SAFETY: i < n, and the caller guarantees 2·n readable floats.
        *o = unsafe {
            [
                xy.add(2 * i).read_unaligned(),
                xy.add(2 * i + 1).read_unaligned(),
            ]
        };
    }
    out
}

/// Writes points to C memory (any alignment).
///
/// # Safety
/// `xy` is non-null and valid for writes of `2·pts.len()` floats.
pub(crate) unsafe fn write_points(xy: *mut f32, pts: &[[f32; 2]]) {
    for (i, p) in pts.iter().enumerate() {
        // SAFETY: i < pts.len(), and the caller guarantees room for 2·len floats.
        unsafe {
            xy.add(2 * i).write_unaligned(p[0]);
            xy.add(2 * i + 1).write_unaligned(p[1]);
        }
    }
}

/// `s` as a NUL-terminated C string, cut to fit.
pub(crate) fn c_name<const N: usize>(s: &str) -> [c_char; N] {
    let mut out = [0 as c_char; N];
    for (o, b) in out
        .iter_mut()
        .take(N.saturating_sub(1))
        .zip(s.bytes().take_while(|&b| b != 0))
    {
        *o = b as c_char;
    }
    out
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use crate::status::GPECNET_E_BAD_LENGTH;

    /// A panic inside an entry point's body becomes a status code, not an unwind into C.
    #[test]
    fn a_panic_is_a_status_code() {
        assert_eq!(guard(|| panic!("injected")), GPECNET_E_PANIC);
        assert_eq!(guard(|| Ok(())), GPECNET_OK);
        assert_eq!(guard(|| Err(GPECNET_E_BAD_LENGTH)), GPECNET_E_BAD_LENGTH);
    }
}
