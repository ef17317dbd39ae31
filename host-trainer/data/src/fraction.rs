//! A fixed part of a data set's tracks, for training on less data than a split holds
//! ([`track_fraction`]).

use crate::Window;

/// The windows of the first `ceil(fraction × tracks)` tracks of `windows` in a fixed order of
/// the tracks (FNV-1a of scene and id, ties by scene and id), all of them for `fraction >= 1`
/// (a run's `train_fraction`, `gpecnet train --train-fraction`). The order does not depend on the seed, so every run
/// on a fraction of one data set sees the same tracks; the kept windows stay in their order.
pub fn track_fraction(windows: Vec<Window>, fraction: f32) -> Vec<Window> {
    if fraction >= 1.0 {
        return windows;
    }
    fn key_hash(scene: &str, id: f64) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in scene.bytes().chain(id.to_bits().to_le_bytes()) {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
        h
    }
    let mut tracks: Vec<(u64, &str, u64)> = windows
        .iter()
        .map(|w| {
            (
                key_hash(&w.scene, w.ped_id),
                w.scene.as_str(),
                w.ped_id.to_bits(),
            )
        })
        .collect();
    tracks.sort_unstable();
    tracks.dedup();
    let keep = ((f64::from(fraction) * tracks.len() as f64).ceil() as usize).min(tracks.len());
    let kept: std::collections::HashSet<(String, u64)> = tracks[..keep]
        .iter()
        .map(|&(_, s, id)| (s.to_string(), id))
        .collect();
    windows
        .into_iter()
        .filter(|w| kept.contains(&(w.scene.clone(), w.ped_id.to_bits())))
        .collect()
}
