//! The camera geometry (`gpecnet_core::camera`) against a double-precision
//! reference written here, independently: quaternions rotate vectors by the
//! Hamilton product `q·v·q*`, Euler angles one axis at a time, the lens is
//! inverted by fixed-point iteration (OpenCV's method) rather than Newton's.
//! Goals: the image → ground → image round trip within 0.01 px over the
//! whole valid image, ground points within 1 mm of the reference at 100 m
//! range, typed errors for hostile inputs, a static ground point unmoved
//! by a 90° yaw, and the documented f32 arithmetic reproduced bit for bit.
//! Run with `--nocapture` to see the measured errors (`docs/camera.md`).
use core::f32::consts::{FRAC_PI_2, PI};

use gpecnet_core::camera::{
    attitude_from_ros, position_from_ros, to_observations, BoundingBox, Camera, CameraError,
    Detection, Distortion, Euler, Intrinsics, MeasurementNoise, Pose, State,
};
use gpecnet_core::tracks::Observation;

// ---------------------------------------------------------------- f64 reference

type V3 = [f64; 3];

fn qmul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    let [aw, ax, ay, az] = a;
    let [bw, bx, by, bz] = b;
    [
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ]
}

/// `v` rotated by the unit quaternion of `q` (normalised here): `q·v·q*`.
fn qrot(q: [f32; 4], v: V3) -> V3 {
    let q = q.map(f64::from);
    let n = q.iter().map(|c| c * c).sum::<f64>().sqrt();
    let q = q.map(|c| c / n);
    let r = qmul(
        qmul(q, [0.0, v[0], v[1], v[2]]),
        [q[0], -q[1], -q[2], -q[3]],
    );
    [r[1], r[2], r[3]]
}

fn rot_x(a: f64, v: V3) -> V3 {
    let (s, c) = a.sin_cos();
    [v[0], c * v[1] - s * v[2], s * v[1] + c * v[2]]
}
fn rot_y(a: f64, v: V3) -> V3 {
    let (s, c) = a.sin_cos();
    [c * v[0] + s * v[2], v[1], -s * v[0] + c * v[2]]
}
fn rot_z(a: f64, v: V3) -> V3 {
    let (s, c) = a.sin_cos();
    [c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]]
}

/// Intrinsic Z-Y-X: `Rz(yaw)·Ry(pitch)·Rx(roll)·v`.
fn euler(e: Euler, v: V3) -> V3 {
    rot_z(e.yaw as f64, rot_y(e.pitch as f64, rot_x(e.roll as f64, v)))
}
/// The inverse of [`euler`].
fn euler_inv(e: Euler, v: V3) -> V3 {
    rot_x(
        -e.roll as f64,
        rot_y(-e.pitch as f64, rot_z(-e.yaw as f64, v)),
    )
}

fn distort64(d: Distortion, x: f64, y: f64) -> [f64; 2] {
    let (k1, k2, p1, p2) = (d.k1 as f64, d.k2 as f64, d.p1 as f64, d.p2 as f64);
    let r2 = x * x + y * y;
    let rad = 1.0 + k1 * r2 + k2 * r2 * r2;
    [
        x * rad + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
        y * rad + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
    ]
}

/// Fixed-point inversion of the lens (OpenCV's `undistortPoints`), to
/// convergence in f64.
fn undistort64(d: Distortion, xd: f64, yd: f64) -> [f64; 2] {
    let (k1, k2, p1, p2) = (d.k1 as f64, d.k2 as f64, d.p1 as f64, d.p2 as f64);
    let (mut x, mut y) = (xd, yd);
    for _ in 0..500 {
        let r2 = x * x + y * y;
        let rad = 1.0 + k1 * r2 + k2 * r2 * r2;
        let dx = 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let dy = p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        x = (xd - dx) / rad;
        y = (yd - dy) / rad;
    }
    [x, y]
}

/// Camera-frame vector → NED (unnormalised quaternion handled by `qrot`).
fn cam_to_ned(cam: &Camera, st: &State, c: V3) -> V3 {
    let gimbal = [c[2], c[0], c[1]]; // x right, y down, z forward → FRD
    qrot(st.attitude, euler(cam.mount, euler(st.gimbal, gimbal)))
}

fn ned_to_cam(cam: &Camera, st: &State, w: V3) -> V3 {
    let q = st.attitude;
    let body = qrot([q[0], -q[1], -q[2], -q[3]], w);
    let g = euler_inv(st.gimbal, euler_inv(cam.mount, body));
    [g[1], g[2], g[0]]
}

