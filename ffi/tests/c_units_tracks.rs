//! The unit declaration and the timed track table through the C ABI, called
//! exactly as C calls them: every unit pairing's status code, the metric
//! model's outputs converted bit for bit as `gpecnet_core::units` specifies,
//! and the table's histories equal to the core's `TimedTrackTable`.
use std::num::NonZeroU32;
use std::ptr::{null, null_mut};

use gpecnet_core::tracks::{Observation, TimedTrackTable};
use gpecnet_ffi::*;

use crate::common::weights_static as weights;

#[repr(C, align(8))]
struct Storage([u8; GPECNET_PREDICTOR_SIZE]);

#[repr(C, align(8))]
struct TableMem([u8; GPECNET_TRACKS_SIZE]);

fn init_units(s: &mut Storage, blob: &[u8], unit: u32, mpp: f32) -> i32 {
    // SAFETY: test: storage and blob valid for their lengths; the blob is leaked ('static).
    unsafe {
        gpecnet_init_units(
            s.0.as_mut_ptr().cast(),
            s.0.len(),
            blob.as_ptr(),
            blob.len(),
            unit,
            mpp,
        )
    }
}

fn info(s: &mut Storage) -> GpecnetModelInfo {
    let mut out = std::mem::MaybeUninit::<GpecnetModelInfo>::uninit();
    // SAFETY: test: an initialised storage and a writable struct.
    let st = unsafe { gpecnet_model_info(s.0.as_mut_ptr().cast(), out.as_mut_ptr()) };
    assert_eq!(st, GPECNET_OK);
    // SAFETY: written on GPECNET_OK.
    unsafe { out.assume_init() }
}

fn point(s: &mut Storage, past: &[f32; 16]) -> (i32, Vec<f32>) {
    let mut out = vec![0.0f32; 2 * GPECNET_MAX_FUTURE];
    let mut n = 0usize;
    // SAFETY: test: buffers as declared.
    let st = unsafe {
        gpecnet_predict_point(
            s.0.as_mut_ptr().cast(),
            past.as_ptr(),
            8,
            out.as_mut_ptr(),
            GPECNET_MAX_FUTURE,
            &mut n,
        )
    };
    out.truncate(2 * n);
    (st, out)
}

#[test]
fn every_unit_pairing_has_its_status() {
    let metric = weights("sdd-m-tiny-qe.gpec");
    let old = weights("sdd-tiny-v2-qe.gpec");
    let mut s = Box::new(Storage([0; GPECNET_PREDICTOR_SIZE]));
    let cases = [
        (metric, GPECNET_UNIT_METRES, 0.0, GPECNET_OK),
        (metric, GPECNET_UNIT_MODEL, 0.0, GPECNET_OK),
        (metric, GPECNET_UNIT_SCALED_PIXELS, 0.04, GPECNET_OK),
        (metric, GPECNET_UNIT_PIXELS, 0.0, GPECNET_E_UNIT_MISMATCH),
        (
            metric,
            GPECNET_UNIT_SCALED_PIXELS,
            0.0,
            GPECNET_E_UNIT_BAD_SCALE,
        ),
        (
            metric,
            GPECNET_UNIT_SCALED_PIXELS,
            f32::NAN,
            GPECNET_E_UNIT_BAD_SCALE,
        ),
        (metric, 99, 0.0, GPECNET_E_UNIT_MISMATCH),
        (old, GPECNET_UNIT_METRES, 0.0, GPECNET_E_UNIT_UNKNOWN_MODEL),
        (old, GPECNET_UNIT_PIXELS, 0.0, GPECNET_E_UNIT_UNKNOWN_MODEL),
        (old, GPECNET_UNIT_MODEL, 0.0, GPECNET_OK),
    ];
    for (blob, unit, mpp, want) in cases {
        assert_eq!(
            init_units(&mut s, blob, unit, mpp),
            want,
            "unit {unit} mpp {mpp}"
        );
        if want != GPECNET_OK {
            // The refused storage holds no predictor.
            assert_eq!(point(&mut s, &[0.0; 16]).0, GPECNET_E_NOT_INITIALISED);
        }
    }
    assert_eq!(
        init_units(&mut s, metric, GPECNET_UNIT_METRES, 0.0),
        GPECNET_OK
    );
    let i = info(&mut s);
    assert_eq!(
        (i.unit, i.period_s, i.metres_per_pixel, i.unit_factor),
        (GPECNET_POSITION_METRE, 0.4, 0.0, 1.0)
    );
    assert_eq!(init_units(&mut s, old, GPECNET_UNIT_MODEL, 0.0), GPECNET_OK);
    assert_eq!(
        (info(&mut s).unit, info(&mut s).period_s),
        (GPECNET_POSITION_UNKNOWN, 0.0)
    );
}

