//! The camera geometry through the C ABI, called exactly as C calls it:
//! every NULL pointer and every hostile input (a NaN quaternion, a camera
//! looking at the sky, a zero focal length, a camera below the ground, ...)
//! is its status code, a refused pose refuses every mapping, every box gets
//! a status, and every result equals the core's `camera` module bit for bit.
use std::ptr::{null, null_mut};

use gpecnet_core::camera::{
    to_observations, BoundingBox, Camera, CameraError, Detection, MeasurementNoise, Pose, State,
};
use gpecnet_core::tracks::Observation;
use gpecnet_ffi::*;

use crate::common::camera;

/// 30 m above the origin, level, facing north, the gimbal 45° down.
fn state() -> GpecnetCameraState {
    GpecnetCameraState {
        attitude: [1.0, 0.0, 0.0, 0.0],
        position: [0.0, 0.0, -30.0],
        gimbal: GpecnetEuler {
            roll: 0.0,
            pitch: -std::f32::consts::FRAC_PI_4,
            yaw: 0.0,
        },
        ground_down: 0.0,
    }
}

/// The C status of a core camera error, written out here (not the crate's
/// mapping) so that a wrong mapping fails.
fn code(e: CameraError) -> i32 {
    match e {
        CameraError::NonFinite => 100,
        CameraError::FocalLength => 101,
        CameraError::MaxRange => 102,
        CameraError::Quaternion => 103,
        CameraError::BelowGround => 104,
        CameraError::AboveHorizon => 105,
        CameraError::BeyondRange => 106,
        CameraError::BehindCamera => 107,
        CameraError::Undistortion => 108,
        CameraError::Overflow => 109,
        CameraError::OutputFull => 110,
        CameraError::BadBox => 111,
        CameraError::Noise => 112,
        _ => unreachable!("a new CameraError variant: give it a code"),
    }
}

/// `gpecnet_camera_pose` as C calls it: (status, the pose written).
fn pose(c: &GpecnetCamera, s: &GpecnetCameraState) -> (i32, GpecnetPose) {
    let mut out = GpecnetPose {
        tag: 0xdead_beef,
        opaque: [0x7fc0_0000; GPECNET_POSE_WORDS],
    };
    // SAFETY: test: valid structs.
    let st = unsafe { gpecnet_camera_pose(c, s, &mut out) };
    (st, out)
}

fn image_to_ground(p: &GpecnetPose, uv: [f32; 2]) -> Result<[f32; 2], i32> {
    let mut ne = [f32::NAN; 2];
    // SAFETY: test: a pose, room for 2 floats.
    match unsafe { gpecnet_image_to_ground(p, uv[0], uv[1], ne.as_mut_ptr()) } {
        GPECNET_OK => Ok(ne),
        e => {
            assert!(ne[0].is_nan() && ne[1].is_nan(), "written on failure");
            Err(e)
        }
    }
}

fn ground_to_image(p: &GpecnetPose, ne: [f32; 2]) -> Result<[f32; 2], i32> {
    let mut uv = [f32::NAN; 2];
    // SAFETY: test: a pose, room for 2 floats.
    match unsafe { gpecnet_ground_to_image(p, ne[0], ne[1], uv.as_mut_ptr()) } {
        GPECNET_OK => Ok(uv),
        e => {
            assert!(uv[0].is_nan() && uv[1].is_nan(), "written on failure");
            Err(e)
        }
    }
}

/// `gpecnet_boxes_to_detections` as C calls it: (status, the detections
/// written, one status per box).
fn boxes_to_detections(
    p: &GpecnetPose,
    boxes: &[GpecnetBox],
    cap: usize,
) -> (i32, Vec<GpecnetDetection>, Vec<i32>) {
    let mut out = vec![
        GpecnetDetection {
            id: u32::MAX,
            x: f32::NAN,
            y: f32::NAN
        };
        cap
    ];
    let mut statuses = vec![-1; boxes.len()];
    let mut n = usize::MAX;
    // SAFETY: test: a pose, `boxes.len()` boxes and codes, room for `cap` detections.
    let st = unsafe {
        gpecnet_boxes_to_detections(
            p,
            boxes.as_ptr(),
            boxes.len(),
            out.as_mut_ptr(),
            cap,
            statuses.as_mut_ptr(),
            &mut n,
        )
    };
    assert!(n <= cap, "{n} > {cap}");
    assert!(
        out[n..].iter().all(|d| d.id == u32::MAX),
        "written past *n_out"
    );
    out.truncate(n);
    (st, out, statuses)
}