/// Reference image → ground: `None` when the ray does not point down.
fn ref_ground(cam: &Camera, st: &State, uv: [f32; 2]) -> Option<[f64; 2]> {
    let k = cam.intrinsics;
    let xd = (uv[0] as f64 - k.cx as f64) / k.fx as f64;
    let yd = (uv[1] as f64 - k.cy as f64) / k.fy as f64;
    let [x, y] = undistort64(cam.distortion, xd, yd);
    let d = cam_to_ned(cam, st, [x, y, 1.0]);
    if d[2] <= 0.0 {
        return None;
    }
    let t = (st.ground_down as f64 - st.position[2] as f64) / d[2];
    Some([
        st.position[0] as f64 + t * d[0],
        st.position[1] as f64 + t * d[1],
    ])
}

/// Reference ground → image.
fn ref_pixel(cam: &Camera, st: &State, ne: [f64; 2]) -> [f64; 2] {
    let w = [
        ne[0] - st.position[0] as f64,
        ne[1] - st.position[1] as f64,
        st.ground_down as f64 - st.position[2] as f64,
    ];
    let c = ned_to_cam(cam, st, w);
    let [xd, yd] = distort64(cam.distortion, c[0] / c[2], c[1] / c[2]);
    let k = cam.intrinsics;
    [
        k.fx as f64 * xd + k.cx as f64,
        k.fy as f64 * yd + k.cy as f64,
    ]
}

// ---------------------------------------------------------------- scenes

const W: f32 = 1920.0;
const H: f32 = 1080.0;

fn lens(distortion: Distortion, max_range: f32) -> Camera {
    Camera {
        intrinsics: Intrinsics {
            fx: 1100.0,
            fy: 1095.0,
            cx: 957.3,
            cy: 544.8,
        },
        distortion,
        mount: Euler::ZERO,
        max_range,
    }
}

/// A calibrated gimbal camera's lens (mild barrel, slight decentring).
const MILD: Distortion = Distortion {
    k1: -0.12,
    k2: 0.03,
    p1: 4e-4,
    p2: -2e-4,
};
/// A strong wide-angle barrel lens.
const STRONG: Distortion = Distortion {
    k1: -0.3,
    k2: 0.08,
    p1: 1e-3,
    p2: -1e-3,
};

/// A quaternion `(w, x, y, z)` from ZYX Euler angles (f64, rounded to f32).
fn quat(roll: f64, pitch: f64, yaw: f64) -> [f32; 4] {
    let (sr, cr) = (roll / 2.0).sin_cos();
    let (sp, cp) = (pitch / 2.0).sin_cos();
    let (sy, cy) = (yaw / 2.0).sin_cos();
    [
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ]
    .map(|c| c as f32)
}

fn state(q: [f32; 4], position: [f32; 3], gimbal_pitch: f32, gimbal_yaw: f32) -> State {
    State {
        attitude: q,
        position,
        gimbal: Euler {
            roll: 0.01,
            pitch: gimbal_pitch,
            yaw: gimbal_yaw,
        },
        ground_down: 0.0,
    }
}

/// Poses of a flight: oblique and nadir views, rolled, pitched and yawed,
/// away from the origin, with every lens.
fn scenes() -> Vec<(&'static str, Camera, State)> {
    let mut v = Vec::new();
    for (lname, d) in [
        ("pinhole", Distortion::NONE),
        ("mild", MILD),
        ("strong", STRONG),
    ] {
        v.push((
            lname,
            lens(d, 500.0),
            state(quat(0.05, -0.08, 0.6), [120.5, -340.25, -30.0], -0.7, 0.0),
        ));
        v.push((
            lname,
            lens(d, 500.0),
            state(
                quat(-0.2, 0.1, -2.5),
                [-812.0, 455.5, -62.0],
                -FRAC_PI_2,
                0.3,
            ),
        ));
        v.push((
            lname,
            lens(d, 500.0),
            state(quat(0.1, 0.15, 3.0), [3.0, 4.0, -12.0], -0.35, -0.4),
        ));
    }
    v
}

// ---------------------------------------------------------------- goals

