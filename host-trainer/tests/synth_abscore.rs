//! AbScore on hand-computed triangles, degenerate segments, the scaled form and filtering.

use gpecnet_trainer::data::{Dataset, Unit, Window, WINDOW};
use gpecnet_trainer::synth::abscore::{
    abscore, abscore_scaled, filter_by_abscore, triple_score, Which,
};
use gpecnet_trainer::synth::{quantile_sorted, Stats};

fn close(a: f64, b: f64) {
    assert!((a - b).abs() < 1e-9, "{a} != {b}");
}

#[test]
fn right_angle_turn_is_9_times_cross() {
    // a = (1,0), b = (0,1): |a×b| = 1, θ = 90° → ceil(9) = 9.
    close(triple_score([0.0, 0.0], [1.0, 0.0], [1.0, 1.0]), 9.0);
    // Scaled by 3 in both axes: |a×b| = 9 → 81.
    close(triple_score([0.0, 0.0], [3.0, 0.0], [3.0, 3.0]), 81.0);
}

#[test]
fn acute_turns() {
    // a = (2,0), b = (1,1): |a×b| = 2, θ = 45° → ceil(4.5) = 5 → 10.
    close(triple_score([0.0, 0.0], [2.0, 0.0], [3.0, 1.0]), 10.0);
    // 3-4-5: a = (3,0), b = (4,3): |a×b| = 9, sin θ = 0.6, θ = 36.87° → 4 → 36.
    close(triple_score([0.0, 0.0], [3.0, 0.0], [7.0, 3.0]), 36.0);
    // Turning the other way gives the same score (|θ|, |a×b|).
    close(triple_score([0.0, 0.0], [3.0, 0.0], [7.0, -3.0]), 36.0);
}

#[test]
fn obtuse_turn_adds_half_pi() {
    // a = (2,0), b = (-1,1): a·b < 0, |a×b| = 2, asin → 45°, + 90° = 135° → ceil(13.5) = 14 → 28.
    close(triple_score([0.0, 0.0], [2.0, 0.0], [1.0, 1.0]), 28.0);
    // The obtuse turn scores more than the acute one with the same cross product.
    assert!(
        triple_score([0.0, 0.0], [2.0, 0.0], [1.0, 1.0])
            > triple_score([0.0, 0.0], [2.0, 0.0], [3.0, 1.0])
    );
}

#[test]
fn straight_reversal_and_zero_steps_score_zero() {
    close(triple_score([0.0, 0.0], [1.0, 1.0], [2.0, 2.0]), 0.0);
    // Exact U-turn: |a×b| = 0.
    close(triple_score([0.0, 0.0], [1.0, 0.0], [0.0, 0.0]), 0.0);
    // Zero-length steps contribute 0 (documented degenerate case).
    close(triple_score([0.0, 0.0], [0.0, 0.0], [1.0, 1.0]), 0.0);
    close(triple_score([0.0, 0.0], [1.0, 1.0], [1.0, 1.0]), 0.0);
    close(abscore(&[[5.0, 5.0]; 20]), 0.0);
    close(abscore(&[[0.0, 0.0], [1.0, 0.0]]), 0.0);
}

#[test]
fn sums_over_triples_and_scales_by_bbox() {
    // Unit square walk: two 90° turns with |a×b| = 1 → 18; bbox area 1.
    let sq = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    close(abscore(&sq), 18.0);
    close(abscore_scaled(&sq), 18.0);
    // 45° triangle: score 10, bbox 3 × 1.
    let t = [[0.0, 0.0], [2.0, 0.0], [3.0, 1.0]];
    close(abscore_scaled(&t), 10.0 / 3.0);
    // Perfectly linear along an axis: zero area → divided by the length (score 0 → 0), finite.
    let lin = [[0.0, 0.0], [1.0, 0.0], [3.0, 0.0]];
    close(abscore_scaled(&lin), 0.0);
    // Stationary: zero length → 0.
    close(abscore_scaled(&[[2.0, 2.0]; 5]), 0.0);
}

fn window(pts: &[[f32; 2]]) -> Window {
    let mut pos = [[0.0; 2]; WINDOW];
    for (i, p) in pos.iter_mut().enumerate() {
        *p = pts[i.min(pts.len() - 1)];
    }
    Window {
        scene: "s".into(),
        ped_id: 1.0,
        frames: [0; WINDOW],
        pos,
    }
}

#[test]
fn filter_removes_windows_above_the_threshold() {
    let ds = Dataset {
        name: "hand".into(),
        unit: Unit::Pixels,
        windows: vec![
            window(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]), // 9
            window(&[[0.0, 0.0], [2.0, 0.0], [1.0, 1.0]]), // 28
            window(&[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]), // 0
        ],
    };
    let (kept, removed) = filter_by_abscore(&ds, Which::Unscaled, 10.0);
    assert_eq!(removed, 1);
    assert_eq!(kept.len(), 2);
    close(abscore(&kept.windows[0].pos), 9.0);
    let (kept, removed) = filter_by_abscore(&ds, Which::Unscaled, 0.0);
    assert_eq!((kept.len(), removed), (1, 2));
}

#[test]
fn stats_and_quantiles() {
    let s = Stats::of(&[1.0, 2.0, 3.0, 4.0, 5.0]);
    close(s.mean, 3.0);
    close(s.std, 2f64.sqrt());
    close(s.median, 3.0);
    close(s.q1, 2.0);
    close(s.min, 1.0);
    close(s.max, 5.0);
    close(quantile_sorted(&[0.0, 10.0], 0.95), 9.5);
    assert_eq!(Stats::of(&[]).n, 0);
}
