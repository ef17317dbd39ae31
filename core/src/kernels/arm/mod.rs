//! Target-specific inner loops of the dense layers: the only module of this
//! crate with `unsafe` (inline assembly), compiled only for
//! `cfg(all(target_arch = "arm", target_feature = "dsp"))` (Cortex-M4/M7:
//! `thumbv7em-*`). Every other target uses the portable loops in
//! [`crate::fixed`] and [`crate::float`], which are the reference: each
//! function here computes exactly the same value (see `docs/kernels.md`).
//!
//! # Q15: two rows per pass, `SMLALD`
//!
//! [`dot_rows_q15`] computes `Σ_i q_j,i · x_i` for every row `j` of a block
//! of rows in one `asm!` block, two rows per pass. Per four inputs: one
//! `LDRD` brings `x_i .. x_i+3` (the activation row is 4-byte aligned;
//! otherwise the caller's portable loop runs) and four `SMLALD` do the
//! eight MACs. The weights come either with one `LDRD` per row (both rows'
//! columns word aligned: a format-3 blob, whose tensors start at multiples
//! of 4, placed at an aligned address, with an even row stride — 7
//! instructions per 8 MACs) or with two `LDR` per row (any alignment: flash
//! is normal memory and the Cortex-M4 allows unaligned `LDR`, as the
//! portable loop's compiled code already assumes; `LDRD` would fault — 9 per
//! 8). `SMLALD` adds both 16 × 16 products to a 64-bit accumulator with
//! 64-bit wrap-around; since `|acc| < 2^47` for every valid blob (see
//! [`crate::fixed`]), nothing wraps and the sum equals the portable `i64`
//! sum exactly, whatever the order or the load width.
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
use core::mem::MaybeUninit;

/// Four of `$block` (16 inputs of a row pair) as asm text: the body of
/// both [`q15_loops`]' main loop and [`q15_loops_x4`].
macro_rules! q15_block4 {
    ($block:ident) => {
        concat!($block!(), $block!(), $block!(), $block!())
    };
}

/// The loops over one row pair of one of [`dot_rows_q15`]'s paths as asm text, `$block` being
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
            q15_block4!($block),
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

/// [`q15_loops`] for a block count `m` that is a positive multiple of 4
/// (rows of `16·j` inputs, every shipped layer): 4 blocks per iteration and
/// nothing else, so per row pair the 4 instructions of [`q15_loops`]'s
/// second loop entry (`subs`/`blt`, `adds`/`beq`) are not paid.
macro_rules! q15_loops_x4 {
    ($block:ident) => {
        concat!("2:\n", q15_block4!($block), "subs {m}, {m}, #4\n", "bne 2b",)
    };
}

/// [`dot_rows_q15`]'s 4-input block for word-aligned rows: one `LDRD` of four
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

/// [`dot_rows_q15`]'s 4-input block for rows at any alignment: one `LDRD` of
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

