//! The timed track table through the C ABI: detections with millisecond
//! timestamps at the camera's rate in, histories on the model's period out
//! (`gpecnet_core::tracks::timed`: the rules, the interpolation, the
//! outcomes).
//!
//! ```c
//! static _Alignas(GPECNET_TRACKS_ALIGN) uint8_t table_mem[GPECNET_TRACKS_SIZE];
//! gpecnet_tracks_init(table_mem, sizeof table_mem, /* period */ 400, /* max gap */ 1000);
//! GpecnetTracks *table = (GpecnetTracks *)table_mem;
//! // each camera frame:
//! GpecnetDetection dets[] = { { .id = 7, .x = 3.1f, .y = -0.4f } };
//! gpecnet_tracks_update(table, t_ms, dets, 1, NULL);
//! GpecnetHistory fresh[GPECNET_TRACKS_CAPACITY];
//! size_t n;
//! gpecnet_tracks_fresh(table, fresh, GPECNET_TRACKS_CAPACITY, &n);
//! // predict from fresh[i].past_xy (GPECNET_HISTORY points, oldest first)
//! ```
use core::ffi::c_void;
use core::mem::{align_of, size_of};
use core::num::NonZeroU32;

use gpecnet_core::tracks::{FrameDelta, Observation, TimedTrackTable, HISTORY};

use crate::boundary::{guard, non_null};
use crate::status::{GPECNET_E_BAD_LENGTH, GPECNET_E_MISALIGNED};
use crate::status::{GPECNET_E_NOT_INITIALISED, GPECNET_E_NULL_POINTER};
use crate::status::{GPECNET_E_TRACKS_BAD_PERIOD, GPECNET_E_TRACKS_STALE_TIME};

/// Most tracks one table holds.
pub const GPECNET_TRACKS_CAPACITY: usize = 32;
/// Bytes of caller storage [`gpecnet_tracks_init`] needs (an upper bound on
/// every target; [`gpecnet_tracks_size`] gives the exact size).
pub const GPECNET_TRACKS_SIZE: usize = 3456;
/// Alignment of that storage, in bytes.
pub const GPECNET_TRACKS_ALIGN: usize = 8;
/// Points of one history (the shipped models' observed steps).
pub const GPECNET_HISTORY: usize = 8;

const _: () = assert!(GPECNET_HISTORY == HISTORY);

/// One detection of a camera frame: the upstream tracker's id and the position.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpecnetDetection {
    /// Track id from the upstream tracker (any value).
    pub id: u32,
    /// Position, x (finite).
    pub x: f32,
    /// Position, y (finite).
    pub y: f32,
}

/// What one [`gpecnet_tracks_update`] did, counted.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GpecnetTracksDelta {
    /// Tracks that entered.
    pub entered: u32,
    /// Tracks that left (their last detection more than `max_gap_ms` ago).
    pub left: u32,
    /// Detections of new ids refused because the table was full.
    pub rejected: u32,
    /// Detections refused because their id already had one at this time.
    pub duplicates: u32,
    /// Detections refused because a coordinate was not finite.
    pub non_finite: u32,
    /// Tracks now fresh: a full history that gained a grid point.
    pub fresh: u32,
}

/// One track's history on the model's period, ready for a prediction.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpecnetHistory {
    /// Track id.
    pub id: u32,
    /// Time of the newest point, in the caller's milliseconds: forecast
    /// step `k` (1-based) is at `end_ms + k · period_ms`.
    pub end_ms: u32,
    /// The history, oldest first, (x, y) per point.
    pub past_xy: [[f32; 2]; GPECNET_HISTORY],
}

/// An initialised track table in caller-owned storage:
/// `(GpecnetTracks *)storage` after [`gpecnet_tracks_init`]. Opaque to C.
pub struct GpecnetTracks {
    _opaque: [u8; 0],
}

type Table = TimedTrackTable<GPECNET_TRACKS_CAPACITY>;

/// Tag of an initialised table storage ("GPTT").
const LIVE: u32 = 0x5454_5047;

#[repr(C)]
struct TableState {
    tag: u32,
    table: Table,
}

const _: () = {
    assert!(size_of::<TableState>() <= GPECNET_TRACKS_SIZE);
    assert!(align_of::<TableState>() <= GPECNET_TRACKS_ALIGN);
};

/// The size the table storage actually needs on this target (at most
/// [`GPECNET_TRACKS_SIZE`]).
#[no_mangle]
pub extern "C" fn gpecnet_tracks_size() -> usize {
    size_of::<TableState>()
}

/// The table in `t`, or why there is none.
///
/// # Safety
/// `t` is NULL or a storage passed to [`gpecnet_tracks_init`], not in use
/// by another call.
unsafe fn table<'a>(t: *mut GpecnetTracks) -> Result<&'a mut Table, i32> {
    if t.is_null() {
        return Err(GPECNET_E_NULL_POINTER);
    }
    if (t as usize) & (GPECNET_TRACKS_ALIGN - 1) != 0 {
        return Err(GPECNET_E_MISALIGNED);
    }
    let s = t.cast::<TableState>();
    // SAFETY: non-null and aligned (checked above); the caller guarantees a
    // storage gpecnet_tracks_init wrote (its tag at least).
    let tag = unsafe { core::ptr::addr_of!((*s).tag).read() };
    if tag != LIVE {
        return Err(GPECNET_E_NOT_INITIALISED);
    }
    // SAFETY: the tag is LIVE only after gpecnet_tracks_init wrote a whole
    // TableState; the caller guarantees exclusive use for this call.
    Ok(unsafe { &mut (*s).table })
}