/// Image → ground → image returns to the pixel within 0.01 px for every
/// pixel of a 4-px grid over the whole 1920 × 1080 image whose ray meets
/// the ground within range (every lens, oblique and nadir views).
#[test]
fn round_trip_within_a_hundredth_of_a_pixel_over_the_whole_image() {
    for (name, cam, st) in scenes() {
        let pose = Pose::new(&cam, &st).unwrap();
        let (mut worst, mut valid, mut all) = (0.0f32, 0, 0);
        let mut v = 0.0;
        while v <= H {
            let mut u = 0.0;
            while u <= W {
                all += 1;
                if let Ok(g) = pose.image_to_ground([u, v]) {
                    let back = pose.ground_to_image(g).unwrap();
                    let e = (back[0] - u).abs().max((back[1] - v).abs());
                    worst = worst.max(e);
                    valid += 1;
                }
                u += 4.0;
            }
            v += 4.0;
        }
        println!(
            "round trip {name:>7} h={:>4} m: max {worst:.2e} px over {valid}/{all} pixels",
            pose.height()
        );
        assert!(worst < 0.01, "{name}: {worst} px");
        assert!(
            valid * 3 > all,
            "{name}: only {valid} of {all} pixels valid"
        );
    }
}

/// Every ground point the camera sees within 100 m (horizontal) is within
/// 1 mm of the f64 reference, and its projection back within 0.01 px of
/// the reference's.
#[test]
fn ground_points_match_the_f64_reference_within_a_millimetre_at_100_m() {
    let mut rng = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut worst, mut worst_px, mut far, mut n) = (0.0f64, 0.0f64, 0.0f32, 0);
    for d in [Distortion::NONE, MILD, STRONG] {
        let cam = lens(d, 100.0);
        for _ in 0..200 {
            let q = quat(
                (next() - 0.5) * 0.6,
                (next() - 0.5) * 0.6,
                (next() - 0.5) * 2.0 * PI as f64,
            );
            let pos = [
                ((next() - 0.5) * 2000.0) as f32,
                ((next() - 0.5) * 2000.0) as f32,
                -(20.0 + next() * 60.0) as f32,
            ];
            let st = state(q, pos, -(0.2 + next() * 1.37) as f32, 0.0);
            let pose = Pose::new(&cam, &st).unwrap();
            for _ in 0..50 {
                let uv = [(next() * W as f64) as f32, (next() * H as f64) as f32];
                let Ok(g) = pose.image_to_ground(uv) else {
                    continue;
                };
                let r = ref_ground(&cam, &st, uv).unwrap();
                let e = (g[0] as f64 - r[0]).hypot(g[1] as f64 - r[1]);
                worst = worst.max(e);
                far = far.max((g[0] - pos[0]).hypot(g[1] - pos[1]));
                let px = pose.ground_to_image(g).unwrap();
                let rp = ref_pixel(&cam, &st, [g[0] as f64, g[1] as f64]);
                worst_px = worst_px.max((px[0] as f64 - rp[0]).hypot(px[1] as f64 - rp[1]));
                n += 1;
            }
        }
    }
    println!(
        "f64 reference: {n} ground points up to {far:.1} m: max {:.3} mm; projection max {worst_px:.2e} px",
        worst * 1000.0
    );
    assert!(n > 5_000, "{n}");
    assert!(far > 99.0, "{far}");
    assert!(worst < 1e-3, "{worst} m");
    assert!(worst_px < 0.01, "{worst_px} px");
}

/// The same ground point, seen while the drone yaws through 90° (and
/// drifts): its pixel moves across the image, the ground point it maps
/// back to stays within a millimetre.
#[test]
fn a_90_degree_yaw_leaves_a_static_ground_point_in_place() {
    let cam = lens(MILD, 200.0);
    let p = [14.0f32, 9.0];
    let mut first = None;
    let mut moved = 0.0f32;
    for step in 0..=60 {
        let s = step as f64 / 60.0; // 2 s at 30 Hz
        let yaw = 0.4 + s * std::f64::consts::FRAC_PI_2;
        let st = state(
            quat(0.03 * s, -0.05, yaw),
            [10.0 + s as f32, 6.0, -25.0],
            -1.35,
            0.0,
        );
        let pose = Pose::new(&cam, &st).unwrap();
        let uv = pose.ground_to_image(p).unwrap();
        assert!(
            (0.0..W).contains(&uv[0]) && (0.0..H).contains(&uv[1]),
            "{uv:?}"
        );
        let g = pose.image_to_ground(uv).unwrap();
        assert!(
            (g[0] - p[0]).hypot(g[1] - p[1]) < 1e-3,
            "step {step}: {g:?}"
        );
        let first = *first.get_or_insert(uv);
        moved = moved.max((uv[0] - first[0]).hypot(uv[1] - first[1]));
    }
    assert!(moved > 200.0, "the pixel moved only {moved} px");
}

// ---------------------------------------------------------------- hostile inputs

fn good() -> (Camera, State) {
    (
        lens(MILD, 150.0),
        state(quat(0.0, 0.0, 0.5), [0.0, 0.0, -30.0], -0.6, 0.0),
    )
}

fn pose_err(cam: Camera, st: State) -> CameraError {
    Pose::new(&cam, &st).unwrap_err()
}