/// The whole of one of [`dot_rows_q15`]'s paths as asm text, `$block` being
/// that path's 4-input block ([`q15_block_ldrd`] or [`q15_block_ldr`]).
///
/// On entry `m` = blocks per row, `xp` = `x`, `p0` = the first row's first
/// column, `x0` = row pairs (≥ 1), `x1` = the output pointer, `w0` = `adv`
/// (bytes from the end of a row pair's columns in its second row to the
/// first column of the next pair's first row: `n − 2k`), `w1` = `n` (row
/// stride). These six are kept in a 24-byte frame below the stack pointer
/// (slots: 0 blocks, 4 `x`, 8 output pointer, 12 `adv`, 16 `n`, 20 pairs
/// left) because all 12 operand registers are busy in the inner loop. Per
/// row pair: zero both 64-bit accumulators, reload `m` and `xp`, run
/// [`q15_loops`], store both sums (`STRD`, low word first: an `i64` in
/// little-endian order), step `p0`/`p1` to the next pair and count down.
macro_rules! q15_rows {
    ($block:ident) => {
        q15_rows!($block, q15_loops)
    };
    ($block:ident, $loops:ident) => {
        concat!(
            "sub sp, sp, #24\n",
            "str {m}, [sp]\n",
            "str {xp}, [sp, #4]\n",
            "str {x1}, [sp, #8]\n",
            "strd {w0}, {w1}, [sp, #12]\n",
            "str {x0}, [sp, #20]\n",
            "add {p1}, {p0}, {w1}\n",
            "5:\n",
            "mov {a0}, #0\n",
            "mov {a1}, #0\n",
            "mov {b0}, #0\n",
            "mov {b1}, #0\n",
            "ldr {m}, [sp]\n",
            "ldr {xp}, [sp, #4]\n",
            $loops!($block),
            "\n9:\n",
            "ldr {w0}, [sp, #8]\n",
            "strd {a0}, {a1}, [{w0}], #8\n",
            "strd {b0}, {b1}, [{w0}], #8\n",
            "str {w0}, [sp, #8]\n",
            "ldrd {w0}, {w1}, [sp, #12]\n",
            "add {p0}, {p1}, {w0}\n",
            "add {p1}, {p0}, {w1}\n",
            "ldr {w0}, [sp, #20]\n",
            "subs {w0}, {w0}, #1\n",
            "str {w0}, [sp, #20]\n",
            "bne 5b\n",
            "add sp, sp, #24",
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

/// Rows per call of [`dot_rows_q15`]: the length of its buffer (256 bytes
/// of stack; 16 rows cost ~7,000 more instructions per sdd-tiny-v2-qe call
/// in per-chunk setup).
pub(crate) const ROW_CHUNK: usize = 32;

/// `Σ_{i<k} q_j,i · x_i` for the rows `j < rows` (at most [`ROW_CHUNK`]) of
/// i16 LE weights `w[j·n + lo ..]` (`n`: the row stride in bytes), where
/// `k` is the largest multiple of 4 with `k ≤ x.len()`, written into the
/// caller's uninitialised `buf` (an array returned by value was copied, and
/// an array or struct initialised in Rust was cleared with a call per
/// chunk); returns the written sums and `k`. The sums start from 0: the caller adds its bias or partial sum
/// (exact integers, so the grouping does not matter). The kernel takes an
/// even number of rows: the sums are those of the first `rows & !1` rows
/// (an odd last row is the caller's), or none (and `k = 0`) when `k` would
/// be 0, `x` is not 4-byte aligned, the columns would run past a row
/// (`lo + 2·x.len() > n`) or `w` holds fewer rows.
///
/// One `asm!` block for all the rows ([`q15_rows`]): what a kernel call per
/// row pair cost around it in Rust (the checks, the accumulators in and
/// out of registers, the alignment test, ~45 instructions) is paid once
/// per call here; per row pair the frame bookkeeping is 17 instructions.
/// Aligned rows (`w + lo` and `n` multiples of 4, tested once) take the
/// `LDRD` block, any others the `LDR` block; with `x4` (a literal at each
/// call site, so that the other callers do not carry a third copy of the
/// loop: only the `Sine` layers' hot path sets it), aligned rows of `16·j`
/// inputs loop 4 blocks at a time without a tail ([`q15_loops_x4`]).
#[inline(always)]
pub(crate) fn dot_rows_q15<'b>(
    w: &[u8],
    n: usize,
    lo: usize,
    x: &[i16],
    rows: usize,
    buf: &'b mut [MaybeUninit<i64>; ROW_CHUNK],
    x4: bool,
) -> (&'b mut [i64], usize) {
    let rows = rows.min(ROW_CHUNK);
    let even = rows & !1;
    let k = x.len() & !3;
    let ok = k != 0
        && even != 0
        && (x.as_ptr() as usize) & 3 == 0
        && lo.saturating_add(2 * x.len()) <= n
        && even.saturating_mul(n) <= w.len();
    if !ok {
        return (&mut [], 0);
    }
    let out = buf.as_mut_ptr().cast::<i64>();
    let p0 = w.as_ptr().wrapping_add(lo);
    // n ≥ lo + 2·x.len() ≥ 2k (checked above).
    let adv = n.wrapping_sub(2 * k);
    // The one `asm!` call of every path, `$text` its program: the operands
    // (on entry: blocks per row, `x`, the first row's first column, row
    // pairs, the output pointer, `adv`, `n`) are the same for all.
    macro_rules! rows_asm {
        ($text:expr) => {
            asm!(
                $text,
                m = inout(reg) k / 4 => _,
                xp = inout(reg) x.as_ptr() => _,
                p0 = inout(reg) p0 => _,
                p1 = out(reg) _,
                x0 = inout(reg) even / 2 => _,
                x1 = inout(reg) out => _,
                w0 = inout(reg) adv => _,
                w1 = inout(reg) n => _,
                a0 = out(reg) _,
                a1 = out(reg) _,
                b0 = out(reg) _,
                b1 = out(reg) _,
            )
        };
    }
    let aligned = (p0 as usize | n) & 3 == 0;
    if x4 && aligned && k % 16 == 0 {
        // SAFETY: reads `x[..k]` with `LDRD` at 4-byte aligned addresses
        // (`x` is 4-byte aligned, checked above, and each row restarts at
        // `x`), and for each row `j < even` the bytes `[j·n + lo, j·n + lo +
        // 2k)` of `w` (inside `w`: lo + 2k ≤ n and even·n ≤ w.len()) with
        // `LDRD` at 4-byte aligned addresses (`w + lo` and `n` are
        // multiples of 4, checked just above, and each pointer advances by
        // 8). Writes `buf[..even]` (even ≤ ROW_CHUNK; 2·even words,
        // `STRD` at the array's 8-byte aligned addresses), nothing else but
        // its own 24-byte frame below the stack pointer, which it releases
        // before the end (no `nostack`: the compiler keeps the stack
        // pointer aligned and nothing lives below it). Every register
        // written is a declared operand; the flags are clobbered (asm!
        // assumes so). `k / 4` is a positive multiple of 4 here (`k ≠ 0`
        // and `k % 16 == 0`), which `q15_loops_x4` needs to end.
        unsafe { rows_asm!(q15_rows!(q15_block_ldrd, q15_loops_x4)) }
    } else if aligned {
        // SAFETY: as just above (`q15_loops` takes any `k / 4 ≥ 1`).
        unsafe { rows_asm!(q15_rows!(q15_block_ldrd)) }
    } else {
        // SAFETY: as above, except that the weights are read with `LDR`,
        // which the Cortex-M4/M7 allow unaligned on normal memory (flash and
        // SRAM; `CCR.UNALIGN_TRP` is 0 out of reset and the firmware never
        // sets it).
        unsafe { rows_asm!(q15_rows!(q15_block_ldr)) }
    }
    // SAFETY: the kernel above has written `buf[..even]` (even ≤
    // ROW_CHUNK); `MaybeUninit<i64>` has the layout of `i64`; the slice
    // reborrows `buf` mutably for `'b`.
    let sums = unsafe { core::slice::from_raw_parts_mut(out, even) };
    (sums, k)
}

/// One row of [`latent_rows_q15`] as asm text: its 64-bit start value from
/// `part` (`LDRD`, post-incremented), the 16 columns as four blocks of one
/// `LDRD` of four latents and one `LDRD` of four weights at immediate
/// offsets and two `SMLALD`, the step to the next row (`n` bytes), the sum
/// stored (`STRD`, post-incremented) and the count: 21 instructions for 16
/// MACs, no frame and no reloads.
macro_rules! q15_latent_row {
    () => {
        concat!(
            "ldrd {a0}, {a1}, [{pp}], #8\n",
            "ldrd {x0}, {x1}, [{xp}]\n",
            "ldrd {w0}, {w1}, [{p0}]\n",
            "smlald {a0}, {a1}, {w0}, {x0}\n",
            "smlald {a0}, {a1}, {w1}, {x1}\n",
            "ldrd {x0}, {x1}, [{xp}, #8]\n",
            "ldrd {w0}, {w1}, [{p0}, #8]\n",
            "smlald {a0}, {a1}, {w0}, {x0}\n",
            "smlald {a0}, {a1}, {w1}, {x1}\n",
            "ldrd {x0}, {x1}, [{xp}, #16]\n",
            "ldrd {w0}, {w1}, [{p0}, #16]\n",
            "smlald {a0}, {a1}, {w0}, {x0}\n",
            "smlald {a0}, {a1}, {w1}, {x1}\n",
            "ldrd {x0}, {x1}, [{xp}, #24]\n",
            "ldrd {w0}, {w1}, [{p0}, #24]\n",
            "smlald {a0}, {a1}, {w0}, {x0}\n",
            "smlald {a0}, {a1}, {w1}, {x1}\n",
            "add {p0}, {p0}, {n}\n",
            "strd {a0}, {a1}, [{op}], #8\n",
            "subs {cnt}, {cnt}, #1\n",
        )
    };
}

/// `part_j + Σ_{i<16} q_j,i · z_i` for the rows `j < part.len()` (at most
/// `N`, the length of `buf`) of i16 LE weights `w[j·n + lo ..]` (`n`: the row stride
/// in bytes): the decoder's first layer over its 16 latent columns, the
/// feature columns' exact partial sum `part_j` (bias included) being the
/// start value. Written into the caller's uninitialised `buf`; returns the
/// written sums, all `part.len()` rows, or none when a precondition fails:
/// `z` 4-byte aligned, `w + lo` and `n` multiples of 4 (`LDRD` needs word
/// alignment; a format-3 blob has them), `lo + 32 ≤ n`, and `w` holding
/// `part.len()` rows.
///
/// One row per pass (12 registers: a second row's accumulator and pointer
/// would not fit without a frame, see `docs/kernels.md`), fully unrolled
/// over the 16 columns ([`q15_latent_row`]): 21 instructions per row,
/// against ~51 per row pair in [`dot_rows_q15`]'s frame-based loop plus the
/// partial sum added in Rust. The sum is the same exact integer (`|acc| <
/// 2^47`, no wrap-around in the 64-bit `SMLALD`; integer addition is
/// associative, so starting from `part_j` equals adding it afterwards).
#[inline(always)]
pub(crate) fn latent_rows_q15<'b, const N: usize>(
    w: &[u8],
    n: usize,
    lo: usize,
    z: &[i16; 16],
    part: &[i64],
    buf: &'b mut [MaybeUninit<i64>; N],
) -> &'b mut [i64] {
    let rows = part.len();
    let p0 = w.as_ptr().wrapping_add(lo);
    let ok = rows != 0
        && rows <= N
        && (z.as_ptr() as usize) & 3 == 0
        && (p0 as usize | n) & 3 == 0
        && lo.saturating_add(32) <= n
        && rows.saturating_mul(n) <= w.len();
    if !ok {
        return &mut [];
    }
    let out = buf.as_mut_ptr().cast::<i64>();
    // SAFETY: reads the 32 bytes of `z` (4-byte aligned, checked above)
    // with `LDRD` at offsets 0, 8, 16, 24; for each row `j < rows` the bytes
    // `[j·n + lo, j·n + lo + 32)` of `w` (inside `w`: lo + 32 ≤ n and
    // rows·n ≤ w.len()) with `LDRD` at 4-byte aligned addresses (`w + lo`
    // and `n` multiples of 4, checked above); `part[..rows]` with `LDRD`
    // (an `&[i64]`: 8-byte aligned). Writes `buf[..rows]` (rows ≤ N;
    // `STRD` at the array's 8-byte aligned addresses) and
    // nothing else; no stack. Every register written is a declared
    // operand; the flags are clobbered (asm! assumes so). `rows ≥ 1`, so
    // the count reaches 0 after `rows` passes.
    unsafe {
        asm!(
            "2:",
            q15_latent_row!(),
            "bne 2b",
            pp = inout(reg) part.as_ptr() => _,
            xp = in(reg) z.as_ptr(),
            p0 = inout(reg) p0 => _,
            n = in(reg) n,
            op = inout(reg) out => _,
            cnt = inout(reg) rows => _,
            a0 = out(reg) _,
            a1 = out(reg) _,
            x0 = out(reg) _,
            x1 = out(reg) _,
            w0 = out(reg) _,
            w1 = out(reg) _,
            options(nostack),
        );
    }
    // SAFETY: the kernel above has written `buf[..rows]` (rows ≤ N);
    // `MaybeUninit<i64>` has the layout of `i64`; the slice reborrows `buf`
    // mutably for `'b`.
    unsafe { core::slice::from_raw_parts_mut(out, rows) }
}

