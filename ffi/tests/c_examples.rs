//! The C and C++ examples (`ffi/examples/{c,cpp}`), compiled with the host's
//! `cc`/`c++` against this crate's staticlib, replay shipped golden files bit
//! for bit through the C API.
//!
//! `cargo test` builds the library (all its crate types, the staticlib
//! included) before this test; the staticlib lies next to the test binary
//! (`target/<profile>/deps/libgpecnet_ffi.a`) or one folder up.
use std::path::{Path, PathBuf};
use std::process::Command;

use gpecnet_core::units::CallerUnit;
use gpecnet_core::{LibmSine, Model, Predictor};

use crate::common::{root, weights_static};

fn staticlib() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    [deps, deps.parent().unwrap()]
        .iter()
        .map(|d| d.join("libgpecnet_ffi.a"))
        .filter(|p| p.exists())
        .max_by_key(|p| p.metadata().and_then(|m| m.modified()).ok())
        .unwrap_or_else(|| panic!("libgpecnet_ffi.a not found next to {}", exe.display()))
}

/// Compiles `src` with `compiler` and `std`, warnings as errors; returns the binary.
fn build(compiler: &str, std: &str, src: &str, name: &str) -> PathBuf {
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let r = Command::new(compiler)
        .arg(format!("-std={std}"))
        .args(["-Wall", "-Wextra", "-Werror", "-O1", "-I"])
        .arg(root().join("ffi/include"))
        .arg(root().join(src))
        .arg(staticlib())
        // What Rust's std needs from the system on Linux (see
        // `cargo rustc -- --print native-static-libs`).
        .args(["-lpthread", "-ldl", "-lm", "-o"])
        .arg(&out)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {compiler} (build-essential): {e}"));
    assert!(
        r.status.success(),
        "{compiler} {src} failed:\n{}",
        String::from_utf8_lossy(&r.stderr)
    );
    out
}

/// Compiles the C example `ffi/examples/c/<name>.c` as C11; returns the binary.
fn build_c(name: &str) -> PathBuf {
    build(
        "cc",
        "c11",
        &format!("ffi/examples/c/{name}.c"),
        &format!("{name}_c"),
    )
}

/// Runs `bin` on the shipped files `weights/<file>`: (whether it exited 0,
/// its stdout followed by its stderr).
fn run(bin: &Path, files: &[&str]) -> (bool, String) {
    let r = Command::new(bin)
        .args(files.iter().map(|f| root().join("weights").join(f)))
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&r.stdout),
        String::from_utf8_lossy(&r.stderr)
    );
    (r.status.success(), text)
}

/// The shipped metric model `weights/<name>` and its predictor, declared in
/// metres as the C examples declare it.
fn metric_predictor(name: &str) -> (Model<'static>, Predictor<'static, LibmSine, 128>) {
    let model = Model::from_blob(weights_static(name)).unwrap();
    let p = Predictor::with_units(model, CallerUnit::Metres).unwrap();
    (model, p)
}

/// Golden files replayed by both examples: the pixel MCU model (fixed point,
/// point head, test-time sampling), its f32 twin, and the metric MCU model.
const MODELS: &[&str] = &["sdd-tiny-v2-qe", "sdd-tiny-v2", "sdd-m-tiny-qe"];

fn check(bin: &Path, lang: &str) {
    for m in MODELS {
        let (ok, text) = run(bin, &[&format!("{m}.gpec"), &format!("{m}.golden")]);
        println!("{lang}: {text}");
        assert!(ok, "{lang} replay of {m} failed:\n{text}");
        assert!(
            text.contains(" 0 differ, 0 calls failed"),
            "{lang} replay of {m}: {text}"
        );
    }
    // A golden file of other weights is refused: the example's exit code means something.
    let (ok, text) = run(bin, &["sdd-tiny-v2.gpec", "sdd-tiny-v2-qe.golden"]);
    assert!(!ok, "{lang}: mismatched golden file accepted: {text}");
    // A corrupt blob: gpecnet_init's status, exit 1.
    let (ok, text) = run(bin, &["sdd-tiny-v2.json", "sdd-tiny-v2.golden"]);
    assert!(
        !ok && text.contains("bad magic"),
        "{lang}: a JSON file as blob: {text}"
    );
}

