//! x86-64: the batched host path's f32 dense lanes ([`crate::lanes`])
//! compiled a second time with AVX2 enabled, chosen at run time when the CPU
//! and the operating system support it ([`has_avx2`]).
//!
//! # Why the bits are the same
//!
//! Enabling AVX2 changes only the width of the vector registers LLVM uses
//! for the same source: 8 f32 (or 4 f64, in the sine) per `ymm` register
//! instead of 4 (2) per `xmm`. `VMULPS`/`VADDPS` (and their f64 forms) are
//! IEEE-754 operations rounded once each with the same MXCSR rounding mode
//! as `MULPS`/`ADDPS`, lane by lane; and no fused multiply-add can appear:
//! the `fma` target feature is *not* enabled here, and Rust never contracts
//! a separate multiply and add anyway (no `contract` fast-math flag). The
//! order of each lane's operations is the source's ([`crate::lanes`]'s
//! module docs), whatever the register width or the number of rows summed
//! side by side. `core/tests/batch_lanes.rs` and the trainer's
//! `batch_vs_scalar` compare the batched results with the scalar engine
//! bit for bit on this path (it is the one a host with AVX2 takes).
//!
//! # Cost
//!
//! Two relaxed atomic loads per layer call ([`has_avx2`] caches CPUID;
//! [`set_wide_vectors`] can turn the path off).

use core::sync::atomic::{AtomicBool, AtomicU8, Ordering};

use crate::blob::Layer;
use crate::lanes::{self, LaneArith};

/// [`has_avx2`]'s cached answer: 0 not yet asked, 1 no, 2 yes.
static AVX2: AtomicU8 = AtomicU8::new(0);

/// Set by [`set_wide_vectors`]`(false)`: take the portable path even where
/// AVX2 is available.
static PORTABLE: AtomicBool = AtomicBool::new(false);

/// Whether the batched path may use AVX2 where the CPU has it (the
/// default, `true`), process-wide. The bits are the same either way; tests
/// and benchmarks turn it off to compare both paths.
pub(crate) fn set_wide_vectors(enabled: bool) {
    PORTABLE.store(!enabled, Ordering::Relaxed);
}

/// Whether this CPU has AVX2 and the operating system saves the `ymm`
/// registers (CPUID leaf 1 `ECX.OSXSAVE` and `ECX.AVX`, `XCR0` bits 1 and 2,
/// CPUID leaf 7 `EBX.AVX2`), asked once and cached; a build with
/// `-C target-feature=+avx2` takes the AVX2 path without asking.
#[inline]
pub(crate) fn has_avx2() -> bool {
    if cfg!(target_feature = "avx2") {
        return true;
    }
    match AVX2.load(Ordering::Relaxed) {
        2 => true,
        1 => false,
        _ => {
            let yes = detect_avx2();
            AVX2.store(if yes { 2 } else { 1 }, Ordering::Relaxed);
            yes
        }
    }
}

/// The CPUID and XGETBV checks of [`has_avx2`] (Intel SDM vol. 1, 14.3,
/// "Detection of Intel AVX instructions").
fn detect_avx2() -> bool {
    use core::arch::x86_64::{__cpuid, __cpuid_count};
    const OSXSAVE: u32 = 1 << 27;
    const AVX: u32 = 1 << 28;
    const AVX2_BIT: u32 = 1 << 5;
    // CPUID is part of the x86-64 baseline (a safe intrinsic); leaf 0
    // reports the highest basic leaf.
    let max_leaf = __cpuid(0).eax;
    if max_leaf < 7 {
        return false;
    }
    let l1 = __cpuid(1);
    if l1.ecx & (OSXSAVE | AVX) != OSXSAVE | AVX {
        return false;
    }
    // SAFETY: `OSXSAVE` is set, so the OS has enabled XGETBV (and XSAVE,
    // the feature `xcr0` is compiled with).
    let xcr0 = unsafe { xcr0() };
    if xcr0 & 0b110 != 0b110 {
        return false;
    }
    let l7 = __cpuid_count(7, 0);
    l7.ebx & AVX2_BIT != 0
}

/// `XCR0`, the OS-enabled state components (bit 1 SSE, bit 2 AVX).
///
/// # Safety
/// Only when CPUID reports `OSXSAVE` (else `XGETBV` is undefined: `#UD`).
#[target_feature(enable = "xsave")]
unsafe fn xcr0() -> u64 {
    // SAFETY: the caller checked `OSXSAVE`, `XGETBV`'s one precondition.
    unsafe { core::arch::x86_64::_xgetbv(0) }
}

/// Rows summed side by side with AVX2: 8 rows of one 8-lane `ymm` sum each
/// (8 independent add chains for 3–4 cycles of `VADDPS` latency on two add
/// ports); with `L = 16` that is 16 registers of sums, which LLVM spills,
/// so wider lanes keep 4 rows.
const fn avx2_rows(lanes: usize) -> usize {
    if lanes <= 8 {
        8
    } else {
        lanes::ROWS
    }
}

/// [`lanes::dense_rows`] compiled with AVX2 (the whole layer, its
/// activations and the vectorised sine included: everything below it is
/// `#[inline(always)]`).
#[target_feature(enable = "avx2")]
fn dense_lanes_avx2<K: LaneArith, const L: usize>(
    layer: &Layer<'_>,
    x: &[[K::Act; L]],
    out: &mut [[K::Act; L]],
    used: usize,
) {
    if avx2_rows(L) == 8 {
        lanes::dense_rows::<K, L, 8>(layer, x, out, used);
    } else {
        lanes::dense_rows::<K, L, { lanes::ROWS }>(layer, x, out, used);
    }
}

/// [`lanes::dense_lanes`], on AVX2 when [`has_avx2`]: the same bits either
/// way (module docs). Its signature is that of `lanes::dense_lanes` on
/// purpose: the float backend calls one or the other by target.
#[inline]
pub(crate) fn dense_lanes<K: LaneArith, const L: usize>(
    layer: &Layer<'_>,
    x: &[[K::Act; L]],
    out: &mut [[K::Act; L]],
    used: usize,
) {
    if has_avx2() && !PORTABLE.load(Ordering::Relaxed) {
        // SAFETY: `has_avx2` checked that the CPU executes AVX2 and the OS
        // saves the `ymm` registers, the only precondition of calling a
        // function compiled with `target_feature(enable = "avx2")`.
        unsafe { dense_lanes_avx2::<K, L>(layer, x, out, used) }
    } else {
        lanes::dense_lanes::<K, L>(layer, x, out, used);
    }
}
