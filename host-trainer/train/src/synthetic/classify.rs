//! The paper's 7 trajectory types ("SDD: Data Analysis") with exact operational rules, and the
//! unique-points histogram.
//!
//! The paper's types are informal; these are the rules used here, on a 20-point trajectory in
//! pixels, applied **in this order** (first match wins). Notation: `U` = number of unique points
//! (exact f32 equality of both coordinates), `W × H` = extent of the tightest axis-aligned
//! bounding box, `E = max(W, H)`, step `i` = `|p[i+1] − p[i]|`, `L` = path length (sum of steps),
//! `D = |p[19] − p[0]|`, `J` = the longest step.
//!
//! | type | rule |
//! |---|---|
//! | 1 stationary | `U == 1` or `E ≤ 1 px` |
//! | 2 | `U ≤ 8` and `E ≤ 5 px` (the paper says 3–8 unique points; 2 is the same phenomenon and included) |
//! | 2F flying | `U ≤ 8`, a single dominant jump (`J ≥ L/2` and `J > 5 px`), and with that jump removed (later points shifted back by it) the extent is `≤ 5 px` |
//! | 3F flying | `U ≤ 9`, a single dominant jump as above, and with it removed the extent is `≤ 100 px` |
//! | 3 | `U ≤ 9` and `E ≤ 100 px` |
//! | 4 | start and end within a 5×5 box: `|Δx| ≤ 5` and `|Δy| ≤ 5` between `p[0]` and `p[19]` |
//! | 5 flying randomly | `U ≤ 9` (anything left: few annotations spread over more than 100 px), or at least 2 jumps, a jump being a step longer than `max(10 px, 4 × median non-zero step)` |
//! | 6 backtracker | the point farthest from the start, at index `k ∈ [3, 16]`, is `R > 5 px` away and the end comes back: `D ≤ R/2` |
//! | 7 linear | straightness `D / L ≥ 0.7` ("perfectly to moderately linear") |
//! | other | none of the above (the paper discards these from augmentation) |

use serde::Serialize;

/// A trajectory type (the paper's 7 types with their F variants, plus "other").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub enum TrajType {
    /// Type 1: stationary.
    T1,
    /// Type 2: a few unique points in a 5×5 box.
    T2,
    /// Type 2F: type 2 shifted by one drone jump.
    T2F,
    /// Type 3: a few unique points in a 100×100 box.
    T3,
    /// Type 3F: type 3 shifted by one drone jump.
    T3F,
    /// Type 4: start and end within a 5×5 box.
    T4,
    /// Type 5: flying randomly (several jumps).
    T5,
    /// Type 6: backtracker.
    T6,
    /// Type 7: linear to moderately linear.
    T7,
    /// None of the above.
    Other,
}

impl TrajType {
    /// All types in table order.
    pub const ALL: [TrajType; 10] = [
        TrajType::T1,
        TrajType::T2,
        TrajType::T2F,
        TrajType::T3,
        TrajType::T3F,
        TrajType::T4,
        TrajType::T5,
        TrajType::T6,
        TrajType::T7,
        TrajType::Other,
    ];

    /// Short label ("1", "2F", ..., "other").
    pub fn label(self) -> &'static str {
        match self {
            TrajType::T1 => "1",
            TrajType::T2 => "2",
            TrajType::T2F => "2F",
            TrajType::T3 => "3",
            TrajType::T3F => "3F",
            TrajType::T4 => "4",
            TrajType::T5 => "5",
            TrajType::T6 => "6",
            TrajType::T7 => "7",
            TrajType::Other => "other",
        }
    }

    /// Index into [`TrajType::ALL`].
    pub fn index(self) -> usize {
        TrajType::ALL.iter().position(|&t| t == self).unwrap_or(9)
    }

    /// Parse a [`TrajType::label`].
    pub fn from_label(s: &str) -> Option<TrajType> {
        TrajType::ALL.iter().copied().find(|t| t.label() == s)
    }
}

/// Number of unique points (exact equality of both f32 coordinates).
pub fn unique_points(pts: &[[f32; 2]]) -> usize {
    let mut v: Vec<(u32, u32)> = pts
        .iter()
        .map(|p| ((p[0] + 0.0).to_bits(), (p[1] + 0.0).to_bits()))
        .collect();
    v.sort_unstable();
    v.dedup();
    v.len()
}