/// [`sine_rows_q15`]'s row sum with a bias: `acc = sum + B` (64-bit `LDRD`,
/// the i32 bias by `LDR`, sign-extended into `ADDS`/`ADC … ASR #31`).
macro_rules! q15_acc_bias {
    () => {
        concat!(
            "ldrd {lo}, {hi}, [{ap}], #8\n",
            "ldr {b}, [{bp}], #4\n",
            "adds {lo}, {lo}, {b}\n",
            "adc {hi}, {hi}, {b}, asr #31\n",
        )
    };
}

/// [`sine_rows_q15`]'s row sum without a bias (the sums hold it already):
/// `acc = sum` (`LDRD`).
macro_rules! q15_acc_plain {
    () => {
        "ldrd {lo}, {hi}, [{ap}], #8\n"
    };
}

/// [`sine_rows_q15`]'s sine of the phase in `{hi}`, its store and the row
/// count as asm text: `sin_q15(phase)` (quadrant fold, table word,
/// interpolation, `v − (v >> 15)`, sign), `STRH`, then back to label 2
/// while rows are left (falls through after the last). The interpolation's
/// `d·frac + 2^15` is one `MLA` with `{rnd}` = 2^15 (the same wrapping
/// multiply and add as `MUL` then `ADD`).
macro_rules! q15_sine_tail {
    () => {
        concat!(
            "bic {lo}, {hi}, #0xC0000000\n",
            "lsls {t}, {hi}, #1\n",
            "it mi\n",
            "rsbmi {lo}, {lo}, #0x40000000\n",
            "lsrs {t}, {lo}, #22\n",
            "ldr {b}, [{tp}, {t}, lsl #2]\n",
            "ubfx {lo}, {lo}, #6, #16\n",
            "lsrs {t}, {b}, #16\n",
            "mla {lo}, {t}, {lo}, {rnd}\n",
            "asrs {lo}, {lo}, #16\n",
            "uxtah {lo}, {lo}, {b}\n",
            "sub {lo}, {lo}, {lo}, lsr #15\n",
            "eor {lo}, {lo}, {hi}, asr #31\n",
            "sub {lo}, {lo}, {hi}, asr #31\n",
            "strh {lo}, [{op}], #2\n",
            "subs {cnt}, {cnt}, #1\n",
            "bne 2b\n",
        )
    };
}

