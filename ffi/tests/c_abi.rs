//! The C entry points' contract, exercised from Rust exactly as C calls them:
//! every bad argument is a status code, every corrupt blob is refused, and a
//! storage whose initialisation failed refuses predictions.
//!
//! Corruption coverage (the smallest shipped blob, `weights/sdd-tiny-qe.gpec`,
//! 11,283 bytes): every truncation, every single-bit flip of every byte (the
//! full set, ~90k inits), every truncation re-sealed with a valid CRC, and
//! every single-bit flip of the first 512 bytes re-sealed with a valid CRC
//! (the header, config and first layer: the parser's and the guards' paths
//! rather than the CRC's). After each refusal a prediction on that storage
//! must return `GPECNET_E_NOT_INITIALISED`; a re-sealed blob that validates
//! must predict or refuse with a status code.
use std::ffi::CStr;
use std::ptr::{null, null_mut};

use gpecnet_core::blob::CRC32;
use gpecnet_ffi::*;

use crate::common::{root, weights};

/// Caller storage as C declares it.
#[repr(C, align(8))]
struct Storage([u8; GPECNET_PREDICTOR_SIZE + 16]);

impl Storage {
    fn new() -> Box<Self> {
        Box::new(Storage([0; GPECNET_PREDICTOR_SIZE + 16]))
    }
    fn ptr(&mut self) -> *mut std::ffi::c_void {
        self.0.as_mut_ptr().cast()
    }
    fn p(&mut self) -> *mut GpecnetPredictor {
        self.0.as_mut_ptr().cast()
    }
}

fn init(s: &mut Storage, blob: &[u8]) -> i32 {
    // SAFETY: test: storage and blob are valid for their lengths.
    unsafe { gpecnet_init(s.ptr(), GPECNET_PREDICTOR_SIZE, blob.as_ptr(), blob.len()) }
}

const PAST: [f32; 16] = [
    512.0, 300.0, 514.0, 301.0, 516.5, 302.0, 519.0, 303.5, 521.0, 304.5, 523.5, 305.0, 526.0,
    306.0, 528.0, 307.5,
];

fn endpoints(s: &mut Storage, k: usize) -> (i32, Vec<f32>) {
    let mut out = vec![0.0f32; 2 * k.max(1)];
    // SAFETY: test: PAST has 8 points, out room for k points.
    let st = unsafe { gpecnet_predict_endpoints(s.p(), PAST.as_ptr(), 8, 7, out.as_mut_ptr(), k) };
    (st, out)
}

fn point(s: &mut Storage) -> (i32, Vec<f32>, usize) {
    let mut out = vec![0.0f32; 2 * GPECNET_MAX_FUTURE];
    let mut n = 0usize;
    // SAFETY: test: buffers as declared.
    let st = unsafe {
        gpecnet_predict_point(
            s.p(),
            PAST.as_ptr(),
            8,
            out.as_mut_ptr(),
            GPECNET_MAX_FUTURE,
            &mut n,
        )
    };
    (st, out, n)
}

/// Every code the library can return, with its text.
fn known(status: i32) -> bool {
    // SAFETY: gpecnet_status_str returns a static NUL-terminated string.
    let s = unsafe { CStr::from_ptr(gpecnet_status_str(status)) };
    s.to_str().unwrap() != "unknown status code"
}

#[test]
fn status_strings_cover_every_code_and_are_distinct() {
    let codes: Vec<i32> = (0..=6)
        .chain(10..=21)
        .chain(30..=40)
        .chain(50..=53)
        .chain(60..=61)
        .chain(70..=74)
        .collect();
    let mut texts = std::collections::BTreeSet::new();
    for &c in &codes {
        assert!(known(c), "code {c} has no text");
        // SAFETY: static string.
        let t = unsafe { CStr::from_ptr(gpecnet_status_str(c)) };
        assert!(texts.insert(t.to_owned()), "code {c}: duplicate text");
    }
    for c in [7, 41, 49, 54, 59, 62, 69, 75, -1, i32::MAX] {
        assert!(!known(c), "{c}");
    }
}