#[test]
fn c_example_replays_golden_files_bit_exact() {
    let bin = build_c("replay");
    check(&bin, "C");
}

#[test]
fn cpp_example_replays_golden_files_bit_exact() {
    let bin = build("c++", "c++17", "ffi/examples/cpp/replay.cpp", "replay_cpp");
    check(&bin, "C++");
}

/// The header alone compiles as strict C99 and as C++11 (no C11 or C++17 needed).
#[test]
fn header_compiles_as_c99_and_cpp11() {
    let tmp = Path::new(env!("CARGO_TARGET_TMPDIR"));
    let src = tmp.join("header_only.c");
    std::fs::write(
        &src,
        "#include \"gpecnet.h\"\nint main(void) { return (int)sizeof(GpecnetGoldenCase) == 0; }\n",
    )
    .unwrap();
    for (cc, std, lang) in [("cc", "c99", "c"), ("c++", "c++11", "c++")] {
        let r = Command::new(cc)
            .arg(format!("-std={std}"))
            .args([
                "-Wall",
                "-Wextra",
                "-pedantic",
                "-Werror",
                "-fsyntax-only",
                "-x",
                lang,
                "-I",
            ])
            .arg(root().join("ffi/include"))
            .arg(&src)
            .output()
            .unwrap();
        assert!(
            r.status.success(),
            "{cc} -std={std}: {}",
            String::from_utf8_lossy(&r.stderr)
        );
    }
}

/// The scene of `metric_tracker.c` (and of `core/examples/metric_tracker.rs`):
/// frame `f`'s timestamp and pedestrian `id`'s position in metres, `None` when missed.
fn camera(f: u32, id: u32) -> (u32, Option<[f32; 2]>) {
    let t_ms = f * 1000 / 30 + (f * 7919) % 9;
    if (f * 31 + id * 17).is_multiple_of(10) {
        return (t_ms, None);
    }
    let (t, k) = (t_ms as f32 / 1000.0, id as f32);
    let x = 2.0 * k + (1.1 + 0.05 * k) * t;
    let y = -3.0 + k + (0.3 - 0.1 * k) * t + 0.05 * t * t;
    (t_ms, Some([x, y]))
}

/// The scene of `metric_tracker.c` through the timed track table at `period`: every fresh
/// history as (end time, id, the observed past), in the order the C example prints them.
fn scene_histories(period: core::num::NonZeroU32) -> Vec<(u32, u32, [[f32; 2]; 8])> {
    use gpecnet_core::tracks::{Observation, TimedTrackTable};
    let mut table: TimedTrackTable<16> = TimedTrackTable::new(period, 1_000);
    let mut out = Vec::new();
    for f in 0..150 {
        let mut seen = Vec::new();
        let mut t_ms = 0;
        for id in 0..6 {
            let (t, pos) = camera(f, id);
            t_ms = t;
            if let Some(pos) = pos {
                seen.push(Observation { id, pos });
            }
        }
        table.update(t_ms, &seen);
        for tr in table.fresh() {
            out.push((tr.end_ms(), tr.id(), tr.past()));
        }
    }
    out
}

