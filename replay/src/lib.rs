//! Golden replay, one crate for the firmware (defmt output) and the host
//! (`golden-host`, println output): the same code, the same lines, so `cargo
//! xtask qemu` can compare the two runs line by line. `no_std`, no heap.
//!
//! Lines (the host prints each [`Line`] through [`Line::print`] and the
//! totals with [`Summary`]'s `Display`; the firmware prints the same text
//! with typed defmt, `firmware/src/golden_run.rs`, because the Cortex-M0's
//! golden run has no stack left for `core::fmt`; `tests/lines.rs` pins the text):
//!
//! ```text
//! model <model> <numeric> <sine> <n>     before a model's cases: f32|int16q15, the sidecar's sine
//! golden <model> <case> <fnv32>          one per golden case, sidecar's sine, bit-compared
//! xcheck <model> <sine> <case> <fnv32>   the same inputs through the other sine paths
//!                                        (no expected values; host vs target only)
//! resample <frames> <points> <fnv32>     the timed track table on a jittery 30 Hz scene
//!                                        ([`resample_scene`]; host vs target only)
//! flight <frames> <detections> <points> <fnv32>
//!                                        the camera, the measurement model, the filter and
//!                                        the table on a simulated drone's detections
//!                                        ([`flight_scene`]; host vs target only)
//! online <model> <frame> <t_ms> <forecasts> <feedback> <fnv32>
//!                                        one per camera frame of the streamed scene through
//!                                        the online loop, after [`ONLINE_MODEL`]'s cases
//!                                        ([`online_scene`]; host vs target only)
//! ```
//!
//! `fnv32` is FNV-1a over the output bit patterns (x0, y0, x1, y1, ...).
//!
//! `Predictor<S, W>` picks its engine from the blob's numeric kind (`W`:
//! the caller's scratch width, see [`verify_all`]);
//! `S` is the sine the sidecar names for an f32 blob (plus `xcheck` lines for
//! the other compiled-in sines). A fixed-point blob's sidecar must name
//! `q15-table` (`Predictor::sine_name`); it has one numeric path, so no
//! `xcheck` lines.

#![no_std]
#![deny(missing_docs)]

use core::fmt;

use gpecnet_core::golden::{fnv1a, fnv1a_continue, GoldenCase, GoldenSet};
use gpecnet_core::online::{Calibration, Config, Forecaster, TrackForecast, STATE_LEN};
use gpecnet_core::planner::Radii;
use gpecnet_core::sine::{FastSine, LibmSine, Sine};
use gpecnet_core::tracks::{Observation, TimedTrackTable};
use gpecnet_core::{fixed, Model, NumericKind, PredictError, Predictor, Trajectory};
use heapless::Vec;

mod flight;
pub mod pack;

pub use flight::{flight_camera, flight_scene, FLIGHT_FRAMES, FLIGHT_PEDESTRIANS};

/// Maximum endpoints per golden case / prediction.
pub const MAX_K: usize = 20;
/// Most latent samples one prediction draws (test-time sampling reduces them to K):
/// 8 bytes of stack each.
pub const MAX_SAMPLES: usize = 128;

/// One model compiled into the image, read from a [`pack`], or read from disk on the host.
pub struct EmbeddedModel {
    /// The model's name (its file stem), as the lines print it.
    pub name: &'static str,
    /// The weight blob (`weights/<name>.gpec`).
    pub blob: &'static [u8],
    /// Its golden file (`weights/<name>.golden`).
    pub golden: &'static [u8],
}

