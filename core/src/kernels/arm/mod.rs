//! Target-specific inner loops of the dense layers: the only module of this
//! crate with `unsafe` (inline assembly), compiled only for
//! `cfg(all(target_arch = "arm", target_feature = "dsp"))` (Cortex-M4/M7:
//! `thumbv7em-*`). Every other target uses the portable loops in
//! [`crate::fixed`] and [`crate::float`], which are the reference: each
//! function here computes exactly the same value (see `docs/kernels.md`).
//!
//! One file per kernel family: `q15_rows.rs` ([`dot_rows_q15`], the dense
//! layers' row sums, `SMLALD`), `q15_latent.rs` ([`latent_rows_q15`], the
//! decoder's 16 latent columns), `q15_sine.rs` ([`sine_rows_q15`], the
//! activations of a `Sine` layer) and `fpu.rs` (`sqrt_f32` and `dot4_f32`,
//! `VSQRT.F32` and `VMLA.F32`, on targets with FPU registers).

#[cfg(target_feature = "fpregs")]
mod fpu;
mod q15_latent;
mod q15_rows;
mod q15_sine;

#[cfg(target_feature = "fpregs")]
pub(crate) use fpu::{dot4_f32, sqrt_f32};
pub(crate) use q15_latent::latent_rows_q15;
pub(crate) use q15_rows::{dot_rows_q15, ROW_CHUNK};
pub(crate) use q15_sine::sine_rows_q15;
