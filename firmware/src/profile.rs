//! Profiling build (`--features profile`, driven by `cargo xtask profile`):
//! for each embedded model, one K = 20 prediction through the sine selected
//! at build time (GPECNET_SINE -> cfg `prof_sine`; `q15-table` = the
//! fixed-point engine for `Int16Q15` blobs), between `bench_start` and
//! `bench_end`. The QEMU TCG plugin (tools/insn_window.c) counts the guest
//! instructions executed between the two markers; on a real board
//! (`--features board`) DWT CYCCNT gives the cycles.
use core::hint::black_box;
use core::ptr::{addr_of_mut, write_volatile};

use gpecnet_core::{Model, PredictError, Trajectory};
use heapless::Vec;

use crate::golden::MAX_SAMPLES;
use crate::SCRATCH;

#[cfg(prof_sine = "libm")]
type ProfSine = gpecnet_core::sine::LibmSine;
#[cfg(prof_sine = "fast-f32")]
type ProfSine = gpecnet_core::sine::FastSine;
#[cfg(all(prof_sine = "micromath", feature = "micromath"))]
type ProfSine = gpecnet_core::sine::MicromathSine;

/// The engine of this image's numeric path: one backend only, as an
/// integrator who knows the blob's kind would link it.
#[cfg(not(prof_sine = "q15-table"))]
type ProfPredictor<'a> = gpecnet_core::Engine<'a, gpecnet_core::float::Float<ProfSine>, SCRATCH>;
#[cfg(prof_sine = "q15-table")]
type ProfPredictor<'a> = gpecnet_core::Engine<'a, gpecnet_core::fixed::Q15, SCRATCH>;
#[cfg(not(prof_sine = "q15-table"))]
const PATH_NAME: &str = <ProfSine as gpecnet_core::Sine>::NAME;
#[cfg(prof_sine = "q15-table")]
const PATH_NAME: &str = gpecnet_core::fixed::SINE_NAME;

pub const K: usize = 20;

static mut BENCH_MARK: u32 = 0;

/// Marker: the plugin starts counting when this executes. Distinct body from
/// `bench_end`, so LTO cannot merge the two into one address.
#[inline(never)]
#[no_mangle]
pub extern "C" fn bench_start() {
    unsafe { write_volatile(addr_of_mut!(BENCH_MARK), 1) };
}

#[inline(never)]
#[no_mangle]
pub extern "C" fn bench_end() {
    unsafe { write_volatile(addr_of_mut!(BENCH_MARK), 2) };
}

/// The measured function: out of line, so its instruction count does not
/// depend on what LTO inlines around it. One call of what a planner asks for:
/// the point forecast (when the model has a point head) and the model's set of
/// K = 20 endpoints (plain samples, or test-time sampling when the blob says so).
#[inline(never)]
#[no_mangle]
pub fn gpecnet_predict_k20(
    p: &mut ProfPredictor<'_>,
    past: &[[f32; 2]; 8],
    seed: u64,
) -> Result<(Vec<[f32; 2], K>, Trajectory), PredictError> {
    let point = if p.model().has_point_head() {
        p.predict_point(past)?
    } else {
        Trajectory::new()
    };
    let mut ends: Vec<[f32; 2], K> = Vec::new();
    let _ = ends.resize(K, [0.0; 2]);
    p.predict_endpoint_set::<MAX_SAMPLES>(past, seed, &mut ends)?;
    Ok((ends, point))
}

/// A pedestrian walking ~2.5 px per step (pixel units, like the SDD models).
const PAST: [[f32; 2]; 8] = [
    [512.0, 300.0],
    [514.0, 301.0],
    [516.5, 302.0],
    [519.0, 303.5],
    [521.0, 304.5],
    [523.5, 305.0],
    [526.0, 306.0],
    [528.0, 307.5],
];

pub fn run() -> bool {
    let mut ok = !crate::models::BLOBS.is_empty();
    if !ok {
        defmt::error!("profile: no model embedded");
    }
    #[cfg(all(feature = "board", not(armv6m)))]
    let mut cp = unsafe { cortex_m::Peripherals::steal() };
    #[cfg(all(feature = "board", not(armv6m)))]
    {
        cp.DCB.enable_trace();
        cp.DWT.enable_cycle_counter();
    }
    for &(name, blob) in crate::models::BLOBS {
        crate::watchdog::feed();
        let model = match Model::from_blob(blob) {
            Ok(m) => m,
            Err(e) => {
                defmt::error!("profile {=str}: {}", name, e);
                ok = false;
                continue;
            }
        };
        let mut p = match ProfPredictor::new(model) {
            Ok(p) => p,
            Err(e) => {
                defmt::error!("profile {=str}: {}", name, e);
                ok = false;
                continue;
            }
        };
        let base = crate::stack::repaint();
        #[cfg(all(feature = "board", not(armv6m)))]
        let c0 = cortex_m::peripheral::DWT::cycle_count();
        bench_start();
        let r = gpecnet_predict_k20(black_box(&mut p), black_box(&PAST), black_box(0x5eed));
        bench_end();
        #[cfg(all(feature = "board", not(armv6m)))]
        {
            let c1 = cortex_m::peripheral::DWT::cycle_count();
            defmt::println!("cycles {=str} {=u32}", name, c1.wrapping_sub(c0));
        }
        let used = crate::stack::high_water().saturating_sub(base);
        match r {
            Ok((ends, point)) => {
                let hash = gpecnet_core::golden::fnv1a(
                    ends.iter()
                        .chain(point.iter())
                        .flat_map(|e| [e[0].to_bits(), e[1].to_bits()]),
                );
                let samples = gpecnet_core::sampling::samples_needed(model.extensions(), K);
                let macs = model.endpoint_macs(samples) + model.point_head().macs();
                defmt::println!(
                    "profile {=str} sine={=str} k={=usize} macs={=usize} predict_stack={=u32} predictor_size={=u32} hash={=u32:08x}",
                    name,
                    PATH_NAME,
                    ends.len(),
                    macs,
                    used as u32,
                    core::mem::size_of_val(&p) as u32,
                    hash
                );
            }
            Err(e) => {
                defmt::error!("profile {=str}: {}", name, e);
                ok = false;
            }
        }
    }
    ok
}