/// A result line.
pub enum Line<'a> {
    /// `model <model> <numeric> <sine> <cases>`: before a model's cases.
    Model {
        /// The model's name.
        model: &'a str,
        /// `f32` or `int16q15`.
        numeric: &'static str,
        /// The golden file's sine (the numeric path the cases were made with).
        sine: &'a str,
        /// Number of golden cases.
        cases: u32,
    },
    /// `golden <model> <case> <hash>` (+ whether it matched the sidecar).
    Golden {
        /// The model's name.
        model: &'a str,
        /// Case index in the golden file.
        case: u32,
        /// FNV-1a over the output bit patterns.
        hash: u32,
        /// Every output bit equals the golden file's.
        ok: bool,
    },
    /// `xcheck <model> <sine> <case> <hash>`.
    Xcheck {
        /// The model's name.
        model: &'a str,
        /// The other sine the case ran through.
        sine: &'static str,
        /// Case index in the golden file.
        case: u32,
        /// FNV-1a over the output bit patterns.
        hash: u32,
    },
    /// `resample <frames> <points> <hash>`: [`resample_scene`]'s result.
    Resample {
        /// Camera frames fed to the table.
        frames: u32,
        /// Fresh full histories hashed.
        points: u32,
        /// FNV-1a over every fresh history's id, end time and position bits.
        hash: u32,
    },
    /// `flight <frames> <detections> <points> <hash>`: [`flight_scene`]'s result.
    Flight {
        /// Camera frames of the scene.
        frames: u32,
        /// Ground points given to the filter.
        detections: u32,
        /// Fresh full histories hashed.
        points: u32,
        /// FNV-1a over every ground point, σ, filtered position and fresh history.
        hash: u32,
    },
    /// `online <model> <frame> <t_ms> <forecasts> <feedback> <hash>`: one
    /// camera frame of [`online_scene`].
    Online {
        /// The model's name.
        model: &'a str,
        /// The frame's index in the scene.
        frame: u32,
        /// Its timestamp (milliseconds, wrapping).
        t_ms: u32,
        /// Forecasts the frame issued.
        forecasts: u32,
        /// Feedback updates it applied to the calibration.
        feedback: u32,
        /// FNV-1a over the frame's report, every forecast's outputs and the
        /// calibration's state bytes after the frame.
        hash: u32,
    },
    /// Something that prevents verification (counts as a failure).
    Error {
        /// The model's name.
        model: &'a str,
        /// What went wrong.
        what: &'static str,
    },
    /// The model is wider than the caller's scratch width `W` (counts as a failure).
    TooWide {
        /// The model's name.
        model: &'a str,
        /// Its [`Model::scratch_width`].
        needed: u32,
        /// The caller's `W`.
        capacity: u32,
    },
}

impl Line<'_> {
    /// The line as text through `print(text, error)`: `error` is `false` for
    /// the result lines `cargo xtask qemu` compares (`model`, `golden`,
    /// `xcheck`, `resample`, `flight`, `online`) and `true` for failures (printed on stderr on the host, at
    /// error level by defmt); a golden case that differs from its sidecar is
    /// followed by the error line `MISMATCH <model> case <case>`.
    pub fn print(&self, print: &mut dyn FnMut(fmt::Arguments<'_>, bool)) {
        // `firmware/src/golden_run.rs` names every variant's fields again to
        // print the same text with defmt: defmt takes typed arguments, and the
        // Cortex-M0 has no stack for the `core::fmt` of these format strings.
        match *self {
            Line::Model {
                model,
                numeric,
                sine,
                cases,
            } => print(format_args!("model {model} {numeric} {sine} {cases}"), false),
            Line::Golden {
                model,
                case,
                hash,
                ok,
            } => {
                print(format_args!("golden {model} {case} {hash:08x}"), false);
                if !ok {
                    print(format_args!("MISMATCH {model} case {case}"), true);
                }
            }
            Line::Xcheck {
                model,
                sine,
                case,
                hash,
            } => print(format_args!("xcheck {model} {sine} {case} {hash:08x}"), false),
            Line::Resample {
                frames,
                points,
                hash,
            } => print(format_args!("resample {frames} {points} {hash:08x}"), false),
            Line::Flight {
                frames,
                detections,
                points,
                hash,
            } => print(
                format_args!("flight {frames} {detections} {points} {hash:08x}"),
                false,
            ),
            Line::Online {
                model,
                frame,
                t_ms,
                forecasts,
                feedback,
                hash,
            } => print(
                format_args!("online {model} {frame} {t_ms} {forecasts} {feedback} {hash:08x}"),
                false,
            ),
            Line::Error { model, what } => print(format_args!("golden {model}: {what}"), true),
            Line::TooWide {
                model,
                needed,
                capacity,
            } => print(
                format_args!(
                    "golden {model}: model needs scratch width {needed} > SCRATCH {capacity} (firmware/src/lib.rs)"
                ),
                true,
            ),
        }
    }
}

/// Totals over all models.
#[derive(Default, Clone, Copy)]
pub struct Summary {
    /// Models seen.
    pub models: u32,
    /// Golden cases run.
    pub cases: u32,
    /// Cases whose outputs differ from the golden file.
    pub mismatches: u32,
    /// Models or cases that could not be verified.
    pub errors: u32,
    /// Cross-check lines (other sines).
    pub xchecks: u32,
}