#[test]
fn scaled_pixels_convert_exactly() {
    let metric = weights("sdd-m-tiny-qe.gpec");
    let s_mpp = 0.031f32;
    let past_m: [f32; 16] = std::array::from_fn(|i| {
        let t = (i / 2) as f32 * 0.4;
        if i % 2 == 0 {
            1.0 + 1.3 * t
        } else {
            2.0 - 0.2 * t
        }
    });
    let past_px = past_m.map(|v| v / s_mpp);
    let model_in = past_px.map(|v| v * s_mpp);
    let (mut a, mut b) = (
        Box::new(Storage([0; GPECNET_PREDICTOR_SIZE])),
        Box::new(Storage([0; GPECNET_PREDICTOR_SIZE])),
    );
    assert_eq!(
        init_units(&mut a, metric, GPECNET_UNIT_SCALED_PIXELS, s_mpp),
        GPECNET_OK
    );
    assert_eq!(
        init_units(&mut b, metric, GPECNET_UNIT_METRES, 0.0),
        GPECNET_OK
    );
    assert_eq!(info(&mut a).unit_factor, s_mpp);
    let (sa, pa) = point(&mut a, &past_px);
    let (sb, pb) = point(&mut b, &model_in);
    assert_eq!((sa, sb), (GPECNET_OK, GPECNET_OK));
    assert_eq!(pa.len(), 24);
    for (x, y) in pa.iter().zip(&pb) {
        assert_eq!(x.to_bits(), (y / s_mpp).to_bits());
    }
}

fn table_ptr(m: &mut TableMem) -> *mut GpecnetTracks {
    m.0.as_mut_ptr().cast()
}

#[test]
fn track_table_matches_the_core() {
    let mut mem = Box::new(TableMem([0; GPECNET_TRACKS_SIZE]));
    // SAFETY: test: storage valid for its length.
    let st = unsafe { gpecnet_tracks_init(mem.0.as_mut_ptr().cast(), mem.0.len(), 400, 1_000) };
    assert_eq!(st, GPECNET_OK);
    assert!(gpecnet_tracks_size() <= GPECNET_TRACKS_SIZE);
    let mut core: TimedTrackTable<GPECNET_TRACKS_CAPACITY> =
        TimedTrackTable::new(NonZeroU32::new(400).unwrap(), 1_000);
    // 40 pedestrians (more than the capacity: 8 rejected per frame) at ~30 Hz.
    let mut fresh = vec![
        GpecnetHistory {
            id: 0,
            end_ms: 0,
            past_xy: [[0.0; 2]; GPECNET_HISTORY]
        };
        GPECNET_TRACKS_CAPACITY
    ];
    let mut total_fresh = 0;
    for f in 0..150u32 {
        let t_ms = f * 33 + f % 7;
        let dets: Vec<GpecnetDetection> = (0..40)
            .filter(|id| (f + id) % 9 != 0)
            .map(|id| GpecnetDetection {
                id,
                x: id as f32 + 0.001 * t_ms as f32,
                y: 0.5 * id as f32 - 0.0007 * t_ms as f32,
            })
            .collect();
        let obs: Vec<Observation> = dets
            .iter()
            .map(|d| Observation {
                id: d.id,
                pos: [d.x, d.y],
            })
            .collect();
        let mut delta = GpecnetTracksDelta::default();
        // SAFETY: test: dets valid for its length, delta writable.
        let st = unsafe {
            gpecnet_tracks_update(
                table_ptr(&mut mem),
                t_ms,
                dets.as_ptr(),
                dets.len(),
                &mut delta,
            )
        };
        assert_eq!(st, GPECNET_OK);
        let d = core.update(t_ms, &obs);
        assert_eq!(
            (
                delta.entered,
                delta.left,
                delta.rejected,
                delta.duplicates,
                delta.non_finite
            ),
            (
                d.entered.len() as u32,
                d.left.len() as u32,
                d.rejected,
                d.duplicates,
                d.non_finite
            )
        );
        let mut n = 0usize;
        // SAFETY: test: room for CAPACITY histories.
        let st = unsafe {
            gpecnet_tracks_fresh(table_ptr(&mut mem), fresh.as_mut_ptr(), fresh.len(), &mut n)
        };
        assert_eq!(st, GPECNET_OK);
        assert_eq!(n as u32, delta.fresh);
        let want: Vec<_> = core.fresh().collect();
        assert_eq!(n, want.len());
        for (h, w) in fresh.iter().zip(want) {
            assert_eq!((h.id, h.end_ms), (w.id(), w.end_ms()));
            assert_eq!(h.past_xy, w.past());
        }
        total_fresh += n;
    }
    assert!(total_fresh >= 150, "{total_fresh}");
}

