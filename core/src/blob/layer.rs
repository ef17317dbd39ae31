//! One layer: its wire encodings ([`LayerWire`], [`LayerWireQ`]) and the
//! validated [`Layer`] view of its tensors, still in the blob.

use core::ops::RangeInclusive;

use serde::{Deserialize, Serialize};

use super::Activation;

/// Format version 3: every weight and bias tensor starts at a multiple of
/// this many bytes from the blob's start. 4 is what the Cortex-M4/M7 word
/// loads need (`LDRD`, `LDM`, `VLDM`, `VLDR` require word alignment, not
/// doubleword); 8 would not make every row 8-aligned anyway (an int16 row of
/// `n` weights is `2n` bytes), so it would only add padding.
pub const TENSOR_ALIGN: usize = 4;

#[doc(hidden)]
/// One layer on the wire: dims, activation, and raw little-endian tensors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LayerWire<'a> {
    /// Input width.
    pub in_dim: u16,
    /// Output width.
    pub out_dim: u16,
    /// Activation after the affine map.
    pub activation: Activation,
    /// `out_dim × in_dim` values, row-major (`W[j][i]` at `j·in_dim + i`).
    pub weights: &'a [u8],
    /// `out_dim` values.
    pub bias: &'a [u8],
}

#[doc(hidden)]
/// One fixed-point layer on the wire ([`NumericKind::Int16Q15`]); see
/// `weights/FORMAT.md` and [`crate::fixed`] for the arithmetic.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LayerWireQ<'a> {
    /// Input width.
    pub in_dim: u16,
    /// Output width.
    pub out_dim: u16,
    /// Activation after the affine map.
    pub activation: Activation,
    /// The input vector holds `x_i · 2^in_exp` (i16 range).
    pub in_exp: i8,
    /// The output vector holds `y_j · 2^out_exp`; 15 for `Sine` layers.
    pub out_exp: i8,
    /// `out_dim × in_dim` i16 LE, row-major.
    pub weights: &'a [u8],
    /// `out_dim` i32 LE, in accumulator units.
    pub bias: &'a [u8],
    /// `out_dim` i8: the per-channel requantisation shift.
    pub shifts: &'a [u8],
}

#[doc(hidden)]
/// Smallest exponent a fixed-point activation vector may use.
pub const MIN_EXP: i8 = -8;
#[doc(hidden)]
/// Largest exponent a fixed-point activation vector may use.
pub const MAX_EXP: i8 = 30;
#[doc(hidden)]
/// Allowed shifts of `Linear`/`Relu` channels.
pub const AFFINE_SHIFTS: RangeInclusive<i8> = 0..=62;
#[doc(hidden)]
/// Allowed shifts of `Sine` channels.
pub const SINE_SHIFTS: RangeInclusive<i8> = -31..=62;

#[doc(hidden)]
/// `2^e` as f32 (exact for −126 ≤ e ≤ 127): the value of one step of a
/// fixed-point vector with exponent `−e`.
#[inline]
pub fn pow2(e: i32) -> f32 {
    let e = e.clamp(-126, 127);
    f32::from_bits(((127 + e) as u32) << 23)
}

/// A validated layer: dims, activation, and its tensors still in the blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layer<'a> {
    pub(super) in_dim: usize,
    pub(super) out_dim: usize,
    pub(super) activation: Activation,
    pub(super) weights: &'a [u8],
    pub(super) bias: &'a [u8],
    pub(super) shifts: &'a [u8],
    pub(super) in_exp: i8,
    pub(super) out_exp: i8,
    /// Every shift in `-31..=32` (computed once when the blob is read).
    pub(super) short_shifts: bool,
}

