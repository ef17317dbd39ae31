//! Target-specific code paths of the dense layers: the only module of this
//! crate with `unsafe`, one submodule per target, each with a `SAFETY:` note
//! on every block. Every target also has the portable loops of
//! [`crate::fixed`], [`crate::float`] and [`crate::lanes`], which are the
//! reference: each function here computes exactly the same bits.
//!
//! - `arm` (`cfg(all(target_arch = "arm", target_feature = "dsp"))`,
//!   Cortex-M4/M7): the scalar engine's inner loops in inline assembly
//!   (`SMLALD` for Q15, `VMLA.F32` for f32; `docs/kernels.md`).
//! - `x86` (`cfg(target_arch = "x86_64")`): the batched host path's dense
//!   lanes compiled a second time with AVX enabled and chosen at run time
//!   when the CPU has it (`docs/host-speed.md`).
//! - `softfloat` (feature `softfloat`, `cfg(all(target_arch = "arm",
//!   target_os = "none"))`, for cores without an FPU): a faster, bit-exact
//!   `__aeabi_fmul`, `__aeabi_fadd` and `__aeabi_fsub` over compiler-builtins'
//!   (`docs/kernels.md`); their arithmetic is portable and tested against the
//!   host FPU.

#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
mod arm;
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
pub(crate) use arm::*;

#[cfg(target_arch = "x86_64")]
pub(crate) mod x86;

#[cfg(any(
    test,
    all(feature = "softfloat", target_arch = "arm", target_os = "none")
))]
mod softfloat;