fn bits(v: [f32; 2]) -> [u32; 2] {
    v.map(f32::to_bits)
}

/// The tests below compare the C functions with the core through the crate's
/// conversions of the C structs: those put every field in its place (a value
/// distinct per field comes out where the core reads it).
#[test]
fn conversions_keep_every_field_in_place() {
    let c = GpecnetCamera {
        fy: 1101.0,
        cy: 541.0,
        p1: 0.001,
        p2: 0.002,
        mount: GpecnetEuler {
            roll: 0.01,
            pitch: 0.02,
            yaw: 0.04,
        },
        ..camera()
    };
    let k = Camera::from(c);
    let (i, d, m) = (k.intrinsics, k.distortion, k.mount);
    assert_eq!(
        [i.fx, i.fy, i.cx, i.cy, d.k1, d.k2, d.p1, d.p2],
        [c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.p1, c.p2]
    );
    let cm = c.mount;
    assert_eq!(
        [m.roll, m.pitch, m.yaw, k.max_range],
        [cm.roll, cm.pitch, cm.yaw, c.max_range]
    );
    let s = GpecnetCameraState {
        attitude: [0.5, 0.5, -0.5, 0.5],
        position: [1.0, 2.0, -3.0],
        gimbal: GpecnetEuler {
            roll: 0.1,
            pitch: 0.2,
            yaw: 0.3,
        },
        ground_down: 4.0,
    };
    let (t, g) = (State::from(s), s.gimbal);
    assert_eq!(
        (t.attitude, t.position, t.ground_down),
        (s.attitude, s.position, s.ground_down)
    );
    assert_eq!(
        [t.gimbal.roll, t.gimbal.pitch, t.gimbal.yaw],
        [g.roll, g.pitch, g.yaw]
    );
}

