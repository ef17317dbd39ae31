//! Any byte string given to the blob reader: `Ok` or a typed error, never a
//! panic; whatever is accepted must predict without panicking.
//!
//! `cd core/fuzz && RUSTC_BOOTSTRAP=1 cargo fuzz run blob -- -max_total_time=60`
#![no_main]

use libfuzzer_sys::fuzz_target;

mod common;

fuzz_target!(|data: &[u8]| {
    common::read_and_predict(data);
});
