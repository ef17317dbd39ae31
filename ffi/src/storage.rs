//! The predictor in caller-owned storage: the storage's layout (a tag, then
//! the core's predictor), the size it needs, the opaque [`GpecnetPredictor`],
//! and the init functions that validate a blob and build the predictor in
//! place (the one for signed blobs is in `signed`).
use core::ffi::c_void;
use core::mem::{align_of, size_of};

use gpecnet_core::units::CallerUnit;
use gpecnet_core::{LibmSine, Model, Predictor};

use crate::boundary::{guard, non_null};
use crate::limits::{GPECNET_PREDICTOR_ALIGN, GPECNET_PREDICTOR_SIZE, GPECNET_SCRATCH_WIDTH};
use crate::status::{blob_status, error_status};
use crate::status::{GPECNET_E_BAD_LENGTH, GPECNET_E_MISALIGNED, GPECNET_E_NOT_INITIALISED};
use crate::status::{GPECNET_E_NULL_POINTER, GPECNET_E_UNIT_MISMATCH};
use crate::units::GPECNET_UNIT_SCALED_PIXELS;
use crate::units::{GPECNET_UNIT_METRES, GPECNET_UNIT_MODEL, GPECNET_UNIT_PIXELS};

#[cfg(doc)]
use crate::GPECNET_OK;

pub(crate) type Inner = Predictor<'static, LibmSine, GPECNET_SCRATCH_WIDTH>;

/// Tag of an initialised storage ("GPNT").
const LIVE: u32 = 0x544e_5047;

/// What the caller's storage holds: a tag, then the core's predictor.
#[repr(C)]
struct State {
    tag: u32,
    pred: Inner,
}

const _: () = {
    assert!(size_of::<State>() <= GPECNET_PREDICTOR_SIZE);
    assert!(align_of::<State>() <= GPECNET_PREDICTOR_ALIGN);
    assert!(GPECNET_PREDICTOR_ALIGN.is_power_of_two());
};

/// The size the storage actually needs on the target this library was built
/// for (at most [`GPECNET_PREDICTOR_SIZE`]).
#[no_mangle]
pub extern "C" fn gpecnet_predictor_size() -> usize {
    size_of::<State>()
}

/// An initialised predictor in caller-owned storage: `(GpecnetPredictor *)storage`
/// after [`gpecnet_init`] returned [`GPECNET_OK`]. Opaque to C.
pub struct GpecnetPredictor {
    _opaque: [u8; 0],
}

/// The predictor in `p`, or why there is none.
///
/// # Safety
/// `p` is NULL or points to storage of [`GPECNET_PREDICTOR_SIZE`] bytes that
/// was passed to [`gpecnet_init`], not in use by another call.
pub(crate) unsafe fn state<'a>(p: *mut GpecnetPredictor) -> Result<&'a mut Inner, i32> {
    if p.is_null() {
        return Err(GPECNET_E_NULL_POINTER);
    }
    if (p as usize) & (GPECNET_PREDICTOR_ALIGN - 1) != 0 {
        return Err(GPECNET_E_MISALIGNED);
    }
    let s = p.cast::<State>();
    // SAFETY: `s` is non-null and aligned (checked above); the caller
    // guarantees it points to storage that gpecnet_init has written (its tag
    // at least), so the tag is initialised memory.
    let tag = unsafe { core::ptr::addr_of!((*s).tag).read() };
    if tag != LIVE {
        return Err(GPECNET_E_NOT_INITIALISED);
    }
    // SAFETY: the tag is LIVE only after gpecnet_init wrote a whole valid
    // State; the caller guarantees exclusive use for this call.
    Ok(unsafe { &mut (*s).pred })
}

