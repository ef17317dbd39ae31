//! `gpecnet_init_signed` as C calls it: the shipped metric blob under the
//! committed test key, and every refusal as its status code (unsigned,
//! unknown key, forged with a valid CRC, rolled back, too many keys, NULL
//! keys), each leaving the storage not initialised.
use std::ptr::{null, null_mut};

use ed25519_dalek::{Signer, SigningKey};
use gpecnet_core::blob::signed::{split, trailer_head, TrustedKey};
use gpecnet_core::blob::CRC32;
use gpecnet_ffi::*;

use crate::common::weights;

#[repr(C, align(8))]
struct Storage([u8; GPECNET_PREDICTOR_SIZE]);

fn test_key() -> GpecnetTrustedKey {
    let hex = String::from_utf8(weights("test-signing-key.pub")).unwrap();
    let hex = hex.trim();
    let mut k = [0u8; 32];
    for (i, b) in k.iter_mut().enumerate() {
        *b = u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).unwrap();
    }
    GpecnetTrustedKey { public_key: k }
}

fn init(s: &mut Storage, blob: &[u8], keys: &[GpecnetTrustedKey], min: u32) -> (i32, u32) {
    let mut v = 0u32;
    // SAFETY: test: storage, blob and keys valid for their lengths; the blob outlives the
    // calls made on the storage here (none after the test's last use).
    let st = unsafe {
        gpecnet_init_signed(
            s.0.as_mut_ptr().cast(),
            s.0.len(),
            blob.as_ptr(),
            blob.len(),
            keys.as_ptr(),
            keys.len(),
            min,
            GPECNET_UNIT_METRES,
            0.0,
            &mut v,
        )
    };
    (st, v)
}

fn usable(s: &mut Storage) -> bool {
    let mut info = std::mem::MaybeUninit::<GpecnetModelInfo>::uninit();
    // SAFETY: test: the storage and a writable struct.
    unsafe { gpecnet_model_info(s.0.as_mut_ptr().cast(), info.as_mut_ptr()) == GPECNET_OK }
}

#[test]
fn signed_init_accepts_the_shipped_blob_and_refuses_the_rest() {
    let shipped: &'static [u8] = weights("sdd-m-tiny-qe.gpec").leak();
    let (unsigned, _, _) = split(shipped).unwrap();
    let mut s = Box::new(Storage([0; GPECNET_PREDICTOR_SIZE]));
    let key = test_key();
    assert_eq!(init(&mut s, shipped, &[key], 1), (GPECNET_OK, 1));
    assert!(usable(&mut s));

    let stranger = SigningKey::from_bytes(&[3; 32]);
    let stranger_pub = GpecnetTrustedKey {
        public_key: stranger.verifying_key().to_bytes(),
    };
    let mut other_signed = unsigned.to_vec();
    other_signed.extend_from_slice(&trailer_head(
        TrustedKey::new(stranger_pub.public_key).id(),
        9,
    ));
    let sig = stranger.sign(&other_signed).to_bytes();
    other_signed.extend_from_slice(&sig);
    let other_signed: &'static [u8] = other_signed.leak();
    assert_eq!(
        init(&mut s, other_signed, &[key, stranger_pub], 9),
        (GPECNET_OK, 9)
    );

    // A weight byte changed and the inner CRC recomputed: the CRC-only init takes it,
    // the signed init does not.
    let mut forged = shipped.to_vec();
    let body = unsigned.len() - 4;
    forged[body - 100] ^= 0x01;
    let crc = CRC32.checksum(&forged[..body]).to_le_bytes();
    forged[body..body + 4].copy_from_slice(&crc);
    let forged: &'static [u8] = forged.leak();
    let cases: [(&'static [u8], Vec<GpecnetTrustedKey>, u32, i32); 5] = [
        (unsigned, vec![key], 0, GPECNET_E_SIGN_UNSIGNED),
        (shipped, vec![stranger_pub], 0, GPECNET_E_SIGN_UNKNOWN_KEY),
        (forged, vec![key], 0, GPECNET_E_SIGN_BAD_SIGNATURE),
        (shipped, vec![key], 2, GPECNET_E_SIGN_ROLLED_BACK),
        (
            shipped,
            vec![key; GPECNET_MAX_TRUSTED_KEYS + 1],
            0,
            GPECNET_E_BAD_LENGTH,
        ),
    ];
    for (blob, keys, min, want) in cases {
        assert_eq!(init(&mut s, shipped, &[key], 0).0, GPECNET_OK);
        assert_eq!(init(&mut s, blob, &keys, min).0, want, "want {want}");
        if want != GPECNET_E_BAD_LENGTH {
            assert!(!usable(&mut s), "storage usable after status {want}");
        }
    }
    // The forged bytes pass the unsigned init: only the signature catches them.
    // SAFETY: test: valid storage and blob.
    let st = unsafe {
        gpecnet_init(
            s.0.as_mut_ptr().cast(),
            s.0.len(),
            forged.as_ptr(),
            forged.len(),
        )
    };
    assert_eq!(st, GPECNET_OK);
    // NULL keys with a count, and no keys at all.
    // SAFETY: test: the NULL pointer is the case under test.
    let st = unsafe {
        gpecnet_init_signed(
            s.0.as_mut_ptr().cast(),
            s.0.len(),
            shipped.as_ptr(),
            shipped.len(),
            null(),
            1,
            0,
            GPECNET_UNIT_METRES,
            0.0,
            null_mut(),
        )
    };
    assert_eq!(st, GPECNET_E_NULL_POINTER);
    assert_eq!(init(&mut s, shipped, &[], 0).0, GPECNET_E_SIGN_UNKNOWN_KEY);
}
