//! ETH/UCY (Social-GAN leave-one-scene-out split, metres).

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use super::rows::{id_key, load_split, scene_name};
use super::*;

/// The ETH/UCY splits (Social-GAN leave-one-scene-out).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum EthUcySplit {
    /// `<scene>/train/`: the first part of every other sequence.
    Train,
    /// `<scene>/val/`: the rest of every other sequence.
    Val,
    /// `<scene>/test/`: the held-out sequence(s).
    Test,
}

impl EthUcySplit {
    /// Folder name under `eth_ucy/<scene>/`.
    pub fn dir_name(self) -> &'static str {
        match self {
            EthUcySplit::Train => "train",
            EthUcySplit::Val => "val",
            EthUcySplit::Test => "test",
        }
    }
}

/// Frame-number step of the ETH/UCY benchmark files between consecutive annotations (0.4 s;
/// gaps are multiples of it).
pub const ETH_UCY_FRAME_STEP: i64 = 10;

/// Cut one ETH/UCY file into windows with the Social-GAN rule (see [`load_eth_ucy`]); a file
/// whose frames are not on the benchmark's 0.4 s clock ([`ETH_UCY_FRAME_STEP`]) is refused
/// with [`DataError::FrameStep`] (use a data-set folder with its own `seconds_per_frame` for
/// other clocks, `docs/own-data.md`).
pub fn parse_eth_ucy_file(path: &Path) -> Result<Vec<Window>, DataError> {
    let rows = read_rows(path)?;
    let scene = scene_name(path);
    // Unique sorted frames; per frame, the rows in file order and an index by ped id (a
    // hash look-up per row, so a frame with very many rows costs linear time, not quadratic).
    type FrameRows = (Vec<Row>, HashMap<u64, usize>);
    let mut by_frame: BTreeMap<i64, FrameRows> = BTreeMap::new();
    for r in rows {
        let (v, index) = by_frame.entry(r.frame).or_default();
        if index.contains_key(&id_key(r.ped_id)) {
            return Err(DataError::DuplicateRow {
                path: path.to_path_buf(),
                line: r.line,
                ped_id: r.ped_id,
                frame: r.frame,
            });
        }
        index.insert(id_key(r.ped_id), v.len());
        v.push(r);
    }
    let frames: Vec<(i64, FrameRows)> = by_frame.into_iter().collect();
    // The benchmark's clock: consecutive annotated frames are ETH_UCY_FRAME_STEP apart (0.4 s)
    // or a multiple of it (a gap). Anything else is another clock (a 10 Hz log has steps of 1
    // or 4), which the sliding window would silently train at the wrong period.
    for pair in frames.windows(2) {
        let (prev, (f, (rows, _))) = (pair[0].0, (&pair[1].0, &pair[1].1));
        let step = f - prev;
        if step % ETH_UCY_FRAME_STEP != 0 {
            let r = rows[0];
            return Err(DataError::FrameStep {
                path: path.to_path_buf(),
                line: r.line,
                ped_id: r.ped_id,
                prev_frame: prev,
                frame: *f,
                found: step,
                expected: ETH_UCY_FRAME_STEP,
            });
        }
    }
    let mut out = Vec::new();
    if frames.len() < WINDOW {
        return Ok(out);
    }
    for start in 0..=frames.len() - WINDOW {
        let win = &frames[start..start + WINDOW];
        // Peds of the first frame are the only candidates for being present in all 20; sort
        // them by id like numpy's `np.unique`.
        let mut ids: Vec<f64> = win[0].1 .0.iter().map(|r| r.ped_id).collect();
        ids.sort_by(f64::total_cmp);
        let mut kept = Vec::new();
        'ped: for id in ids {
            let mut w = Window {
                scene: scene.clone(),
                ped_id: id,
                frames: [0; WINDOW],
                pos: [[0.0; 2]; WINDOW],
            };
            for (t, (frame, (rows, index))) in win.iter().enumerate() {
                match index.get(&id_key(id)).map(|&i| &rows[i]) {
                    Some(r) => {
                        w.frames[t] = *frame;
                        w.pos[t] = r.pos;
                    }
                    None => continue 'ped,
                }
            }
            kept.push(w);
        }
        // Social-GAN: min_ped = 1, kept when num_peds_considered > min_ped.
        if kept.len() > 1 {
            out.extend(kept);
        }
    }
    Ok(out)
}

/// Load an ETH/UCY split (metres) from `root/eth_ucy/<scene>/<split>/`.
///
/// `scene` is one of [`ETH_UCY_SCENES`]. Every `*.txt` file is read in sorted file-name order
/// (scene field of each window = the file stem, e.g. `biwi_eth`). Per file, the Social-GAN
/// loader rule: take the unique sorted frame ids; slide 20-frame windows with stride 1 over
/// them (a window may span an annotation gap, as in Social-GAN); keep each pedestrian present
/// in all 20 frames; keep the window only if it has more than one such pedestrian. Within a
/// window, pedestrians are ordered by id.
///
/// Test-split sample counts: eth 181, hotel 1053, univ 24334, zara1 2253, zara2 5833.
pub fn load_eth_ucy(root: &Path, scene: &str, split: EthUcySplit) -> Result<Dataset, DataError> {
    let dir = root.join("eth_ucy").join(scene).join(split.dir_name());
    let what = format!(
        "ETH/UCY {scene}/{} directory (scenes: {})",
        split.dir_name(),
        ETH_UCY_SCENES.join(", ")
    );
    load_split(
        &dir,
        &what,
        parse_eth_ucy_file,
        format!("eth_ucy/{scene}/{}", split.dir_name()),
        Unit::Metres,
    )
}