#[test]
fn storage_constants_match_the_target() {
    let need = gpecnet_predictor_size();
    assert!(need <= GPECNET_PREDICTOR_SIZE);
    // The constant is a tight bound, not a guess: refresh it when the core's predictor shrinks.
    assert!(
        GPECNET_PREDICTOR_SIZE - need < 512,
        "{need} B needed, {GPECNET_PREDICTOR_SIZE} declared"
    );
}

#[test]
fn bad_arguments_are_status_codes() {
    let blob = weights("sdd-tiny-v2-qe.gpec");
    let mut s = Storage::new();
    // SAFETY (this test): every pointer is NULL, or valid for the length given.
    unsafe {
        assert_eq!(
            gpecnet_init(null_mut(), 99999, blob.as_ptr(), blob.len()),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_init(s.ptr(), GPECNET_PREDICTOR_SIZE, null(), 0),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_init(s.ptr(), 64, blob.as_ptr(), blob.len()),
            GPECNET_E_BAD_LENGTH
        );
        let odd = s.ptr().cast::<u8>().add(4).cast();
        assert_eq!(
            gpecnet_init(odd, GPECNET_PREDICTOR_SIZE, blob.as_ptr(), blob.len()),
            GPECNET_E_MISALIGNED
        );
        let odd_p = s.ptr().cast::<u8>().add(1).cast::<GpecnetPredictor>();
        let mut out = [0.0f32; 64];
        assert_eq!(
            gpecnet_predict_endpoints(odd_p, PAST.as_ptr(), 8, 1, out.as_mut_ptr(), 20),
            GPECNET_E_MISALIGNED
        );
        assert_eq!(
            gpecnet_predict_endpoints(null_mut(), PAST.as_ptr(), 8, 1, out.as_mut_ptr(), 20),
            GPECNET_E_NULL_POINTER
        );
        // Never initialised (zeroed storage).
        assert_eq!(endpoints(&mut s, 20).0, GPECNET_E_NOT_INITIALISED);
        assert_eq!(point(&mut s).0, GPECNET_E_NOT_INITIALISED);
        let mut info = std::mem::zeroed::<GpecnetModelInfo>();
        assert_eq!(
            gpecnet_model_info(s.p(), &mut info),
            GPECNET_E_NOT_INITIALISED
        );

        assert_eq!(init(&mut s, &blob), GPECNET_OK);
        assert_eq!(gpecnet_model_info(s.p(), &mut info), GPECNET_OK);
        assert_eq!(
            gpecnet_model_info(s.p(), null_mut()),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            CStr::from_ptr(info.name.as_ptr()).to_str().unwrap(),
            "sdd-tiny-v2-qe"
        );
        assert_eq!(info.numeric, GPECNET_NUMERIC_Q15);
        assert_eq!((info.past_len, info.future_len), (8, 12));
        // k-means gives at most 64 centres: max_endpoints says what predict_endpoints takes.
        assert_eq!((info.tts_samples, info.max_endpoints), (80, 64));
        assert_eq!(info.has_point_head, 1);
        let mut many = [0.0f32; 2 * 80];
        for k in [1, 20, 64] {
            assert_eq!(
                gpecnet_predict_endpoints(s.p(), PAST.as_ptr(), 8, 1, many.as_mut_ptr(), k),
                GPECNET_OK,
                "k = {k}"
            );
        }
        for k in [65, 80] {
            assert_eq!(
                gpecnet_predict_endpoints(s.p(), PAST.as_ptr(), 8, 1, many.as_mut_ptr(), k),
                GPECNET_E_BAD_SAMPLE_COUNT,
                "k = {k}"
            );
        }

        assert_eq!(
            gpecnet_predict_endpoints(s.p(), null(), 8, 1, out.as_mut_ptr(), 20),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_predict_endpoints(s.p(), PAST.as_ptr(), 8, 1, null_mut(), 20),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_predict_endpoints(s.p(), PAST.as_ptr(), 7, 1, out.as_mut_ptr(), 20),
            GPECNET_E_WRONG_PAST_LENGTH
        );
        assert_eq!(
            gpecnet_predict_endpoints(s.p(), PAST.as_ptr(), usize::MAX, 1, out.as_mut_ptr(), 20),
            GPECNET_E_WRONG_PAST_LENGTH
        );
        assert_eq!(endpoints(&mut s, 0).0, GPECNET_E_BAD_SAMPLE_COUNT);
        assert_eq!(endpoints(&mut s, 81).0, GPECNET_E_BAD_SAMPLE_COUNT);
        assert_eq!(endpoints(&mut s, 100_000).0, GPECNET_E_CAPACITY_EXCEEDED);
        let (st, e) = endpoints(&mut s, 20);
        assert_eq!(st, GPECNET_OK);
        assert!(e.iter().all(|v| v.is_finite()));

        let mut bad = PAST;
        bad[3] = f32::NAN;
        assert_eq!(
            gpecnet_predict_endpoints(s.p(), bad.as_ptr(), 8, 1, out.as_mut_ptr(), 20),
            GPECNET_E_NON_FINITE_INPUT
        );
        bad[3] = 1.0e9;
        assert_eq!(
            gpecnet_predict_endpoints(s.p(), bad.as_ptr(), 8, 1, out.as_mut_ptr(), 20),
            GPECNET_E_INPUT_OUT_OF_RANGE
        );

        // Point forecast: too small an output buffer, then the real thing.
        let mut n = 99usize;
        assert_eq!(
            gpecnet_predict_point(s.p(), PAST.as_ptr(), 8, out.as_mut_ptr(), 11, &mut n),
            GPECNET_E_BAD_LENGTH
        );
        assert_eq!(n, 99, "nothing written on failure");
        assert_eq!(
            gpecnet_predict_point(s.p(), PAST.as_ptr(), 8, out.as_mut_ptr(), 12, null_mut()),
            GPECNET_E_NULL_POINTER
        );
        let (st, _, n) = point(&mut s);
        assert_eq!((st, n), (GPECNET_OK, 12));

        // Unaligned float buffers are fine (read and written byte-wise).
        let mut raw = [0u8; 4 * 16 + 1];
        for (i, v) in PAST.iter().enumerate() {
            raw[1 + 4 * i..5 + 4 * i].copy_from_slice(&v.to_ne_bytes());
        }
        let mut out_raw = [0u8; 8 * 20 + 1];
        assert_eq!(
            gpecnet_predict_endpoints(
                s.p(),
                raw.as_ptr().add(1).cast(),
                8,
                7,
                out_raw.as_mut_ptr().add(1).cast(),
                20
            ),
            GPECNET_OK
        );
        let (_, aligned) = endpoints(&mut s, 20);
        for (i, v) in aligned.iter().enumerate() {
            assert_eq!(out_raw[1 + 4 * i..5 + 4 * i], v.to_ne_bytes());
        }

        // Output may overlap the input: the past is copied before anything is written.
        let mut inout = [0.0f32; 40];
        inout[..16].copy_from_slice(&PAST);
        assert_eq!(
            gpecnet_predict_endpoints(s.p(), inout.as_ptr(), 8, 7, inout.as_mut_ptr(), 20),
            GPECNET_OK
        );
        assert_eq!(inout.to_vec(), aligned);

        // A model without a point head.
        let plain = weights("sdd-tiny-qe.gpec");
        assert_eq!(init(&mut s, &plain), GPECNET_OK);
        assert_eq!(point(&mut s).0, GPECNET_E_NO_POINT_HEAD);
        assert_eq!(gpecnet_model_info(s.p(), &mut info), GPECNET_OK);
        assert_eq!((info.tts_samples, info.max_endpoints), (0, 128));
        assert_eq!(endpoints(&mut s, 128).0, GPECNET_OK);
        assert_eq!(endpoints(&mut s, 129).0, GPECNET_E_CAPACITY_EXCEEDED);

        // Golden reader arguments.
        let golden = weights("sdd-tiny-qe.golden");
        let mut g = std::mem::zeroed::<GpecnetGoldenInfo>();
        assert_eq!(
            gpecnet_golden_info(null(), 0, &mut g),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_golden_info(golden.as_ptr(), golden.len() - 1, &mut g),
            GPECNET_E_BLOB_CHECKSUM_MISMATCH
        );
        assert_eq!(
            gpecnet_golden_info(golden.as_ptr(), golden.len(), &mut g),
            GPECNET_OK
        );
        let mut c = Box::new(std::mem::zeroed::<GpecnetGoldenCase>());
        assert_eq!(
            gpecnet_golden_case(golden.as_ptr(), golden.len(), g.n_cases, &mut *c),
            GPECNET_E_BAD_LENGTH
        );
        assert_eq!(
            gpecnet_golden_case(golden.as_ptr(), golden.len(), g.n_cases - 1, &mut *c),
            GPECNET_OK
        );
    }
}

