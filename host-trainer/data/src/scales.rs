//! The per-scene metres-per-pixel table of SDD (`sdd/scales/sdd_meters_per_pixel.csv`).

use std::collections::HashMap;
use std::path::Path;

use super::*;

/// Per-scene SDD metres-per-pixel factors from `root/sdd/scales/sdd_meters_per_pixel.csv`
/// (header `scene,meters_per_pixel`; the "A" ratios of `H_SDD.txt`).
pub fn sdd_metres_per_pixel(root: &Path) -> Result<HashMap<String, f64>, DataError> {
    let path = root
        .join("sdd")
        .join("scales")
        .join("sdd_meters_per_pixel.csv");
    let text = rows::read_data_file(&path, "SDD metres-per-pixel table")?;
    let mut out = HashMap::new();
    for rec in crate::csvfile::records(&text) {
        let (line, rec) = rec.map_err(|e| DataError::BadScale {
            path: path.clone(),
            line: e.position().map_or(0, |p| p.line() as usize),
            msg: e.to_string(),
        })?;
        let line = line as usize;
        let cols = rec
            .iter()
            .map(std::str::from_utf8)
            .collect::<Result<Vec<&str>, _>>()
            .map_err(|_| DataError::Encoding {
                path: path.clone(),
                line,
            })?;
        if line == 1 && cols[0].starts_with("scene") {
            continue;
        }
        let bad = |msg: String| DataError::BadScale {
            path: path.clone(),
            line,
            msg,
        };
        if cols.len() != 2 {
            return Err(bad(format!(
                "expected 2 columns (scene,meters_per_pixel), found {}",
                cols.len()
            )));
        }
        let v: f64 = cols[1]
            .parse()
            .map_err(|_| bad(format!("cannot parse {:?} as a number", cols[1])))?;
        // Positions are scaled in f32: the factor must be a normal f32 too.
        if !(v.is_finite() && v > 0.0 && (v as f32).is_normal()) {
            return Err(bad(format!(
                "factor {:?} is not a positive finite number that is a normal f32",
                cols[1]
            )));
        }
        out.insert(cols[0].to_string(), v);
    }
    Ok(out)
}
