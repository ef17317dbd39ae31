//! Any byte string given to the golden-vector reader: `Ok` or a typed error.
//!
//! `cd core/fuzz && RUSTC_BOOTSTRAP=1 cargo fuzz run golden -- -max_total_time=60`
#![no_main]

use gpecnet_core::golden::GoldenSet;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(set) = GoldenSet::parse(data) {
        for case in set.cases() {
            for i in 0..case.k() {
                let _ = case.endpoint_bits(i);
            }
            let _ = case.trajectory0_bits(0);
        }
    }
});