impl Summary {
    /// Counts an error and reports it as [`Line::Error`].
    fn error<'a>(&mut self, out: &mut dyn FnMut(Line<'a>), model: &'a str, what: &'static str) {
        self.errors += 1;
        out(Line::Error { model, what });
    }
}

impl Summary {
    /// Adds another run's totals (the models of a pack verified one at a time).
    pub fn add(&mut self, other: Summary) {
        self.models += other.models;
        self.cases += other.cases;
        self.mismatches += other.mismatches;
        self.errors += other.errors;
        self.xchecks += other.xchecks;
    }

    /// At least one case ran, and every case of every model matched.
    pub fn ok(&self) -> bool {
        self.models > 0 && self.cases > 0 && self.mismatches == 0 && self.errors == 0
    }
}

/// `golden summary: models=.. cases=.. mismatches=.. errors=.. xchecks=..`,
/// the last line of a replay on both sides.
impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "golden summary: models={} cases={} mismatches={} errors={} xchecks={}",
            self.models, self.cases, self.mismatches, self.errors, self.xchecks
        )
    }
}

/// Sine paths compiled in, by [`Sine::NAME`].
pub const SINES: &[&str] = &[
    LibmSine::NAME,
    FastSine::NAME,
    #[cfg(feature = "micromath")]
    gpecnet_core::sine::MicromathSine::NAME,
];

/// Endpoints of one prediction, the point forecast (empty for models without one), and, for a
/// model with endpoint probabilities, their bits followed by the radii's (empty otherwise).
type Output = (Vec<[f32; 2], MAX_K>, Trajectory, Vec<u32, { MAX_K + 2 }>);

/// Output fingerprint + bit-equality with the sidecar, for each case, of `predict`. The hash
/// covers the endpoints, then the point forecast's points, then the probabilities and radii
/// (which the golden files do not hold: the host's replay of the same core gives the
/// reference, and the trainer's tests compare the core with the reference path).
fn check_cases(
    set: &GoldenSet<'_>,
    emit: &mut dyn FnMut(u32, Result<(u32, bool), ()>),
    predict: &mut dyn FnMut(&GoldenCase<'_>) -> Result<Output, PredictError>,
) {
    for (i, case) in set.cases().enumerate() {
        let k = case.k();
        let r = match predict(&case) {
            Ok((ends, point, planner)) => {
                let bits = |p: &[f32; 2]| [p[0].to_bits(), p[1].to_bits()];
                let hash = fnv1a(
                    ends.iter()
                        .chain(point.iter())
                        .flat_map(bits)
                        .chain(planner.iter().copied()),
                );
                let ok = ends.len() == k
                    && ends
                        .iter()
                        .enumerate()
                        .all(|(j, e)| case.endpoint_bits(j) == bits(e))
                    && point.len() == case.point_len()
                    && point
                        .iter()
                        .enumerate()
                        .all(|(t, q)| case.point_bits(t) == Some(bits(q)));
                Ok((hash, ok))
            }
            Err(_) => Err(()),
        };
        emit(i as u32, r);
    }
}

/// One prediction as the golden files record it: the model's endpoint set of `k` endpoints
/// (plain or test-time sampling, as the blob says) and, when the model has a point head,
/// its point forecast.
fn predict_case<S: Sine, const W: usize>(
    p: &mut Predictor<'_, S, W>,
    c: &GoldenCase<'_>,
) -> Result<Output, PredictError> {
    let mut ends: Vec<[f32; 2], MAX_K> = Vec::new();
    let _ = ends.resize(c.k().min(MAX_K), [0.0; 2]);
    let mut probs = [0.0f32; MAX_K];
    let probs = &mut probs[..ends.len()];
    let out = p.predict_planner::<MAX_SAMPLES>(&c.past, c.seed, &mut ends, probs)?;
    let mut planner = Vec::new();
    if out.learned {
        let r = out.radii.ok_or(PredictError::NoPointHead)?;
        for v in probs.iter().chain([&r.r50, &r.r90]) {
            planner
                .push(v.to_bits())
                .map_err(|_| PredictError::CapacityExceeded)?;
        }
    }
    Ok((ends, out.point.unwrap_or_default(), planner))
}

/// A predictor for `blob`, built out of line: the `Model` view it parses
/// (about 1.5 KiB) lives only in this function's frame, gone before the
/// cases run, so one model copy (the predictor's) is on the stack while
/// they do, which the Cortex-M0's 16 KiB of RAM needs.
#[inline(never)]
fn predictor_for<S: Sine, const W: usize>(blob: &'static [u8]) -> Option<Predictor<'static, S, W>> {
    Predictor::new(Model::from_blob(blob).ok()?).ok()
}

/// Every case of `set` through `Predictor<S>` (the engine follows the blob's kind; `S` is
/// the sine of f32 blobs). `Err` if the predictor's sine is not `sine`.
///
/// Out of line, and the predictor used where `predictor_for` put it (not moved
/// out of the `Option`): one predictor (4 KiB at `W` = 128) on the stack at a
/// time.
#[inline(never)]
fn cases_with<S: Sine, const W: usize>(
    blob: &'static [u8],
    set: &GoldenSet<'_>,
    sine: &str,
    emit: &mut dyn FnMut(u32, Result<(u32, bool), ()>),
) -> Result<(), &'static str> {
    let mut made = predictor_for::<S, W>(blob);
    let Some(p) = made.as_mut() else {
        return Err("no predictor for this blob");
    };
    if p.sine_name() != sine {
        return Err("the sidecar's sine is not this blob's numeric path");
    }
    check_cases(set, emit, &mut |c| predict_case(p, c));
    Ok(())
}

/// [`cases_with`] for the sine named `sine` (fixed-point blobs: `q15-table`).
fn cases_named<const W: usize>(
    blob: &'static [u8],
    set: &GoldenSet<'_>,
    sine: &str,
    emit: &mut dyn FnMut(u32, Result<(u32, bool), ()>),
) -> Result<(), &'static str> {
    match sine {
        n if n == LibmSine::NAME => cases_with::<LibmSine, W>(blob, set, sine, emit),
        n if n == FastSine::NAME => cases_with::<FastSine, W>(blob, set, sine, emit),
        #[cfg(feature = "micromath")]
        n if n == gpecnet_core::sine::MicromathSine::NAME => {
            cases_with::<gpecnet_core::sine::MicromathSine, W>(blob, set, sine, emit)
        }
        // A fixed-point blob runs its integer sine whatever `S` is.
        n if n == fixed::SINE_NAME => cases_with::<LibmSine, W>(blob, set, sine, emit),
        _ => Err("golden sine not compiled in (feature micromath?)"),
    }
}

