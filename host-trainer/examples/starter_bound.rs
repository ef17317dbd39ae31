//! How well can any set of 20 endpoints do for *starters* (standing when forecast, more than
//! 1 m away 4.8 s later: `gpecnet_trainer::data::motion_change`) if the past says only "this
//! one will leave"? A standing pedestrian's past carries no heading and no timing, so the
//! best such forecaster places the same 20 displacements (from the last observed position)
//! for every starter. This example finds them: the 20 points that minimise the mean distance
//! to the starters' true displacements (k-medians: Lloyd's assignment, then each centre moved
//! to its points' geometric median by Weiszfeld's iteration; the best of 10 seeded starts),
//! in the world frame of the recordings, so that a scene's preferred directions count.
//!
//! * **fitted on train**: the points fitted on the training split's starters, scored on the
//!   test split's: a forecaster that knows who starts, and nothing else;
//! * **fitted on test**: fitted on the test starters themselves, in sample: no fixed set of
//!   20 can do better on them (shown where the test split holds at least 10 starters per
//!   point).
//!
//! Both know in advance who will start, which no model does. Prints Markdown.
//!
//! ```sh
//! cargo run --release -p gpecnet-trainer --example starter_bound [-- DATA_ROOT]
//! ```

use std::path::PathBuf;

use anyhow::Result;
use gpecnet_trainer::data::{self, DatasetSpec, Split, Window, PAST, WINDOW};
use gpecnet_trainer::rng::Rng;

/// Endpoints per window.
const K: usize = 20;
/// Seeded starts of the k-medians search.
const STARTS: u64 = 10;
/// Lloyd rounds per start.
const ROUNDS: usize = 60;

fn main() -> Result<()> {
    let root = std::env::args()
        .nth(1)
        .map_or_else(data::default_data_root, PathBuf::from);
    let val = data::default_sdd_val_scenes();
    println!(
        "| test set | training data of the fit | starters: train / test | their median distance at 4.8 s (m): train / test | test starters leaving within 45° of their observed drift | fitted on train: test mean minFDE (m) | fitted on test (in sample) |"
    );
    println!("|---|---|---|---|---|---|---|");
    let mut targets = vec![("SDD".to_string(), "sdd-m".to_string(), "sdd-m".to_string())];
    for scene in ["eth", "hotel", "univ", "zara1", "zara2"] {
        targets.push((
            scene.to_uppercase(),
            format!("sdd-m+eth_ucy:{scene}"),
            format!("eth_ucy:{scene}"),
        ));
    }
    for (name, train_spec, test_spec) in targets {
        let load = |spec: &str, split| -> Result<Vec<Window>> {
            let set = data::load(
                &root,
                &DatasetSpec::parse(spec).map_err(anyhow::Error::msg)?,
                split,
                &val,
            )?;
            Ok(set
                .windows
                .into_iter()
                .filter(|w| data::motion_change(w) == 0)
                .collect())
        };
        let test_windows = load(&test_spec, Split::Test)?;
        let train: Vec<[f32; 2]> = load(&train_spec, Split::Train)?
            .iter()
            .map(displacement)
            .collect();
        let test: Vec<[f32; 2]> = test_windows.iter().map(displacement).collect();
        let described = format!(
            "| {name} | `{train_spec}` | {} / {} | {} / {} | {} |",
            train.len(),
            test.len(),
            median_distance(&train),
            median_distance(&test),
            along_drift(&test_windows)
        );
        if train.len() < K || test.is_empty() {
            println!("{described} – | – |");
            continue;
        }
        let fitted = k_medians(&train);
        // In sample, a handful of points per centre would be fitted, not bounded.
        let in_sample = if test.len() >= 10 * K {
            format!("{:.3}", mean_min_distance(&k_medians(&test), &test))
        } else {
            "–".into()
        };
        println!(
            "{described} {:.3} | {in_sample} |",
            mean_min_distance(&fitted, &test)
        );
    }
    Ok(())
}

/// The true displacement at the horizon from the last observed position.
fn displacement(w: &Window) -> [f32; 2] {
    let (a, b) = (w.pos[PAST - 1], w.pos[WINDOW - 1]);
    [b[0] - a[0], b[1] - a[1]]
}

