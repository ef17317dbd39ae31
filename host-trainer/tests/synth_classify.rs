//! The 7-type classifier on hand-made trajectories of each type.

use gpecnet_trainer::synth::classify::{
    classify, type_counts, unique_histogram, unique_points, TrajType,
};

type T = [[f32; 2]; 20];

fn from_fn(f: impl Fn(usize) -> [f32; 2]) -> T {
    std::array::from_fn(f)
}

/// Four plateaus of five steps each at `(xs[i], ys[i])`.
fn plateaus(xs: [f32; 4], ys: [f32; 4]) -> T {
    from_fn(|k| [xs[k / 5], ys[k / 5]])
}

#[test]
fn stationary_is_type_1() {
    assert_eq!(classify(&[[100.0, 100.0]; 20]), TrajType::T1);
    // Sub-pixel jitter only.
    let t = from_fn(|k| [100.0 + 0.5 * (k % 2) as f32, 100.0]);
    assert_eq!(classify(&t), TrajType::T1);
}

#[test]
fn few_points_in_a_5px_box_is_type_2() {
    let pts = [[100.0, 100.0], [101.0, 100.0], [102.0, 101.0]];
    let t = from_fn(|k| pts[k % 3]);
    assert_eq!(unique_points(&t), 3);
    assert_eq!(classify(&t), TrajType::T2);
}

#[test]
fn jitter_shifted_by_one_jump_is_2f() {
    let t = from_fn(|k| {
        if k < 10 {
            [100.0 + (k % 2) as f32, 100.0]
        } else {
            [160.0 + (k % 2) as f32 * 0.0 + ((k + 1) % 2) as f32, 100.0]
        }
    });
    assert!(unique_points(&t) <= 8);
    assert_eq!(classify(&t), TrajType::T2F);
}

#[test]
fn small_drift_shifted_by_one_jump_is_3f() {
    let t = plateaus([100.0, 130.0, 430.0, 460.0], [100.0; 4]);
    assert_eq!(classify(&t), TrajType::T3F);
}

#[test]
fn few_points_in_a_100px_box_is_type_3() {
    let t = plateaus([100.0, 120.0, 140.0, 160.0], [100.0, 100.0, 110.0, 100.0]);
    assert_eq!(classify(&t), TrajType::T3);
}

#[test]
fn loop_back_to_start_is_type_4() {
    let t = from_fn(|k| {
        let a = std::f32::consts::TAU * k as f32 / 19.0;
        [300.0 + 50.0 * a.cos(), 300.0 + 50.0 * a.sin()]
    });
    assert_eq!(classify(&t), TrajType::T4);
}

#[test]
fn two_jumps_is_type_5() {
    let t = from_fn(|k| {
        let y = if (7..14).contains(&k) { 300.0 } else { 100.0 };
        [100.0 + 10.0 * k as f32, y]
    });
    assert_eq!(classify(&t), TrajType::T5);
}

#[test]
fn out_and_back_is_type_6() {
    let t = from_fn(|k| {
        let x = if k <= 10 {
            100.0 + 10.0 * k as f32
        } else {
            200.0 - 10.0 * (k - 10) as f32
        };
        [x, 100.0 + 0.5 * k as f32]
    });
    assert_eq!(classify(&t), TrajType::T6);
}

#[test]
fn straight_and_gently_curved_are_type_7() {
    let t = from_fn(|k| [100.0 + 10.0 * k as f32, 200.0 + 7.0 * k as f32]);
    assert_eq!(classify(&t), TrajType::T7);
    let c = from_fn(|k| {
        let a = 0.05 * k as f32;
        [500.0 + 200.0 * a.sin(), 500.0 + 200.0 * (1.0 - a.cos())]
    });
    assert_eq!(classify(&c), TrajType::T7);
}

#[test]
fn zigzag_is_other() {
    let t = from_fn(|k| [100.0 + 5.0 * k as f32, 100.0 + 40.0 * (k % 2) as f32]);
    assert_eq!(classify(&t), TrajType::Other);
}

#[test]
fn counts_and_histogram() {
    let a = [[1.0f32, 1.0]; 20];
    let b = from_fn(|k| [100.0 + 10.0 * k as f32, 100.0]);
    let trajs = [&a[..], &b[..]];
    let c = type_counts(trajs.iter().copied());
    assert_eq!(c[TrajType::T1.index()], 1);
    assert_eq!(c[TrajType::T7.index()], 1);
    let h = unique_histogram(trajs.iter().copied());
    assert_eq!(h[1], 1);
    assert_eq!(h[20], 1);
    for t in TrajType::ALL {
        assert_eq!(TrajType::from_label(t.label()), Some(t));
    }
}
