//! Absurd data is an error, not a number: coordinates beyond ±1e6
//! (`gpecnet_core::frame::MAX_COORDINATE`) or non-finite are rejected at load time with
//! file:line; `gpecnet eval` on a test set with no window fails instead of printing NaN.

use crate::common;

use std::path::{Path, PathBuf};

use common::*;
use gpecnet_trainer::data::{self, DataError, Unit};
use gpecnet_trainer::eval::{self, EvalError, Prediction};

fn blob() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../weights/sdd-tiny.gpec")
}

/// An SDD file whose 3rd trajectory's 5th row has x = `x`: returns (text, 1-based line).
/// `gpecnet eval` of the shipped blob on the data under `data`, drawing to `svg`.
fn eval_shipped(data: &Path, svg: &Path, extra: &[&str]) -> (bool, String) {
    let blob = blob();
    let args = [
        "eval",
        "--blob",
        s(&blob),
        "--data",
        s(data),
        "--draw",
        s(svg),
    ];
    run_with(&args, extra)
}

fn file_with_x(x: &str) -> (String, usize) {
    let text = sdd_file(4, 0.0);
    let line = 2 * 20 + 5;
    let lines: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i + 1 == line {
                let c: Vec<&str> = l.split(' ').collect();
                format!("{} {} {x} {}", c[0], c[1], c[3])
            } else {
                l.to_string()
            }
        })
        .collect();
    (lines.join("\n") + "\n", line)
}

#[test]
fn coordinates_beyond_the_core_range_are_rejected_with_file_and_line() {
    let dir = temp_dir("range");
    let p = dir.join("s.txt");
    for bad in ["1e30", "-1000000.5", "2000000"] {
        let (text, line) = file_with_x(bad);
        std::fs::write(&p, text).unwrap();
        let e = data::parse_sdd_file(&p).unwrap_err();
        assert!(
            matches!(e, DataError::OutOfRange { column: 3, .. }),
            "{bad}: {e:?}"
        );
        assert_eq!(e.line(), Some(line));
        let msg = e.to_string();
        assert!(msg.contains(&format!("s.txt:{line}:")), "{msg}");
        assert!(msg.contains(bad) && msg.contains("1e6"), "{msg}");
    }
    for bad in ["inf", "NaN", "1e39"] {
        let (text, line) = file_with_x(bad);
        std::fs::write(&p, text).unwrap();
        let e = data::parse_sdd_file(&p).unwrap_err();
        assert!(matches!(e, DataError::NonFinite { .. }), "{bad}: {e:?}");
        assert_eq!(e.line(), Some(line));
    }
    // The bound itself is accepted.
    for ok in ["1000000", "-1e6", "999999.9"] {
        std::fs::write(&p, file_with_x(ok).0).unwrap();
        assert_eq!(data::parse_sdd_file(&p).unwrap().len(), 4, "{ok}");
    }

    // Training on such a file fails at load time with file:line, exit status != 0.
    tiny_data(&dir);
    let (text, line) = file_with_x("1e30");
    std::fs::write(dir.join("sdd/train/b.txt"), text).unwrap();
    let cfg = write_config(&dir, "");
    let (ok, out) = train(&dir, &dir.join("run"), &["--config", cfg.to_str().unwrap()]);
    assert!(!ok, "{out}");
    assert!(out.contains(&format!("b.txt:{line}: column 3")), "{out}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn evaluating_no_window_is_an_error_not_nan() {
    let empty = data::Dataset {
        name: "empty".into(),
        unit: Unit::Pixels,
        windows: Vec::new(),
    };
    let r = eval::evaluate(&empty, |_| Prediction::single([[0.0; 2]; data::FUTURE]));
    assert!(matches!(r, Err(EvalError::NoWindows)), "{r:?}");

    // `gpecnet eval` on a test folder whose only file is empty.
    let dir = temp_dir("eval-empty");
    std::fs::create_dir_all(dir.join("sdd/test")).unwrap();
    std::fs::write(dir.join("sdd/test/empty.txt"), "").unwrap();
    let svg = dir.join("p.svg");
    for json in [false, true] {
        let (ok, text) = eval_shipped(&dir, &svg, if json { &["--json"] } else { &[] });
        assert!(!ok, "{text}");
        assert!(text.contains("no window"), "{text}");
        assert!(!text.contains("NaN"), "{text}");
    }

    // A test file with an absurd coordinate: file:line, exit status != 0.
    let (text, line) = file_with_x("1e30");
    std::fs::write(dir.join("sdd/test/empty.txt"), text).unwrap();
    let (ok, text) = eval_shipped(&dir, &svg, &[]);
    assert!(!ok, "{text}");
    assert!(
        text.contains(&format!("empty.txt:{line}: column 3")),
        "{text}"
    );
    let _ = std::fs::remove_dir_all(dir);
}