/// A refused blob leaves the storage refusing predictions, whatever it held before.
fn assert_refused(s: &mut Storage, blob: &[u8], what: &str) {
    let st = init(s, blob);
    assert!(
        (10..=21).contains(&st),
        "{what}: status {st}, expected a blob error"
    );
    assert_eq!(endpoints(s, 20).0, GPECNET_E_NOT_INITIALISED, "{what}");
}

#[test]
fn every_truncation_and_bit_flip_is_refused() {
    let blob = weights("sdd-tiny-qe.gpec");
    assert!(blob.len() < 16 * 1024, "the smallest shipped blob");
    let mut s = Storage::new();
    assert_eq!(init(&mut s, &blob), GPECNET_OK);
    for n in 0..blob.len() {
        assert_refused(&mut s, &blob[..n], &format!("truncated to {n}"));
        // A live predictor again, so each refusal must really reset the storage.
        if n % 1024 == 0 {
            assert_eq!(init(&mut s, &blob), GPECNET_OK);
        }
    }
    let mut b = blob.clone();
    for byte in 0..blob.len() {
        for bit in 0..8 {
            b[byte] ^= 1 << bit;
            assert_refused(&mut s, &b, &format!("bit {bit} of byte {byte} flipped"));
            b[byte] ^= 1 << bit;
        }
    }
    assert_eq!(init(&mut s, &blob), GPECNET_OK);
    assert_eq!(endpoints(&mut s, 20).0, GPECNET_OK);
}

