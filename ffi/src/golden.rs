//! Golden files (`weights/<model>.golden`) through the C ABI: what a file
//! was produced with, and its cases one at a time, for the C and C++ replay
//! examples and their tests.
use core::ffi::c_char;

use gpecnet_core::golden::GoldenSet;

use crate::boundary::{c_name, guard, non_null};
use crate::limits::GPECNET_NAME_LEN;
use crate::limits::{GPECNET_GOLDEN_MAX_K, GPECNET_MAX_FUTURE, GPECNET_MAX_PAST};
use crate::status::{blob_status, GPECNET_E_BAD_LENGTH, GPECNET_E_CAPACITY_EXCEEDED};

#[cfg(doc)]
use crate::GpecnetModelInfo;

/// What a golden file (`weights/<model>.golden`) was produced with.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpecnetGoldenInfo {
    /// CRC-32 of the blob the cases belong to ([`GpecnetModelInfo::crc`]).
    pub model_crc: u32,
    /// Number of cases.
    pub n_cases: u32,
    /// Observed steps per case.
    pub past_len: u32,
    /// Steps per trajectory.
    pub future_len: u32,
    /// Endpoints per case.
    pub k: u32,
    /// Model name, NUL-terminated, cut to fit.
    pub model_name: [c_char; GPECNET_NAME_LEN],
    /// Sine the f32 cases were computed with (`libm`, `q15-table`, ...), NUL-terminated.
    pub sine: [c_char; GPECNET_NAME_LEN],
}

/// One golden case: inputs and the expected outputs.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpecnetGoldenCase {
    /// Latent seed.
    pub seed: u64,
    /// Observed points.
    pub past_len: u32,
    /// Expected endpoints.
    pub k: u32,
    /// Points of the expected point forecast (0 when the file has none).
    pub point_len: u32,
    /// Observed (x, y) points.
    pub past_xy: [[f32; 2]; GPECNET_MAX_PAST],
    /// Expected endpoints (the model's endpoint set for `seed`).
    pub endpoints_xy: [[f32; 2]; GPECNET_GOLDEN_MAX_K],
    /// Expected point forecast.
    pub point_xy: [[f32; 2]; GPECNET_MAX_FUTURE],
}

/// The body of the golden-file functions: checks the pointers, validates the golden file at
/// `golden`/`len` and writes what `f` makes of it to `*out`, or returns the status code of
/// the first failure.
///
/// # Safety
/// `golden` is NULL or valid for reads of `len` bytes; `out` is NULL or valid for a write.
unsafe fn golden_out<T>(
    golden: *const u8,
    len: usize,
    out: *mut T,
    f: impl FnOnce(&GoldenSet<'_>) -> Result<T, i32>,
) -> i32 {
    guard(|| {
        non_null(golden)?;
        non_null(out)?;
        // SAFETY: non-null, readable for `len` bytes (caller's contract).
        let bytes = unsafe { core::slice::from_raw_parts(golden, len) };
        let value = f(&GoldenSet::parse(bytes).map_err(blob_status)?)?;
        // SAFETY: non-null, writable (caller's contract).
        unsafe { out.write_unaligned(value) };
        Ok(())
    })
}

/// Validates a golden file (magic, version, CRC, every case's shape) and fills `*out`.
/// Blob status codes describe a bad file.
///
/// # Safety
/// `golden` is NULL or valid for reads of `len` bytes; `out` is NULL or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_golden_info(
    golden: *const u8,
    len: usize,
    out: *mut GpecnetGoldenInfo,
) -> i32 {
    let fill = |set: &GoldenSet<'_>| {
        let i = set.info();
        Ok(GpecnetGoldenInfo {
            model_crc: i.model_crc,
            n_cases: i.n_cases,
            past_len: i.past_len.into(),
            future_len: i.future_len.into(),
            k: i.k.into(),
            model_name: c_name(i.model_name),
            sine: c_name(i.sine),
        })
    };
    // SAFETY: the caller's contract is `golden_out`'s.
    unsafe { golden_out(golden, len, out, fill) }
}

/// Decodes case `index` of a golden file into `*out` (validating the file
/// again: meant for tests and examples, not for a control loop). Fails with
/// [`GPECNET_E_BAD_LENGTH`] when `index >= n_cases`, and with
/// [`GPECNET_E_CAPACITY_EXCEEDED`] when a case has more than
/// [`GPECNET_GOLDEN_MAX_K`] endpoints.
///
/// # Safety
/// As [`gpecnet_golden_info`].
#[no_mangle]
pub unsafe extern "C" fn gpecnet_golden_case(
    golden: *const u8,
    len: usize,
    index: u32,
    out: *mut GpecnetGoldenCase,
) -> i32 {
    let fill = |set: &GoldenSet<'_>| {
        let Some(case) = set.cases().nth(index as usize) else {
            return Err(GPECNET_E_BAD_LENGTH);
        };
        if case.k() > GPECNET_GOLDEN_MAX_K || case.point_len() > GPECNET_MAX_FUTURE {
            return Err(GPECNET_E_CAPACITY_EXCEEDED);
        }
        let mut c = GpecnetGoldenCase {
            seed: case.seed,
            past_len: case.past.len() as u32,
            k: case.k() as u32,
            point_len: case.point_len() as u32,
            past_xy: [[0.0; 2]; GPECNET_MAX_PAST],
            endpoints_xy: [[0.0; 2]; GPECNET_GOLDEN_MAX_K],
            point_xy: [[0.0; 2]; GPECNET_MAX_FUTURE],
        };
        for (dst, p) in c.past_xy.iter_mut().zip(case.past.iter()) {
            *dst = *p;
        }
        for (i, dst) in c.endpoints_xy.iter_mut().take(case.k()).enumerate() {
            *dst = case.endpoint_bits(i).map(f32::from_bits);
        }
        for (t, dst) in c.point_xy.iter_mut().enumerate() {
            match case.point_bits(t) {
                Some(b) => *dst = b.map(f32::from_bits),
                None => break,
            }
        }
        Ok(c)
    };
    // SAFETY: the caller's contract is `golden_out`'s.
    unsafe { golden_out(golden, len, out, fill) }
}