#[test]
fn a_nan_or_unnormalised_quaternion_is_refused() {
    let (cam, mut st) = good();
    st.attitude[2] = f32::NAN;
    assert_eq!(pose_err(cam, st), CameraError::NonFinite);
    st.attitude = [f32::INFINITY, 0.0, 0.0, 0.0];
    assert_eq!(pose_err(cam, st), CameraError::NonFinite);
    for q in [
        [0.0; 4],
        [1.001, 0.0, 0.0, 0.0],
        [0.999, 0.0, 0.0, 0.0],
        [0.5, 0.5, 0.5, 0.6],
    ] {
        st.attitude = q;
        assert_eq!(pose_err(cam, st), CameraError::Quaternion, "{q:?}");
    }
    // Within tolerance: accepted.
    st.attitude = [1.0004, 0.0, 0.0, 0.0];
    assert!(Pose::new(&cam, &st).is_ok());
}

#[test]
fn a_camera_looking_at_the_sky_sees_no_ground() {
    let (cam, mut st) = good();
    st.gimbal.pitch = 0.3; // above the horizon
    let pose = Pose::new(&cam, &st).unwrap();
    assert_eq!(
        pose.image_to_ground([957.3, 544.8]),
        Err(CameraError::AboveHorizon)
    );
    // Level: the principal ray is exactly on the horizon.
    st.gimbal = Euler::ZERO;
    st.attitude = [1.0, 0.0, 0.0, 0.0];
    let pose = Pose::new(&cam, &st).unwrap();
    assert_eq!(
        pose.image_to_ground([957.3, 544.8]),
        Err(CameraError::AboveHorizon)
    );
    // Just below it, but 10 km away.
    assert_eq!(
        pose.image_to_ground([957.3, 548.0]),
        Err(CameraError::BeyondRange)
    );
    // Rolled upside down, looking "down" in the body frame is up.
    let (_, mut st) = good();
    st.attitude = quat(PI as f64, 0.0, 0.0);
    st.gimbal.pitch = -FRAC_PI_2;
    let pose = Pose::new(&cam, &st).unwrap();
    assert_eq!(
        pose.image_to_ground([957.3, 544.8]),
        Err(CameraError::AboveHorizon)
    );
}

#[test]
fn zero_negative_or_non_finite_intrinsics_are_refused() {
    for (fx, fy) in [
        (0.0, 1000.0),
        (1000.0, 0.0),
        (-1000.0, 1000.0),
        (0.5, 1000.0),
    ] {
        let (mut cam, st) = good();
        cam.intrinsics.fx = fx;
        cam.intrinsics.fy = fy;
        assert_eq!(pose_err(cam, st), CameraError::FocalLength, "{fx} {fy}");
    }
    let (mut cam, st) = good();
    cam.intrinsics.cx = f32::NAN;
    assert_eq!(pose_err(cam, st), CameraError::NonFinite);
    let (mut cam, st) = good();
    cam.distortion.k2 = f32::INFINITY;
    assert_eq!(pose_err(cam, st), CameraError::NonFinite);
    let (mut cam, st) = good();
    cam.mount.yaw = f32::NAN;
    assert_eq!(pose_err(cam, st), CameraError::NonFinite);
    for r in [0.0, -5.0] {
        let (mut cam, st) = good();
        cam.max_range = r;
        assert_eq!(pose_err(cam, st), CameraError::MaxRange);
    }
}

#[test]
fn a_camera_at_or_below_the_ground_is_refused() {
    let (cam, mut st) = good();
    for (down, ground) in [(0.0, 0.0), (5.0, 0.0), (-30.0, -31.0), (-30.0, -30.0)] {
        st.position[2] = down;
        st.ground_down = ground;
        assert_eq!(
            pose_err(cam, st),
            CameraError::BelowGround,
            "{down} {ground}"
        );
    }
    st.position[2] = -30.0;
    st.ground_down = f32::NAN;
    assert_eq!(pose_err(cam, st), CameraError::NonFinite);
    st.ground_down = -29.5; // terrain 29.5 m up: the camera is 0.5 m above it
    assert!(Pose::new(&cam, &st).is_ok());
}

