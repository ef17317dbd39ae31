//! Golden verification, shared verbatim by the firmware (defmt output) and
//! the host (`golden-host`, println output): the same code, the same lines,
//! so `cargo xtask qemu` can compare the two runs line by line.
//!
//! Lines (the firmware prints them with defmt, decoded by defmt-print):
//!   model <model> <numeric> <sine> <n>  before a model's cases: f32|int16q15, the sidecar's sine
//!   golden <model> <case> <fnv32>      one per golden case, sidecar's sine, bit-compared
//!   xcheck <model> <sine> <case> <fnv32> the same inputs through the other sine
//!                                      paths (no expected values; host vs target only)
//! `fnv32` is FNV-1a over the output bit patterns (x0, y0, x1, y1, ...).
//!
//! `Predictor<S, SCRATCH>` picks its engine from the blob's numeric kind;
//! `S` is the sine the sidecar names for an f32 blob (plus `xcheck` lines for
//! the other compiled-in sines). A fixed-point blob's sidecar must name
//! `q15-table` (`Predictor::sine_name`); it has one numeric path, so no
//! `xcheck` lines.

use gpecnet_core::golden::{fnv1a, GoldenCase, GoldenSet};
use gpecnet_core::sine::{FastSine, LibmSine, Sine};
use gpecnet_core::{fixed, Model, NumericKind, PredictError, Predictor, Trajectory};
use heapless::Vec;

/// Scratch width of the predictor: the widest layer the firmware supports
/// (`Predictor` holds 5 × SCRATCH f32). 128 fits the `sdd-small`/`quick`
/// configurations; raise it for wider models (RAM: 20 B per unit). The
/// Cortex-M0 build (16 KiB of RAM) takes 64: the `sdd-tiny*` models; `cargo
/// xtask qemu --mcu m0` embeds only models that fit.
pub const SCRATCH: usize = if cfg!(armv6m) { 64 } else { 128 };
/// Maximum endpoints per golden case / prediction.
pub const MAX_K: usize = 20;
/// Most latent samples one prediction draws (test-time sampling reduces them to K):
/// 8 bytes of stack each.
pub const MAX_SAMPLES: usize = 128;

/// One model compiled into the image.
pub struct EmbeddedModel {
    pub name: &'static str,
    pub blob: &'static [u8],
    pub golden: &'static [u8],
}

/// A result line.
pub enum Line<'a> {
    /// `model <model> <numeric> <sine> <cases>`: before a model's cases.
    Model {
        model: &'a str,
        numeric: &'static str,
        sine: &'a str,
        cases: u32,
    },
    /// `golden <model> <case> <hash>` (+ whether it matched the sidecar).
    Golden {
        model: &'a str,
        case: u32,
        hash: u32,
        ok: bool,
    },
    /// `xcheck <model> <sine> <case> <hash>`.
    Xcheck {
        model: &'a str,
        sine: &'static str,
        case: u32,
        hash: u32,
    },
    /// Something that prevents verification (counts as a failure).
    Error { model: &'a str, what: &'static str },
    /// The model is wider than [`SCRATCH`] (counts as a failure).
    TooWide { model: &'a str, needed: u32 },
}

/// Totals over all models.
#[derive(Default, Clone, Copy)]
pub struct Summary {
    pub models: u32,
    pub cases: u32,
    pub mismatches: u32,
    pub errors: u32,
    pub xchecks: u32,
}

impl Summary {
    pub fn ok(&self) -> bool {
        self.models > 0 && self.cases > 0 && self.mismatches == 0 && self.errors == 0
    }
}

/// Sine paths compiled in, by [`Sine::NAME`].
pub const SINES: &[&str] = &[
    LibmSine::NAME,
    FastSine::NAME,
    #[cfg(feature = "micromath")]
    gpecnet_core::sine::MicromathSine::NAME,
];

/// Endpoints of one prediction, and the point forecast (empty for models without one).
type Output = (Vec<[f32; 2], MAX_K>, Trajectory);