/// What [`verify_all`] needs of a model besides its cases (the `Model`
/// view itself is not kept: see [`predictor_for`]).
struct Opened {
    /// The golden set.
    set: GoldenSet<'static>,
    /// [`Model::scratch_width`].
    scratch_width: usize,
    /// [`Model::numeric`].
    numeric: NumericKind,
}

impl EmbeddedModel {
    /// The blob's golden set, checked to belong to the blob, and what the
    /// replay needs of the model; `Err`: why not, as [`Line::Error`]
    /// reports it. Out of line, for the reason of [`predictor_for`].
    #[inline(never)]
    fn open(&self) -> Result<Opened, &'static str> {
        let model = Model::from_blob(self.blob).map_err(|_| "blob rejected by Model::from_blob")?;
        let set = GoldenSet::parse(self.golden)
            .map_err(|_| "golden sidecar rejected by GoldenSet::parse")?;
        if set.info().model_crc != model.crc() {
            return Err("golden sidecar belongs to another blob (model_crc)");
        }
        Ok(Opened {
            set,
            scratch_width: model.scratch_width(),
            numeric: model.numeric(),
        })
    }
}

/// [`verify_all`] over the models of the [`pack::ModelPack`] at the start of
/// `pack`, one model at a time (the same lines as one `verify_all` over the same
/// models); a pack that cannot be read is one [`Line::Error`] (model `pack`).
pub fn verify_pack<const W: usize, const ONLINE: bool>(
    pack: &'static [u8],
    xcheck: bool,
    out: &mut dyn FnMut(Line<'_>),
) -> Summary {
    let mut s = Summary::default();
    match pack::ModelPack::parse(pack) {
        Ok(models) => {
            for m in (0..models.len()).filter_map(|i| models.get(i)) {
                s.add(verify_all::<W, ONLINE>(
                    core::slice::from_ref(&m),
                    xcheck,
                    out,
                ));
            }
        }
        Err(e) => s.error(out, "pack", e.what()),
    }
    s
}

/// Verifies every model with predictors of scratch width `W` (a model
/// wider than `W` is reported as [`Line::TooWide`]); `xcheck`: also run the
/// other compiled-in sines. The firmware takes `W` = 128 (64 on the
/// Cortex-M0), the host 128. `ONLINE`: after [`ONLINE_MODEL`]'s cases, also
/// run [`online_scene`] (the Cortex-M0's golden image leaves it out and
/// plays it in an image of its own: see `firmware/src/lib.rs`).
pub fn verify_all<const W: usize, const ONLINE: bool>(
    models: &[EmbeddedModel],
    xcheck: bool,
    out: &mut dyn FnMut(Line<'_>),
) -> Summary {
    let mut s = Summary::default();
    for m in models {
        s.models += 1;
        let Opened {
            set,
            scratch_width,
            numeric,
        } = match m.open() {
            Ok(opened) => opened,
            Err(what) => {
                s.error(out, m.name, what);
                continue;
            }
        };
        if scratch_width > W {
            s.errors += 1;
            out(Line::TooWide {
                model: m.name,
                needed: scratch_width as u32,
                capacity: W as u32,
            });
            continue;
        }
        let sine = set.info().sine;
        out(Line::Model {
            model: m.name,
            numeric: match numeric {
                NumericKind::F32 => "f32",
                NumericKind::Int16Q15 => "int16q15",
            },
            sine,
            cases: set.info().n_cases,
        });
        let mut emit = |case: u32, r: Result<(u32, bool), ()>| match r {
            Ok((hash, ok)) => {
                s.cases += 1;
                s.mismatches += (!ok) as u32;
                out(Line::Golden {
                    model: m.name,
                    case,
                    hash,
                    ok,
                });
            }
            Err(()) => {
                s.error(out, m.name, "prediction failed");
            }
        };
        if let Err(what) = cases_named::<W>(m.blob, &set, sine, &mut emit) {
            s.error(out, m.name, what);
            continue;
        }
        // The other compiled-in sines of an f32 blob (a fixed-point blob has one path).
        if xcheck && numeric == NumericKind::F32 {
            for &other in SINES.iter().filter(|&&n| n != sine) {
                let mut emit = |case: u32, r: Result<(u32, bool), ()>| match r {
                    Ok((hash, _)) => {
                        s.xchecks += 1;
                        out(Line::Xcheck {
                            model: m.name,
                            sine: other,
                            case,
                            hash,
                        });
                    }
                    Err(()) => {
                        s.error(out, m.name, "prediction failed (xcheck)");
                    }
                };
                let _ = cases_named::<W>(m.blob, &set, other, &mut emit);
            }
        }
        // The streamed scene through the online loop, on its one model.
        if ONLINE && m.name == ONLINE_MODEL {
            if let Err(what) = online_scene::<W>(m.name, m.blob, out) {
                s.error(out, m.name, what);
            }
        }
    }
    s
}

/// Camera frames of [`resample_scene`].
pub const RESAMPLE_FRAMES: u32 = 400;

/// The timed track table ([`gpecnet_core::tracks::TimedTrackTable`]) on a
/// deterministic scene, its result as one [`Line::Resample`]: 12 pedestrians
/// on accelerating, curving paths (f32 polynomials of time), seen at 30 Hz
/// with 0–9 ms of jitter, 10 % of detections dropped, one detection in 50
/// non-finite, some ids repeated in a frame, a pause of 1.5 s that makes
/// tracks leave, and a clock that starts 5 s before the `u32` wrap. Every
/// update hashes each fresh full history (id, end time, the positions'
/// bits): the same bits on every target when the table's arithmetic is
/// portable, which `cargo xtask qemu` checks on each MCU class.
///
/// Out of line: its table (1.7 KiB) must not join its caller's frame, which
/// is live during the golden replay's deepest calls (the Cortex-M0 has no
/// stack to spare).
#[inline(never)]
pub fn resample_scene(out: &mut dyn FnMut(Line<'_>)) {
    const PEDESTRIANS: u32 = 12;
    let period = core::num::NonZeroU32::MIN.saturating_add(399);
    let mut table: TimedTrackTable<16> = TimedTrackTable::new(period, 1_000);
    // A 32-bit LCG (Numerical Recipes): jitter, drops, faults.
    let mut state: u32 = 0x2545_f491;
    let mut next = move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        state >> 8
    };
    let mut h = fnv1a([]);
    let mut points = 0u32;
    let start = u32::MAX - 5_000;
    for frame in 0..RESAMPLE_FRAMES {
        // 1.5 s without frames halfway through.
        let pause = if frame >= RESAMPLE_FRAMES / 2 {
            1_500
        } else {
            0
        };
        let t_ms = start
            .wrapping_add(frame * 1000 / 30 + pause)
            .wrapping_add(next() % 10);
        let t = (frame * 1000 / 30 + pause) as f32 / 1000.0;
        let mut seen: Vec<Observation, 16> = Vec::new();
        for id in 0..PEDESTRIANS {
            let r = next();
            if r % 10 == 0 {
                continue; // dropped
            }
            let k = id as f32;
            let mut pos = [
                2.0 * k + (0.8 + 0.05 * k) * t + 0.01 * k * t * t,
                -3.0 + k - 0.6 * t + 0.002 * (k + 1.0) * t * t * t,
            ];
            if r % 50 == 1 {
                pos[0] = f32::NAN;
            }
            let _ = seen.push(Observation { id, pos });
            if r % 97 == 2 {
                let _ = seen.push(Observation { id, pos }); // a duplicate
            }
        }
        table.update(t_ms, &seen);
        let (hashed, fresh) = hash_fresh(h, &table);
        h = hashed;
        points += fresh;
    }
    out(Line::Resample {
        frames: RESAMPLE_FRAMES,
        points,
        hash: h,
    });
}

/// `h` continued over every fresh full history of `table` (its id, end time
/// and the positions' bits), and how many there were.
pub(crate) fn hash_fresh<const N: usize>(h: u32, table: &TimedTrackTable<N>) -> (u32, u32) {
    let mut words = [0u32; 2 + 2 * gpecnet_core::tracks::HISTORY];
    let (mut h, mut n) = (h, 0);
    for track in table.fresh() {
        words[0] = track.id();
        words[1] = track.end_ms();
        for (w, p) in words[2..].chunks_exact_mut(2).zip(track.past().iter()) {
            w[0] = p[0].to_bits();
            w[1] = p[1].to_bits();
        }
        h = fnv1a_continue(h, words.iter().copied());
        n += 1;
    }
    (h, n)
}

/// The model [`online_scene`] runs on, after its golden cases: the metric
/// MCU model (learned probabilities and radii, a point head, 0.4 s period).
pub const ONLINE_MODEL: &str = "sdd-m-lp-qe";
/// Camera frames of [`online_scene`]: 36 s at 10 Hz.
pub const ONLINE_FRAMES: u32 = 360;
/// Tracks of [`online_scene`]'s forecaster: with its calibration, about
/// 3.8 KiB on a 32-bit target.
pub const ONLINE_TRACKS: usize = 4;
/// Forecasts per track awaiting their truth in [`online_scene`].
pub const ONLINE_PENDING: usize = 2;

/// Where pedestrian `id` of [`online_scene`] is at `t` seconds into the
/// scene (metres), or `None` while out of view: a walker on a gentle
/// curve; one standing for 12 s who then starts walking (1.2 m/s after a
/// 2 s start); one who leaves at 14 s, its id re-entering at 20 s as
/// another pedestrian far away; a slow walker from 3 s; and a fifth from
/// 24 s to 30 s, for whom the table has no room.
fn online_position(id: u32, t: f32) -> Option<[f32; 2]> {
    match id {
        1 => Some([1.0 + 1.3 * t, 2.0 + 0.15 * t - 0.004 * t * t]),
        2 => {
            let s = if t > 12.0 { t - 12.0 } else { 0.0 };
            let d = if s < 2.0 {
                0.3 * s * s
            } else {
                1.2 + 1.2 * (s - 2.0)
            };
            Some([6.0 + 0.6 * d, 4.0 + 0.8 * d])
        }
        3 if t < 1.0 => None,
        3 if t < 14.0 => Some([15.0 - 1.0 * t, 1.0 + 0.5 * t]),
        3 if t < 20.0 => None,
        3 => Some([-3.0 + 0.9 * (t - 20.0), 10.0 - 0.4 * (t - 20.0)]),
        4 if t >= 3.0 => Some([2.0 + 0.6 * (t - 3.0), 8.0 + 0.1 * (t - 3.0)]),
        5 if (24.0..30.0).contains(&t) => Some([10.0, 1.5 * (t - 24.0)]),
        _ => None,
    }
}

/// A streamed scene through the online loop
/// ([`gpecnet_core::online::Forecaster`], `ONLINE_TRACKS` tracks,
/// `ONLINE_PENDING` forecasts each, the loop on with
/// [`Config::metres`]), one [`Line::Online`] per camera frame: the
/// detections of five scripted pedestrians (`online_position`) at 10 Hz with
/// 0–12 ms of jitter and ±1.5 cm of detection noise (a 32-bit LCG), one
/// detection in 12 missed, one in 60 not finite, ids 1 and 4 swapped for
/// three frames (an id switch), one frame with a stale timestamp, and a
/// clock that starts 10 s before the `u32` wrap. Each line's hash covers
/// the frame's report, every forecast's outputs (endpoints,
/// probabilities, point head, static radii, aggregate point, per-horizon
/// radii, weights, experts) and [`Calibration::state`]'s bytes after the
/// frame: the same bits on every target when the loop's arithmetic is
/// portable, which `cargo xtask qemu` checks on each MCU class.
///
/// Out of line, with the predictor built in its own frame (as for the
/// golden cases): it runs after the model's golden cases, whose predictor
/// is gone by then. This frame holds only the predictor; the forecaster
/// and the frames' buffers are `play_scene`'s, so the construction's
/// temporaries (`predictor_for`) and the forecasts are never on the stack
/// together: the scene's peak fits the Cortex-M0's 16 KiB of RAM.
/// `Err`: why the scene could not run.
#[inline(never)]
pub fn online_scene<const W: usize>(
    model: &str,
    blob: &'static [u8],
    out: &mut dyn FnMut(Line<'_>),
) -> Result<(), &'static str> {
    let mut made = predictor_for::<LibmSine, W>(blob);
    let Some(p) = made.as_mut() else {
        return Err("online scene: no predictor for this blob");
    };
    play_scene(model, blob, p, out)
}

/// [`online_scene`]'s camera frames through a forecaster of its own on the
/// predictor `p` (built by the caller).
#[inline(never)]
fn play_scene<const W: usize>(
    model: &str,
    blob: &'static [u8],
    p: &mut Predictor<'static, LibmSine, W>,
    out: &mut dyn FnMut(Line<'_>),
) -> Result<(), &'static str> {
    // Used where `online_forecaster` put it: moved out of the `Result`, a
    // second copy (about 3.7 KiB) would share this frame.
    let mut made = online_forecaster(blob);
    let forecaster = made.as_mut().map_err(|e| *e)?;
    // A 32-bit LCG (Numerical Recipes): jitter, noise, misses, faults.
    let mut state: u32 = 0x0a11_ce55;
    let mut next = move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        state >> 8
    };
    let start = u32::MAX - 9_999;
    let mut last_ms = start;
    for frame in 0..ONLINE_FRAMES {
        let nominal = frame * 100;
        // One frame stamped 40 ms before the previous one: refused as stale.
        let t_ms = if frame == 150 {
            last_ms.wrapping_sub(40)
        } else {
            start.wrapping_add(nominal + next() % 13)
        };
        if frame != 150 {
            last_ms = t_ms;
        }
        let t = nominal as f32 / 1000.0;
        let mut seen: Vec<Observation, 8> = Vec::new();
        for id in 1..=5u32 {
            // Ids 1 and 4 swapped for three frames.
            let at = match (id, (200..203).contains(&frame)) {
                (1, true) => 4,
                (4, true) => 1,
                _ => id,
            };
            let Some(mut pos) = online_position(at, t) else {
                continue;
            };
            let r = next();
            if r % 12 == 0 {
                continue; // missed
            }
            pos[0] += ((r >> 4) % 31) as f32 * 0.001 - 0.015;
            pos[1] += ((r >> 9) % 31) as f32 * 0.001 - 0.015;
            if r % 60 == 7 {
                pos[1] = f32::NAN;
            }
            let _ = seen.push(Observation { id, pos });
        }
        let counted = scene_frame(forecaster, p, t_ms, &seen);
        out(Line::Online {
            model,
            frame,
            t_ms,
            forecasts: counted.forecasts,
            feedback: counted.feedback,
            hash: counted.hash,
        });
    }
    Ok(())
}

/// What one camera frame of [`online_scene`] counts, for its [`Line::Online`].
struct FrameCounts {
    /// Forecasts the frame issued.
    forecasts: u32,
    /// Feedback updates it applied to the calibration.
    feedback: u32,
    /// FNV-1a over the frame's report, every forecast and the calibration's
    /// state after the frame.
    hash: u32,
}

/// One camera frame of [`online_scene`] through `forecaster`: the frame's
/// forecasts and feedback, and the hash over its report, every forecast and
/// the calibration's state after it. Out of line, so the forecast's buffers
/// are on the stack only while it runs, not beside the caller's
/// forecaster.
#[inline(never)]
fn scene_frame<const W: usize>(
    forecaster: &mut Forecaster<ONLINE_TRACKS, ONLINE_PENDING>,
    p: &mut Predictor<'static, LibmSine, W>,
    t_ms: u32,
    seen: &[Observation],
) -> FrameCounts {
    let mut h = fnv1a([]);
    let report =
        forecaster.frame::<LibmSine, W, MAX_K>(p, t_ms, seen, |fc| h = hash_forecast(h, fc));
    let d = &report.delta;
    h = fnv1a_continue(
        h,
        [
            report.forecasts,
            report.failed,
            report.feedback,
            d.rejected,
            d.duplicates,
            d.non_finite,
            d.stale as u32,
        ]
        .into_iter()
        .chain(d.entered.iter().copied())
        .chain([u32::MAX])
        .chain(d.left.iter().copied()),
    );
    FrameCounts {
        forecasts: report.forecasts,
        feedback: report.feedback,
        hash: hash_state(h, forecaster.calibration()),
    }
}

/// [`online_scene`]'s forecaster for `blob`, the `Model` view parsed in
/// this frame only (see [`predictor_for`]).
#[inline(never)]
fn online_forecaster(
    blob: &'static [u8],
) -> Result<Forecaster<ONLINE_TRACKS, ONLINE_PENDING>, &'static str> {
    let model = Model::from_blob(blob).map_err(|_| "online scene: blob rejected")?;
    Forecaster::new(&model, Config::metres(), 1_000)
        .map_err(|_| "online scene: the online loop refused the model")
}

