//! The f32 kernels on the FPU (`target_feature = "fpregs"`): the square
//! root [`sqrt_f32`] and the four-row dense sums [`dot4_f32`].
//!
//! # f32 square root: `VSQRT.F32`
//!
//! [`sqrt_f32`]: the FPU's correctly rounded square root, the same bits as
//! the correctly rounded `libm::sqrtf` (the latent sampler's root).
//!
//! # f32: four rows per pass, `VMLA.F32`
//!
//! [`dot4_f32`] continues four left-to-right sums `s_j += W_ji · x_i`.
//! `VMLA.F32 Sd, Sn, Sm` is defined (Armv7-M Architecture Reference
//! Manual, VMLA/VMLS pseudocode: `addend32 = FPMul(S[n], S[m], TRUE);
//! S[d] = FPAdd(S[d], addend32, TRUE)`; the fused `FPMulAdd` belongs to
//! `VFMA`) as a rounded product then a rounded
//! sum, each with FPSCR's rounding mode, flush-to-zero and default-NaN
//! settings: the same two operations, in the same operand order, as
//! `VMUL` then `VADD` — what the portable `s += w * x` compiles to — so
//! the result is bit-identical (it is not a fused multiply-add, which
//! `VFMA` would be). Per four inputs: one `VLDM` of `x_i .. x_i+3` shared by
//! the four rows; per row either one `VLDM` of four weights (row and stride
//! 4-byte aligned) or four unaligned `LDR` + two `VMOV` (any alignment:
//! `VLDR`/`VLDM` would fault), then four `VMLA`.

use core::arch::asm;

/// The whole of one of [`dot4_f32`]'s paths as asm text: save s0–s11, load
/// the four sums into s0–s3, form `p1..p3` (row stride `n`), then per 4
/// inputs one `VLDM` of `x` into s4–s7 and `$row` for each row (pointer,
/// sum register), `m` times; store the sums and restore s0–s11.
macro_rules! f32_loop {
    ($row:ident) => {
        concat!(
            "vpush {{s0-s11}}\n",
            "vldmia {ap}, {{s0-s3}}\n",
            "add {p1}, {p0}, {n}\n",
            "add {p2}, {p1}, {n}\n",
            "add {p3}, {p2}, {n}\n",
            "2:\n",
            "vldmia {xp}!, {{s4-s7}}\n",
            $row!("p0", "s0"),
            $row!("p1", "s1"),
            $row!("p2", "s2"),
            $row!("p3", "s3"),
            "subs {m}, {m}, #1\n",
            "bne 2b\n",
            "vstmia {ap}, {{s0-s3}}\n",
            "vpop {{s0-s11}}",
        )
    };
}

/// Four `VMLA.F32` into sum register `$s`: `$s += s8·s4`, then s9·s5,
/// s10·s6, s11·s7, in this order (each product and sum rounded).
macro_rules! f32_vmla4 {
    ($s:literal) => {
        concat!(
            concat!("vmla.f32 ", $s, ", s8, s4\n"),
            concat!("vmla.f32 ", $s, ", s9, s5\n"),
            concat!("vmla.f32 ", $s, ", s10, s6\n"),
            concat!("vmla.f32 ", $s, ", s11, s7\n"),
        )
    };
}

/// One row of [`dot4_f32`]'s aligned path: one `VLDM` of four weights from
/// the pointer operand named `$p` into s8–s11, then `f32_vmla4!` into `$s`.
macro_rules! f32_row_vldm {
    ($p:literal, $s:literal) => {
        concat!("vldmia {", $p, "}!, {{s8-s11}}\n", f32_vmla4!($s))
    };
}

/// One row of [`dot4_f32`]'s any-alignment path: four unaligned `LDR` of
/// weights from the pointer operand named `$p` (into `n`, `t1`–`t3`), two
/// `VMOV` into s8–s11, then `f32_vmla4!` into `$s`.
macro_rules! f32_row_ldr {
    ($p:literal, $s:literal) => {
        concat!(
            concat!("ldr {n}, [{", $p, "}], #4\n"),
            concat!("ldr {t1}, [{", $p, "}], #4\n"),
            concat!("ldr {t2}, [{", $p, "}], #4\n"),
            concat!("ldr {t3}, [{", $p, "}], #4\n"),
            "vmov s8, s9, {n}, {t1}\n",
            "vmov s10, s11, {t2}, {t3}\n",
            f32_vmla4!($s),
        )
    };
}