/// The C metric tracker (the signed metric model verified under the test key,
/// 30 Hz detections in metres → timed track table → the model declared in
/// metres) prints the forecasts the core computes directly, bit for bit, and
/// refuses an unsigned blob.
#[test]
fn c_metric_tracker_matches_the_core() {
    use gpecnet_core::tracks::period_ms_of;

    let bin = build_c("metric_tracker");
    let run = |blob: &str| run(&bin, &[blob, "test-signing-key.pub"]);
    let (ok, text) = run("sdd-m-tiny-qe.gpec");
    assert!(ok, "{text}");

    let (model, mut p) = metric_predictor("sdd-m-tiny-qe.gpec");
    let period = period_ms_of(&model).unwrap();
    let mut want = Vec::new();
    for (end_ms, id, past) in scene_histories(period) {
        let end = *p.predict_point(&past).unwrap().last().unwrap();
        want.push(format!(
            "t={end_ms:>5} ms id={id} [{:08x} {:08x}]",
            end[0].to_bits(),
            end[1].to_bits()
        ));
    }
    let got: Vec<String> = text
        .lines()
        .filter(|l| l.starts_with("t="))
        .map(|l| {
            let (head, bits) = (
                l.split(" endpoint").next().unwrap(),
                l.rsplit('[').next().unwrap(),
            );
            format!("{head} [{bits}")
        })
        .collect();
    assert!(want.len() > 20, "{}", want.len());
    assert_eq!(got, want);
    assert!(
        text.starts_with("signature ok: model version 1\nsdd-m-tiny-qe: unit m, period 400 ms"),
        "{text}"
    );

    // A model with endpoint probabilities: every forecast is followed by its planner line,
    // the core's `predict_forecast` bit for bit.
    let (ok, text) = run("sdd-m-lp-qe.gpec");
    assert!(ok, "{text}");
    let (_, mut p) = metric_predictor("sdd-m-lp-qe.gpec");
    let mut want = Vec::new();
    for (end_ms, id, past) in scene_histories(period) {
        let fc: gpecnet_core::planner::Forecast<20> = p.predict_forecast(&past, 0).unwrap();
        let top = fc.most_probable().unwrap();
        want.push(format!(
            "t={end_ms:>5} ms id={id} [{:08x} {:08x}] e{top}",
            fc.radii.unwrap().r90.to_bits(),
            fc.probabilities[top].to_bits()
        ));
    }
    let got: Vec<String> = text
        .lines()
        .filter_map(|l| l.strip_prefix("  planner "))
        .map(|l| {
            let head = l.split(':').next().unwrap();
            let top = l
                .split("most probable ")
                .nth(1)
                .unwrap()
                .split(' ')
                .next()
                .unwrap();
            format!("{head} [{} {top}", l.rsplit('[').next().unwrap())
        })
        .collect();
    assert!(want.len() > 20, "{}", want.len());
    assert_eq!(got, want);
    assert!(
        text.starts_with("signature ok: model version 3\nsdd-m-lp-qe"),
        "{text}"
    );

    // An unsigned blob is refused by gpecnet_init_signed.
    let (ok, text) = run("sdd-tiny-qe.gpec");
    assert!(!ok && text.contains("the blob is not signed"), "{text}");
}

/// The scene of `online_tracker.c` at frame `f` (10 Hz): a walker (id 7), a
/// pedestrian who stands until 12 s and then walks (id 3), and one who crosses
/// from 3 s to 15 s (id 11), in metres; the same f32 operations as the C code.
fn online_scene(f: u32) -> Vec<gpecnet_core::tracks::Observation> {
    use gpecnet_core::tracks::Observation;
    let t = (f * 100) as f32 / 1000.0;
    let mut obs = vec![Observation {
        id: 7,
        pos: [-4.0 + 1.3 * t, 2.0 + 0.1 * t],
    }];
    let jitter = 0.02 * ((f * 7) % 5) as f32 - 0.04;
    let walk = if t < 12.0 { 0.0 } else { 1.1 * (t - 12.0) };
    obs.push(Observation {
        id: 3,
        pos: [5.0 + jitter, -1.0 + walk],
    });
    if (30..150).contains(&f) {
        obs.push(Observation {
            id: 11,
            pos: [8.0 - 0.8 * t, 4.0],
        });
    }
    obs
}

/// Runs `online_tracker.c` on `sdd-m-lp-qe`: (exit status, stdout + stderr).
fn run_online_tracker() -> (bool, String) {
    run(&build_c("online_tracker"), &["sdd-m-lp-qe.gpec"])
}

