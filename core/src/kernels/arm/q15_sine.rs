//! The Q15 sine-row kernel [`sine_rows_q15`]: a `Sine` layer's
//! activations from its exact row sums (bias, phase, table sine, store) in
//! one `asm!` loop, the same integer steps as `fixed`'s `sine_phase` and
//! [`crate::fixed::sin_q15`].

use core::arch::asm;

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
