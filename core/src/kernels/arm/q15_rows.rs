//! The Q15 row kernel [`dot_rows_q15`]: the dense layers' row sums, two
//! rows per pass, in one `asm!` block for a chunk of up to [`ROW_CHUNK`]
//! rows.
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