/// The scene of `online_tracker.c` through the core's `online::Forecaster<16,
/// 2>` on `sdd-m-lp-qe` in metres: the bits the C program prints per forecast
/// (id, end time, endpoint-horizon point, its r90, the first step's r90) and
/// the forecaster at the end.
fn online_core() -> (Vec<String>, gpecnet_core::online::Forecaster<16, 2>) {
    use gpecnet_core::online::{Config, Forecaster, MotionState};

    let (model, mut p) = metric_predictor("sdd-m-lp-qe.gpec");
    let mut f: Forecaster<16, 2> = Forecaster::new(&model, Config::metres(), 1_000).unwrap();
    let mut want = Vec::new();
    let mut motions = std::collections::BTreeSet::new();
    for frame in 0..300u32 {
        let report = f.frame::<_, 128, 20>(&mut p, frame * 100, &online_scene(frame), |fc| {
            let end = fc.point[11];
            motions.insert(fc.motion);
            want.push(format!(
                "{:08x} {:08x} {:08x} {:08x} {:08x} {:08x}",
                fc.id,
                fc.end_ms,
                end[0].to_bits(),
                end[1].to_bits(),
                fc.radii[11].r90.to_bits(),
                fc.radii[0].r90.to_bits()
            ));
        });
        assert_eq!(report.failed, 0, "{report:?}");
    }
    // Three pedestrians for 30 s: a forecast per track and grid step once its
    // history is full, standing and walking among them.
    assert!(want.len() > 150, "{}", want.len());
    assert!(motions.contains(&MotionState::Standing) && motions.contains(&MotionState::Walking));
    (want, f)
}

/// The C online tracker (`online_tracker.c`: the forecaster through the C
/// ABI, 30 s at 10 Hz) prints, bit for bit, what the core's
/// `online::Forecaster<16, 2>` computes for the same scene, forecast by
/// forecast, and the same feedback counts.
#[test]
fn c_online_tracker_forecasts_match_the_core() {
    use gpecnet_core::online::MotionState;
    let (_, text) = run_online_tracker();
    let (want, f) = online_core();
    let got: Vec<String> = text
        .lines()
        .filter(|l| l.starts_with("t="))
        .map(|l| {
            l.rsplit('[')
                .next()
                .unwrap()
                .trim_end_matches(']')
                .to_owned()
        })
        .collect();
    assert_eq!(got, want, "{text}");
    let counts = MotionState::ALL.map(|s| f.calibration().feedback_count(s));
    assert!(counts.iter().sum::<u32>() > 100, "{counts:?}");
    let line = format!(
        "feedback: standing {}, slow {}, walking {}, fast {}\n",
        counts[0], counts[1], counts[2], counts[3]
    );
    assert!(text.contains(&line), "{text}");
}

/// The C online tracker ends with the calibration state the core writes (its
/// length and CRC), restores it into a second forecaster, refuses a damaged
/// copy with the CRC status, and exits 0.
#[test]
fn c_online_tracker_state_matches_the_core() {
    use gpecnet_core::online::STATE_LEN;
    let (ok, text) = run_online_tracker();
    let (_, f) = online_core();
    let mut state = [0u8; STATE_LEN];
    let len = f.calibration().state(&mut state).unwrap();
    assert_eq!(len, STATE_LEN);
    let crc = u32::from_le_bytes(state[len - 4..].try_into().unwrap());
    let tail = format!(
        "state: {len} bytes, crc {crc:08x}\n\
         restored; a damaged copy: calibration state checksum mismatch (damaged)\n",
    );
    assert!(ok && text.ends_with(&tail), "{text}");
}

/// `drone_camera.c`'s sine and cosine of `|x| ≤ π`: their Taylor series to
/// `x¹¹` and `x¹⁰`, the same f32 operations in the same order as the C code.
fn taylor_sin(x: f32) -> f32 {
    let x2 = x * x;
    x * (1.0
        - x2 / 6.0 * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0 * (1.0 - x2 / 110.0)))))
}

/// See [`taylor_sin`].
fn taylor_cos(x: f32) -> f32 {
    let x2 = x * x;
    1.0 - x2 / 2.0 * (1.0 - x2 / 12.0 * (1.0 - x2 / 30.0 * (1.0 - x2 / 56.0 * (1.0 - x2 / 90.0))))
}

/// `drone_camera.c`'s wave: `−sin(x)` for `x ≥ 0`, reduced to `[−π, π)`.
fn wave(x: f32) -> f32 {
    use std::f32::consts::{PI, TAU};
    taylor_sin(x - TAU * (x / TAU).floor() - PI)
}

/// `drone_camera.c`'s pedestrian `id` at `t` seconds, `[north, east]` metres.
fn drone_pedestrian(id: u32, t: f32) -> [f32; 2] {
    let k = id as f32;
    let speed = 1.0 + 0.1 * k;
    let turn = 0.02 * (k - 2.0);
    let heading = 0.6 + 0.15 * k + turn * t;
    [
        -4.0 + 2.0 * k + speed * t * taylor_cos(heading),
        3.0 - 1.5 * k + speed * t * taylor_sin(heading),
    ]
}

