//! Signed blobs (`gpecnet_core::blob::signed`, feature `signed`): RFC 8032's
//! test vectors through our verification, then a shipped blob signed with a
//! key made here: accepted with its version, the same model and the same
//! predictions as unsigned; refused, with the typed error, when unsigned,
//! signed by an unknown key, rolled back, truncated, of an unknown trailer
//! version, or changed in any byte (signature, key id, version, body, even
//! with the inner CRC recomputed).
#![cfg(feature = "signed")]

use ed25519_dalek::{Signer, SigningKey};
use gpecnet_core::blob::signed::{
    self, trailer_head, SignError, TrustedKey, SIGNED_TRAILER_LEN, TRAILER_LEN,
};
use gpecnet_core::blob::CRC32;
use gpecnet_core::{LibmSine, Model, Predictor};

/// The shipped metric blob (signed with the project's test key) and its unsigned blob.
const SHIPPED: &[u8] = include_bytes!("../../weights/sdd-m-tiny-qe.gpec");
/// The public half of the test key the shipped MCU blob is signed with.
const TEST_KEY: &str = include_str!("../../weights/test-signing-key.pub");

fn unsigned() -> &'static [u8] {
    signed::split(SHIPPED).map_or(SHIPPED, |(b, _, _)| b)
}

fn hex<const N: usize>(s: &str) -> [u8; N] {
    let v: Vec<u8> = (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect();
    v.try_into().unwrap()
}

fn hexv(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}

/// RFC 8032, section 7.1, tests 1–3 (public key, message, signature).
#[test]
fn rfc8032_test_vectors_verify() {
    let vectors = [
        (
            "d75a980182b10ab7d54bfed3c964073a0ee172f3daa62325af021a68f707511a",
            "",
            "e5564300c360ac729086e2cc806e828a84877f1eb8e5d974d873e065224901555fb8821590a33bacc61e39701cf9b46bd25bf5f0595bbe24655141438e7a100b",
        ),
        (
            "3d4017c3e843895a92b70aa74d1b7ebc9c982ccf2ec4968cc0cd55f12af4660c",
            "72",
            "92a009a9f0d4cab8720e820b5f642540a2b27b5416503f8fb3762223ebdb69da085ac1e43e15996e458f3613d0f11d8c387b2eaeb4302aeeb00d291612bb0c00",
        ),
        (
            "fc51cd8e6218a1a38da47ed00230f0580816ed13ba3303ac5deb911548908025",
            "af82",
            "6291d657deec24024827e69c3abe01a30ce548a284743a445e3680d7db5ac3ac18ff9b538d16f290ae67f760984dc6594a7c15e9716ed28dc027beceea1ec40a",
        ),
    ];
    for (pk, msg, sig) in vectors {
        let (pk, msg, sig) = (hex::<32>(pk), hexv(msg), hex::<64>(sig));
        assert_eq!(signed::verify(&pk, &msg, &sig), Ok(()));
        let mut bad = sig;
        bad[0] ^= 1;
        assert_eq!(
            signed::verify(&pk, &msg, &bad),
            Err(SignError::BadSignature)
        );
        let mut other = msg.clone();
        other.push(0);
        assert_eq!(
            signed::verify(&pk, &other, &sig),
            Err(SignError::BadSignature)
        );
    }
}

fn key(seed: u8) -> SigningKey {
    SigningKey::from_bytes(&[seed; 32])
}

fn trusted(k: &SigningKey) -> TrustedKey {
    TrustedKey::new(k.verifying_key().to_bytes())
}

/// `blob` signed by `k` at `version`, as `gpecnet sign` writes it.
fn sign(blob: &[u8], k: &SigningKey, version: u32) -> Vec<u8> {
    let mut out = blob.to_vec();
    out.extend_from_slice(&trailer_head(trusted(k).id(), version));
    let sig = k.sign(&out).to_bytes();
    out.extend_from_slice(&sig);
    out
}

#[test]
fn signed_blob_loads_with_its_version_and_predicts_the_same() {
    let k = key(7);
    let s = sign(unsigned(), &k, 12);
    assert_eq!(s.len(), unsigned().len() + TRAILER_LEN);
    let (m, v) = Model::from_signed_blob(&s, &[trusted(&key(1)), trusted(&k)], 12).unwrap();
    assert_eq!(v, 12);
    let plain = Model::from_blob(unsigned()).unwrap();
    assert_eq!(m.crc(), plain.crc());
    // The unverified reader sees the same model in the signed bytes.
    assert_eq!(Model::from_blob(&s).unwrap().crc(), plain.crc());
    let past: [[f32; 2]; 8] = core::array::from_fn(|i| [0.5 * i as f32, 1.0 - 0.2 * i as f32]);
    let mut a = Predictor::<LibmSine, 128>::new(m).unwrap();
    let mut b = Predictor::<LibmSine, 128>::new(plain).unwrap();
    assert_eq!(
        a.predict_point(&past).unwrap(),
        b.predict_point(&past).unwrap()
    );
    let (mut ea, mut eb) = ([[0.0f32; 2]; 20], [[0.0f32; 2]; 20]);
    a.predict_endpoint_set::<128>(&past, 3, &mut ea).unwrap();
    b.predict_endpoint_set::<128>(&past, 3, &mut eb).unwrap();
    assert_eq!(ea, eb);
    let (_, _, t) = signed::split(&s).unwrap();
    assert_eq!(
        (t.version, t.model_version, t.key_id),
        (1, 12, trusted(&k).id())
    );
}

#[test]
fn refusals_are_typed() {
    let k = key(7);
    let keys = [trusted(&k)];
    let s = sign(unsigned(), &k, 5);
    assert_eq!(
        Model::from_signed_blob(unsigned(), &keys, 0).err(),
        Some(SignError::UnsignedBlob)
    );
    assert_eq!(
        Model::from_signed_blob(&s, &[trusted(&key(9))], 0).err(),
        Some(SignError::UnknownKey)
    );
    assert_eq!(
        Model::from_signed_blob(&s, &[], 0).err(),
        Some(SignError::UnknownKey)
    );
    assert_eq!(
        Model::from_signed_blob(&s, &keys, 6).err(),
        Some(SignError::RolledBack { have: 5, min: 6 })
    );
    assert!(Model::from_signed_blob(&s, &keys, 5).is_ok());
    // Another key with the same id (first 8 bytes) cannot pass for it.
    let mut impostor = keys[0];
    impostor.public_key[31] ^= 0x40;
    assert!(matches!(
        Model::from_signed_blob(&s, &[impostor], 0).err(),
        Some(SignError::BadSignature)
    ));
    // An unknown trailer version.
    let mut t = s.clone();
    let at = unsigned().len() + 4;
    t[at] = 2;
    assert_eq!(
        Model::from_signed_blob(&t, &keys, 0).err(),
        Some(SignError::BadTrailer)
    );
    // A validly signed blob whose body is not a valid blob.
    let junk = sign(b"GPEC not a blob at all", &k, 1);
    assert!(matches!(
        Model::from_signed_blob(&junk, &keys, 0).err(),
        Some(SignError::Blob(_))
    ));
    // Every truncation is refused (a sample of cut points, all of the trailer).
    for cut in (0..s.len())
        .step_by(97)
        .chain(s.len() - TRAILER_LEN..s.len())
    {
        assert!(
            Model::from_signed_blob(&s[..cut], &keys, 0).is_err(),
            "cut {cut}"
        );
    }
}

/// One bit flipped in every byte of a signed blob: each is refused, and a
/// flip in the body stays refused when the body's CRC is recomputed (a
/// forgery that passes the CRC-only reader).
#[test]
fn every_changed_byte_is_refused() {
    let k = key(7);
    let keys = [trusted(&k)];
    let s = sign(unsigned(), &k, 5);
    let body = unsigned().len() - 4;
    let mut refused = [0usize; 4];
    let mut crc_only_accepts = 0;
    for i in 0..s.len() {
        let mut t = s.clone();
        t[i] ^= 1 << (i % 8);
        if i < body {
            // Re-seal the inner blob: its CRC is valid again.
            let crc = CRC32.checksum(&t[..body]).to_le_bytes();
            t[body..body + 4].copy_from_slice(&crc);
            crc_only_accepts += Model::from_blob(&t[..unsigned().len()]).is_ok() as usize;
        }
        let e = Model::from_signed_blob(&t, &keys, 0).err();
        let slot = match e {
            Some(SignError::BadSignature) => 0,
            Some(SignError::UnknownKey) => 1,
            Some(SignError::UnsignedBlob) | Some(SignError::BadTrailer) => 2,
            Some(_) => 3,
            None => panic!("byte {i} flipped: accepted"),
        };
        refused[slot] += 1;
    }
    // Key-id flips name the key; trailer-head flips name the trailer; the rest the signature.
    assert_eq!(refused[1], 8);
    assert_eq!(refused[2], 6);
    assert_eq!(refused[0], s.len() - 14);
    // Most re-sealed body flips are weights: the unsigned reader takes them.
    assert!(crc_only_accepts > body / 2, "{crc_only_accepts} of {body}");
    assert_eq!(s.len() - unsigned().len() - SIGNED_TRAILER_LEN, 64);
}

/// The shipped MCU blob verifies under the documented test key, at version 1.
#[test]
fn shipped_blob_is_signed_with_the_test_key() {
    let key = TrustedKey::new(hex::<32>(TEST_KEY.trim()));
    let (m, v) = Model::from_signed_blob(SHIPPED, &[key], 1).unwrap();
    assert_eq!((m.name(), v), ("sdd-m-tiny-qe", 1));
    assert_eq!(
        Model::from_signed_blob(SHIPPED, &[key], 2).err(),
        Some(SignError::RolledBack { have: 1, min: 2 })
    );
}

/// The forgery search, run for its numbers, not in CI (`docs/signing.md`):
/// `GPECNET_FORGERIES=10000000 cargo test --release -p gpecnet-core --features
/// signed --test it signed:: -- --ignored --nocapture`. Each trial edits 1–4 random
/// bytes of a signed blob, each edit in the body (the inner CRC recomputed
/// half of the time, so the CRC-only reader would take it), the trailer head
/// or the signature, keeping the rest, and must be refused.
#[test]
#[ignore]
fn random_signature_preserving_edits_are_never_accepted() {
    let k = key(7);
    let keys = [trusted(&k)];
    let s = sign(unsigned(), &k, 5);
    let n: u64 = std::env::var("GPECNET_FORGERIES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100_000);
    let body = unsigned().len() - 4;
    let mut rng = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng
    };
    let mut t = s.clone();
    let (mut resealed, mut by_kind) = (0u64, [0u64; 4]);
    for _ in 0..n {
        t.copy_from_slice(&s);
        let edits = 1 + next() % 4;
        let mut reseal = false;
        for _ in 0..edits {
            let r = next();
            let i = match r % 3 {
                0 => (r >> 8) as usize % body,
                1 => unsigned().len() + (r >> 8) as usize % SIGNED_TRAILER_LEN,
                _ => s.len() - 64 + (r >> 8) as usize % 64,
            };
            let v = (r >> 40) as u8;
            t[i] = if v == s[i] { v ^ 0x80 } else { v };
            reseal |= i < body && r & (1 << 60) != 0;
        }
        if reseal {
            let crc = CRC32.checksum(&t[..body]).to_le_bytes();
            t[body..body + 4].copy_from_slice(&crc);
            resealed += 1;
        }
        match Model::from_signed_blob(&t, &keys, 0) {
            Ok(_) => panic!("forgery accepted: {:?}", &t[..16]),
            Err(SignError::BadSignature) => by_kind[0] += 1,
            Err(SignError::UnknownKey) => by_kind[1] += 1,
            Err(SignError::UnsignedBlob | SignError::BadTrailer) => by_kind[2] += 1,
            Err(_) => by_kind[3] += 1,
        }
    }
    println!(
        "{n} edited blobs ({resealed} with the inner CRC recomputed): 0 accepted; \
         bad signature {}, unknown key {}, trailer {}, other {}",
        by_kind[0], by_kind[1], by_kind[2], by_kind[3]
    );
}
