//! The Q15 latent-row kernel [`latent_rows_q15`]: the decoder's first
//! layer over its 16 latent columns, one fully unrolled row per pass,
//! starting from the exact partial sums of the feature columns.

use core::arch::asm;
use core::mem::MaybeUninit;

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
/// against ~51 per row pair in [`dot_rows_q15`](super::dot_rows_q15)'s frame-based loop plus the
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
        // Operands listed per kernel, as in `q15_sine`/`q15_rows`/`fpu`: each
        // program's registers are its own, checked against its own SAFETY note.
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
