//! Signed blobs: [`gpecnet_init_signed`] builds the predictor only from a
//! blob whose Ed25519 signature verifies under one of the caller's trusted
//! keys and whose model version is not below the caller's minimum (the
//! checks: `gpecnet_core::blob::signed`).
use core::ffi::c_void;

use gpecnet_core::blob::signed::TrustedKey;
use gpecnet_core::Model;

use crate::status::{sign_status, GPECNET_E_BAD_LENGTH, GPECNET_E_NULL_POINTER, GPECNET_OK};
use crate::storage::init_with;

#[cfg(doc)]
use crate::{gpecnet_init, gpecnet_init_units};

/// Most trusted keys one `gpecnet_init_signed` call takes.
pub const GPECNET_MAX_TRUSTED_KEYS: usize = 8;

/// One trusted Ed25519 public key (RFC 8032 encoding) for [`gpecnet_init_signed`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpecnetTrustedKey {
    /// The 32-byte public key; its first 8 bytes are its key id.
    pub public_key: [u8; 32],
}

/// [`gpecnet_init_units`] for a signed blob only: refused unless the blob's
/// Ed25519 signature verifies under one of the `n_keys` keys at `keys`
/// (at most [`GPECNET_MAX_TRUSTED_KEYS`]) and its model version is at least
/// `min_version` (`GPECNET_E_SIGN_*`, checked before the blob is parsed;
/// the trailer: `weights/FORMAT.md`, "Signed blobs"). On success
/// `*out_version` (when not NULL) receives the blob's model version: store
/// it as the next `min_version` where it survives a reset.
///
/// # Safety
/// As [`gpecnet_init`]; `keys` is NULL (only with `n_keys` = 0) or valid for
/// reads of `n_keys` keys; `out_version` is NULL or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_init_signed(
    storage: *mut c_void,
    storage_len: usize,
    blob: *const u8,
    blob_len: usize,
    keys: *const GpecnetTrustedKey,
    n_keys: usize,
    min_version: u32,
    unit: u32,
    metres_per_pixel: f32,
    out_version: *mut u32,
) -> i32 {
    let mut trusted = [TrustedKey::new([0; 32]); GPECNET_MAX_TRUSTED_KEYS];
    if n_keys > GPECNET_MAX_TRUSTED_KEYS {
        return GPECNET_E_BAD_LENGTH;
    }
    if n_keys > 0 && keys.is_null() {
        return GPECNET_E_NULL_POINTER;
    }
    for (i, t) in trusted.iter_mut().take(n_keys).enumerate() {
        // SAFETY: i < n_keys, and the caller guarantees n_keys readable keys.
        *t = TrustedKey::new(unsafe { keys.add(i).read_unaligned() }.public_key);
    }
    let trusted = trusted.get(..n_keys).unwrap_or(&[]);
    let mut version = 0;
    // SAFETY: the caller's contract, passed on unchanged.
    let status = unsafe {
        init_with(
            (storage, storage_len),
            (blob, blob_len),
            (unit, metres_per_pixel),
            |bytes| {
                let (m, v) =
                    Model::from_signed_blob(bytes, trusted, min_version).map_err(sign_status)?;
                version = v;
                Ok(m)
            },
        )
    };
    if status == GPECNET_OK && !out_version.is_null() {
        // SAFETY: non-null, writable (caller's contract).
        unsafe { out_version.write_unaligned(version) };
    }
    status
}