fn seal(mut body: Vec<u8>) -> Vec<u8> {
    let crc = CRC32.checksum(&body);
    body.extend(crc.to_le_bytes());
    body
}

#[test]
fn resealed_corruption_is_refused_or_predicts_safely() {
    let blob = weights("sdd-tiny-qe.gpec");
    let body = &blob[..blob.len() - 4];
    let mut s = Storage::new();
    for n in 0..body.len() {
        assert_refused(
            &mut s,
            &seal(body[..n].to_vec()),
            &format!("truncated to {n}, resealed"),
        );
    }
    let (mut refused, mut ran) = (0, 0);
    for byte in 0..512 {
        for bit in 0..8 {
            let mut b = body.to_vec();
            b[byte] ^= 1 << bit;
            let b = seal(b);
            let st = init(&mut s, &b);
            if st == GPECNET_OK {
                // Validated (e.g. a weight changed): predictions are values or status codes.
                ran += 1;
                let (st, _) = endpoints(&mut s, 20);
                assert!(known(st), "byte {byte} bit {bit}: endpoints gave {st}");
                let st = point(&mut s).0;
                assert!(known(st), "byte {byte} bit {bit}: point gave {st}");
            } else {
                refused += 1;
                assert!((10..=39).contains(&st), "byte {byte} bit {bit}: {st}");
                assert_eq!(endpoints(&mut s, 20).0, GPECNET_E_NOT_INITIALISED);
            }
        }
    }
    println!(
        "resealed bit flips in the first 512 bytes: {refused} refused, {ran} validated and ran"
    );
    assert!(refused > 0);
}

