//! Synthetic **starters** and **stoppers** built on real observations, in metres: the
//! motion changes a forecaster sees least (`gpecnet_data::motion_change`), made plentiful.
//!
//! A real pedestrian's 8 observed positions are kept as recorded (so the encoder sees real
//! detection jitter and real standing or walking), and only the 12 future positions are
//! replaced:
//!
//! * [`starter`]: from a window whose pedestrian is **standing** when forecast (observed
//!   speed under [`STANDING_M_S`]): it stays at its last observed position for `s` steps,
//!   `s` uniform in `0..=7`, then walks off in a uniformly drawn direction at a speed drawn
//!   uniformly from [`WALK_M_S`], reaching it over [`RAMP_STEPS`] steps (half the speed on
//!   the first). At the horizon it has walked at least `1.8 · 0.8 = 1.44 m`, so every one
//!   is a starter by `motion_change`'s definition (more than 1 m away).
//! * [`stopper`]: from a window whose pedestrian is **walking** when forecast (observed
//!   speed at least [`WALK_M_S`]`.start`): it goes on at its last observed velocity (the mean
//!   over the last two observed steps) for `s` steps, `s` uniform in `0..=6`, slows to 2/3
//!   and then 1/3 of it over the next two, and stands from then on, so it has stood for at
//!   least the last 4 steps (1.6 s): a stopper by `motion_change`'s definition.
//!
//! A starter's direction is uniform, as if nothing in a standing pedestrian's past said
//! where it will go. Measured, that is not so: most real starters leave within 45° of the
//! direction they drift while standing, and walk less far than these do, so these synthetic
//! starters teach a proposal to ignore that cue and hurt the real starters
//! (`docs/generalisation.md`, "Starters in the union"). Every draw comes from the caller's
//! [`Rng`], so a set is reproducible from its seed.

use crate::data::{observed_speed, Window, PAST, PERIOD_S};
use crate::rng::Rng;

/// Observed speed below which a pedestrian is standing when forecast (metres per second;
/// `gpecnet_data::SPEED_BINS_M_S[0]`, the threshold of `motion_change`).
pub const STANDING_M_S: f64 = crate::data::SPEED_BINS_M_S[0];

/// The walking speeds a synthetic starter reaches and the observed speeds a stopper's
/// source window walks at (metres per second): the "walking" bin's lower edge to a brisk
/// walk.
pub const WALK_M_S: std::ops::Range<f32> = 0.8..1.6;

/// Steps over which a starter reaches its speed (half of it on the first).
pub const RAMP_STEPS: usize = 2;

/// A synthetic starter on `w`'s observed positions, or `None` when `w`'s pedestrian is
/// not standing when forecast (its observed speed is at least [`STANDING_M_S`]).
pub fn starter(w: &Window, rng: &mut Rng) -> Option<Window> {
    if observed_speed(w) >= STANDING_M_S {
        return None;
    }
    let wait = rng.below(8);
    let speed = rng.uniform(WALK_M_S.start, WALK_M_S.end);
    let (sin, cos) = rng.uniform(0.0, std::f32::consts::TAU).sin_cos();
    let mut out = w.clone();
    let mut p = w.pos[PAST - 1];
    for (j, slot) in out.pos[PAST..].iter_mut().enumerate() {
        if j >= wait {
            let ramp = ((j - wait + 1) as f32 / RAMP_STEPS as f32).min(1.0);
            let step = speed * ramp * PERIOD_S;
            p = [p[0] + step * cos, p[1] + step * sin];
        }
        *slot = p;
    }
    Some(out)
}

/// A synthetic stopper on `w`'s observed positions, or `None` when `w`'s pedestrian does
/// not walk when forecast (its observed speed is under [`WALK_M_S`]`.start`).
pub fn stopper(w: &Window, rng: &mut Rng) -> Option<Window> {
    if observed_speed(w) < f64::from(WALK_M_S.start) {
        return None;
    }
    let go_on = rng.below(7);
    let (a, b) = (w.pos[PAST - 3], w.pos[PAST - 1]);
    let v = [(b[0] - a[0]) / 2.0, (b[1] - a[1]) / 2.0];
    let mut out = w.clone();
    let mut p = b;
    for (j, slot) in out.pos[PAST..].iter_mut().enumerate() {
        let share = match j.checked_sub(go_on) {
            None => 1.0,
            Some(0) => 2.0 / 3.0,
            Some(1) => 1.0 / 3.0,
            Some(_) => 0.0,
        };
        p = [p[0] + share * v[0], p[1] + share * v[1]];
        *slot = p;
    }
    Some(out)
}

/// `n` synthetic windows made by `make` ([`starter`] or [`stopper`]), each with the index
/// of its source in `from`: sources drawn uniformly with replacement among the windows
/// `make` accepts; empty when it accepts none. The draws use `rng` only, in a fixed order.
pub fn synthesize(
    from: &[Window],
    n: usize,
    make: fn(&Window, &mut Rng) -> Option<Window>,
    rng: &mut Rng,
) -> Vec<(usize, Window)> {
    // Acceptance depends on the observed speed only, never on the draws.
    let mut probe = Rng::new(0);
    let sources: Vec<usize> = (0..from.len())
        .filter(|&i| make(&from[i], &mut probe).is_some())
        .collect();
    if sources.is_empty() {
        return Vec::new();
    }
    (0..n)
        .filter_map(|_| {
            let i = sources[rng.below(sources.len())];
            make(&from[i], rng).map(|w| (i, w))
        })
        .collect()
}
