//! The text of every line kind: what the firmware (defmt) and the host
//! (`golden-host`) print and `cargo xtask qemu` compares.
use gpecnet_replay::{Line, Summary};

/// Every `(text, error)` pair `line` prints.
fn printed(line: Line<'_>) -> Vec<(String, bool)> {
    let mut out = Vec::new();
    line.print(&mut |text, error| out.push((text.to_string(), error)));
    out
}

#[test]
fn every_line_kind_has_its_text() {
    let model = Line::Model {
        model: "m",
        numeric: "f32",
        sine: "libm",
        cases: 3,
    };
    assert_eq!(printed(model), [("model m f32 libm 3".into(), false)]);
    let golden = |ok| Line::Golden {
        model: "m",
        case: 2,
        hash: 0xab,
        ok,
    };
    assert_eq!(
        printed(golden(true)),
        [("golden m 2 000000ab".into(), false)]
    );
    assert_eq!(
        printed(golden(false)),
        [
            ("golden m 2 000000ab".into(), false),
            ("MISMATCH m case 2".into(), true)
        ]
    );
    let xcheck = Line::Xcheck {
        model: "m",
        sine: "fast-f32",
        case: 0,
        hash: 0xdead_beef,
    };
    assert_eq!(
        printed(xcheck),
        [("xcheck m fast-f32 0 deadbeef".into(), false)]
    );
    let resample = Line::Resample {
        frames: 400,
        points: 77,
        hash: 0x0102_0304,
    };
    assert_eq!(
        printed(resample),
        [("resample 400 77 01020304".into(), false)]
    );
    let flight = Line::Flight {
        frames: 360,
        detections: 4_321,
        points: 512,
        hash: 0x00c0_ffee,
    };
    assert_eq!(
        printed(flight),
        [("flight 360 4321 512 00c0ffee".into(), false)]
    );
    let online = Line::Online {
        model: "m",
        frame: 7,
        t_ms: 4_294_967_200,
        forecasts: 2,
        feedback: 3,
        hash: 0xbeef,
    };
    assert_eq!(
        printed(online),
        [("online m 7 4294967200 2 3 0000beef".into(), false)]
    );
    let error = Line::Error {
        model: "m",
        what: "bad blob",
    };
    assert_eq!(printed(error), [("golden m: bad blob".into(), true)]);
    let too_wide = Line::TooWide {
        model: "m",
        needed: 256,
        capacity: 128,
    };
    assert_eq!(
        printed(too_wide),
        [(
            "golden m: model needs scratch width 256 > SCRATCH 128 (firmware/src/lib.rs)".into(),
            true
        )]
    );
}

#[test]
fn summary_line() {
    let s = Summary {
        models: 2,
        cases: 10,
        mismatches: 1,
        errors: 0,
        xchecks: 4,
    };
    assert_eq!(
        s.to_string(),
        "golden summary: models=2 cases=10 mismatches=1 errors=0 xchecks=4"
    );
}