fn dist(a: [f32; 2], b: [f32; 2]) -> f64 {
    (a[0] as f64 - b[0] as f64).hypot(a[1] as f64 - b[1] as f64)
}

fn extent(pts: &[[f64; 2]]) -> f64 {
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for p in pts {
        x0 = x0.min(p[0]);
        x1 = x1.max(p[0]);
        y0 = y0.min(p[1]);
        y1 = y1.max(p[1]);
    }
    (x1 - x0).max(y1 - y0).max(0.0)
}

/// Classify one trajectory with the rules in the module docs.
pub fn classify(pts: &[[f32; 2]]) -> TrajType {
    if pts.len() < 2 {
        return TrajType::T1;
    }
    let p64: Vec<[f64; 2]> = pts.iter().map(|p| [p[0] as f64, p[1] as f64]).collect();
    let u = unique_points(pts);
    let e = extent(&p64);
    let steps: Vec<f64> = pts.windows(2).map(|w| dist(w[0], w[1])).collect();
    let l: f64 = steps.iter().sum();
    let (first, last) = (pts[0], pts[pts.len() - 1]);
    let d = dist(first, last);
    if u == 1 || e <= 1.0 {
        return TrajType::T1;
    }
    if u <= 8 && e <= 5.0 {
        return TrajType::T2;
    }
    // Single dominant jump (drone shift).
    let (ji, jlen) =
        steps.iter().copied().enumerate().fold(
            (0, 0.0f64),
            |acc, (i, s)| if s > acc.1 { (i, s) } else { acc },
        );
    if u <= 9 && jlen > 5.0 && jlen >= 0.5 * l {
        let shift = [p64[ji + 1][0] - p64[ji][0], p64[ji + 1][1] - p64[ji][1]];
        let dejumped: Vec<[f64; 2]> = p64
            .iter()
            .enumerate()
            .map(|(i, p)| {
                if i > ji {
                    [p[0] - shift[0], p[1] - shift[1]]
                } else {
                    *p
                }
            })
            .collect();
        let e2 = extent(&dejumped);
        if u <= 8 && e2 <= 5.0 {
            return TrajType::T2F;
        }
        if e2 <= 100.0 {
            return TrajType::T3F;
        }
    }
    if u <= 9 && e <= 100.0 {
        return TrajType::T3;
    }
    if (last[0] as f64 - first[0] as f64).abs() <= 5.0
        && (last[1] as f64 - first[1] as f64).abs() <= 5.0
    {
        return TrajType::T4;
    }
    let mut nz: Vec<f64> = steps.iter().copied().filter(|&s| s > 0.0).collect();
    nz.sort_by(f64::total_cmp);
    let med = super::quantile_sorted(&nz, 0.5);
    let jump = (4.0 * med).max(10.0);
    let jumps = steps.iter().filter(|&&s| s > jump).count();
    if u <= 9 || jumps >= 2 {
        return TrajType::T5;
    }
    let (k, r) = pts
        .iter()
        .enumerate()
        .map(|(i, &p)| (i, dist(first, p)))
        .fold((0, 0.0f64), |acc, x| if x.1 > acc.1 { x } else { acc });
    if (3..=16).contains(&k) && r > 5.0 && d <= 0.5 * r {
        return TrajType::T6;
    }
    if l > 0.0 && d / l >= 0.7 {
        return TrajType::T7;
    }
    TrajType::Other
}

/// Counts per type, indexed like [`TrajType::ALL`].
pub fn type_counts<'a>(trajs: impl IntoIterator<Item = &'a [[f32; 2]]>) -> [usize; 10] {
    let mut c = [0usize; 10];
    for t in trajs {
        c[classify(t).index()] += 1;
    }
    c
}

/// Unique-points histogram: `h[u]` = number of trajectories with `u` unique points
/// (`u ∈ 0..=20`, index 0 unused for non-empty trajectories).
pub fn unique_histogram<'a>(trajs: impl IntoIterator<Item = &'a [[f32; 2]]>) -> Vec<usize> {
    let mut h = vec![0usize; crate::data::WINDOW + 1];
    for t in trajs {
        let u = unique_points(t).min(crate::data::WINDOW);
        h[u] += 1;
    }
    h
}