#[test]
fn points_behind_the_camera_or_absurd_pixels_are_refused() {
    let (cam, st) = good();
    let pose = Pose::new(&cam, &st).unwrap();
    // The camera looks north-east-ish (yaw 0.5 rad); a point south-west of it is behind.
    assert_eq!(
        pose.ground_to_image([-50.0, -30.0]),
        Err(CameraError::BehindCamera)
    );
    assert_eq!(
        pose.ground_to_image([f32::NAN, 1.0]),
        Err(CameraError::NonFinite)
    );
    assert_eq!(
        pose.image_to_ground([1.0, f32::INFINITY]),
        Err(CameraError::NonFinite)
    );
    // Far outside the image the lens model does not invert.
    assert_eq!(
        pose.image_to_ground([1e7, 1e7]),
        Err(CameraError::Undistortion)
    );
    // Without distortion an absurd pixel overflows, or looks at the sky.
    let (mut cam, st) = good();
    cam.distortion = Distortion::NONE;
    let pose = Pose::new(&cam, &st).unwrap();
    for uv in [
        [f32::MAX, f32::MAX],
        [-f32::MAX, f32::MAX],
        [f32::MAX, -f32::MAX],
    ] {
        let e = pose.image_to_ground(uv).unwrap_err();
        assert!(
            matches!(
                e,
                CameraError::Overflow | CameraError::AboveHorizon | CameraError::BeyondRange
            ),
            "{uv:?}: {e:?}"
        );
    }
    assert!(pose.ground_to_image([f32::MAX, -f32::MAX]).is_err());
}

/// Every error has a message and the type is `Copy`.
#[test]
fn errors_are_copy_and_display() {
    let e = CameraError::AboveHorizon;
    let f = e;
    assert_eq!(e, f);
    assert_eq!(e.to_string(), "ray at or above the horizon");
}

// ---------------------------------------------------------------- detections

#[test]
fn detections_become_observations_and_refusals_are_reported() {
    let (cam, st) = good();
    let pose = Pose::new(&cam, &st).unwrap();
    let b = BoundingBox {
        x_min: 900.0,
        y_min: 500.0,
        x_max: 940.0,
        y_max: 620.0,
    };
    assert_eq!(b.foot(), [920.0, 620.0]);
    assert_eq!(b.centre(), [920.0, 560.0]);
    let dets = [
        Detection::from_box(4, &b),
        Detection {
            id: 5,
            pixel: [957.3, -350.0], // above the horizon (off the image)
        },
        Detection {
            id: 6,
            pixel: [100.0, 1000.0],
        },
        Detection {
            id: 7,
            pixel: [f32::NAN, 3.0],
        },
        Detection {
            id: 8,
            pixel: [1500.0, 900.0],
        },
    ];
    let mut out = [Observation {
        id: 0,
        pos: [0.0; 2],
    }; 2];
    let mut refused = Vec::new();
    let n = to_observations(&pose, &dets, &mut out, |i, id, e| refused.push((i, id, e)));
    assert_eq!(n, 2);
    assert_eq!(out[0].id, 4);
    assert_eq!(out[0].pos, pose.image_to_ground([920.0, 620.0]).unwrap());
    assert_eq!(out[1].id, 6);
    assert_eq!(
        refused,
        vec![
            (1, 5, CameraError::AboveHorizon),
            (3, 7, CameraError::NonFinite),
            (4, 8, CameraError::OutputFull)
        ]
    );
}

// ---------------------------------------------------------------- ROS

/// The ROS conversion equals composing the frame changes in f64: ENU → NED
/// swaps x and y and negates z; FRD → FLU negates y and z.
#[test]
fn ros_attitude_and_position_map_to_ned() {
    assert_eq!(position_from_ros([1.0, 2.0, 3.0]), [2.0, 1.0, -3.0]);
    let q_id = attitude_from_ros([1.0, 0.0, 0.0, 0.0]);
    // Facing east (ROS identity) is yaw +90° in NED.
    let fwd = qrot(q_id, [1.0, 0.0, 0.0]);
    assert!(
        (fwd[0]).abs() < 1e-6 && (fwd[1] - 1.0).abs() < 1e-6,
        "{fwd:?}"
    );
    for (r, p, y) in [(0.1, -0.2, 0.3), (-1.0, 0.4, 2.9), (0.0, 0.0, -1.2)] {
        let q_ros = quat(r, p, y); // some rotation FLU → ENU
        let q = attitude_from_ros(q_ros);
        let n2: f32 = q.iter().map(|c| c * c).sum();
        assert!((n2 - 1.0).abs() < 1e-5);
        for v_frd in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
            let ned = qrot(q, v_frd);
            let flu = [v_frd[0], -v_frd[1], -v_frd[2]];
            let enu = qrot(q_ros, flu);
            let want = [enu[1], enu[0], -enu[2]];
            for k in 0..3 {
                assert!((ned[k] - want[k]).abs() < 1e-6, "{ned:?} {want:?}");
            }
        }
    }
}

// ---------------------------------------------------------------- the arithmetic, as documented

