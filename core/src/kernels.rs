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
//! runs), four `LDR` bring two weights each from the two rows (flash is
//! normal memory: the Cortex-M4 allows unaligned `LDR`, as the portable
//! loop's compiled code already assumes), and four `SMLALD` do the eight
//! MACs. `SMLALD` adds both 16 × 16 products to a 64-bit accumulator with
//! 64-bit wrap-around; since `|acc| < 2^47` for every valid blob (see
//! [`crate::fixed`]), nothing wraps and the sum equals the portable `i64`
//! sum exactly, whatever the order.
//!
//! # f32: four rows per pass, `VMLA.F32`
//!
//! [`dot4_f32`] continues four left-to-right sums `s_j += W_ji · x_i`.
//! `VMLA.F32 Sd, Sn, Sm` is defined (Arm ARMv7-M ARM, A7.7.239) as
//! `FPAdd(Sd, FPMul(Sn, Sm))`, each rounded with the FPSCR's rounding
//! mode, flush-to-zero and default-NaN settings: the same two operations,
//! in the same operand order, as `VMUL` then `VADD` — what the portable
//! `s += w * x` compiles to — so the result is bit-identical (it is *not*
//! a fused multiply-add, which `VFMA` would be). The weights are read
//! with unaligned `LDR` + `VMOV` (blobs are not 4-byte aligned; `VLDR`
//! would fault), the input once per four rows.

use core::arch::asm;