#[test]
fn null_pointers_are_refused() {
    let (c, s) = (camera(), state());
    let mut out = pose(&c, &s).1;
    // SAFETY (every call below): test: NULL or valid pointers.
    unsafe {
        assert_eq!(
            gpecnet_camera_pose(null(), &s, &mut out),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(out.tag, 0, "a refused pose still holds one");
        assert_eq!(
            gpecnet_camera_pose(&c, null(), &mut out),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_camera_pose(&c, &s, null_mut()),
            GPECNET_E_NULL_POINTER
        );
    }
    let p = pose(&c, &s).1;
    let mut xy = [0.0f32; 2];
    // SAFETY (every call below): test: NULL or valid pointers.
    unsafe {
        assert_eq!(
            gpecnet_image_to_ground(null(), 960.0, 900.0, xy.as_mut_ptr()),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_image_to_ground(&p, 960.0, 900.0, null_mut()),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_ground_to_image(null(), 30.0, 0.0, xy.as_mut_ptr()),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_ground_to_image(&p, 30.0, 0.0, null_mut()),
            GPECNET_E_NULL_POINTER
        );
    }
    let b = [GpecnetBox {
        id: 1,
        x_min: 940.0,
        y_min: 480.0,
        x_max: 980.0,
        y_max: 540.0,
    }];
    let mut d = [GpecnetDetection {
        id: 0,
        x: 0.0,
        y: 0.0,
    }];
    let mut st = [0i32];
    let mut n: usize;
    let (bp, dp, sp) = (b.as_ptr(), d.as_mut_ptr(), st.as_mut_ptr());
    // SAFETY (every call below): test: NULL or valid pointers for the lengths given.
    unsafe {
        assert_eq!(
            gpecnet_boxes_to_detections(&p, bp, 1, dp, 1, sp, null_mut()),
            GPECNET_E_NULL_POINTER
        );
        for (pp, bp, dp, sp) in [
            (null(), bp, dp, sp),
            (&p as *const GpecnetPose, null(), dp, sp),
            (&p, bp, null_mut(), sp),
            (&p, bp, dp, null_mut()),
        ] {
            n = 7;
            assert_eq!(
                gpecnet_boxes_to_detections(pp, bp, 1, dp, 1, sp, &mut n),
                GPECNET_E_NULL_POINTER
            );
            assert_eq!(n, 0);
        }
        // No boxes and no room: NULL arrays are fine.
        n = 7;
        assert_eq!(
            gpecnet_boxes_to_detections(&p, null(), 0, null_mut(), 0, null_mut(), &mut n),
            GPECNET_OK
        );
        assert_eq!(n, 0);
    }
    assert_eq!(st, [0], "a status written on an argument error");
}

#[test]
fn a_refused_or_zeroed_pose_maps_nothing() {
    let zeroed = GpecnetPose {
        tag: 0,
        opaque: [0; GPECNET_POSE_WORDS],
    };
    let mut s = state();
    s.attitude = [f32::NAN, 0.0, 0.0, 0.0];
    let (st, refused) = pose(&camera(), &s);
    assert_eq!(st, GPECNET_E_CAMERA_NON_FINITE);
    for p in [zeroed, refused] {
        assert_eq!(
            image_to_ground(&p, [960.0, 900.0]),
            Err(GPECNET_E_NOT_INITIALISED)
        );
        assert_eq!(
            ground_to_image(&p, [30.0, 0.0]),
            Err(GPECNET_E_NOT_INITIALISED)
        );
        let b = GpecnetBox {
            id: 3,
            x_min: 900.0,
            y_min: 800.0,
            x_max: 920.0,
            y_max: 900.0,
        };
        let (st, d, statuses) = boxes_to_detections(&p, &[b], 4);
        assert_eq!(
            (st, d.len(), statuses),
            (GPECNET_E_NOT_INITIALISED, 0, vec![-1])
        );
    }
}

/// The hostile inputs: each its typed status, the core's.
#[test]
fn hostile_inputs_give_their_status() {
    let c = camera();
    let s = state();
    let expect = |c: &GpecnetCamera, s: &GpecnetCameraState, want: i32| {
        let (st, p) = pose(c, s);
        assert_eq!(st, want, "{c:?} {s:?}");
        assert_eq!(p.tag, 0);
        let core = Pose::new(&Camera::from(*c), &State::from(*s)).unwrap_err();
        assert_eq!(code(core), want);
    };
    // A NaN quaternion (any component), or an infinite one.
    for i in 0..4 {
        let mut q = s;
        q.attitude[i] = f32::NAN;
        expect(&c, &q, GPECNET_E_CAMERA_NON_FINITE);
        q.attitude[i] = f32::INFINITY;
        expect(&c, &q, GPECNET_E_CAMERA_NON_FINITE);
    }
    // An all-zero or an unnormalised quaternion.
    let mut q = s;
    q.attitude = [0.0; 4];
    expect(&c, &q, GPECNET_E_CAMERA_QUATERNION);
    q.attitude = [1.1, 0.0, 0.0, 0.0];
    expect(&c, &q, GPECNET_E_CAMERA_QUATERNION);
    // Other non-finite inputs.
    let mut q = s;
    q.position[2] = f32::NEG_INFINITY;
    expect(&c, &q, GPECNET_E_CAMERA_NON_FINITE);
    let mut q = s;
    q.gimbal.yaw = f32::NAN;
    expect(&c, &q, GPECNET_E_CAMERA_NON_FINITE);
    let mut q = s;
    q.ground_down = f32::NAN;
    expect(&c, &q, GPECNET_E_CAMERA_NON_FINITE);
    let mut k = c;
    k.k1 = f32::NAN;
    expect(&k, &s, GPECNET_E_CAMERA_NON_FINITE);
    // A zero, negative, sub-pixel or NaN focal length.
    for (fx, fy, want) in [
        (0.0, 1100.0, GPECNET_E_CAMERA_FOCAL_LENGTH),
        (1100.0, 0.0, GPECNET_E_CAMERA_FOCAL_LENGTH),
        (-1100.0, 1100.0, GPECNET_E_CAMERA_FOCAL_LENGTH),
        (0.5, 0.5, GPECNET_E_CAMERA_FOCAL_LENGTH),
        (f32::NAN, 1100.0, GPECNET_E_CAMERA_NON_FINITE),
    ] {
        let mut k = c;
        (k.fx, k.fy) = (fx, fy);
        expect(&k, &s, want);
    }
    // No range.
    let mut k = c;
    k.max_range = 0.0;
    expect(&k, &s, GPECNET_E_CAMERA_MAX_RANGE);
    // The camera at, or below, the ground plane (and with terrain above it).
    for (down, ground) in [(0.0, 0.0), (5.0, 0.0), (-30.0, -30.0), (-30.0, -40.0)] {
        let mut q = s;
        (q.position[2], q.ground_down) = (down, ground);
        expect(&c, &q, GPECNET_E_CAMERA_BELOW_GROUND);
    }

    // A camera looking at the sky: a valid pose that sees no ground.
    let mut sky = s;
    sky.gimbal.pitch = 0.5;
    let (st, p) = pose(&c, &sky);
    assert_eq!(st, GPECNET_OK);
    let core = Pose::new(&Camera::from(c), &State::from(sky)).unwrap();
    for uv in [[960.0, 540.0], [0.0, 1079.0], [1919.0, 1079.0]] {
        assert_eq!(image_to_ground(&p, uv), Err(GPECNET_E_CAMERA_ABOVE_HORIZON));
        assert_eq!(core.image_to_ground(uv), Err(CameraError::AboveHorizon));
    }
    let b = GpecnetBox {
        id: 9,
        x_min: 900.0,
        y_min: 900.0,
        x_max: 940.0,
        y_max: 1000.0,
    };
    let (st, d, statuses) = boxes_to_detections(&p, &[b, b], 4);
    assert_eq!(st, GPECNET_OK, "refused boxes are not a failed call");
    assert!(d.is_empty());
    assert_eq!(statuses, [GPECNET_E_CAMERA_ABOVE_HORIZON; 2]);

    // Upside down: the same.
    let mut flipped = s;
    flipped.attitude = [0.0, 1.0, 0.0, 0.0];
    let p = pose(&c, &flipped).1;
    assert_eq!(
        image_to_ground(&p, [960.0, 900.0]),
        Err(GPECNET_E_CAMERA_ABOVE_HORIZON)
    );

    // Near the horizon: beyond range. Behind the camera. NaN pixels and
    // points. A pixel far outside the lens's field.
    let p = pose(&c, &s).1;
    assert_eq!(
        image_to_ground(&p, [960.0, -300.0]),
        Err(GPECNET_E_CAMERA_BEYOND_RANGE)
    );
    assert_eq!(
        ground_to_image(&p, [-40.0, 0.0]),
        Err(GPECNET_E_CAMERA_BEHIND_CAMERA)
    );
    assert_eq!(
        image_to_ground(&p, [f32::NAN, 900.0]),
        Err(GPECNET_E_CAMERA_NON_FINITE)
    );
    assert_eq!(
        ground_to_image(&p, [30.0, f32::INFINITY]),
        Err(GPECNET_E_CAMERA_NON_FINITE)
    );
    assert_eq!(
        image_to_ground(&p, [960.0, 1.0e5]),
        Err(GPECNET_E_CAMERA_UNDISTORTION)
    );
}

#[test]
fn every_camera_error_has_its_code_and_text() {
    use std::ffi::CStr;
    let all = [
        CameraError::NonFinite,
        CameraError::FocalLength,
        CameraError::MaxRange,
        CameraError::Quaternion,
        CameraError::BelowGround,
        CameraError::AboveHorizon,
        CameraError::BeyondRange,
        CameraError::BehindCamera,
        CameraError::Undistortion,
        CameraError::Overflow,
        CameraError::OutputFull,
        CameraError::BadBox,
        CameraError::Noise,
    ];
    let mut texts = std::collections::BTreeSet::new();
    for e in all {
        assert_eq!(camera_status(e), code(e), "{e:?}");
        // SAFETY: gpecnet_status_str returns a static NUL-terminated string.
        let text = unsafe { CStr::from_ptr(gpecnet_status_str(code(e))) }
            .to_str()
            .unwrap();
        assert_ne!(text, "unknown status code", "{e:?}");
        assert!(texts.insert(text), "{e:?}: {text} twice");
    }
    assert_eq!(GPECNET_E_CAMERA_NON_FINITE, 100);
    assert_eq!(GPECNET_E_CAMERA_OUTPUT_FULL, 110);
    assert_eq!(GPECNET_E_CAMERA_BAD_BOX, 111);
}

/// Poses of every kind: altitudes, lenses, rolled, pitched and yawed bodies,
/// mounts and gimbals, far from the origin, terrain above it.
fn poses() -> Vec<(GpecnetCamera, GpecnetCameraState)> {
    let mut out = Vec::new();
    for (i, (k1, k2, p1, p2)) in [
        (0.0, 0.0, 0.0, 0.0),
        (-0.12, 0.03, 0.0, 0.0),
        (-0.3, 0.08, 0.001, -0.0005),
    ]
    .into_iter()
    .enumerate()
    {
        for j in 0..6 {
            let (a, b) = (i as f32, j as f32);
            let c = GpecnetCamera {
                k1,
                k2,
                p1,
                p2,
                mount: GpecnetEuler {
                    roll: 0.0,
                    pitch: -0.1 * b / 5.0,
                    yaw: 0.05 * a,
                },
                ..camera()
            };
            // A rotation about an oblique axis, normalised in f64.
            let (ax, ay, az) = (0.1 + 0.05 * b as f64, -0.07 * a as f64, 1.0);
            let half = 0.4 * j as f64 - 1.0;
            let len = (ax * ax + ay * ay + az * az).sqrt();
            let sh = half.sin() / len;
            let s = GpecnetCameraState {
                attitude: [
                    half.cos() as f32,
                    (sh * ax) as f32,
                    (sh * ay) as f32,
                    (sh * az) as f32,
                ],
                position: [120.0 * a - 400.0 * b, -35.0 * b + 800.0, -12.0 - 10.0 * b],
                gimbal: GpecnetEuler {
                    roll: 0.02 * a,
                    pitch: -0.5 - 0.2 * b,
                    yaw: 0.1 * b - 0.2,
                },
                ground_down: if j == 3 { -5.0 } else { 0.0 },
            };
            out.push((c, s));
        }
    }
    out
}

#[test]
fn c_results_equal_the_cores_bit_for_bit() {
    let (mut mapped, mut refused, mut back) = (0, 0, 0);
    let mut kinds = std::collections::BTreeSet::new();
    for (c, s) in poses() {
        let (st, p) = pose(&c, &s);
        assert_eq!(st, GPECNET_OK, "{c:?} {s:?}");
        let core = Pose::new(&Camera::from(c), &State::from(s)).unwrap();
        for v in (-40..=1120).step_by(29) {
            for u in (-40..=1960).step_by(37) {
                let uv = [u as f32 + 0.25, v as f32 + 0.5];
                let got = image_to_ground(&p, uv);
                match core.image_to_ground(uv) {
                    Ok(ne) => {
                        assert_eq!(got.map(bits), Ok(bits(ne)), "{uv:?}");
                        mapped += 1;
                        let want = core.ground_to_image(ne).map_err(code).map(bits);
                        assert_eq!(ground_to_image(&p, ne).map(bits), want);
                        back += 1;
                    }
                    Err(e) => {
                        assert_eq!(got, Err(code(e)), "{uv:?}");
                        kinds.insert(code(e));
                        refused += 1;
                    }
                }
            }
        }
        // Ground points all around the camera, behind it included.
        for k in 0..64 {
            let a = k as f32 * 0.1;
            let ne = [
                s.position[0] + (5.0 + 2.0 * k as f32) * a.cos(),
                s.position[1] + (5.0 + 2.0 * k as f32) * a.sin(),
            ];
            let want = core.ground_to_image(ne).map_err(code).map(bits);
            assert_eq!(ground_to_image(&p, ne).map(bits), want);
        }
    }
    println!(
        "{mapped} pixels mapped, {refused} refused ({kinds:?}), {back} mapped back, bit for bit"
    );
    assert!(mapped > 20_000 && refused > 500, "{mapped} {refused}");
    assert!(
        kinds.contains(&GPECNET_E_CAMERA_ABOVE_HORIZON)
            && kinds.contains(&GPECNET_E_CAMERA_BEYOND_RANGE),
        "{kinds:?}"
    );
}

/// A frame of boxes: seen ones, one above the horizon, NaN, beyond range,
/// one far outside the lens, in this order.
fn frame_boxes() -> Vec<GpecnetBox> {
    let at = |id: u32, u: f32, v: f32| GpecnetBox {
        id,
        x_min: u - 15.0,
        y_min: v - 70.0,
        x_max: u + 15.0,
        y_max: v,
    };
    let mut b = vec![
        at(1, 960.0, 900.0),
        at(2, 100.5, 1000.25),
        at(3, 1800.0, 300.0),
        at(4, 960.0, -900.0),
        at(5, f32::NAN, 700.0),
        at(6, 960.0, -300.0),
        at(7, 700.0, 650.0),
        at(8, 960.0, 1.0e5),
        at(9, 1500.0, 1070.0),
        at(10, 500.0, 600.0),
    ];
    b[4].x_min = f32::NAN;
    // Corners swapped (a box given right-to-left): refused, not a foot point off the person.
    (b[9].x_min, b[9].x_max) = (b[9].x_max, b[9].x_min);
    b
}

#[test]
fn boxes_become_the_cores_observations_with_a_status_each() {
    let (c, s) = (camera(), state());
    let p = pose(&c, &s).1;
    let core = Pose::new(&Camera::from(c), &State::from(s)).unwrap();
    let boxes = frame_boxes();
    // The core's checked boxes; a box it refuses keeps its refusal's code.
    let mut want_status = vec![GPECNET_OK; boxes.len()];
    let mut kept = Vec::new();
    let mut dets: Vec<Detection> = Vec::new();
    for (i, b) in boxes.iter().enumerate() {
        let bb = BoundingBox {
            x_min: b.x_min,
            y_min: b.y_min,
            x_max: b.x_max,
            y_max: b.y_max,
        };
        match Detection::try_from_box(b.id, &bb) {
            Ok(d) => {
                dets.push(d);
                kept.push(i);
            }
            Err(e) => want_status[i] = code(e),
        }
    }
    let mut obs = [Observation {
        id: 0,
        pos: [0.0; 2],
    }; 16];
    let n = to_observations(&core, &dets, &mut obs, |i, _, e| {
        want_status[kept[i]] = code(e)
    });

    let (st, got, statuses) = boxes_to_detections(&p, &boxes, 16);
    assert_eq!(st, GPECNET_OK);
    assert_eq!(statuses, want_status);
    assert_eq!(got.len(), n);
    for (g, o) in got.iter().zip(&obs[..n]) {
        assert_eq!(
            (g.id, g.x.to_bits(), g.y.to_bits()),
            (o.id, o.pos[0].to_bits(), o.pos[1].to_bits())
        );
    }
    // Which boxes failed, and why.
    assert_eq!(
        statuses,
        [
            GPECNET_OK,
            GPECNET_OK,
            GPECNET_OK,
            GPECNET_E_CAMERA_ABOVE_HORIZON,
            GPECNET_E_CAMERA_NON_FINITE,
            GPECNET_E_CAMERA_BEYOND_RANGE,
            GPECNET_OK,
            GPECNET_E_CAMERA_UNDISTORTION,
            GPECNET_OK,
            GPECNET_E_CAMERA_BAD_BOX,
        ]
    );
    assert_eq!(
        got.iter().map(|d| d.id).collect::<Vec<_>>(),
        [1, 2, 3, 7, 9]
    );
}

#[test]
fn a_full_output_is_a_status_per_box_and_for_the_call() {
    let p = pose(&camera(), &state()).1;
    let boxes = frame_boxes();
    let (_, all, all_statuses) = boxes_to_detections(&p, &boxes, 16);
    for cap in 0..all.len() {
        let (st, got, statuses) = boxes_to_detections(&p, &boxes, cap);
        assert_eq!(st, GPECNET_E_CAMERA_OUTPUT_FULL, "cap {cap}");
        assert_eq!(got, all[..cap]);
        // The boxes that mapped beyond the first `cap` are refused as full;
        // the others keep their own status.
        let mut seen = 0;
        for (s, a) in statuses.iter().zip(&all_statuses) {
            if *a == GPECNET_OK {
                let want = if seen < cap {
                    GPECNET_OK
                } else {
                    GPECNET_E_CAMERA_OUTPUT_FULL
                };
                assert_eq!(*s, want);
                seen += 1;
            } else {
                assert_eq!(s, a);
            }
        }
    }
    let (st, got, _) = boxes_to_detections(&p, &boxes, all.len());
    assert_eq!((st, got), (GPECNET_OK, all));
}

/// A pose copied byte for byte to an odd address (as C may pack it), and
/// output arrays at odd addresses, give the same bits.
#[test]
fn a_copied_pose_and_unaligned_buffers_give_the_same_bits() {
    assert_eq!(
        std::mem::size_of::<GpecnetPose>(),
        4 + 4 * GPECNET_POSE_WORDS
    );
    let p = pose(&camera(), &state()).1;
    let size = std::mem::size_of::<GpecnetPose>();
    let mut bytes = vec![0u8; size + 1];
    // SAFETY: test: `size` readable bytes of the pose, `size + 1` writable.
    unsafe {
        std::ptr::copy_nonoverlapping(
            (&p as *const GpecnetPose).cast::<u8>(),
            bytes.as_mut_ptr().add(1),
            size,
        )
    };
    // SAFETY: test: the functions read the pose unaligned.
    let odd = unsafe { bytes.as_ptr().add(1) }.cast::<GpecnetPose>();
    let mut buf = [0u8; 9];
    // SAFETY: test: an unaligned pose and 8 writable bytes at an odd address.
    let st = unsafe { gpecnet_image_to_ground(odd, 700.0, 650.0, buf.as_mut_ptr().add(1).cast()) };
    assert_eq!(st, GPECNET_OK);
    let ne = [
        f32::from_ne_bytes(buf[1..5].try_into().unwrap()),
        f32::from_ne_bytes(buf[5..9].try_into().unwrap()),
    ];
    assert_eq!(bits(ne), bits(image_to_ground(&p, [700.0, 650.0]).unwrap()));
    // SAFETY: as above.
    let st = unsafe { gpecnet_ground_to_image(odd, ne[0], ne[1], buf.as_mut_ptr().add(1).cast()) };
    assert_eq!(st, GPECNET_OK);
    let uv = [
        f32::from_ne_bytes(buf[1..5].try_into().unwrap()),
        f32::from_ne_bytes(buf[5..9].try_into().unwrap()),
    ];
    assert_eq!(bits(uv), bits(ground_to_image(&p, ne).unwrap()));
    assert!((uv[0] - 700.0).abs() < 0.01 && (uv[1] - 650.0).abs() < 0.01);

    let boxes = frame_boxes();
    let (_, want, want_statuses) = boxes_to_detections(&p, &boxes, 16);
    let det = std::mem::size_of::<GpecnetDetection>();
    let mut out = vec![0u8; 16 * det + 1];
    let mut st_bytes = vec![0u8; 4 * boxes.len() + 1];
    let mut in_bytes = vec![0u8; std::mem::size_of_val(&boxes[..]) + 1];
    let mut n = 0usize;
    // SAFETY: test: every buffer at an odd address with room for what it holds.
    let st = unsafe {
        std::ptr::copy_nonoverlapping(
            boxes.as_ptr().cast::<u8>(),
            in_bytes.as_mut_ptr().add(1),
            in_bytes.len() - 1,
        );
        gpecnet_boxes_to_detections(
            odd,
            in_bytes.as_ptr().add(1).cast(),
            boxes.len(),
            out.as_mut_ptr().add(1).cast(),
            16,
            st_bytes.as_mut_ptr().add(1).cast(),
            &mut n,
        )
    };
    assert_eq!((st, n), (GPECNET_OK, want.len()));
    for (i, w) in want.iter().enumerate() {
        let o = &out[1 + i * det..1 + (i + 1) * det];
        let word = |k: usize| u32::from_ne_bytes(o[4 * k..4 * k + 4].try_into().unwrap());
        assert_eq!(
            [word(0), word(1), word(2)],
            [w.id, w.x.to_bits(), w.y.to_bits()]
        );
    }
    for (i, w) in want_statuses.iter().enumerate() {
        let s = i32::from_ne_bytes(st_bytes[1 + 4 * i..5 + 4 * i].try_into().unwrap());
        assert_eq!(s, *w);
    }
}

/// The ROS conversions are the core's, in place too; NULL is refused.
#[test]
fn ros_conversions_are_the_cores() {
    use gpecnet_core::camera::{attitude_from_ros, position_from_ros};
    let q = [0.9f32, 0.1, -0.3, 0.2969];
    let mut out = [f32::NAN; 4];
    // SAFETY: test: 4 readable and 4 writable floats.
    assert_eq!(
        unsafe { gpecnet_attitude_from_ros(q.as_ptr(), out.as_mut_ptr()) },
        GPECNET_OK
    );
    assert_eq!(
        out.map(f32::to_bits),
        attitude_from_ros(q).map(f32::to_bits)
    );
    let mut inplace = q;
    // SAFETY: test: the same 4 floats in and out.
    let st = unsafe { gpecnet_attitude_from_ros(inplace.as_ptr(), inplace.as_mut_ptr()) };
    assert_eq!((st, inplace), (GPECNET_OK, out));
    let enu = [3.0f32, -4.0, 30.0];
    let mut ned = [f32::NAN; 3];
    // SAFETY: test: 3 readable and 3 writable floats.
    assert_eq!(
        unsafe { gpecnet_position_from_ros(enu.as_ptr(), ned.as_mut_ptr()) },
        GPECNET_OK
    );
    assert_eq!(ned, position_from_ros(enu));
    assert_eq!(ned, [-4.0, 3.0, -30.0]);
    // SAFETY (every call below): test: NULL or valid pointers.
    unsafe {
        assert_eq!(
            gpecnet_attitude_from_ros(null(), out.as_mut_ptr()),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_attitude_from_ros(q.as_ptr(), null_mut()),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_position_from_ros(null(), ned.as_mut_ptr()),
            GPECNET_E_NULL_POINTER
        );
        assert_eq!(
            gpecnet_position_from_ros(enu.as_ptr(), null_mut()),
            GPECNET_E_NULL_POINTER
        );
    }
}

/// The ground point's covariance through C equals the core's bit for bit
/// over the image; a bad noise, a NULL output, a refused pose and a pixel
/// above the horizon are their status codes, with nothing written.
#[test]
fn ground_covariance_through_c_equals_the_core() {
    let (st, p) = pose(&camera(), &state());
    assert_eq!(st, GPECNET_OK);
    let core = Pose::new(&Camera::from(camera()), &State::from(state())).unwrap();
    let cov = |p: &GpecnetPose, uv: [f32; 2], sp: f32, sa: f32| -> Result<[f32; 3], i32> {
        let mut out = [f32::NAN; 3];
        // SAFETY: test: a pose, room for 3 floats.
        match unsafe { gpecnet_ground_covariance(p, uv[0], uv[1], sp, sa, out.as_mut_ptr()) } {
            GPECNET_OK => Ok(out),
            e => {
                assert!(out.iter().all(|x| x.is_nan()), "written on failure");
                Err(e)
            }
        }
    };
    let mut seen = 0;
    for iu in 0..=12 {
        for iv in 0..=8 {
            let uv = [iu as f32 * 160.0, iv as f32 * 135.0];
            let noise = MeasurementNoise {
                pixel: 1.5,
                attitude: 0.008,
            };
            match core.ground_covariance(uv, &noise) {
                Ok(c) => {
                    let got = cov(&p, uv, 1.5, 0.008).unwrap();
                    assert_eq!(got.map(f32::to_bits), [c.nn, c.ne, c.ee].map(f32::to_bits));
                    seen += 1;
                }
                Err(e) => assert_eq!(cov(&p, uv, 1.5, 0.008), Err(code(e))),
            }
        }
    }
    assert!(seen > 40, "{seen} pixels see the ground");
    assert_eq!(
        cov(&p, [960.0, 900.0], -1.0, 0.0),
        Err(GPECNET_E_CAMERA_NOISE)
    );
    assert_eq!(
        cov(&p, [960.0, 900.0], 1.0, f32::NAN),
        Err(GPECNET_E_CAMERA_NOISE)
    );
    assert_eq!(
        cov(&p, [960.0, -4000.0], 1.0, 0.01),
        Err(GPECNET_E_CAMERA_ABOVE_HORIZON)
    );
    // SAFETY: test: NULL output and NULL pose are refused before any access.
    unsafe {
        assert_eq!(
            gpecnet_ground_covariance(&p, 960.0, 900.0, 1.0, 0.0, null_mut()),
            GPECNET_E_NULL_POINTER
        );
        let mut out = [0.0f32; 3];
        assert_ne!(
            gpecnet_ground_covariance(null(), 960.0, 900.0, 1.0, 0.0, out.as_mut_ptr()),
            GPECNET_OK
        );
    }
}
