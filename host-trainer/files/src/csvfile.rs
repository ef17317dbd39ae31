//! CSV through the `csv` crate: every table the trainer writes (`metrics.csv`, `sweep.csv`,
//! `abscore.csv`, `rl_curve.csv`, the synthetic pool) goes through [`to_csv`], and every CSV it
//! reads (the pool, SDD's metres-per-pixel table) through [`records`].

use anyhow::{anyhow, Result};

/// A CSV document: the `header` record, then one record per row. Fields are written as given
/// (quoted only where CSV needs it: a comma, a quote or a line break), every record ends in
/// `\n`.
pub fn to_csv<I, R, F>(header: &[&str], rows: I) -> Result<String>
where
    I: IntoIterator<Item = R>,
    R: IntoIterator<Item = F>,
    F: AsRef<[u8]>,
{
    let mut w = csv::WriterBuilder::new()
        .terminator(csv::Terminator::Any(b'\n'))
        .from_writer(Vec::new());
    w.write_record(header)?;
    for row in rows {
        w.write_record(row)?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| anyhow!("writing CSV: {}", e.error()))?;
    Ok(String::from_utf8(bytes)?)
}

/// The records of a CSV document with the 1-based line each starts on; the header, if any, is
/// a record like the others (the caller knows whether to skip it). Fields are trimmed, records
/// may differ in length (the caller checks and names the line), blank lines are skipped.
pub fn records(
    bytes: &[u8],
) -> impl Iterator<Item = Result<(u64, csv::ByteRecord), csv::Error>> + '_ {
    csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(bytes)
        .into_byte_records()
        .filter_map(|r| match r {
            Ok(rec) if rec.len() == 1 && rec[0].is_empty() => None,
            Ok(rec) => Some(Ok((rec.position().map_or(0, |p| p.line()), rec))),
            Err(e) => Some(Err(e)),
        })
}