/// [`sine_rows_q15`]'s row loop as asm text (see there), `$acc` one of
/// [`q15_acc_bias`], [`q15_acc_plain`]: label 2 per row, 3 the `s ≤ 0`
/// phase, 8 the exit. Each sign of the shift checks its own end of the
/// range `−31 ..= 32` (two compares per row instead of a range test and a
/// sign test) and has its own copy of [`q15_sine_tail`] (no branch from the
/// `s > 0` phase to a shared tail). A row outside the range leaves with its
/// count not yet taken (the pointers it advanced are discarded). With
/// `unchecked` (every shift known to be in the range) the two compares are
/// left out.
macro_rules! q15_sine_rows {
    ($acc:ident) => {
        q15_sine_rows!($acc, "cmp {s}, #32\nbhi 8f\n", "cmn {s}, #31\nblt 8f\n")
    };
    ($acc:ident, unchecked) => {
        q15_sine_rows!($acc, "", "")
    };
    ($acc:ident, $check_hi:expr, $check_lo:expr) => {
        concat!(
            "2:\n",
            "ldrsb {s}, [{sh}], #1\n",
            $acc!(),
            "cmp {s}, #0\n",
            "ble 3f\n",
            // 1 ≤ s (≤ 32, or leave). Then bits s .. s + 31 of acc plus
            // bit s − 1.
            $check_hi,
            "rsb {t}, {s}, #32\n",
            "lsl {hi}, {hi}, {t}\n",
            "sub {t}, {s}, #1\n",
            "lsr {t}, {lo}, {t}\n",
            "and {b}, {t}, #1\n",
            "orr {hi}, {hi}, {t}, lsr #1\n",
            "add {hi}, {hi}, {b}\n",
            q15_sine_tail!(),
            "b 8f\n",
            // s ≤ 0 (≥ −31, or leave). Then the low word shifted left by
            // −s.
            "3:\n",
            $check_lo,
            "rsb {t}, {s}, #0\n",
            "lsl {hi}, {lo}, {t}\n",
            q15_sine_tail!(),
            "8:",
        )
    };
}