/// `drone_camera.c`'s flight stack at `t` seconds: the drone's attitude
/// quaternion (yawing 90° between 9 and 11 s, wobbling), NED position and
/// gimbal angles.
fn drone_flight(t: f32) -> gpecnet_core::camera::State {
    use gpecnet_core::camera::{Euler, State};
    let yaw = std::f32::consts::FRAC_PI_2 * ((t - 9.0) / 2.0).clamp(0.0, 1.0);
    let roll = 0.03 * wave(1.7 * t);
    let pitch = -0.05 + 0.02 * wave(2.3 * t);
    let (sr, cr) = (taylor_sin(roll / 2.0), taylor_cos(roll / 2.0));
    let (sp, cp) = (taylor_sin(pitch / 2.0), taylor_cos(pitch / 2.0));
    let (sy, cy) = (taylor_sin(yaw / 2.0), taylor_cos(yaw / 2.0));
    State {
        attitude: [
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ],
        position: [1.0 * t - 6.0, 0.8 * t, -30.0 - 0.2 * t],
        // 70° down, compensating the vehicle's pitch; no roll, no yaw.
        gimbal: Euler {
            pitch: -1.22 - pitch,
            ..Euler::ZERO
        },
        ground_down: 0.0,
    }
}

/// `drone_camera.c`'s detector noise, up to ±1 px.
fn drone_noise(seed: u32) -> f32 {
    let h = seed.wrapping_mul(0x9E37_79B9).rotate_left(13) ^ 0x5bd1_e995;
    (h >> 8) as f32 / 8_388_608.0 - 1.0
}

/// The scene of `drone_camera.c` through the core: boxes projected with
/// `Pose::ground_to_image`, mapped back by `camera::to_observations`, then
/// `online::Forecaster<16, 2>` on `sdd-m-lp-qe` in metres. Returns what the
/// C program prints, line by line: each refused box (time, id, status code)
/// and each forecast's bits (id, end time, endpoint north and east, its
/// r90 | the endpoint's pixel or the status of why it has none), then the
/// summary line; and each forecast's endpoint error with its end time.
fn drone_core() -> (Vec<String>, String, Vec<(u32, f32)>) {
    use gpecnet_core::camera::{to_observations, BoundingBox, Camera, Detection, Pose};
    use gpecnet_core::online::{Config, Forecaster};
    use gpecnet_core::tracks::Observation;
    use gpecnet_ffi::camera_status;

    // The C program's camera, through the crate's conversion of the C struct
    // (`c_camera.rs` checks that conversion field by field).
    let camera = Camera::from(crate::common::camera());
    let (model, mut p) = metric_predictor("sdd-m-lp-qe.gpec");
    let mut f: Forecaster<16, 2> = Forecaster::new(&model, Config::metres(), 1_000).unwrap();
    let (mut lines, mut errors, mut refused, mut sum) = (Vec::new(), Vec::new(), 0u32, 0.0f32);
    for frame in 0..600u32 {
        let t_ms = frame * 1000 / 30;
        let t = t_ms as f32 / 1000.0;
        let pose = Pose::new(&camera, &drone_flight(t)).unwrap();
        let at = |u: f32, v: f32| BoundingBox {
            x_min: u - 15.0,
            y_min: v - 70.0,
            x_max: u + 15.0,
            y_max: v,
        };
        let mut dets = Vec::new();
        for id in 0..5 {
            let Ok([u, v]) = pose.ground_to_image(drone_pedestrian(id, t)) else {
                continue;
            };
            let (u, v) = (
                u + drone_noise(frame * 8 + id),
                v + drone_noise(frame * 8 + id + 4),
            );
            if (0.0..1920.0).contains(&u) && (0.0..1080.0).contains(&v) {
                dets.push(Detection::from_box(id, &at(u, v)));
            }
        }
        if frame % 150 == 75 {
            let glitch = BoundingBox {
                x_min: f32::NAN,
                y_min: 500.0,
                x_max: f32::NAN,
                y_max: 560.0,
            };
            dets.push(Detection::from_box(98, &glitch));
            dets.push(Detection::from_box(99, &at(960.0, -3000.0)));
        }
        let mut obs = [Observation {
            id: 0,
            pos: [0.0; 2],
        }; 8];
        let n = to_observations(&pose, &dets, &mut obs, |_, id, e| {
            lines.push(format!(
                "t={t_ms:>5} ms box id={id} refused ({}",
                camera_status(e)
            ));
            refused += 1;
        });
        let report = f.frame::<_, 128, 20>(&mut p, t_ms, &obs[..n], |fc| {
            let end = fc.point[11];
            let at_ms = fc.end_ms + 12 * 400;
            let truth = drone_pedestrian(fc.id, at_ms as f32 / 1000.0);
            let (dn, de) = (end[0] - truth[0], end[1] - truth[1]);
            let err = (dn * dn + de * de).sqrt();
            sum += err;
            errors.push((fc.end_ms, err));
            let drawn = match pose.ground_to_image(end) {
                Ok([u, v]) => format!("{:08x} {:08x}", u.to_bits(), v.to_bits()),
                Err(e) => format!("status {}", camera_status(e)),
            };
            lines.push(format!(
                "{:08x} {:08x} {:08x} {:08x} {:08x} | {drawn}",
                fc.id,
                fc.end_ms,
                end[0].to_bits(),
                end[1].to_bits(),
                fc.radii[11].r90.to_bits()
            ));
        });
        assert_eq!(report.failed, 0, "{report:?}");
    }
    let mean = sum / errors.len().max(1) as f32;
    let summary = format!(
        "{} forecasts, mean endpoint error {mean:.3} m (4.8 s ahead) [{:08x}], {refused} boxes refused",
        errors.len(),
        mean.to_bits()
    );
    (lines, summary, errors)
}