/// The module docs' arithmetic, written out again here in f32 from the
/// docs (not the code): image → ground and ground → image give the same
/// bits as the crate.
#[test]
fn the_documented_f32_arithmetic_is_the_code_bit_for_bit() {
    type M = [[f32; 3]; 3];
    fn mm(a: &M, b: &M) -> M {
        let mut r = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                r[i][j] = (a[i][0] * b[0][j] + a[i][1] * b[1][j]) + a[i][2] * b[2][j];
            }
        }
        r
    }
    fn mv(a: &M, v: [f32; 3]) -> [f32; 3] {
        [0, 1, 2].map(|i| (a[i][0] * v[0] + a[i][1] * v[1]) + a[i][2] * v[2])
    }
    fn e(a: Euler) -> M {
        let (sf, cf) = (libm::sinf(a.roll), libm::cosf(a.roll));
        let (st, ct) = (libm::sinf(a.pitch), libm::cosf(a.pitch));
        let (sp, cp) = (libm::sinf(a.yaw), libm::cosf(a.yaw));
        [
            [ct * cp, (sf * st) * cp - cf * sp, (cf * st) * cp + sf * sp],
            [ct * sp, (sf * st) * sp + cf * cp, (cf * st) * sp - sf * cp],
            [-st, sf * ct, cf * ct],
        ]
    }
    fn d(k: Distortion, x: f32, y: f32) -> [f32; 2] {
        let a = x * y;
        let r2 = x * x + y * y;
        let rad = 1.0 + (k.k1 + k.k2 * r2) * r2;
        [
            (x * rad + (2.0 * k.p1) * a) + k.p2 * (r2 + (2.0 * x) * x),
            (y * rad + k.p1 * (r2 + (2.0 * y) * y)) + (2.0 * k.p2) * a,
        ]
    }
    fn u(k: Distortion, xd: f32, yd: f32) -> [f32; 2] {
        let (mut x, mut y) = (xd, yd);
        for _ in 0..6 {
            let [fx, fy] = d(k, x, y);
            let (ex, ey) = (fx - xd, fy - yd);
            let r2 = x * x + y * y;
            let rad = 1.0 + (k.k1 + k.k2 * r2) * r2;
            let g = k.k1 + (2.0 * k.k2) * r2;
            let jxx = ((rad + (2.0 * x) * (x * g)) + (2.0 * k.p1) * y) + (6.0 * k.p2) * x;
            let jxy = ((2.0 * x) * (y * g) + (2.0 * k.p1) * x) + (2.0 * k.p2) * y;
            let jyy = ((rad + (2.0 * y) * (y * g)) + (6.0 * k.p1) * y) + (2.0 * k.p2) * x;
            let det = jxx * jyy - jxy * jxy;
            x -= (jyy * ex - jxy * ey) / det;
            y -= (jxx * ey - jxy * ex) / det;
        }
        [x, y]
    }
    let mut checked = 0;
    for (_, cam, st) in scenes() {
        let [w, x, y, z] = st.attitude;
        let a: M = [
            [
                ((w * w + x * x) - y * y) - z * z,
                2.0 * (x * y - w * z),
                2.0 * (x * z + w * y),
            ],
            [
                2.0 * (x * y + w * z),
                ((w * w - x * x) + y * y) - z * z,
                2.0 * (y * z - w * x),
            ],
            [
                2.0 * (x * z - w * y),
                2.0 * (y * z + w * x),
                ((w * w - x * x) - y * y) + z * z,
            ],
        ];
        let g = e(st.gimbal);
        // Camera (x, y, z) = gimbal (z, x, y): G's columns reordered (1, 2, 0).
        let gp: M = [0, 1, 2].map(|i| [g[i][1], g[i][2], g[i][0]]);
        let r = mm(&a, &mm(&e(cam.mount), &gp));
        let rt: M = [0, 1, 2].map(|i| [r[0][i], r[1][i], r[2][i]]);
        let h = st.ground_down - st.position[2];
        let k = cam.intrinsics;
        let pose = Pose::new(&cam, &st).unwrap();
        for v in (0..=1080).step_by(60) {
            for uu in (0..=1920).step_by(60) {
                let px = [uu as f32, v as f32];
                let (xd, yd) = ((px[0] - k.cx) / k.fx, (px[1] - k.cy) / k.fy);
                let [xn, yn] = if cam.distortion.is_none() {
                    [xd, yd]
                } else {
                    u(cam.distortion, xd, yd)
                };
                let [dn, de, dd] = mv(&r, [xn, yn, 1.0]);
                let Ok(got) = pose.image_to_ground(px) else {
                    continue;
                };
                assert!(dd > 0.0);
                let t = h / dd;
                let want = [st.position[0] + dn * t, st.position[1] + de * t];
                assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits));
                let c = mv(&rt, [want[0] - st.position[0], want[1] - st.position[1], h]);
                let [xd, yd] = if cam.distortion.is_none() {
                    [c[0] / c[2], c[1] / c[2]]
                } else {
                    d(cam.distortion, c[0] / c[2], c[1] / c[2])
                };
                let want_px = [k.fx * xd + k.cx, k.fy * yd + k.cy];
                let got_px = pose.ground_to_image(want).unwrap();
                assert_eq!(got_px.map(f32::to_bits), want_px.map(f32::to_bits));
                checked += 1;
            }
        }
    }
    assert!(checked > 2_000, "{checked}");
}