/// Builds an empty table in `storage` (`storage_len >= GPECNET_TRACKS_SIZE`
/// bytes aligned to [`GPECNET_TRACKS_ALIGN`]) resampling onto `period_ms`
/// (the model's period) and bridging gaps between a track's detections of
/// at most `max_gap_ms`. `period_ms` = 0 is [`GPECNET_E_TRACKS_BAD_PERIOD`].
///
/// # Safety
/// `storage` is NULL or valid for writes of `storage_len` bytes.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_tracks_init(
    storage: *mut c_void,
    storage_len: usize,
    period_ms: u32,
    max_gap_ms: u32,
) -> i32 {
    guard(|| {
        non_null(storage)?;
        if (storage as usize) & (GPECNET_TRACKS_ALIGN - 1) != 0 {
            return Err(GPECNET_E_MISALIGNED);
        }
        if storage_len < size_of::<TableState>() {
            return Err(GPECNET_E_BAD_LENGTH);
        }
        let s = storage.cast::<TableState>();
        // SAFETY: non-null, aligned, at least size_of::<TableState>() writable bytes.
        unsafe { core::ptr::addr_of_mut!((*s).tag).write(0) };
        let period = NonZeroU32::new(period_ms).ok_or(GPECNET_E_TRACKS_BAD_PERIOD)?;
        let table = Table::new(period, max_gap_ms);
        // SAFETY: as above; TableState has no drop glue.
        unsafe { s.write(TableState { tag: LIVE, table }) };
        Ok(())
    })
}

/// Applies one camera frame: `n` detections at `dets`, all at timestamp
/// `t_ms` (milliseconds, wrapping `u32`). Counts go to `*out` when `out` is
/// not NULL. A timestamp before the table's last one refuses the whole call
/// ([`GPECNET_E_TRACKS_STALE_TIME`], nothing changes); a frame may be given
/// in several calls with the same `t_ms`. Refused detections (duplicates,
/// non-finite, table full) are counted, not errors.
///
/// # Safety
/// `t` is NULL or a storage passed to [`gpecnet_tracks_init`], not in use by
/// another call; `dets` is NULL (only with `n` = 0) or valid for
/// reads of `n` detections; `out` is NULL or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_tracks_update(
    t: *mut GpecnetTracks,
    t_ms: u32,
    dets: *const GpecnetDetection,
    n: usize,
    out: *mut GpecnetTracksDelta,
) -> i32 {
    guard(|| {
        // SAFETY: the caller's contract on `t`.
        let table = unsafe { table(t) }?;
        if n > 0 {
            non_null(dets)?;
        }
        let mut delta = GpecnetTracksDelta::default();
        let mut add = |d: &FrameDelta<GPECNET_TRACKS_CAPACITY>| {
            delta.entered += d.entered.len() as u32;
            delta.left += d.left.len() as u32;
            delta.rejected = delta.rejected.saturating_add(d.rejected);
            delta.duplicates = delta.duplicates.saturating_add(d.duplicates);
            delta.non_finite = delta.non_finite.saturating_add(d.non_finite);
        };
        // In chunks of the table's capacity, each a continuation of the frame.
        let mut chunk = [Observation {
            id: 0,
            pos: [0.0; 2],
        }; GPECNET_TRACKS_CAPACITY];
        let mut done = 0;
        loop {
            let m = (n - done).min(GPECNET_TRACKS_CAPACITY);
            for (i, o) in chunk.iter_mut().take(m).enumerate() {
                // SAFETY: done + i < n, and the caller guarantees n readable detections.
                let d = unsafe { dets.add(done + i).read_unaligned() };
                *o = Observation {
                    id: d.id,
                    pos: [d.x, d.y],
                };
            }
            let d = table.update(t_ms, chunk.get(..m).unwrap_or(&[]));
            if d.stale {
                return Err(GPECNET_E_TRACKS_STALE_TIME);
            }
            add(&d);
            done += m;
            if done >= n {
                break;
            }
        }
        delta.fresh = table.fresh().count() as u32;
        if !out.is_null() {
            // SAFETY: non-null, writable (caller's contract).
            unsafe { out.write_unaligned(delta) };
        }
        Ok(())
    })
}

/// Copies the fresh tracks' histories (full, and a grid point newer since
/// time last advanced: the ones to predict for now), in the order they
/// entered, to `out` (room for `cap`); `*out_len` receives their number.
/// When `cap` is smaller, nothing is copied and the status is
/// [`GPECNET_E_BAD_LENGTH`] (`*out_len` still says how many there are).
///
/// # Safety
/// `t` as in [`gpecnet_tracks_update`]; `out` is NULL (only with `cap` = 0) or valid for
/// writes of `cap` histories; `out_len` is NULL or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn gpecnet_tracks_fresh(
    t: *mut GpecnetTracks,
    out: *mut GpecnetHistory,
    cap: usize,
    out_len: *mut usize,
) -> i32 {
    guard(|| {
        non_null(out_len)?;
        // SAFETY: the caller's contract on `t`.
        let table = unsafe { table(t) }?;
        let n = table.fresh().count();
        // SAFETY: non-null, writable (caller's contract).
        unsafe { out_len.write_unaligned(n) };
        if n > cap {
            return Err(GPECNET_E_BAD_LENGTH);
        }
        if n > 0 {
            non_null(out)?;
        }
        for (i, tr) in table.fresh().enumerate() {
            let h = GpecnetHistory {
                id: tr.id(),
                end_ms: tr.end_ms(),
                past_xy: tr.past(),
            };
            // SAFETY: i < n <= cap, and the caller guarantees room for cap histories.
            unsafe { out.add(i).write_unaligned(h) };
        }
        Ok(())
    })
}
