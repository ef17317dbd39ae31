//! Data loading on malformed temp files: every problem is a `DataError` naming the file and
//! the 1-based line, never a panic.

use crate::common;

use std::fs;
use std::path::Path;

use gpecnet_trainer::data::*;

/// Write `lines` as root/sdd/train/bad.txt and load the train split.
fn load_bad_sdd(lines: &[String]) -> (tempfile::TempDir, Result<Dataset, DataError>) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("sdd/train");
    fs::create_dir_all(&d).unwrap();
    fs::write(d.join("bad.txt"), lines.join("\n")).unwrap();
    let r = load_sdd(dir.path(), SddSplit::Train);
    (dir, r)
}

fn assert_names(e: &DataError, line: usize) {
    assert_eq!(e.line(), Some(line), "{e}");
    assert!(e.path().ends_with("sdd/train/bad.txt"), "{e}");
    let msg = e.to_string();
    assert!(msg.contains(&format!("bad.txt:{line}:")), "{msg}");
}

/// The error of loading `lines`, checked to name bad.txt and the 1-based `line`.
fn load_error(lines: &[String], line: usize) -> DataError {
    let e = load_bad_sdd(lines).1.unwrap_err();
    assert_names(&e, line);
    e
}

/// Asserts that the error `$e` matches the pattern (and its guard; the error is matched by
/// reference), and prints the error when it does not.
macro_rules! assert_error {
    ($e:expr, $($pattern:tt)+) => {{
        let e = &$e;
        assert!(matches!(e, $($pattern)+), "{e:?}");
    }};
}

/// The error of ped 1's 20 good rows with row `at` (0-based) replaced by `row`.
fn bad_row(at: usize, row: &str) -> DataError {
    let mut l = common::good_rows("1", 0);
    l[at] = row.into();
    load_error(&l, at + 1)
}

#[test]
fn good_temp_file_loads() {
    let mut l = common::good_rows("3", 0);
    l.extend(common::good_rows("4.0", 600));
    let (_d, r) = load_bad_sdd(&l);
    let ds = r.unwrap();
    assert_eq!(ds.len(), 2);
    assert_eq!(ds.windows[1].ped_id, 4.0);
    assert_eq!(ds.windows[1].frames[0], 600);
    assert_eq!(ds.windows[0].scene, "bad");
}

#[test]
fn bad_column_count() {
    let e = bad_row(2, "24 1 5.0");
    assert_error!(
        e,
        DataError::ColumnCount {
            found: 3,
            expected: 4,
            ..
        }
    );
}

#[test]
fn text_in_number() {
    let e = bad_row(4, "48 1 abc 5.0");
    assert_error!(e, DataError::BadNumber { column: 3, text, .. } if text == "abc");
    assert!(e.to_string().contains("abc"));
}

#[test]
fn fractional_frame() {
    let e = bad_row(1, "12.5 1 5.0 5.0");
    assert_error!(e, DataError::BadNumber { column: 1, .. });
}

#[test]
fn nan_and_inf() {
    for bad in ["NaN", "inf", "1e39"] {
        let e = bad_row(6, &format!("72 1 5.0 {bad}"));
        assert_error!(e, DataError::NonFinite { column: 4, .. });
    }
}

#[test]
fn nineteen_row_ped() {
    let mut l = common::good_rows("1", 0);
    let mut second = common::good_rows("2", 0);
    second.pop();
    l.extend(second);
    let e = load_error(&l, 21);
    assert_error!(e, DataError::TrajectoryLength { rows: 19, last_line: 39, ped_id, .. }
        if *ped_id == 2.0);
}

#[test]
fn wrong_frame_step() {
    let e = bad_row(5, "61 1 5.0 5.0");
    assert_error!(
        e,
        DataError::FrameStep {
            found: 13,
            prev_frame: 48,
            frame: 61,
            ..
        }
    );
}

#[test]
fn non_utf8_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("sdd/train");
    fs::create_dir_all(&d).unwrap();
    let mut bytes = common::good_rows("1", 0).join("\n").into_bytes();
    bytes.extend_from_slice(b"\n0 9 \xff\xfe 1");
    fs::write(d.join("bad.txt"), bytes).unwrap();
    let e = load_sdd(dir.path(), SddSplit::Train).unwrap_err();
    assert_error!(e, DataError::Encoding { line: 21, .. });
}

#[test]
fn crlf_and_blank_lines_are_tolerated() {
    let mut l = common::good_rows("1", 0);
    l.insert(3, String::new());
    let text = l.join("\r\n") + "\r\n";
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("sdd/test");
    fs::create_dir_all(&d).unwrap();
    fs::write(d.join("x.txt"), text).unwrap();
    let ds = load_sdd(dir.path(), SddSplit::Test).unwrap();
    assert_eq!(ds.len(), 1);
    assert_eq!(ds.windows[0].pos[19], [29.0, 5.5]);
}

#[test]
fn missing_directory_has_hint() {
    let dir = tempfile::tempdir().unwrap();
    let e = load_sdd(dir.path(), SddSplit::Test).unwrap_err();
    assert_error!(e, DataError::Missing { .. });
    assert!(e.path().ends_with("sdd/test"));
    assert_eq!(e.line(), None);
    let msg = e.to_string();
    assert!(msg.contains("README") && msg.contains("--data"), "{msg}");

    let e = load_eth_ucy(dir.path(), "nowhere", EthUcySplit::Val).unwrap_err();
    assert_error!(e, DataError::Missing { .. });
    assert!(e.to_string().contains("zara1"));
}

#[test]
fn empty_directory() {
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir_all(dir.path().join("sdd/train")).unwrap();
    let e = load_sdd(dir.path(), SddSplit::Train).unwrap_err();
    assert_error!(e, DataError::NoFiles { .. });
}

#[test]
fn eth_ucy_duplicate_and_bad_rows() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("eth_ucy/zara1/train");
    fs::create_dir_all(&d).unwrap();
    let f = d.join("a.txt");
    fs::write(
        &f,
        "0\t1.0\t1.0\t1.0\n10\t1.0\t1.0\t1.0\n10\t1.0\t2.0\t2.0\n",
    )
    .unwrap();
    let e = load_eth_ucy(dir.path(), "zara1", EthUcySplit::Train).unwrap_err();
    assert_error!(
        e,
        DataError::DuplicateRow {
            line: 3,
            frame: 10,
            ..
        }
    );
    fs::write(&f, "0\t1.0\t1.0\t1.0\n10\t1.0\t1.0\n").unwrap();
    let e = load_eth_ucy(dir.path(), "zara1", EthUcySplit::Train).unwrap_err();
    assert_error!(
        e,
        DataError::ColumnCount {
            line: 2,
            found: 3,
            ..
        }
    );
    assert!(e.path() == Path::new(&f));
}