/// The size the module docs give.
#[test]
fn a_pose_is_84_bytes() {
    assert_eq!(core::mem::size_of::<Pose>(), 84);
}

/// A box is checked before its foot point is used: non-finite edges and edges out of order
/// (corners swapped, or `(x, y, w, h)` read as corners) are typed errors, a degenerate box
/// (a point) is accepted.
#[test]
fn boxes_out_of_order_or_not_finite_are_refused() {
    use gpecnet_core::camera::{BoundingBox, Detection};
    let b = |x_min, y_min, x_max, y_max| BoundingBox {
        x_min,
        y_min,
        x_max,
        y_max,
    };
    let ok = b(940.0, 480.0, 980.0, 540.0);
    assert_eq!(ok.check(), Ok(()));
    assert_eq!(
        Detection::try_from_box(3, &ok),
        Ok(Detection::from_box(3, &ok))
    );
    assert_eq!(b(5.0, 5.0, 5.0, 5.0).check(), Ok(()));
    assert_eq!(
        b(980.0, 480.0, 940.0, 540.0).check(),
        Err(CameraError::BadBox)
    );
    assert_eq!(
        b(940.0, 540.0, 980.0, 480.0).check(),
        Err(CameraError::BadBox)
    );
    // x, y, width, height read as corners: the "right edge" 40 is left of x = 940.
    assert_eq!(
        b(940.0, 480.0, 40.0, 60.0).check(),
        Err(CameraError::BadBox)
    );
    for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert_eq!(b(v, 0.0, 1.0, 1.0).check(), Err(CameraError::NonFinite));
        assert_eq!(b(0.0, 0.0, 1.0, v).check(), Err(CameraError::NonFinite));
    }
    assert_eq!(
        Detection::try_from_box(1, &b(2.0, 0.0, 1.0, 1.0)),
        Err(CameraError::BadBox)
    );
    assert!(!CameraError::BadBox.to_string().is_empty());
}

// ---------------------------------------------------------------- measurement model

/// Reference image → ground with the camera turned by `angle` radians about
/// world axis `axis` (0 north, 1 east, 2 down) before casting the ray.
fn ref_ground_turned(cam: &Camera, st: &State, uv: [f64; 2], axis: usize, angle: f64) -> [f64; 2] {
    let k = cam.intrinsics;
    let xd = (uv[0] - k.cx as f64) / k.fx as f64;
    let yd = (uv[1] - k.cy as f64) / k.fy as f64;
    let [x, y] = undistort64(cam.distortion, xd, yd);
    let d = cam_to_ned(cam, st, [x, y, 1.0]);
    let d = match axis {
        0 => rot_x(angle, d),
        1 => rot_y(angle, d),
        _ => rot_z(angle, d),
    };
    let t = (st.ground_down as f64 - st.position[2] as f64) / d[2];
    [
        st.position[0] as f64 + t * d[0],
        st.position[1] as f64 + t * d[1],
    ]
}

/// The f64 reference covariance: central differences of the reference
/// ground point in `u`, `v` (±0.25 px) and in the three world-axis
/// rotations (±10⁻⁵ rad), then `Σ = σ_p²·J_p·J_pᵀ + σ_a²·J_a·J_aᵀ`.
fn ref_covariance(cam: &Camera, st: &State, uv: [f32; 2], sp: f64, sa: f64) -> [f64; 3] {
    let uv = [uv[0] as f64, uv[1] as f64];
    let mut c = [0.0; 3];
    let mut add = |g: [f64; 2], s: f64| {
        c[0] += s * s * g[0] * g[0];
        c[1] += s * s * g[0] * g[1];
        c[2] += s * s * g[1] * g[1];
    };
    let h = 0.25;
    for i in 0..2 {
        let (mut a, mut b) = (uv, uv);
        a[i] += h;
        b[i] -= h;
        let (ga, gb) = (
            ref_ground_turned(cam, st, a, 0, 0.0),
            ref_ground_turned(cam, st, b, 0, 0.0),
        );
        add(
            [(ga[0] - gb[0]) / (2.0 * h), (ga[1] - gb[1]) / (2.0 * h)],
            sp,
        );
    }
    let e = 1e-5;
    for axis in 0..3 {
        let ga = ref_ground_turned(cam, st, uv, axis, e);
        let gb = ref_ground_turned(cam, st, uv, axis, -e);
        add(
            [(ga[0] - gb[0]) / (2.0 * e), (ga[1] - gb[1]) / (2.0 * e)],
            sa,
        );
    }
    c
}