/// `out_j = sin_q15(phase(sums_j + B_j, s_j))` (the `Sine` activation of
/// [`crate::fixed`]: `sine_phase`, then `sin_q15` with the `(a, b − a)`
/// word table `tab`) for the rows `j` from 0 while `−31 ≤ s_j ≤ 32`, where
/// `B_j` is the i32 LE bias at `bias[4j..]` (any alignment: `LDR`), or 0
/// when `bias` is `None` (the sums hold it: 3 instructions less per row),
/// and `s_j = shifts[j] as i8`; returns how many rows it did (it stops
/// before the first row with another shift, or at the end of the shortest
/// of `sums`, `bias / 4`, `shifts`, `out`). `short` says that every shift
/// is in −31..=32 (the layer's [`crate::blob::Layer::short_shifts`], found
/// when the blob was read): the loop then leaves the per-row range check
/// out (2 instructions per row).
///
/// One `asm!` loop (12 registers) instead of Rust's per-row loop, which
/// kept the table address, the shift dispatch and three iterator ends in
/// its way: ~27 instructions per row for `s ≤ 0` and ~31 for `s > 0` with
/// `short` (2 more without), against ~34 and ~48. Every step is the Rust one on the same integers:
/// `acc = sum + B` in 64 bits (`ADDS`/`ADC` with the sign-extended bias);
/// for `1 ≤ s ≤ 32` the phase is `(lo >> s) | (hi << (32 − s))` plus bit
/// `s − 1` of `lo` (for `s = 32`: `hi + bit 31`, which is `rshr(acc, 32)
/// mod 2^32`; `LSL` by 0 is the identity and `lo >> 31 >> 1` is 0), for
/// `s ≤ 0` it is `lo << −s`; then the quadrant fold, the table word, the
/// interpolation `a + ((d·frac + 2^15) >> 16)` (`d·frac < 2^24`: no
/// overflow), `v − (v >> 15)` and the sign as in `sin_q15`.
#[inline(always)]
pub(crate) fn sine_rows_q15(
    sums: &[i64],
    bias: Option<&[u8]>,
    shifts: &[u8],
    out: &mut [i16],
    tab: &[u32; 257],
    short: bool,
) -> usize {
    let rows = sums
        .len()
        .min(bias.map_or(usize::MAX, |b| b.len() / 4))
        .min(shifts.len())
        .min(out.len());
    if rows == 0 {
        return 0;
    }
    let left: usize;
    // The one `asm!` call of every variant, `$text` its program, `$bias`
    // the bias operand (or nothing).
    macro_rules! sine_asm {
        ($text:expr $(, $bias:tt)?) => {
            asm!(
                $text,
                sh = inout(reg) shifts.as_ptr() => _,
                ap = inout(reg) sums.as_ptr() => _,
                $(bp = inout(reg) $bias.as_ptr() => _,)?
                op = inout(reg) out.as_mut_ptr() => _,
                tp = in(reg) tab.as_ptr(),
                rnd = in(reg) 1u32 << 15,
                cnt = inout(reg) rows => left,
                s = out(reg) _,
                t = out(reg) _,
                lo = out(reg) _,
                hi = out(reg) _,
                b = out(reg) _,
                options(nostack),
            )
        };
    }
    // What the four `unsafe` blocks below rely on: per row `j < rows` (the
    // loop counts `rows` down and stops at 0, or leaves earlier) it reads
    // `shifts[j]` (`LDRSB`), `sums[j]` (`LDRD`, an `&[i64]`: 8-byte aligned), with a
    // bias the 4 bytes `bias[4j..4j + 4]` (`LDR`, unaligned allowed on the
    // Cortex-M4/M7 for normal memory: `CCR.UNALIGN_TRP` is 0 and never set)
    // and one word of `tab` at index `p >> 22 ≤ 256` (`p ≤ 2^30` after the
    // fold, whatever the shift) with `LDR` (a `&[u32; 257]`: aligned), and
    // writes `out[j]` (`STRH`, an `&mut [i16]`: 2-byte aligned). Nothing
    // else is written; no stack. Every register written is a declared
    // operand; the flags are clobbered (asm! assumes so). The `IT` block
    // covers one instruction inside the asm. The shift only enters register
    // shifts (the unchecked variant relies on `short` for the value, not
    // for memory safety).
    match (bias, short) {
        // SAFETY: as above, with the bias read.
        (Some(bias), false) => unsafe { sine_asm!(q15_sine_rows!(q15_acc_bias), bias) },
        // SAFETY: as above, with the bias read; no range check.
        (Some(bias), true) => unsafe { sine_asm!(q15_sine_rows!(q15_acc_bias, unchecked), bias) },
        // SAFETY: as above, no bias read.
        (None, false) => unsafe { sine_asm!(q15_sine_rows!(q15_acc_plain)) },
        // SAFETY: as above, no bias read; no range check.
        (None, true) => unsafe { sine_asm!(q15_sine_rows!(q15_acc_plain, unchecked)) },
    }
    rows - left
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