/// `h` continued over one forecast of [`online_scene`]: id, time, speed,
/// motion state, endpoints, probabilities, whether they are learned, the
/// point head, the static radii, the aggregate point, the per-horizon
/// radii, the scale, the experts' weights, anchor and velocities.
fn hash_forecast(h: u32, fc: &TrackForecast<MAX_K>) -> u32 {
    let bits = |p: &[f32; 2]| [p[0].to_bits(), p[1].to_bits()];
    let radii = |r: &Radii| [r.r50.to_bits(), r.r90.to_bits()];
    let h = fnv1a_continue(
        h,
        [
            fc.id,
            fc.end_ms,
            fc.speed.to_bits(),
            fc.motion as u32,
            fc.learned as u32,
            fc.endpoints.len() as u32,
        ],
    );
    let h = fnv1a_continue(h, fc.endpoints.iter().flat_map(bits));
    let h = fnv1a_continue(h, fc.probabilities.iter().map(|p| p.to_bits()));
    let h = fnv1a_continue(h, fc.head.iter().flatten().flat_map(bits));
    let h = fnv1a_continue(h, fc.static_radii.iter().flat_map(radii));
    let h = fnv1a_continue(h, fc.point.iter().flat_map(bits));
    let h = fnv1a_continue(h, fc.radii.iter().flat_map(radii));
    let h = fnv1a_continue(h, [fc.scale.to_bits()]);
    let h = fnv1a_continue(h, fc.weights.iter().map(|w| w.to_bits()));
    fnv1a_continue(
        h,
        core::iter::once(&fc.anchor)
            .chain(fc.velocities.iter())
            .flat_map(bits),
    )
}

/// `h` continued over the bytes of [`Calibration::state`] (little-endian
/// words). Out of line: its buffer ([`STATE_LEN`] bytes) is on the stack
/// only while it runs, not during the forecasts.
#[inline(never)]
fn hash_state(h: u32, calibration: &Calibration) -> u32 {
    let mut bytes = [0u8; STATE_LEN];
    let n = calibration.state(&mut bytes).unwrap_or(0);
    let words = bytes.get(..n).unwrap_or(&[]).chunks(4).map(|c| {
        let mut w = [0u8; 4];
        for (d, s) in w.iter_mut().zip(c) {
            *d = *s;
        }
        u32::from_le_bytes(w)
    });
    fnv1a_continue(h, core::iter::once(n as u32).chain(words))
}
