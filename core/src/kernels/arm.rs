//! Target-specific inner loops of the dense layers: the only module of this
//! crate with `unsafe` (inline assembly), compiled only for
//! `cfg(all(target_arch = "arm", target_feature = "dsp"))` (Cortex-M4/M7:
//! `thumbv7em-*`). Every other target uses the portable loops in
//! [`crate::fixed`] and [`crate::float`], which are the reference: each
//! function here computes exactly the same value (see `docs/kernels.md`).
//!
//! # Q15: two rows per pass, `SMLALD`
//!
//! [`dot2_q15`] adds `Σ_i q0_i · x_i` and `Σ_i q1_i · x_i` to two `i64`
//! accumulators. Per four inputs: one `LDRD` brings `x_i .. x_i+3` (the
//! activation row is 4-byte aligned; otherwise the caller's portable loop
//! runs) and four `SMLALD` do the eight MACs. The weights come either with
//! one `LDRD` per row (both rows' columns word aligned: a format-3 blob, whose
//! tensors start at multiples of 4, placed at an aligned address, with an
//! even row stride — 7 instructions per 8 MACs) or with two `LDR` per row
//! (any alignment: flash is normal memory and the Cortex-M4 allows unaligned
//! `LDR`, as the portable loop's compiled code already assumes; `LDRD`
//! would fault — 9 per 8). `SMLALD` adds both 16 × 16 products to a 64-bit
//! accumulator with 64-bit wrap-around; since `|acc| < 2^47` for every
//! valid blob (see [`crate::fixed`]), nothing wraps and the sum equals the
//! portable `i64` sum exactly, whatever the order or the load width.
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

/// The loops of one of [`dot2_q15`]'s paths as asm text, `$block` being
/// that path's 4-input block: with `m` = the number of 4-input blocks
/// (≥ 1), 4 blocks per iteration (label 2) while at least 4 remain, then 1
/// block per iteration (label 4); branches to label 9 (`9f`) when none is
/// left after the first loop, else falls through at the end. Both paths use
/// labels 2–4: a numeric local label may be defined again, and `2b`/`3f`
/// mean the nearest one before/after.
macro_rules! q15_loops {
    ($block:ident) => {
        concat!(
            "subs {m}, {m}, #4\n",
            "blt 3f\n",
            "2:\n",
            $block!(),
            $block!(),
            $block!(),
            $block!(),
            "subs {m}, {m}, #4\n",
            "bge 2b\n",
            "3:\n",
            "adds {m}, {m}, #4\n",
            "beq 9f\n",
            "4:\n",
            $block!(),
            "subs {m}, {m}, #1\n",
            "bne 4b",
        )
    };
}

/// [`dot2_q15`]'s 4-input block for word-aligned rows: one `LDRD` of four
/// activations, per row one `LDRD` of four weights and two `SMLALD` (7
/// instructions, 8 MACs).
macro_rules! q15_block_ldrd {
    () => {
        concat!(
            "ldrd {x0}, {x1}, [{xp}], #8\n",
            "ldrd {w0}, {w1}, [{p0}], #8\n",
            "smlald {a0}, {a1}, {w0}, {x0}\n",
            "smlald {a0}, {a1}, {w1}, {x1}\n",
            "ldrd {w0}, {w1}, [{p1}], #8\n",
            "smlald {b0}, {b1}, {w0}, {x0}\n",
            "smlald {b0}, {b1}, {w1}, {x1}\n",
        )
    };
}

/// [`dot2_q15`]'s 4-input block for rows at any alignment: one `LDRD` of
/// four activations, then twice: one unaligned `LDR` of two weights per
/// row and one `SMLALD` per row (9 instructions, 8 MACs).
macro_rules! q15_block_ldr {
    () => {
        concat!(
            "ldrd {x0}, {x1}, [{xp}], #8\n",
            "ldr {w0}, [{p0}], #4\n",
            "ldr {w1}, [{p1}], #4\n",
            "smlald {a0}, {a1}, {w0}, {x0}\n",
            "smlald {b0}, {b1}, {w1}, {x0}\n",
            "ldr {w0}, [{p0}], #4\n",
            "ldr {w1}, [{p1}], #4\n",
            "smlald {a0}, {a1}, {w0}, {x1}\n",
            "smlald {b0}, {b1}, {w1}, {x1}\n",
        )
    };
}

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