/// The C drone example (`drone_camera.c`: boxes from a yawing, climbing
/// drone's gimballed camera through `gpecnet_camera_pose`,
/// `gpecnet_boxes_to_detections` and the online forecaster, endpoints drawn
/// back with `gpecnet_ground_to_image`) prints, bit for bit, what the core's
/// camera module and `online::Forecaster<16, 2>` compute for the same scene:
/// every refused box with its status, every forecast, the summary. The
/// drone's 90° yaw leaves no jump in the tracks: the forecasts around it are
/// no worse than the others.
#[test]
fn c_drone_camera_matches_the_core() {
    let (ok, text) = run(&build_c("drone_camera"), &["sdd-m-lp-qe.gpec"]);
    assert!(ok, "{text}");
    let got: Vec<String> = text
        .lines()
        .filter(|l| l.starts_with("t="))
        .map(|l| match l.split_once(" refused (") {
            Some(_) => l.split(':').next().unwrap().to_owned(),
            None => l.split(['[', ']']).nth(1).unwrap().to_owned(),
        })
        .collect();
    let (want, summary, errors) = drone_core();
    assert_eq!(got, want, "{text}");
    assert!(text.ends_with(&format!("{summary}\n")), "{text}\n{summary}");

    // Both kinds of glitch, four times each; forecasts all along the flight.
    let refusals = want.iter().filter(|l| l.contains("refused")).count();
    assert_eq!(refusals, 8, "{want:?}");
    assert!(want.iter().any(|l| l.ends_with("refused (100")));
    assert!(want.iter().any(|l| l.ends_with("refused (106")));
    assert!(errors.len() > 150, "{}", errors.len());
    // The yaw (9–11 s) against the rest: forecasts made from histories
    // that saw it are as good as the others.
    let mean = |e: &[f32]| e.iter().sum::<f32>() / e.len() as f32;
    let yaw_seen = |end_ms: u32| (9_000..=14_200).contains(&end_ms);
    let of = |seen: bool| -> Vec<f32> {
        errors
            .iter()
            .filter(|(end_ms, _)| yaw_seen(*end_ms) == seen)
            .map(|e| e.1)
            .collect()
    };
    let (during, other) = (of(true), of(false));
    println!(
        "mean endpoint error: {:.3} m with the yaw in the history ({} forecasts), {:.3} m without ({})",
        mean(&during),
        during.len(),
        mean(&other),
        other.len()
    );
    assert!(during.len() > 30 && mean(&during) < 1.25 * mean(&other));
}