/// `sqrt(x)` with the FPU's `VSQRT.F32`, which IEEE 754 (and the Armv7-M
/// `FPSqrt` pseudocode) define as correctly rounded, like `libm::sqrtf`:
/// so the same bits for every input that is not NaN or below −0 (the
/// latent sampler only takes roots of `−2·ln(u) ≥ −0`; for those two the
/// result is a NaN either way). s0 is saved in a core register and
/// restored (stable Rust cannot name VFP registers as operands, see
/// [`dot4_f32`]).
#[cfg(target_feature = "fpregs")]
#[inline(always)]
pub(crate) fn sqrt_f32(x: f32) -> f32 {
    let y: u32;
    // SAFETY: register-only: `t` keeps s0 while s0 holds `x` and its root,
    // then s0 is restored; `t` is an `out` operand (not `lateout`), so it
    // never shares a register with `x`. No memory, no stack, no flags (the
    // FPSCR's cumulative exception bits are set as by any f32 operation).
    unsafe {
        asm!(
            "vmov {t}, s0",
            "vmov s0, {x}",
            "vsqrt.f32 s0, s0",
            "vmov {y}, s0",
            "vmov s0, {t}",
            x = in(reg) x.to_bits(),
            y = lateout(reg) y,
            t = out(reg) _,
            options(pure, nomem, nostack, preserves_flags),
        );
    }
    f32::from_bits(y)
}

/// Four rows of f32 LE weights, `g[j·n + lo..(j + 1)·n]` for `j < 4`
/// (`n`: the row stride in bytes), continue the sums
/// `acc_j += W_ji · x_i`, `i` ascending, each product and each sum rounded
/// (`VMLA.F32`: not fused), over `i < k`: `k` is the largest multiple of 4
/// with `k ≤ x.len()` and `lo + 4k ≤ n`. Returns `k` (0: nothing done,
/// also when `g` is shorter than `4n`).
///
/// The sums live in s0–s3 inside the loop; s0–s11 are saved on the stack
/// around it and restored (stable Rust cannot name VFP registers as asm
/// operands without the unstable `vfp2` target feature, so they are saved
/// by hand instead).
#[cfg(target_feature = "fpregs")]
#[inline(always)]
pub(crate) fn dot4_f32(g: &[u8], n: usize, lo: usize, x: &[f32], acc: &mut [f32; 4]) -> usize {
    let k = x.len().min(n.saturating_sub(lo) / 4) & !3;
    if k == 0 || g.len() / 4 < n {
        return 0;
    }
    let p0 = g.as_ptr().wrapping_add(lo);
    if (p0 as usize | n) & 3 == 0 {
        // SAFETY: reads `x[..k]` and bytes `[j·n + lo, j·n + lo + 4k)` of
        // `g` for j < 4 (inside `g`: lo + 4k ≤ n, 4n ≤ g.len()) with
        // `VLDM`, at 4-byte aligned addresses (`x` is a `&[f32]`; `g + lo`
        // and `n` were checked just above; each pointer advances by 16);
        // reads and writes the 16 bytes of `acc` (a `&mut [f32; 4]`,
        // aligned) with `VLDM`/`VSTM`. The only other memory written is the
        // 48 bytes `VPUSH` puts below the stack pointer, popped before the
        // end, so every VFP register is as it was; the core registers
        // written are declared operands. `VMLA.F32` uses FPSCR's rounding,
        // flush-to-zero and default-NaN settings exactly as `VMUL` + `VADD`.
        unsafe {
            asm!(
                f32_loop!(f32_row_vldm),
                m = inout(reg) k / 4 => _,
                xp = inout(reg) x.as_ptr() => _,
                ap = in(reg) acc.as_mut_ptr(),
                n = in(reg) n,
                p0 = inout(reg) p0 => _,
                p1 = out(reg) _,
                p2 = out(reg) _,
                p3 = out(reg) _,
            );
        }
    } else {
        // SAFETY: as above, except that the weights are read with `LDR`,
        // which the Cortex-M4/M7 allow unaligned on normal memory (flash,
        // SRAM; `CCR.UNALIGN_TRP` is 0 out of reset and never set by the
        // firmware), then copied to s8–s11 with `VMOV` (bit copies); `n` is
        // free once p1–p3 are set and serves as the fourth temporary.
        unsafe {
            asm!(
                f32_loop!(f32_row_ldr),
                m = inout(reg) k / 4 => _,
                xp = inout(reg) x.as_ptr() => _,
                ap = in(reg) acc.as_mut_ptr(),
                n = inout(reg) n => _,
                p0 = inout(reg) p0 => _,
                p1 = out(reg) _,
                p2 = out(reg) _,
                p3 = out(reg) _,
                t1 = out(reg) _,
                t2 = out(reg) _,
                t3 = out(reg) _,
            );
        }
    }
    k
}
