//! Blob bytes that always pass the checksum: the input's last 4 bytes are
//! replaced by the CRC-32 of the rest, so the fuzzer explores the structure
//! parser, the shape/scale validation and the predictor behind it (the `blob`
//! target rarely gets past the CRC). Seed the corpus with the shipped blobs:
//!
//! `cd core/fuzz && mkdir -p corpus/blob_resealed && cp ../../weights/*-q*.gpec ../../weights/sdd-tiny*.gpec corpus/blob_resealed/ && RUSTC_BOOTSTRAP=1 cargo fuzz run blob_resealed -- -max_total_time=60`
#![no_main]

use gpecnet_core::blob::CRC32;
use libfuzzer_sys::fuzz_target;

mod common;

fuzz_target!(|data: &[u8]| {
    if data.len() < 8 {
        return;
    }
    let mut blob = data.to_vec();
    let body = blob.len() - 4;
    let crc = CRC32.checksum(&blob[..body]);
    blob[body..].copy_from_slice(&crc.to_le_bytes());
    common::read_and_predict(&blob);
});