/// Output fingerprint + bit-equality with the sidecar, for each case, of `predict`. The hash
/// covers the endpoints, then the point forecast's points.
fn check_cases(
    set: &GoldenSet<'_>,
    emit: &mut dyn FnMut(u32, Result<(u32, bool), ()>),
    predict: &mut dyn FnMut(&GoldenCase<'_>) -> Result<Output, PredictError>,
) {
    for (i, case) in set.cases().enumerate() {
        let k = case.k();
        let r = match predict(&case) {
            Ok((ends, point)) => {
                let bits = |p: &[f32; 2]| [p[0].to_bits(), p[1].to_bits()];
                let hash = fnv1a(ends.iter().chain(point.iter()).flat_map(bits));
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
fn predict_case<S: Sine>(
    p: &mut Predictor<'_, S, SCRATCH>,
    c: &GoldenCase<'_>,
) -> Result<Output, PredictError> {
    let mut ends: Vec<[f32; 2], MAX_K> = Vec::new();
    let _ = ends.resize(c.k().min(MAX_K), [0.0; 2]);
    p.predict_endpoint_set::<MAX_SAMPLES>(&c.past, c.seed, &mut ends)?;
    let point = if p.model().has_point_head() {
        p.predict_point(&c.past)?
    } else {
        Trajectory::new()
    };
    Ok((ends, point))
}

/// (`model` by reference: a `Model` is about 1.5 KiB, copied once, into the predictor.)
///
/// Every case of `set` through `Predictor<S>` (the engine follows the blob's kind; `S` is
/// the sine of f32 blobs). `Err` if the predictor's sine is not `sine`.
///
/// Out of line, and the predictor used where `new` put it (not moved out of
/// the `Result`): one predictor (4 KiB at `SCRATCH` = 128) on the stack at a
/// time, which the Cortex-M0's 16 KiB of RAM needs.
#[inline(never)]
fn cases_with<S: Sine>(
    model: &Model<'_>,
    set: &GoldenSet<'_>,
    sine: &str,
    emit: &mut dyn FnMut(u32, Result<(u32, bool), ()>),
) -> Result<(), &'static str> {
    let mut made = Predictor::<S, SCRATCH>::new(*model);
    let Ok(p) = made.as_mut() else {
        return Err("no predictor for this blob");
    };
    if p.sine_name() != sine {
        return Err("the sidecar's sine is not this blob's numeric path");
    }
    check_cases(set, emit, &mut |c| predict_case(p, c));
    Ok(())
}

/// [`cases_with`] for the sine named `sine` (fixed-point blobs: `q15-table`).
fn cases_named(
    model: &Model<'_>,
    set: &GoldenSet<'_>,
    sine: &str,
    emit: &mut dyn FnMut(u32, Result<(u32, bool), ()>),
) -> Result<(), &'static str> {
    match sine {
        n if n == LibmSine::NAME => cases_with::<LibmSine>(model, set, sine, emit),
        n if n == FastSine::NAME => cases_with::<FastSine>(model, set, sine, emit),
        #[cfg(feature = "micromath")]
        n if n == gpecnet_core::sine::MicromathSine::NAME => {
            cases_with::<gpecnet_core::sine::MicromathSine>(model, set, sine, emit)
        }
        // A fixed-point blob runs its integer sine whatever `S` is.
        n if n == fixed::SINE_NAME => cases_with::<LibmSine>(model, set, sine, emit),
        _ => Err("golden sine not compiled in (feature micromath?)"),
    }
}

/// Verifies every model; `xcheck`: also run the other compiled-in sines.
pub fn verify_all(
    models: &[EmbeddedModel],
    xcheck: bool,
    out: &mut dyn FnMut(Line<'_>),
) -> Summary {
    let mut s = Summary::default();
    for m in models {
        s.models += 1;
        let model = match Model::from_blob(m.blob) {
            Ok(model) => model,
            Err(_) => {
                s.errors += 1;
                out(Line::Error {
                    model: m.name,
                    what: "blob rejected by Model::from_blob",
                });
                continue;
            }
        };
        let set = match GoldenSet::parse(m.golden) {
            Ok(set) => set,
            Err(_) => {
                s.errors += 1;
                out(Line::Error {
                    model: m.name,
                    what: "golden sidecar rejected by GoldenSet::parse",
                });
                continue;
            }
        };
        if set.info().model_crc != model.crc() {
            s.errors += 1;
            out(Line::Error {
                model: m.name,
                what: "golden sidecar belongs to another blob (model_crc)",
            });
            continue;
        }
        if model.scratch_width() > SCRATCH {
            s.errors += 1;
            out(Line::TooWide {
                model: m.name,
                needed: model.scratch_width() as u32,
            });
            continue;
        }
        let sine = set.info().sine;
        out(Line::Model {
            model: m.name,
            numeric: match model.numeric() {
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
                s.errors += 1;
                out(Line::Error {
                    model: m.name,
                    what: "prediction failed",
                });
            }
        };
        if let Err(what) = cases_named(&model, &set, sine, &mut emit) {
            s.errors += 1;
            out(Line::Error {
                model: m.name,
                what,
            });
            continue;
        }
        // The other compiled-in sines of an f32 blob (a fixed-point blob has one path).
        if xcheck && model.numeric() == NumericKind::F32 {
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
                        s.errors += 1;
                        out(Line::Error {
                            model: m.name,
                            what: "prediction failed (xcheck)",
                        });
                    }
                };
                let _ = cases_named(&model, &set, other, &mut emit);
            }
        }
    }
    s
}