impl<'a> Layer<'a> {
    /// Input width.
    pub fn in_dim(&self) -> usize {
        self.in_dim
    }
    /// Output width.
    pub fn out_dim(&self) -> usize {
        self.out_dim
    }
    /// Activation.
    pub fn activation(&self) -> Activation {
        self.activation
    }
    /// `W[j][i]`, or 0 when out of range (never panics).
    #[inline]
    pub fn weight(&self, j: usize, i: usize) -> f32 {
        read_f32(self.weights, j * self.in_dim + i)
    }
    /// `b[j]`, or 0 when out of range (never panics).
    #[inline]
    pub fn bias(&self, j: usize) -> f32 {
        read_f32(self.bias, j)
    }
    #[doc(hidden)]
    /// Row `j` of `W` as raw little-endian bytes (empty when out of range).
    #[inline]
    pub fn row_bytes(&self, j: usize) -> &'a [u8] {
        let n = self.in_dim * 4;
        self.weights.get(j * n..j * n + n).unwrap_or(&[])
    }
    /// Fixed point: input exponent (0 for f32 layers).
    pub fn in_exp(&self) -> i8 {
        self.in_exp
    }
    /// Fixed point: output exponent (0 for f32 layers).
    pub fn out_exp(&self) -> i8 {
        self.out_exp
    }
    /// Fixed point: `W[j][i]` as i16, or 0 when out of range (never panics).
    #[inline]
    pub fn weight_q(&self, j: usize, i: usize) -> i16 {
        let k = (j * self.in_dim + i) * 2;
        match self.weights.get(k..k + 2) {
            Some(&[a, b]) => i16::from_le_bytes([a, b]),
            _ => 0,
        }
    }
    #[doc(hidden)]
    /// Fixed point: row `j` of `W` as raw i16 LE bytes (empty when out of range).
    #[inline]
    pub fn row_bytes_q(&self, j: usize) -> &'a [u8] {
        let n = self.in_dim * 2;
        self.weights.get(j * n..j * n + n).unwrap_or(&[])
    }
    /// Fixed point: `b[j]` as i32 accumulator units, or 0 when out of range.
    #[inline]
    pub fn bias_q(&self, j: usize) -> i32 {
        match self.bias.get(j * 4..j * 4 + 4) {
            Some(&[a, b, c, d]) => i32::from_le_bytes([a, b, c, d]),
            _ => 0,
        }
    }
    #[doc(hidden)]
    /// Fixed point: the whole layer's raw tensors `(weights, bias, shifts)`:
    /// `out_dim × in_dim` i16 LE (row-major), `out_dim` i32 LE and
    /// `out_dim` i8, for walking all rows in one pass without per-row
    /// bounds checks (empty for f32 layers' shifts).
    #[inline]
    pub fn tensors_q(&self) -> (&'a [u8], &'a [u8], &'a [u8]) {
        (self.weights, self.bias, self.shifts)
    }
    #[doc(hidden)]
    /// Fixed point: whether every requantisation shift is in `-31..=32`
    /// (found once, when the blob is read): a `Sine` layer's phase is then
    /// one 32-bit shift of one word of the accumulator, which the
    /// Cortex-M4/M7 sine loop takes without a range check per row.
    #[inline]
    pub fn short_shifts(&self) -> bool {
        self.short_shifts
    }
    /// Fixed point: requantisation shift of channel `j`, or 0 when out of range.
    #[inline]
    pub fn shift(&self, j: usize) -> i8 {
        self.shifts.get(j).map_or(0, |&s| s as i8)
    }
    /// Multiply-accumulates of this layer.
    pub fn macs(&self) -> usize {
        self.in_dim * self.out_dim
    }
    /// Rows `first .. first + n` of this layer as a layer of `n` outputs (the
    /// same inputs, activation and exponents); `None` when out of range.
    /// The engine computes one latent of a proposal this way.
    pub(crate) fn rows(&self, first: usize, n: usize) -> Option<Layer<'a>> {
        let end = first.checked_add(n).filter(|&e| e <= self.out_dim)?;
        let wsize = self
            .weights
            .len()
            .checked_div(self.in_dim.checked_mul(self.out_dim)?)?;
        let w = self
            .weights
            .get(first * self.in_dim * wsize..end * self.in_dim * wsize)?;
        let bias = self.bias.get(first * 4..end * 4)?;
        let shifts = if self.shifts.is_empty() {
            self.shifts
        } else {
            self.shifts.get(first..end)?
        };
        Some(Layer {
            out_dim: n,
            weights: w,
            bias,
            shifts,
            ..*self
        })
    }
}

#[inline]
pub(crate) fn read_f32(bytes: &[u8], idx: usize) -> f32 {
    match bytes.get(idx * 4..idx * 4 + 4) {
        Some(&[a, b, c, d]) => f32::from_le_bytes([a, b, c, d]),
        _ => 0.0,
    }
}
