//! The per-track Kalman filter (`gpecnet_core::tracks::filter`) against an
//! independent double-precision filter on a recorded pedestrian with noise
//! and an irregular clock, against its documented f32 arithmetic bit for
//! bit, and against hostile input (NaN, teleports, stale and duplicate
//! timestamps, the `u32` wrap, coordinates near `f32::MAX`, a full bank).
// The f64 reference is written with explicit matrix indices, as in a textbook.
#![allow(clippy::needless_range_loop)]

use core::num::NonZeroU32;

use gpecnet_core::prng::{Gaussian, Xoshiro128PlusPlus};
use gpecnet_core::tracks::filter::{FilterConfig, FilterError, FilterReport, TrackFilter};
use gpecnet_core::tracks::{Observation, TimedTrackTable};

/// Pedestrian 3 of ETH/UCY `crowds_zara01.txt` (frame, x, y in metres),
/// every 10th frame of 25 fps: one point per 0.4 s, walking, turning.
const ZARA01_PED3: [(u32, f32, f32); 32] = [
    (0, 11.912_325, 4.439_072),
    (10, 11.504_654, 4.513_534),
    (20, 11.096_773, 4.588_235),
    (30, 10.689_102, 4.662_696),
    (40, 10.279_958, 4.709_474),
    (50, 9.870_814, 4.749_33),
    (60, 9.461_669, 4.789_186),
    (70, 9.050_842, 4.829_758),
    (80, 8.634_331, 4.874_626),
    (90, 8.217_821, 4.919_256),
    (100, 7.801_31, 4.964_124),
    (110, 7.384_589, 5.008_753),
    (120, 6.972_078, 5.037_87),
    (130, 6.565_038, 5.043_12),
    (140, 6.158_209, 5.048_371),
    (150, 5.751_38, 5.053_86),
    (160, 5.344_341, 5.059_11),
    (170, 4.962_767, 5.073_907),
    (180, 4.583_93, 5.089_898),
    (190, 4.205_093, 5.105_649),
    (200, 3.826_256, 5.121_639),
    (210, 3.444_051, 5.163_643),
    (220, 3.056_585, 5.245_026),
    (230, 2.669_119, 5.326_409),
    (240, 2.281_652, 5.407_792),
    (250, 1.894_186, 5.489_175),
    (260, 1.551_338, 5.666_5),
    (270, 1.208_701, 5.843_824),
    (280, 0.865_853, 6.021_148),
    (290, 0.552_471, 6.199_188),
    (300, 0.268_343, 6.378_183),
    (310, -0.015_785, 6.557_178),
];

/// The recorded track at 30 Hz with jitter and drops: positions linearly
/// interpolated between the recorded points, Gaussian noise of `sigma` m,
/// timestamps from `t0` ms (wrapping).
fn detections(sigma: f32, t0: u32, seed: u64) -> Vec<(u32, [f32; 2])> {
    let mut g = Gaussian::new(seed);
    let mut out = Vec::new();
    let end_ms = ZARA01_PED3[31].0 * 40;
    let mut frame = 0u32;
    loop {
        let jitter = [0, 7, 3, 0, 11, 2, 5][frame as usize % 7];
        let t = frame * 1000 / 30 + jitter;
        frame += 1;
        if t > end_ms {
            break;
        }
        if frame % 13 == 5 || frame.is_multiple_of(29) {
            continue; // dropped frames
        }
        let k = (t / 400) as usize;
        let (a, b) = (ZARA01_PED3[k], ZARA01_PED3[(k + 1).min(31)]);
        let f = (t - k as u32 * 400) as f32 / 400.0;
        let x = a.1 + (b.1 - a.1) * f + sigma * g.next();
        let y = a.2 + (b.2 - a.2) * f + sigma * g.next();
        out.push((t0.wrapping_add(t), [x, y]));
    }
    out
}

/// An independent filter in f64: the textbook 4-state constant-velocity
/// Kalman filter, full 4 × 4 matrices, `K = P·Hᵀ·(H·P·Hᵀ + R)⁻¹` by an
/// explicit 2 × 2 inverse and the Joseph-form covariance update.
struct Reference {
    x: [f64; 4],
    p: [[f64; 4]; 4],
    last: u64,
}