/// `(a0 + Σ_i q0_i x_i, a1 + Σ_i q1_i x_i)` over `i < k`, where `q0`/`q1`
/// are the i16 LE weights at `w0`/`w1` and `k` is the largest multiple of 4
/// with `k ≤ x.len()`, `2k ≤ w0.len()`, `2k ≤ w1.len()`; returns the sums
/// and `k`. Does nothing (returns `k = 0`) when `x` is not 4-byte aligned.
#[inline(always)]
pub(crate) fn dot2_q15(w0: &[u8], w1: &[u8], x: &[i16], a0: i64, a1: i64) -> (i64, i64, usize) {
    let k = x.len().min(w0.len() / 2).min(w1.len() / 2) & !3;
    if k == 0 || (x.as_ptr() as usize) & 3 != 0 {
        return (a0, a1, 0);
    }
    let (mut a0l, mut a0h) = (a0 as u32, (a0 >> 32) as u32);
    let (mut a1l, mut a1h) = (a1 as u32, (a1 >> 32) as u32);
    // Row 1 relative to row 0, as a (wrapping) register offset.
    let d = (w1.as_ptr() as usize).wrapping_sub(w0.as_ptr() as usize);
    // SAFETY: reads `x[..k]` (k ≤ x.len(), by `LDRD` at 4-byte aligned
    // addresses: `x` is 4-byte aligned, checked above, and advances by 8)
    // and bytes `[0, 2k)` of `w0` and of `w1` (2k ≤ both lengths; row 1 is
    // read at `p + d` where `p` walks row 0, so `p + d` walks row 1) with
    // `LDR`, which the Cortex-M4 allows unaligned on normal memory (flash
    // and SRAM; `CCR.UNALIGN_TRP` is 0 out of reset and the firmware never
    // sets it). No writes to memory, no stack; the flags are clobbered
    // (asm! assumes so without `preserves_flags`); all registers written
    // are declared outputs.
    unsafe {
        asm!(
            // m = number of 4-input blocks (≥ 1); 4 blocks per iteration first.
            "subs {m}, {m}, #4",
            "blt 3f",
            "2:",
            "ldrd {x0}, {x1}, [{xp}], #8",
            "ldr {w}, [{p}, {d}]",
            "smlald {b0}, {b1}, {w}, {x0}",
            "ldr {w}, [{p}], #4",
            "smlald {a0}, {a1}, {w}, {x0}",
            "ldr {w}, [{p}, {d}]",
            "smlald {b0}, {b1}, {w}, {x1}",
            "ldr {w}, [{p}], #4",
            "smlald {a0}, {a1}, {w}, {x1}",
            "ldrd {x0}, {x1}, [{xp}], #8",
            "ldr {w}, [{p}, {d}]",
            "smlald {b0}, {b1}, {w}, {x0}",
            "ldr {w}, [{p}], #4",
            "smlald {a0}, {a1}, {w}, {x0}",
            "ldr {w}, [{p}, {d}]",
            "smlald {b0}, {b1}, {w}, {x1}",
            "ldr {w}, [{p}], #4",
            "smlald {a0}, {a1}, {w}, {x1}",
            "ldrd {x0}, {x1}, [{xp}], #8",
            "ldr {w}, [{p}, {d}]",
            "smlald {b0}, {b1}, {w}, {x0}",
            "ldr {w}, [{p}], #4",
            "smlald {a0}, {a1}, {w}, {x0}",
            "ldr {w}, [{p}, {d}]",
            "smlald {b0}, {b1}, {w}, {x1}",
            "ldr {w}, [{p}], #4",
            "smlald {a0}, {a1}, {w}, {x1}",
            "ldrd {x0}, {x1}, [{xp}], #8",
            "ldr {w}, [{p}, {d}]",
            "smlald {b0}, {b1}, {w}, {x0}",
            "ldr {w}, [{p}], #4",
            "smlald {a0}, {a1}, {w}, {x0}",
            "ldr {w}, [{p}, {d}]",
            "smlald {b0}, {b1}, {w}, {x1}",
            "ldr {w}, [{p}], #4",
            "smlald {a0}, {a1}, {w}, {x1}",
            "subs {m}, {m}, #4",
            "bge 2b",
            "3:",
            // 0..=3 blocks left.
            "adds {m}, {m}, #4",
            "beq 5f",
            "4:",
            "ldrd {x0}, {x1}, [{xp}], #8",
            "ldr {w}, [{p}, {d}]",
            "smlald {b0}, {b1}, {w}, {x0}",
            "ldr {w}, [{p}], #4",
            "smlald {a0}, {a1}, {w}, {x0}",
            "ldr {w}, [{p}, {d}]",
            "smlald {b0}, {b1}, {w}, {x1}",
            "ldr {w}, [{p}], #4",
            "smlald {a0}, {a1}, {w}, {x1}",
            "subs {m}, {m}, #1",
            "bne 4b",
            "5:",
            m = inout(reg) k / 4 => _,
            xp = inout(reg) x.as_ptr() => _,
            p = inout(reg) w0.as_ptr() => _,
            d = in(reg) d,
            x0 = out(reg) _,
            x1 = out(reg) _,
            w = out(reg) _,
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

/// Four rows of f32 weights (LE bytes, `w[0..4]`) continue the sums
/// `acc_j += W_ji · x_i`, `i` ascending, each product and each sum rounded
/// (`VMLA.F32`: not fused), over `i < k`: `k` is the largest multiple of 4
/// with `k ≤ x.len()` and `4k ≤ w_j.len()` for every row. Returns the sums
/// and `k` (0: nothing done).
///
/// The sums travel in core registers (their bits) and live in s0–s3 inside
/// the loop; s0–s11 are saved on the stack around it and restored (stable
/// Rust cannot name VFP registers as asm operands without the unstable
/// `vfp2` target feature, so they are not operands but saved by hand).
#[cfg(target_feature = "fpregs")]
#[inline(always)]
pub(crate) fn dot4_f32(w: [&[u8]; 4], x: &[f32], acc: [f32; 4]) -> ([f32; 4], usize) {
    let k = w.iter().fold(x.len(), |k, r| k.min(r.len() / 4)) & !3;
    if k == 0 {
        return (acc, 0);
    }
    let mut a = acc.map(f32::to_bits);
    let p = w.map(|r| r.as_ptr());
    if p.iter().all(|&q| q as usize & 3 == 0) {
        // SAFETY: reads `x[..k]` and the first `4k` bytes of each row (k ≤
        // every length, see above) with `VLDM`, at 4-byte aligned addresses
        // (`x` is a `&[f32]`, the rows were checked just above, and each
        // pointer advances by 16). The only memory written is the 48 bytes
        // `VPUSH` puts below the stack pointer, popped before the end, so
        // every VFP register is as it was; the core registers written are
        // declared operands. `VMLA.F32` uses FPSCR's rounding, flush-to-zero
        // and default-NaN settings exactly as `VMUL` + `VADD` do.
        unsafe {
            asm!(
                "vpush {{s0-s11}}",
                "vmov s0, s1, {a0}, {a1}",
                "vmov s2, s3, {a2}, {a3}",
                "2:",
                "vldmia {xp}!, {{s4-s7}}",
                "vldmia {p0}!, {{s8-s11}}",
                "vmla.f32 s0, s8, s4",
                "vmla.f32 s0, s9, s5",
                "vmla.f32 s0, s10, s6",
                "vmla.f32 s0, s11, s7",
                "vldmia {p1}!, {{s8-s11}}",
                "vmla.f32 s1, s8, s4",
                "vmla.f32 s1, s9, s5",
                "vmla.f32 s1, s10, s6",
                "vmla.f32 s1, s11, s7",
                "vldmia {p2}!, {{s8-s11}}",
                "vmla.f32 s2, s8, s4",
                "vmla.f32 s2, s9, s5",
                "vmla.f32 s2, s10, s6",
                "vmla.f32 s2, s11, s7",
                "vldmia {p3}!, {{s8-s11}}",
                "vmla.f32 s3, s8, s4",
                "vmla.f32 s3, s9, s5",
                "vmla.f32 s3, s10, s6",
                "vmla.f32 s3, s11, s7",
                "subs {m}, {m}, #1",
                "bne 2b",
                "vmov {a0}, {a1}, s0, s1",
                "vmov {a2}, {a3}, s2, s3",
                "vpop {{s0-s11}}",
                m = inout(reg) k / 4 => _,
                xp = inout(reg) x.as_ptr() => _,
                p0 = inout(reg) p[0] => _,
                p1 = inout(reg) p[1] => _,
                p2 = inout(reg) p[2] => _,
                p3 = inout(reg) p[3] => _,
                a0 = inout(reg) a[0],
                a1 = inout(reg) a[1],
                a2 = inout(reg) a[2],
                a3 = inout(reg) a[3],
                options(readonly),
            );
        }
    } else {
        // SAFETY: as above, except that the weights are read with `LDR`
        // (into the sum registers, free inside the loop), which the
        // Cortex-M4/M7 allows unaligned on normal memory (flash, SRAM;
        // `CCR.UNALIGN_TRP` is 0 out of reset and never set by the
        // firmware), then copied to s8–s11 with `VMOV` (bit copies).
        unsafe {
            asm!(
                "vpush {{s0-s11}}",
                "vmov s0, s1, {a0}, {a1}",
                "vmov s2, s3, {a2}, {a3}",
                "2:",
                "vldmia {xp}!, {{s4-s7}}",
                "ldr {a0}, [{p0}], #4",
                "ldr {a1}, [{p0}], #4",
                "ldr {a2}, [{p0}], #4",
                "ldr {a3}, [{p0}], #4",
                "vmov s8, s9, {a0}, {a1}",
                "vmov s10, s11, {a2}, {a3}",
                "vmla.f32 s0, s8, s4",
                "vmla.f32 s0, s9, s5",
                "vmla.f32 s0, s10, s6",
                "vmla.f32 s0, s11, s7",
                "ldr {a0}, [{p1}], #4",
                "ldr {a1}, [{p1}], #4",
                "ldr {a2}, [{p1}], #4",
                "ldr {a3}, [{p1}], #4",
                "vmov s8, s9, {a0}, {a1}",
                "vmov s10, s11, {a2}, {a3}",
                "vmla.f32 s1, s8, s4",
                "vmla.f32 s1, s9, s5",
                "vmla.f32 s1, s10, s6",
                "vmla.f32 s1, s11, s7",
                "ldr {a0}, [{p2}], #4",
                "ldr {a1}, [{p2}], #4",
                "ldr {a2}, [{p2}], #4",
                "ldr {a3}, [{p2}], #4",
                "vmov s8, s9, {a0}, {a1}",
                "vmov s10, s11, {a2}, {a3}",
                "vmla.f32 s2, s8, s4",
                "vmla.f32 s2, s9, s5",
                "vmla.f32 s2, s10, s6",
                "vmla.f32 s2, s11, s7",
                "ldr {a0}, [{p3}], #4",
                "ldr {a1}, [{p3}], #4",
                "ldr {a2}, [{p3}], #4",
                "ldr {a3}, [{p3}], #4",
                "vmov s8, s9, {a0}, {a1}",
                "vmov s10, s11, {a2}, {a3}",
                "vmla.f32 s3, s8, s4",
                "vmla.f32 s3, s9, s5",
                "vmla.f32 s3, s10, s6",
                "vmla.f32 s3, s11, s7",
                "subs {m}, {m}, #1",
                "bne 2b",
                "vmov {a0}, {a1}, s0, s1",
                "vmov {a2}, {a3}, s2, s3",
                "vpop {{s0-s11}}",
                m = inout(reg) k / 4 => _,
                xp = inout(reg) x.as_ptr() => _,
                p0 = inout(reg) p[0] => _,
                p1 = inout(reg) p[1] => _,
                p2 = inout(reg) p[2] => _,
                p3 = inout(reg) p[3] => _,
                a0 = inout(reg) a[0],
                a1 = inout(reg) a[1],
                a2 = inout(reg) a[2],
                a3 = inout(reg) a[3],
                options(readonly),
            );
        }
    }
    (a.map(f32::from_bits), k)
}