/// The first-order covariance against the f64 reference's numeric
/// Jacobians, over a grid of pixels of every pose: within 0.01 % (of the
/// larger variance) for a rectified lens, where the model is exact to
/// first order; with distortion the model leaves the lens's own slope out:
/// within 1 % for a calibrated gimbal camera's lens, 4 % for a strong
/// wide-angle one (`docs/camera.md`, "Measurement model").
#[test]
fn ground_covariance_matches_the_f64_reference_to_first_order() {
    let noise = MeasurementNoise {
        pixel: 2.0,
        attitude: 0.5f32.to_radians(),
    };
    for (lname, cam, st) in scenes() {
        let pose = Pose::new(&cam, &st).unwrap();
        let (mut worst, mut n) = (0.0f64, 0);
        for iu in 0..=16 {
            for iv in 0..=9 {
                let uv = [iu as f32 * W / 16.0, iv as f32 * H / 9.0];
                let Ok(c) = pose.ground_covariance(uv, &noise) else {
                    assert!(
                        pose.image_to_ground(uv).is_err(),
                        "refused only where the ray is"
                    );
                    continue;
                };
                let r = ref_covariance(&cam, &st, uv, 2.0, 0.5f64.to_radians());
                let scale = r[0].max(r[2]);
                let gap = [c.nn, c.ne, c.ee]
                    .iter()
                    .zip(r)
                    .map(|(a, b)| (*a as f64 - b).abs() / scale)
                    .fold(0.0, f64::max);
                worst = worst.max(gap);
                n += 1;
                assert!(
                    (c.sigma() as f64 - ((r[0] + r[2]) / 2.0).sqrt()).abs()
                        <= 0.2 * c.sigma() as f64
                );
            }
        }
        println!("{lname}: {n} pixels, worst relative gap {worst:.5}");
        assert!(n > 20, "{lname}: {n} pixels see the ground");
        // Measured: pinhole 1e-5, mild lens 0.7 %, strong wide-angle lens 3.3 %.
        let tol = match lname {
            "pinhole" => 1e-4,
            "mild" => 0.01,
            _ => 0.04,
        };
        assert!(worst <= tol, "{lname}: {worst}");
    }
}

#[test]
fn ground_covariance_scales_as_the_noise_and_refuses_bad_noise() {
    let (cam, st) = good();
    let pose = Pose::new(&cam, &st).unwrap();
    let uv = [900.0, 700.0];
    let px = |p: f32, a: f32| {
        pose.ground_covariance(
            uv,
            &MeasurementNoise {
                pixel: p,
                attitude: a,
            },
        )
    };
    let zero = px(0.0, 0.0).unwrap();
    assert_eq!((zero.nn, zero.ne, zero.ee), (0.0, 0.0, 0.0));
    let (one, two) = (px(1.0, 0.0).unwrap(), px(2.0, 0.0).unwrap());
    assert!((two.nn / one.nn - 4.0).abs() < 1e-5 && (two.ee / one.ee - 4.0).abs() < 1e-5);
    let both = px(1.0, 0.01).unwrap();
    let att = px(0.0, 0.01).unwrap();
    assert!((both.nn - (one.nn + att.nn)).abs() <= 1e-6 * both.nn);
    assert!(one.nn * one.ee >= one.ne * one.ne, "positive semi-definite");
    for (p, a) in [
        (-1.0, 0.0),
        (0.0, -0.01),
        (f32::NAN, 0.0),
        (1.0, f32::INFINITY),
    ] {
        assert_eq!(px(p, a), Err(CameraError::Noise), "{p} {a}");
    }
    // The refusals of image_to_ground come first for a valid noise.
    assert_eq!(
        pose.ground_covariance(
            [f32::NAN, 1.0],
            &MeasurementNoise {
                pixel: 1.0,
                attitude: 0.0
            }
        ),
        Err(CameraError::NonFinite)
    );
}