type M4 = [[f64; 4]; 4];

fn mul(a: &M4, b: &M4) -> M4 {
    let mut c = [[0.0; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            c[i][j] = (0..4).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    c
}

fn transpose(a: &M4) -> M4 {
    let mut t = [[0.0; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            t[i][j] = a[j][i];
        }
    }
    t
}

impl Reference {
    /// State order (x, y, vx, vy).
    fn start(z: [f32; 2], r: f64, s0: f64, t: u64) -> Self {
        let mut p = [[0.0; 4]; 4];
        p[0][0] = r;
        p[1][1] = r;
        p[2][2] = s0 * s0;
        p[3][3] = s0 * s0;
        Reference {
            x: [z[0] as f64, z[1] as f64, 0.0, 0.0],
            p,
            last: t,
        }
    }

    fn step(&mut self, t: u64, z: [f32; 2], r: f64, q: f64) {
        let dt = (t - self.last) as f64 / 1000.0;
        self.last = t;
        let mut f = [[0.0; 4]; 4];
        for (i, row) in f.iter_mut().enumerate() {
            row[i] = 1.0;
        }
        f[0][2] = dt;
        f[1][3] = dt;
        let mut qm = [[0.0; 4]; 4];
        for a in 0..2 {
            qm[a][a] = q * dt.powi(3) / 3.0;
            qm[a][a + 2] = q * dt.powi(2) / 2.0;
            qm[a + 2][a] = q * dt.powi(2) / 2.0;
            qm[a + 2][a + 2] = q * dt;
        }
        let x = self.x;
        self.x = [x[0] + dt * x[2], x[1] + dt * x[3], x[2], x[3]];
        let fp = mul(&f, &self.p);
        let mut p = mul(&fp, &transpose(&f));
        for i in 0..4 {
            for j in 0..4 {
                p[i][j] += qm[i][j];
            }
        }
        // S = H P Hᵀ + R (H picks the positions), K = P Hᵀ S⁻¹.
        let s = [[p[0][0] + r, p[0][1]], [p[1][0], p[1][1] + r]];
        let det = s[0][0] * s[1][1] - s[0][1] * s[1][0];
        let si = [
            [s[1][1] / det, -s[0][1] / det],
            [-s[1][0] / det, s[0][0] / det],
        ];
        let mut k = [[0.0; 2]; 4];
        for i in 0..4 {
            for j in 0..2 {
                k[i][j] = p[i][0] * si[0][j] + p[i][1] * si[1][j];
            }
        }
        let e = [z[0] as f64 - self.x[0], z[1] as f64 - self.x[1]];
        for i in 0..4 {
            self.x[i] += k[i][0] * e[0] + k[i][1] * e[1];
        }
        // Joseph form: (I − KH) P (I − KH)ᵀ + K R Kᵀ.
        let mut ikh = [[0.0; 4]; 4];
        for i in 0..4 {
            ikh[i][i] = 1.0;
            ikh[i][0] -= k[i][0];
            ikh[i][1] -= k[i][1];
        }
        let mut pn = mul(&mul(&ikh, &p), &transpose(&ikh));
        for i in 0..4 {
            for j in 0..4 {
                pn[i][j] += r * (k[i][0] * k[j][0] + k[i][1] * k[j][1]);
            }
        }
        self.p = pn;
    }
}

fn filtered<const N: usize>(
    f: &mut TrackFilter<N>,
    t: u32,
    z: [f32; 2],
) -> ([f32; 2], FilterReport) {
    let mut obs = [Observation { id: 3, pos: z }];
    let r = f.update(t, &mut obs);
    (obs[0].pos, r)
}

#[test]
fn the_filter_matches_an_f64_kalman_filter_on_a_recorded_pedestrian() {
    let c = FilterConfig::metres();
    let (r, q) = ((c.sigma as f64).powi(2), (c.accel as f64).powi(2));
    for (sigma, t0) in [(0.1, 0), (0.2, 5_000), (0.0, u32::MAX - 3_000)] {
        let dets = detections(sigma, t0, 7);
        assert!(dets.len() > 300);
        let mut f: TrackFilter<4> = TrackFilter::new(c).unwrap();
        let mut reference: Option<Reference> = None;
        let (mut worst, mut raw_err, mut filt_err) = (0.0f64, 0.0f64, 0.0f64);
        let clean = detections(0.0, t0, 7);
        for (&(t, z), &(_, truth)) in dets.iter().zip(&clean) {
            let (pos, rep) = filtered(&mut f, t, z);
            assert_eq!(rep.resets, 0);
            let unwrapped = u64::from(t.wrapping_sub(t0));
            match reference.as_mut() {
                None => reference = Some(Reference::start(z, r, c.init_speed as f64, unwrapped)),
                Some(re) => re.step(unwrapped, z, r, q),
            }
            let re = reference.as_ref().unwrap();
            let d = ((pos[0] as f64 - re.x[0]).powi(2) + (pos[1] as f64 - re.x[1]).powi(2)).sqrt();
            worst = worst.max(d);
            // The covariance too: the per-axis block of the reference.
            let p = f.get(3).unwrap().covariance();
            for (a, b) in [(p[0], re.p[0][0]), (p[1], re.p[0][2]), (p[2], re.p[2][2])] {
                assert!(
                    ((a as f64) - b).abs() <= 1e-4 * b.abs().max(1e-3),
                    "{a} vs {b}"
                );
            }
            // Symmetric in the reference as well (a sanity check on it).
            assert!((re.p[0][2] - re.p[2][0]).abs() < 1e-12);
            let dist = |a: [f32; 2]| {
                ((a[0] as f64 - truth[0] as f64).powi(2) + (a[1] as f64 - truth[1] as f64).powi(2))
                    .sqrt()
            };
            raw_err += dist(z);
            filt_err += dist(pos);
        }
        // Positions within 20 µm of the f64 filter over 10 s of 30 Hz updates.
        assert!(
            worst < 2e-5,
            "σ = {sigma}: {worst} m from the f64 reference"
        );
        if sigma > 0.0 {
            // And the point of it: the filtered positions are closer to the truth.
            assert!(filt_err < 0.6 * raw_err, "{filt_err} vs {raw_err}");
        }
    }
}

/// The module's arithmetic, written out again from its documentation.
fn documented(
    st: &mut ([f32; 2], [f32; 2], [f32; 3]),
    dt: f32,
    z: [f32; 2],
    c: &FilterConfig,
) -> [f32; 2] {
    let q = c.accel * c.accel;
    let r = c.sigma * c.sigma;
    let (x, v, p) = st;
    for i in 0..2 {
        x[i] += v[i] * dt;
    }
    let d2 = dt * dt;
    let d3 = d2 * dt;
    let a01 = p[1] + dt * p[2];
    p[0] = (p[0] + dt * (p[1] + a01)) + q * (d3 / 3.0);
    p[1] = a01 + q * (d2 * 0.5);
    p[2] += q * dt;
    let e = [z[0] - x[0], z[1] - x[1]];
    assert!(e[0] * e[0] + e[1] * e[1] <= c.reset * c.reset);
    let s = p[0] + r;
    let (k0, k1) = (p[0] / s, p[1] / s);
    for i in 0..2 {
        x[i] += k0 * e[i];
        v[i] += k1 * e[i];
    }
    p[2] -= k1 * p[1];
    p[1] = k1 * r;
    p[0] = k0 * r;
    *x
}

#[test]
fn the_documented_f32_arithmetic_is_the_code_bit_for_bit() {
    let mut c = FilterConfig::metres();
    for (accel, sigma) in [(0.5, 0.1), (2.0, 0.05), (0.1, 0.3)] {
        c.accel = accel;
        c.sigma = sigma;
        let mut f: TrackFilter<4> = TrackFilter::new(c).unwrap();
        let dets = detections(sigma, 1_000, 11);
        let (t_first, z_first) = dets[0];
        filtered(&mut f, t_first, z_first);
        let mut st = (
            z_first,
            [0.0; 2],
            [sigma * sigma, 0.0, c.init_speed * c.init_speed],
        );
        let mut last = t_first;
        for &(t, z) in &dets[1..] {
            let (pos, _) = filtered(&mut f, t, z);
            let want = documented(&mut st, (t - last) as f32 / 1000.0, z, &c);
            last = t;
            assert_eq!(pos.map(f32::to_bits), want.map(f32::to_bits));
            assert_eq!(
                f.get(3).unwrap().covariance().map(f32::to_bits),
                st.2.map(f32::to_bits)
            );
            assert_eq!(
                f.get(3).unwrap().velocity().map(f32::to_bits),
                st.1.map(f32::to_bits)
            );
        }
    }
}

#[test]
fn constant_velocity_is_followed_without_lag() {
    let mut f: TrackFilter<4> = TrackFilter::new(FilterConfig::metres()).unwrap();
    for k in 0..100u32 {
        let t = k * 100;
        let truth = [
            1.3 * t as f32 / 1000.0 - 5.0,
            -0.4 * t as f32 / 1000.0 + 2.0,
        ];
        let (pos, _) = filtered(&mut f, t, truth);
        if k >= 40 {
            let d = ((pos[0] - truth[0]).powi(2) + (pos[1] - truth[1]).powi(2)).sqrt();
            assert!(d < 1e-3, "step {k}: {d}");
        }
    }
    let v = f.get(3).unwrap().velocity();
    assert!(
        (v[0] - 1.3).abs() < 1e-3 && (v[1] + 0.4).abs() < 1e-3,
        "{v:?}"
    );
}

#[test]
fn hostile_detections_never_give_a_non_finite_position() {
    let mut f: TrackFilter<8> = TrackFilter::new(FilterConfig::metres()).unwrap();
    let mut rng = Xoshiro128PlusPlus::seed_from_u64(99);
    let specials = [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::MAX,
        -f32::MAX,
        1e30,
        -1e30,
        0.0,
        1e-40,
    ];
    let mut t = u32::MAX - 50_000; // crosses the u32 wrap
    let mut finite_out = 0u32;
    for step in 0..200_000u32 {
        let r = rng.next_u32();
        // Mostly forward in time, sometimes the same time, sometimes backwards.
        t = match r % 16 {
            0 => t.wrapping_sub(1 + r % 1_000),
            1 => t,
            2 => t.wrapping_add(5_000),
            _ => t.wrapping_add(1 + r % 120),
        };
        let mut obs: Vec<Observation> = (0..(1 + r % 5))
            .map(|i| {
                let s = rng.next_u32();
                let mut pos = [
                    (s % 2000) as f32 / 100.0 - 10.0,
                    ((s >> 11) % 2000) as f32 / 100.0 - 10.0,
                ];
                if s.is_multiple_of(7) {
                    pos[(s >> 3) as usize % 2] = specials[(s >> 5) as usize % specials.len()];
                }
                Observation {
                    id: (s >> 20) % 12 + i % 2,
                    pos,
                }
            })
            .collect();
        let before: Vec<[f32; 2]> = obs.iter().map(|o| o.pos).collect();
        let sigma_of = |i: usize, _: &Observation| match (step + i as u32) % 5 {
            0 => f32::NAN,
            1 => -1.0,
            2 => 0.0,
            3 => 1e30,
            _ => 0.05,
        };
        let rep = f.update_with(t, &mut obs, sigma_of);
        for (o, b) in obs.iter().zip(&before) {
            if b.iter().all(|v| v.is_finite()) {
                assert!(o.pos.iter().all(|v| v.is_finite()), "{o:?} from {b:?}");
                finite_out += 1;
            } else {
                // Non-finite detections are left for the table to refuse.
                assert_eq!(o.pos.map(f32::to_bits), b.map(f32::to_bits));
            }
        }
        if rep.stale {
            let bits = |v: &[[f32; 2]]| v.iter().map(|p| p.map(f32::to_bits)).collect::<Vec<_>>();
            let after: Vec<[f32; 2]> = obs.iter().map(|o| o.pos).collect();
            assert_eq!(bits(&after), bits(&before));
        }
        for tr in f.iter() {
            let p = tr.covariance();
            assert!(p.iter().all(|v| v.is_finite()) && p[0] > 0.0 && p[2] > 0.0);
            assert!(p[0] * p[2] > p[1] * p[1]);
            assert!(tr
                .position()
                .iter()
                .chain(&tr.velocity())
                .all(|v| v.is_finite()));
        }
        assert!(f.len() <= 8);
    }
    assert!(finite_out > 100_000);
}

#[test]
fn teleports_stale_and_duplicate_timestamps_and_the_wrap() {
    let mut f: TrackFilter<2> = TrackFilter::new(FilterConfig::metres()).unwrap();
    let t0 = u32::MAX - 150;
    let (_, r) = filtered(&mut f, t0, [1.0, 1.0]);
    assert_eq!(r.started, 1);
    // Across the wrap: 100 ms later, then 200 ms.
    let (p, r) = filtered(&mut f, t0.wrapping_add(100), [1.1, 1.0]);
    assert_eq!(r.filtered, 1);
    assert!(p[0] > 1.0 && p[0] < 1.1);
    let (_, r) = filtered(&mut f, t0.wrapping_add(200), [1.2, 1.0]);
    assert_eq!(r.filtered, 1);
    assert_eq!(f.get(3).unwrap().last_detection_ms(), t0.wrapping_add(200));
    // The same timestamp again: a duplicate, left as it is.
    let (p, r) = filtered(&mut f, t0.wrapping_add(200), [9.0, 9.0]);
    assert_eq!((p, r.duplicates), ([9.0, 9.0], 1));
    // A timestamp before the last: stale, nothing changes.
    let before = f.get(3).cloned();
    let (p, r) = filtered(&mut f, t0.wrapping_add(150), [5.0, 5.0]);
    assert!(r.stale);
    assert_eq!(p, [5.0, 5.0]);
    assert_eq!(f.get(3).cloned(), before);
    // A teleport (an id switch) restarts the track at the detection.
    let (p, r) = filtered(&mut f, t0.wrapping_add(300), [40.0, -3.0]);
    assert_eq!((p, r.resets), ([40.0, -3.0], 1));
    assert_eq!(f.get(3).unwrap().velocity(), [0.0, 0.0]);
    // A gap longer than max_gap_ms forgets the track: it starts afresh.
    let (p, r) = filtered(&mut f, t0.wrapping_add(1_400), [40.5, -3.0]);
    assert_eq!((p, r.started), ([40.5, -3.0], 1));
    // NaN is left for the table, and the track is untouched.
    let before = f.get(3).cloned();
    let (p, r) = filtered(&mut f, t0.wrapping_add(1_500), [f32::NAN, 0.0]);
    assert!(p[0].is_nan() && r.non_finite == 1);
    assert_eq!(f.get(3).cloned(), before);
    // A full bank leaves newcomers as they are.
    let mut obs = [
        Observation {
            id: 10,
            pos: [0.0, 0.0],
        },
        Observation {
            id: 11,
            pos: [1.0, 0.0],
        },
    ];
    let r = f.update(t0.wrapping_add(1_600), &mut obs);
    assert_eq!((r.started, r.untracked), (1, 1));
    assert_eq!(obs[1].pos, [1.0, 0.0]);
    // Coordinates near f32::MAX overflow the prediction: the track restarts, finite.
    let mut f: TrackFilter<2> = TrackFilter::new(FilterConfig::metres()).unwrap();
    filtered(&mut f, 0, [f32::MAX, -f32::MAX]);
    let (p, _) = filtered(&mut f, 100, [f32::MAX, -f32::MAX]);
    assert!(p.iter().all(|v| v.is_finite()));
    f.clear();
    assert!(f.is_empty());
}

#[test]
fn bad_configs_are_refused() {
    let ok = FilterConfig::metres();
    assert!(TrackFilter::<4>::new(ok).is_ok());
    assert_eq!(FilterConfig::default(), ok);
    let bad = [
        FilterConfig { accel: 0.0, ..ok },
        FilterConfig {
            accel: f32::NAN,
            ..ok
        },
        FilterConfig { accel: 1e30, ..ok },
        FilterConfig { sigma: -0.1, ..ok },
        FilterConfig { sigma: 1e-30, ..ok },
        FilterConfig {
            init_speed: f32::INFINITY,
            ..ok
        },
        FilterConfig { reset: 0.0, ..ok },
        FilterConfig {
            max_gap_ms: 0,
            ..ok
        },
        FilterConfig {
            max_gap_ms: 60_001,
            ..ok
        },
    ];
    for c in bad {
        assert_eq!(
            TrackFilter::<4>::new(c).err(),
            Some(FilterError::BadConfig),
            "{c:?}"
        );
    }
    assert!(!FilterError::BadConfig.to_string().is_empty());
    let px = ok.scaled(20.0);
    assert_eq!((px.sigma, px.reset, px.max_gap_ms), (2.0, 60.0, 1_000));
}

#[test]
fn filtered_detections_through_the_timed_table() {
    // 30 Hz detections of a walker with ±0.1 m of noise: the grid history
    // of the filtered detections is closer to the truth than the raw one's.
    let period = NonZeroU32::new(400).unwrap();
    let mut raw: TimedTrackTable<4> = TimedTrackTable::new(period, 1_000);
    let mut filt: TimedTrackTable<4> = TimedTrackTable::new(period, 1_000);
    let mut f: TrackFilter<4> = TrackFilter::new(FilterConfig::metres()).unwrap();
    let dets = detections(0.1, 0, 3);
    let clean = detections(0.0, 0, 3);
    let mut truth: TimedTrackTable<4> = TimedTrackTable::new(period, 1_000);
    let (mut e_raw, mut e_filt, mut n) = (0.0f64, 0.0f64, 0);
    for (&(t, z), &(_, c)) in dets.iter().zip(&clean) {
        raw.update(t, &[Observation { id: 3, pos: z }]);
        truth.update(t, &[Observation { id: 3, pos: c }]);
        let mut o = [Observation { id: 3, pos: z }];
        f.update(t, &mut o);
        filt.update(t, &o);
        let (Some(a), Some(b), Some(y)) = (raw.get(3), filt.get(3), truth.get(3)) else {
            continue;
        };
        if y.ready() && y.fresh() && t > 3_000 {
            let d = |p: [f32; 2], q: [f32; 2]| {
                (((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)) as f64).sqrt()
            };
            for ((pa, pb), py) in a.past().iter().zip(b.past()).zip(y.past()) {
                e_raw += d(*pa, py);
                e_filt += d(pb, py);
                n += 1;
            }
        }
    }
    assert!(n > 100);
    assert!(
        e_filt < 0.5 * e_raw,
        "filtered {} m vs raw {} m",
        e_filt / n as f64,
        e_raw / n as f64
    );
}

/// A textbook RTS smoother in f64 per axis, 2 × 2 matrices, for `smooth_history`.
fn rts_reference(z: &[f64], dt: f64, r: f64, q: f64, s0: f64) -> Vec<f64> {
    type M = [[f64; 2]; 2];
    let mm = |a: &M, b: &M| -> M {
        let mut c = [[0.0; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                c[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j];
            }
        }
        c
    };
    let t = |a: &M| -> M { [[a[0][0], a[1][0]], [a[0][1], a[1][1]]] };
    let f: M = [[1.0, dt], [0.0, 1.0]];
    let qm: M = [
        [q * dt.powi(3) / 3.0, q * dt.powi(2) / 2.0],
        [q * dt.powi(2) / 2.0, q * dt],
    ];
    let n = z.len();
    let mut xf = vec![[z[0], 0.0]];
    let mut pf: Vec<M> = vec![[[r, 0.0], [0.0, s0 * s0]]];
    let mut xp = vec![[0.0; 2]];
    let mut pp: Vec<M> = vec![[[0.0; 2]; 2]];
    for k in 1..n {
        let x = xf[k - 1];
        let xk = [x[0] + dt * x[1], x[1]];
        let mut p = mm(&mm(&f, &pf[k - 1]), &t(&f));
        for i in 0..2 {
            for j in 0..2 {
                p[i][j] += qm[i][j];
            }
        }
        xp.push(xk);
        pp.push(p);
        let s = p[0][0] + r;
        let k0 = p[0][0] / s;
        let k1 = p[1][0] / s;
        let e = z[k] - xk[0];
        xf.push([xk[0] + k0 * e, xk[1] + k1 * e]);
        let ikh: M = [[1.0 - k0, 0.0], [-k1, 1.0]];
        let mut pn = mm(&mm(&ikh, &p), &t(&ikh));
        pn[0][0] += r * k0 * k0;
        pn[0][1] += r * k0 * k1;
        pn[1][0] += r * k0 * k1;
        pn[1][1] += r * k1 * k1;
        pf.push(pn);
    }
    let mut xs = xf.clone();
    for k in (0..n - 1).rev() {
        let p = pp[k + 1];
        let det = p[0][0] * p[1][1] - p[0][1] * p[1][0];
        let inv: M = [
            [p[1][1] / det, -p[0][1] / det],
            [-p[1][0] / det, p[0][0] / det],
        ];
        let c = mm(&mm(&pf[k], &t(&f)), &inv);
        let d = [xs[k + 1][0] - xp[k + 1][0], xs[k + 1][1] - xp[k + 1][1]];
        xs[k] = [
            xf[k][0] + c[0][0] * d[0] + c[0][1] * d[1],
            xf[k][1] + c[1][0] * d[0] + c[1][1] * d[1],
        ];
    }
    xs.iter().map(|x| x[0]).collect()
}

#[test]
fn the_history_smoother_matches_an_f64_rts_smoother() {
    use gpecnet_core::tracks::filter::smooth_history;
    use gpecnet_core::tracks::HISTORY;
    let mut g = Gaussian::new(21);
    let mut worst = 0.0f64;
    let (mut raw_err, mut smooth_err) = (0.0, 0.0);
    for (accel, sigma) in [(0.2, 0.1), (0.5, 0.05), (1.0, 0.2)] {
        let c = FilterConfig {
            accel,
            sigma,
            ..FilterConfig::metres()
        };
        // Every 8-point window of the recorded pedestrian, with noise.
        for start in 0..ZARA01_PED3.len() - HISTORY {
            let truth: Vec<[f32; 2]> = ZARA01_PED3[start..start + HISTORY]
                .iter()
                .map(|p| [p.1, p.2])
                .collect();
            let mut past = [[0.0f32; 2]; HISTORY];
            for (p, y) in past.iter_mut().zip(&truth) {
                *p = [y[0] + sigma * g.next(), y[1] + sigma * g.next()];
            }
            let s = smooth_history(&past, 0.4, &c);
            for axis in 0..2 {
                let z: Vec<f64> = past.iter().map(|p| p[axis] as f64).collect();
                let want = rts_reference(
                    &z,
                    0.4,
                    (sigma as f64).powi(2),
                    (accel as f64).powi(2),
                    c.init_speed as f64,
                );
                for k in 0..HISTORY {
                    worst = worst.max((s[k][axis] as f64 - want[k]).abs());
                    raw_err += (past[k][axis] - truth[k][axis]).abs() as f64;
                    smooth_err += (s[k][axis] - truth[k][axis]).abs() as f64;
                }
            }
        }
    }
    assert!(worst < 1e-5, "{worst} m from the f64 smoother");
    assert!(smooth_err < 0.8 * raw_err, "{smooth_err} vs {raw_err}");
    // Hostile histories come back finite: unchanged where the smoother overflows.
    let c = FilterConfig::metres();
    for bad in [f32::MAX, -f32::MAX, 1e30] {
        let mut past = [[0.0f32; 2]; HISTORY];
        past[3] = [bad, -bad];
        let s = smooth_history(&past, 0.4, &c);
        assert!(s.iter().flatten().all(|v| v.is_finite()), "{s:?}");
    }
    let nan = [[f32::NAN, 0.0]; HISTORY];
    assert!(smooth_history(&nan, 0.4, &c)[0][0].is_nan()); // unchanged, not invented
                                                           // A standing pedestrian stays put.
    let still = [[3.0f32, -2.0]; HISTORY];
    let s = smooth_history(&still, 0.4, &c);
    assert!(s
        .iter()
        .all(|p| (p[0] - 3.0).abs() < 1e-5 && (p[1] + 2.0).abs() < 1e-5));
}