/// Validates the blob and builds a predictor in `storage` that takes and
/// returns positions in the model's own unit, unchecked: the same as
/// [`gpecnet_init_units`] with [`GPECNET_UNIT_MODEL`]. Prefer
/// `gpecnet_init_units`, which refuses a unit the model cannot take.
///
/// `storage` must be `storage_len >= GPECNET_PREDICTOR_SIZE` bytes aligned to
/// [`GPECNET_PREDICTOR_ALIGN`]; `blob` points to `blob_len` bytes that stay
/// valid and unchanged while the predictor is used (it is read in place). On
/// failure the storage is marked not initialised (when it is usable at all),
/// so later calls on it return [`GPECNET_E_NOT_INITIALISED`]. Initialising a
/// storage again replaces its predictor.
///
/// # Safety
/// `storage` is NULL or valid for writes of `storage_len` bytes; `blob` is
/// NULL or valid for reads of `blob_len` bytes for as long as the predictor
/// is used.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_init(
    storage: *mut c_void,
    storage_len: usize,
    blob: *const u8,
    blob_len: usize,
) -> i32 {
    // SAFETY: the caller's contract, passed on unchanged.
    unsafe {
        gpecnet_init_units(
            storage,
            storage_len,
            blob,
            blob_len,
            GPECNET_UNIT_MODEL,
            0.0,
        )
    }
}

/// [`gpecnet_init`] for a caller whose positions are in `unit`
/// (`GPECNET_UNIT_*`; `metres_per_pixel` is read only for
/// [`GPECNET_UNIT_SCALED_PIXELS`]): refused with a `GPECNET_E_UNIT_*` code
/// when the model cannot take them, else every input is converted into the
/// model's unit and every output back (`gpecnet_core::units`: `x · f` in,
/// `y / f` out). A `unit` value that is none of the four is
/// [`GPECNET_E_UNIT_MISMATCH`].
///
/// # Safety
/// As [`gpecnet_init`].
#[no_mangle]
pub unsafe extern "C" fn gpecnet_init_units(
    storage: *mut c_void,
    storage_len: usize,
    blob: *const u8,
    blob_len: usize,
    unit: u32,
    metres_per_pixel: f32,
) -> i32 {
    // SAFETY: the caller's contract, passed on unchanged.
    unsafe {
        init_with(
            (storage, storage_len),
            (blob, blob_len),
            (unit, metres_per_pixel),
            |bytes| Model::from_blob(bytes).map_err(blob_status),
        )
    }
}

/// The body of the init functions: checks the storage, reads the model with
/// `model` and builds the predictor for `unit` in the storage. The C
/// arguments come in pairs as the init functions take them: `(storage,
/// storage_len)`, `(blob, blob_len)` and `(unit, metres_per_pixel)`.
///
/// # Safety
/// As [`gpecnet_init`].
pub(crate) unsafe fn init_with(
    (storage, storage_len): (*mut c_void, usize),
    (blob, blob_len): (*const u8, usize),
    (unit, metres_per_pixel): (u32, f32),
    model: impl FnOnce(&'static [u8]) -> Result<Model<'static>, i32>,
) -> i32 {
    guard(|| {
        non_null(storage)?;
        if (storage as usize) & (GPECNET_PREDICTOR_ALIGN - 1) != 0 {
            return Err(GPECNET_E_MISALIGNED);
        }
        if storage_len < size_of::<State>() {
            return Err(GPECNET_E_BAD_LENGTH);
        }
        let s = storage.cast::<State>();
        // SAFETY: non-null, aligned, and at least size_of::<State>() writable
        // bytes (checked above; the caller guarantees storage_len is true).
        unsafe { core::ptr::addr_of_mut!((*s).tag).write(0) };
        non_null(blob)?;
        let unit = match unit {
            GPECNET_UNIT_MODEL => CallerUnit::ModelUnit,
            GPECNET_UNIT_METRES => CallerUnit::Metres,
            GPECNET_UNIT_PIXELS => CallerUnit::Pixels,
            GPECNET_UNIT_SCALED_PIXELS => CallerUnit::ScaledPixels { metres_per_pixel },
            _ => return Err(GPECNET_E_UNIT_MISMATCH),
        };
        // SAFETY: the caller guarantees `blob_len` readable bytes that outlive
        // every use of the predictor (the documented lifetime contract), hence 'static.
        let bytes: &'static [u8] = unsafe { core::slice::from_raw_parts(blob, blob_len) };
        let pred = Inner::with_units(model(bytes)?, unit).map_err(error_status)?;
        // SAFETY: as above; State has no drop glue, so overwriting a previous
        // predictor leaks nothing.
        unsafe { s.write(State { tag: LIVE, pred }) };
        Ok(())
    })
}