/// `gpecnet_model_info`'s `max_endpoints` is what `gpecnet_predict_endpoints` and
/// `gpecnet_predict_forecast` accept, for every shipped blob (formats 1 to 6, f32 and
/// Q15): `k = max_endpoints` is answered, one more is refused. A proposal model (format 5
/// or 6) ends its stream after its K latents: `sdd-m-lp-qe` gives 20 endpoints, and
/// `k = 21` is `GPECNET_E_BAD_SAMPLE_COUNT` (its logit rows are not a 21st latent).
#[test]
fn every_shipped_blob_refuses_max_endpoints_plus_one() {
    let dir = root().join("weights");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".gpec"))
        .collect();
    names.sort();
    let mut s = Storage::new();
    let (mut checked, mut proposals) = (0, 0);
    for name in &names {
        let blob = weights(name);
        let st = init(&mut s, &blob);
        if st == GPECNET_E_SCRATCH_TOO_SMALL {
            continue; // a host-only model (wider than the C ABI's scratch)
        }
        assert_eq!(st, GPECNET_OK, "{name}");
        // SAFETY: test: a zeroed plain C struct, written by the call.
        let mut info = unsafe { std::mem::zeroed::<GpecnetModelInfo>() };
        // SAFETY: test: an initialised predictor and a valid out pointer.
        assert_eq!(unsafe { gpecnet_model_info(s.p(), &mut info) }, GPECNET_OK);
        let most = info.max_endpoints as usize;
        assert!(most >= 1, "{name}");
        assert_eq!(endpoints(&mut s, most).0, GPECNET_OK, "{name}: k = {most}");
        let (over, out) = endpoints(&mut s, most + 1);
        let want = if most == GPECNET_MAX_SAMPLES {
            GPECNET_E_CAPACITY_EXCEEDED
        } else {
            GPECNET_E_BAD_SAMPLE_COUNT
        };
        assert_eq!(over, want, "{name}: k = max_endpoints + 1 = {}", most + 1);
        assert!(out.iter().all(|&v| v == 0.0), "{name}: nothing written");
        let core = gpecnet_core::Model::from_blob(&blob).unwrap();
        if core.has_proposal() {
            proposals += 1;
            assert_eq!(most, core.proposal_latents(), "{name}: K");
            let mut ends = vec![0.0f32; 2 * (most + 1)];
            let mut probs = vec![0.0f32; most + 1];
            // SAFETY: test: a zeroed plain C struct, written by the call.
            let mut planner = unsafe { std::mem::zeroed::<GpecnetPlanner>() };
            // SAFETY: test: PAST has 8 points, the buffers room for K + 1.
            let st = unsafe {
                gpecnet_predict_forecast(
                    s.p(),
                    PAST.as_ptr(),
                    8,
                    7,
                    ends.as_mut_ptr(),
                    probs.as_mut_ptr(),
                    most + 1,
                    &mut planner,
                )
            };
            assert_eq!(st, GPECNET_E_BAD_SAMPLE_COUNT, "{name}: forecast K + 1");
        }
        checked += 1;
    }
    assert!(
        checked >= 10 && proposals >= 2,
        "{checked} blobs, {proposals} proposals"
    );
    // The MCU default, by name.
    assert_eq!(init(&mut s, &weights("sdd-m-lp-qe.gpec")), GPECNET_OK);
    assert_eq!(endpoints(&mut s, 20).0, GPECNET_OK);
    assert_eq!(endpoints(&mut s, 21).0, GPECNET_E_BAD_SAMPLE_COUNT);
    assert_eq!(endpoints(&mut s, 22).0, GPECNET_E_BAD_SAMPLE_COUNT);
}