/// Two rows of i16 LE weights, `g[lo..n]` and `g[n + lo..2n]` (`n`: the
/// row stride in bytes): `(a0 + Σ_i q0_i x_i, a1 + Σ_i q1_i x_i)` over
/// `i < k`, where `k` is the largest multiple of 4 with `k ≤ x.len()`;
/// returns the sums and `k`. Does nothing (returns `k = 0`) when `x` is
/// not 4-byte aligned, `g` is shorter than `2n` or the columns would run
/// past a row (`lo + 2·x.len() > n`).
#[inline(always)]
pub(crate) fn dot2_q15(
    g: &[u8],
    n: usize,
    lo: usize,
    x: &[i16],
    a0: i64,
    a1: i64,
) -> (i64, i64, usize) {
    let k = x.len() & !3;
    if k == 0
        || (x.as_ptr() as usize) & 3 != 0
        || g.len() / 2 < n
        || lo.saturating_add(2 * x.len()) > n
    {
        return (a0, a1, 0);
    }
    let (mut a0l, mut a0h) = (a0 as u32, (a0 >> 32) as u32);
    let (mut a1l, mut a1h) = (a1 as u32, (a1 >> 32) as u32);
    // SAFETY: reads `x[..k]` (k ≤ x.len()) with `LDRD` at 4-byte aligned
    // addresses (`x` is 4-byte aligned, checked above, and advances by 8),
    // and bytes `[lo, lo + 2k)` and `[n + lo, n + lo + 2k)` of `g` (inside
    // `g`: lo + 2k ≤ lo + 2·x.len() ≤ n and 2n ≤ g.len()) through `p0 = g +
    // lo` and `p1 = p0 + n`, each advancing over its own row. When both are
    // 4-byte aligned (tested in the block: `(p0 | p1) & 3 == 0`) the
    // weights are read with `LDRD`, which needs word alignment only
    // (Armv7-M), so it holds; otherwise with `LDR`, which the Cortex-M4/M7
    // allow unaligned on normal memory (flash and SRAM; `CCR.UNALIGN_TRP` is
    // 0 out of reset and the firmware never sets it). No writes to memory,
    // no stack; the flags are clobbered (asm! assumes so without
    // `preserves_flags`); every register written is a declared operand.
    unsafe {
        asm!(
            "add {p1}, {p1}, {p0}",
            "orr {w0}, {p0}, {p1}",
            "tst {w0}, #3",
            "bne 6f",
            // Aligned rows: one LDRD of two weight pairs per row (7
            // instructions, 8 MACs).
            q15_loops!(q15_block_ldrd),
            "b 9f",
            // Rows at any alignment: two LDR per row (9 instructions, 8 MACs).
            "6:",
            q15_loops!(q15_block_ldr),
            "9:",
            m = inout(reg) k / 4 => _,
            xp = inout(reg) x.as_ptr() => _,
            p0 = inout(reg) g.as_ptr().wrapping_add(lo) => _,
            // p1 = p0 + n, formed in n's register.
            p1 = inout(reg) n => _,
            x0 = out(reg) _,
            x1 = out(reg) _,
            w0 = out(reg) _,
            w1 = out(reg) _,
            a0 = inout(reg) a0l,
            a1 = inout(reg) a0h,
            b0 = inout(reg) a1l,
            b1 = inout(reg) a1h,
            options(nostack, readonly),
        );
    }
    (
        (u64::from(a0l) | (u64::from(a0h) << 32)) as i64,
        (u64::from(a1l) | (u64::from(a1h) << 32)) as i64,
        k,
    )
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
