//! The integer table sine against f64 `sin`, and the table against its definition.
use gpecnet_core::fixed::{sin_q15, QUARTER_SINE, SIN_Q15_MAX_ERROR};

fn err_at(phase: u32) -> f64 {
    let want = (core::f64::consts::TAU * phase as f64 / 4_294_967_296.0).sin();
    (sin_q15(phase) as f64 / 32768.0 - want).abs()
}

#[test]
fn table_is_rounded_quarter_sine() {
    for (i, &v) in QUARTER_SINE.iter().enumerate() {
        let want = (32768.0 * (core::f64::consts::FRAC_PI_2 * i as f64 / 256.0).sin()).round();
        assert_eq!(v as f64, want, "entry {i}");
    }
}

#[test]
fn key_points_and_symmetry() {
    assert_eq!(sin_q15(0), 0);
    // The peak saturates so that every activation fits an i16.
    assert_eq!(sin_q15(1 << 30), 32767);
    assert_eq!(sin_q15(1 << 31), 0);
    assert_eq!(sin_q15(3 << 30), -32767);
    for p in (0..=u32::MAX)
        .step_by(65_537)
        .chain((1 << 30) - 4096..(1 << 30) + 4096)
    {
        let v = sin_q15(p);
        assert!((-32767..=32767).contains(&v), "phase {p:#x}: {v}");
        assert_eq!(sin_q15(p.wrapping_add(1 << 31)), -v, "phase {p:#x}");
    }
}

/// Every 64th phase is a distinct input (the low 6 bits are ignored), so a
/// stride of 64 covers all 2^26 inputs; the test runs a 2^20 subset by
/// default and the full sweep with `--ignored`.
fn sweep(stride: u64) -> f64 {
    let mut worst = 0.0f64;
    let mut p = 0u64;
    while p < 1 << 32 {
        worst = worst.max(err_at(p as u32)).max(err_at((p as u32) | 63));
        p += stride;
    }
    worst
}

#[test]
fn max_error_subset() {
    let e = sweep(1 << 12);
    assert!(e <= SIN_Q15_MAX_ERROR, "max error {e}");
}

#[test]
#[ignore = "full sweep of all 2^26 distinct inputs; run in release with --ignored --nocapture"]
fn max_error_all_inputs() {
    let e = sweep(64);
    println!(
        "sin_q15 max abs error over all inputs: {e:.3e} ({:.3} Q15 LSB)",
        e * 32768.0
    );
    assert!(e <= SIN_Q15_MAX_ERROR, "max error {e}");
}