#[test]
fn track_table_bad_arguments_are_status_codes() {
    let mut mem = Box::new(TableMem([0; GPECNET_TRACKS_SIZE]));
    let p = mem.0.as_mut_ptr();
    // SAFETY: test: each pointer NULL or valid for its length.
    unsafe {
        assert_eq!(
            gpecnet_tracks_init(null_mut(), 0, 400, 1),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_tracks_init(p.cast(), 16, 400, 1),
            GPECNET_E_BAD_LENGTH
        );
        assert_eq!(
            gpecnet_tracks_init(p.add(1).cast(), GPECNET_TRACKS_SIZE - 8, 400, 1),
            GPECNET_E_MISALIGNED
        );
        assert_eq!(
            gpecnet_tracks_init(p.cast(), GPECNET_TRACKS_SIZE, 0, 1),
            GPECNET_E_TRACKS_BAD_PERIOD
        );
        // The failed init left the storage unusable.
        assert_eq!(
            gpecnet_tracks_update(p.cast(), 0, null(), 0, null_mut()),
            GPECNET_E_NOT_INITIALISED
        );
        assert_eq!(
            gpecnet_tracks_init(p.cast(), GPECNET_TRACKS_SIZE, 400, 1_000),
            GPECNET_OK
        );
        assert_eq!(
            gpecnet_tracks_update(p.cast(), 0, null(), 3, null_mut()),
            GPECNET_E_NULL_POINTER
        );
        let d = GpecnetDetection {
            id: 1,
            x: 0.0,
            y: 0.0,
        };
        assert_eq!(
            gpecnet_tracks_update(p.cast(), 1_000, &d, 1, null_mut()),
            GPECNET_OK
        );
        assert_eq!(
            gpecnet_tracks_update(p.cast(), 999, &d, 1, null_mut()),
            GPECNET_E_TRACKS_STALE_TIME
        );
        let mut n = 0usize;
        assert_eq!(
            gpecnet_tracks_fresh(p.cast(), null_mut(), 0, null_mut()),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_tracks_fresh(p.cast(), null_mut(), 0, &mut n),
            GPECNET_OK
        );
        assert_eq!(n, 0);
        // A frame given in two calls is one frame; more fresh tracks than room is a status.
        for k in 0..8u32 {
            let two = [
                GpecnetDetection {
                    id: 1,
                    x: k as f32,
                    y: 0.0,
                },
                GpecnetDetection {
                    id: 2,
                    x: 0.0,
                    y: k as f32,
                },
            ];
            assert_eq!(
                gpecnet_tracks_update(p.cast(), 1_000 + 400 * k, two.as_ptr(), 1, null_mut()),
                GPECNET_OK
            );
            assert_eq!(
                gpecnet_tracks_update(
                    p.cast(),
                    1_000 + 400 * k,
                    two.as_ptr().add(1),
                    1,
                    null_mut()
                ),
                GPECNET_OK
            );
        }
        let mut one = [GpecnetHistory {
            id: 0,
            end_ms: 0,
            past_xy: [[0.0; 2]; GPECNET_HISTORY],
        }];
        assert_eq!(
            gpecnet_tracks_fresh(p.cast(), one.as_mut_ptr(), 1, &mut n),
            GPECNET_E_BAD_LENGTH
        );
        assert_eq!(n, 2);
    }
}