/// The median length of the displacements, to two decimals ("–" for none).
fn median_distance(points: &[[f32; 2]]) -> String {
    let mut d: Vec<f64> = points.iter().map(|&p| dist(p, [0.0, 0.0])).collect();
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2).map_or("–".into(), |m| format!("{m:.2}"))
}

/// The share of starters whose displacement at the horizon points within 45° of their
/// observed drift (`p_7 − p_0`: under 0.3 m/s, but rarely nothing); a direction drawn
/// uniformly gives 25 %. "–" for none.
fn along_drift(ws: &[Window]) -> String {
    if ws.is_empty() {
        return "–".into();
    }
    let along = ws
        .iter()
        .filter(|w| {
            let (a, b) = (w.pos[0], w.pos[PAST - 1]);
            let drift = [b[0] - a[0], b[1] - a[1]];
            let d = displacement(w);
            let norms = dist(drift, [0.0, 0.0]) * dist(d, [0.0, 0.0]);
            let dot = f64::from(drift[0] * d[0] + drift[1] * d[1]);
            norms > 0.0 && dot / norms > std::f64::consts::FRAC_1_SQRT_2
        })
        .count();
    format!("{:.0} %", 100.0 * along as f64 / ws.len() as f64)
}

fn dist(a: [f32; 2], b: [f32; 2]) -> f64 {
    f64::from(a[0] - b[0]).hypot(f64::from(a[1] - b[1]))
}

/// The index of the centre nearest to `p`.
fn nearest(centres: &[[f32; 2]], p: [f32; 2]) -> usize {
    (0..centres.len())
        .min_by(|&i, &j| dist(centres[i], p).total_cmp(&dist(centres[j], p)))
        .unwrap_or(0)
}

/// The mean over `points` of the distance to the nearest centre.
fn mean_min_distance(centres: &[[f32; 2]], points: &[[f32; 2]]) -> f64 {
    let total: f64 = points
        .iter()
        .map(|&p| dist(centres[nearest(centres, p)], p))
        .sum();
    total / points.len().max(1) as f64
}

/// The best of [`STARTS`] k-medians searches of [`K`] centres (`points.len() >= K`).
fn k_medians(points: &[[f32; 2]]) -> Vec<[f32; 2]> {
    let mut best: Option<(f64, Vec<[f32; 2]>)> = None;
    for seed in 0..STARTS {
        let mut rng = Rng::new(seed);
        // k-means++-like start: each next centre the point farthest from the chosen ones
        // among a few random candidates.
        let mut centres = vec![points[rng.below(points.len())]];
        while centres.len() < K {
            let pick = (0..8)
                .map(|_| points[rng.below(points.len())])
                .max_by(|&a, &b| {
                    dist(centres[nearest(&centres, a)], a)
                        .total_cmp(&dist(centres[nearest(&centres, b)], b))
                })
                .unwrap_or(points[0]);
            centres.push(pick);
        }
        for _ in 0..ROUNDS {
            let mut groups = vec![Vec::new(); K];
            for &p in points {
                groups[nearest(&centres, p)].push(p);
            }
            for (c, g) in centres.iter_mut().zip(&groups) {
                if !g.is_empty() {
                    *c = geometric_median(g, *c);
                }
            }
        }
        let score = mean_min_distance(&centres, points);
        if best.as_ref().is_none_or(|(s, _)| score < *s) {
            best = Some((score, centres));
        }
    }
    best.map(|(_, c)| c).unwrap_or_default()
}

/// The point minimising the summed distance to `g`, by Weiszfeld's iteration from `start`.
fn geometric_median(g: &[[f32; 2]], start: [f32; 2]) -> [f32; 2] {
    let mut m = [f64::from(start[0]), f64::from(start[1])];
    for _ in 0..50 {
        let (mut num, mut den) = ([0.0f64; 2], 0.0f64);
        for p in g {
            let d = (f64::from(p[0]) - m[0])
                .hypot(f64::from(p[1]) - m[1])
                .max(1e-9);
            num[0] += f64::from(p[0]) / d;
            num[1] += f64::from(p[1]) / d;
            den += 1.0 / d;
        }
        m = [num[0] / den, num[1] / den];
    }
    [m[0] as f32, m[1] as f32]
}
