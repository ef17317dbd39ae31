//! Metric definitions on hand-made predictions, and the constant-velocity baselines on the
//! real test sets. Run with `-- --nocapture` to see the baseline numbers.

use crate::common;

use gpecnet_trainer::baseline::*;
use gpecnet_trainer::data::*;
use gpecnet_trainer::dist::*;
use gpecnet_trainer::eval::*;

fn line_window() -> Window {
    common::line_window("hand", 1.0, [10.0, 20.0], [3.0, -0.5])
}

fn offset(w: &Window, dx: f32, dy: f32) -> [[f32; 2]; FUTURE] {
    let mut f = w.future();
    for p in &mut f {
        p[0] += dx;
        p[1] += dy;
    }
    f
}

#[test]
fn offset_3_4_gives_5() {
    let w = line_window();
    let mut acc = MetricsAccumulator::new();
    acc.add(&w, &Prediction::single(offset(&w, 3.0, 4.0)))
        .unwrap();
    let m = acc.finish();
    assert_eq!((m.n, m.k), (1, 1));
    for v in [
        m.min_ade, m.min_fde, m.ade_k1, m.fde_k1, m.mean_ade, m.mean_fde,
    ] {
        assert!((v - 5.0).abs() < 1e-9, "{m}");
    }
}

#[test]
fn best_of_k_hand_computed() {
    let w = line_window();
    // Sample 0: (3,4) off everywhere -> ADE 5, FDE 5.
    // Sample 1: exact except the endpoint, 12 off in y -> ADE 12/12 = 1, FDE 12.
    let s0 = offset(&w, 3.0, 4.0);
    let mut s1 = w.future();
    s1[FUTURE - 1][1] += 12.0;
    let pred = Prediction {
        trajectories: vec![s0, s1],
    };
    let mut acc = MetricsAccumulator::new();
    acc.add(&w, &pred).unwrap();
    let m = acc.finish();
    assert_eq!(m.k, 2);
    let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
    assert!(close(m.min_ade, 1.0), "{m}");
    assert!(close(m.min_fde, 5.0), "{m}");
    assert!(close(m.ade_k1, 5.0), "{m}");
    assert!(close(m.fde_k1, 5.0), "{m}");
    assert!(close(m.mean_ade, 3.0), "{m}");
    assert!(close(m.mean_fde, 8.5), "{m}");

    // Add a second window predicted exactly by both samples: everything halves.
    let exact = Prediction {
        trajectories: vec![w.future(), w.future()],
    };
    acc.add(&w, &exact).unwrap();
    let m = acc.finish();
    assert_eq!(m.n, 2);
    assert!(
        close(m.min_ade, 0.5) && close(m.min_fde, 2.5) && close(m.mean_fde, 4.25),
        "{m}"
    );

    // Scaled: errors times 0.1.
    let mut sc = MetricsAccumulator::new();
    sc.add_scaled(&w, &pred, 0.1).unwrap();
    assert!(close(sc.finish().min_fde, 0.5));
}

#[test]
fn merge_equals_sequential() {
    let w = line_window();
    let preds: Vec<Prediction> = (0..6)
        .map(|i| Prediction {
            trajectories: vec![offset(&w, i as f32, 0.0), offset(&w, 0.0, 2.0 * i as f32)],
        })
        .collect();
    let mut all = MetricsAccumulator::new();
    let (mut a, mut b) = (MetricsAccumulator::new(), MetricsAccumulator::new());
    for (i, p) in preds.iter().enumerate() {
        all.add(&w, p).unwrap();
        if i < 2 { &mut a } else { &mut b }.add(&w, p).unwrap();
    }
    let mut merged = MetricsAccumulator::new();
    merged.merge(&a).unwrap();
    merged.merge(&b).unwrap();
    let (x, y) = (all.finish(), merged.finish());
    assert_eq!(x.n, y.n);
    assert!((x.mean_ade - y.mean_ade).abs() < 1e-12 && (x.min_fde - y.min_fde).abs() < 1e-12);
    // Per window min ADE = min(i, 2i) = i, so the mean over i = 0..6 is 15/6.
    assert!((x.min_ade - 2.5).abs() < 1e-9, "{x}");
}

#[test]
fn errors_and_empty() {
    let w = line_window();
    let mut acc = MetricsAccumulator::new();
    assert!(acc.finish().min_ade.is_nan());
    assert_eq!(acc.finish().n, 0);
    assert!(matches!(
        acc.add(&w, &Prediction::default()),
        Err(EvalError::EmptyPrediction { .. })
    ));
    acc.add(&w, &Prediction::single(w.future())).unwrap();
    let two = Prediction {
        trajectories: vec![w.future(); 2],
    };
    assert_eq!(
        acc.add(&w, &two),
        Err(EvalError::KMismatch {
            expected: 1,
            found: 2
        })
    );
    let mut nan = w.future();
    nan[3][0] = f32::NAN;
    assert!(matches!(
        acc.add(&w, &Prediction::single(nan)),
        Err(EvalError::NonFinite { sample: 0, .. })
    ));
    assert_eq!(acc.len(), 1);
    let m = acc.finish();
    assert_eq!(m.min_ade, 0.0);
}

#[test]
fn constant_velocity_is_exact_on_straight_lines() {
    let w = line_window();
    assert_eq!(constant_velocity(&w), w.future());
    assert_eq!(constant_velocity_avg(&w), w.future());
    // Last-step vs averaged velocity differ when only the last step changes.
    let mut bent = w.clone();
    bent.pos[PAST - 1] = [bent.pos[PAST - 2][0] + 6.0, bent.pos[PAST - 2][1]];
    let cv = constant_velocity(&bent);
    assert_eq!(cv[0], [bent.pos[PAST - 1][0] + 6.0, bent.pos[PAST - 1][1]]);
    let avg = constant_velocity_avg(&bent);
    let v = [
        (bent.pos[7][0] - bent.pos[0][0]) / 7.0,
        (bent.pos[7][1] - bent.pos[0][1]) / 7.0,
    ];
    assert!((avg[11][0] - (bent.pos[7][0] + 12.0 * v[0])).abs() < 1e-4);
    assert!((avg[11][1] - (bent.pos[7][1] + 12.0 * v[1])).abs() < 1e-4);
}

fn check_baseline(m: &Metrics, lo: f64, hi: f64) {
    for v in [
        m.min_ade, m.min_fde, m.ade_k1, m.fde_k1, m.mean_ade, m.mean_fde,
    ] {
        assert!(v.is_finite(), "{m}");
    }
    assert_eq!(m.k, 1);
    // With K = 1, all three flavours coincide.
    assert_eq!(m.min_ade, m.ade_k1);
    assert_eq!(m.min_fde, m.mean_fde);
    assert!(m.min_fde > m.min_ade, "{m}");
    assert!((lo..hi).contains(&m.min_ade), "{m}");
}

#[test]
fn cv_baseline_sdd_test() {
    let root = default_data_root();
    let ds = load_sdd(&root, SddSplit::Test).unwrap();
    let cv = evaluate_baseline(&ds, constant_velocity);
    let cva = evaluate_baseline(&ds, constant_velocity_avg);
    println!("SDD test (px), constant velocity (last step): {cv}");
    println!("SDD test (px), constant velocity (7-step avg): {cva}");
    assert_eq!(cv.n, 2829);
    check_baseline(&cv, 5.0, 60.0);
    check_baseline(&cva, 5.0, 60.0);

    // Metres, with per-scene factors.
    let scales = sdd_metres_per_pixel(&root).unwrap();
    let mut acc = MetricsAccumulator::new();
    for w in &ds.windows {
        let s = scales[&w.scene];
        acc.add_scaled(w, &Prediction::single(constant_velocity(w)), s)
            .unwrap();
    }
    let m = acc.finish();
    println!("SDD test (m), constant velocity (last step): {m}");
    check_baseline(&m, 0.2, 3.0);
}

#[test]
fn cv_baseline_eth_ucy_test() {
    let root = default_data_root();
    for scene in ETH_UCY_SCENES {
        let ds = load_eth_ucy(&root, scene, EthUcySplit::Test).unwrap();
        let cv = evaluate_baseline(&ds, constant_velocity);
        let cva = evaluate_baseline(&ds, constant_velocity_avg);
        println!("{scene} test (m), constant velocity (last step): {cv}");
        println!("{scene} test (m), constant velocity (7-step avg): {cva}");
        assert_eq!(cv.n, ds.len());
        check_baseline(&cv, 0.1, 3.0);
        check_baseline(&cva, 0.1, 3.0);
    }
}

#[test]
fn metres_per_pixel_table() {
    let s = sdd_metres_per_pixel(&default_data_root()).unwrap();
    assert_eq!(s.len(), 54);
    assert_eq!(s["gates_0"], 0.03976968);
    let ds = load_sdd(&default_data_root(), SddSplit::Train).unwrap();
    assert!(ds.scenes().iter().all(|sc| s.contains_key(sc)));
}

#[test]
fn bad_metres_per_pixel_table() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("sdd/scales");
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(
        d.join("sdd_meters_per_pixel.csv"),
        "scene,meters_per_pixel\na,0.1\nb,x\n",
    )
    .unwrap();
    let e = sdd_metres_per_pixel(dir.path()).unwrap_err();
    assert!(matches!(e, DataError::BadScale { line: 3, .. }), "{e:?}");
    let e = sdd_metres_per_pixel(&dir.path().join("nope")).unwrap_err();
    assert!(matches!(e, DataError::Missing { .. }), "{e:?}");
}

#[test]
fn kde_nll_and_hit_rates_on_hand_made_sets() {
    // scipy 1.17: -gaussian_kde(pts.T).logpdf([2, 1]) = 5.921155544059406.
    let pts = [
        [0.0, 0.0],
        [10.0, 2.0],
        [3.0, -7.0],
        [-4.0, 5.0],
        [8.0, 8.0],
    ];
    assert!((kde_nll(&pts, [2.0, 1.0]) - 5.921155544059406).abs() < 1e-6);
    // Floor: log-density never below -20, so NLL never above 20; degenerate sets are finite.
    assert_eq!(kde_nll(&pts, [5000.0, 0.0]), -KDE_LOG_PDF_FLOOR);
    assert!(kde_nll(&[[1.0, 1.0]; 20], [1.0, 1.0]).is_finite());

    // Two windows through DistAccumulator::add (trajectories' last points vs Window::endpoint).
    let w = line_window();
    let near = offset(&w, 12.0, 16.0); // 20 from the truth: within 20 (inclusive)
    let far = offset(&w, 30.0, 0.0); // 30: within 40 only
    let mut acc = DistAccumulator::new();
    acc.add(
        &w,
        &Prediction {
            trajectories: vec![near, far],
        },
    );
    acc.add(&w, &Prediction::single(far));
    assert_eq!(acc.len(), 2);
    assert_eq!(acc.within(20.0), 0.5);
    assert_eq!(acc.within(40.0), 1.0);
    assert_eq!(acc.within(19.999), 0.0);
    let d = acc.finish().unwrap();
    assert_eq!((d.hit20, d.hit40), (0.5, 1.0));
    assert!(d.kde_nll.is_finite() && d.kde_nll <= 20.0);
    assert!(DistAccumulator::new().finish().is_none());
}

#[test]
fn constant_velocity_n_on_sdd() {
    let root = default_data_root();
    let (_, val) = split_by_scene(
        load_sdd(&root, SddSplit::Train).unwrap(),
        &default_sdd_val_scenes(),
    );
    let test = load_sdd(&root, SddSplit::Test).unwrap();
    // n = 1 and n = 7 are the named baselines, bit for bit.
    let sweep = cv_sweep(&test);
    assert_eq!(sweep.len(), 7);
    assert_eq!(sweep[0], evaluate_baseline(&test, constant_velocity));
    assert_eq!(sweep[6], evaluate_baseline(&test, constant_velocity_avg));
    for w in test.windows.iter().step_by(97) {
        assert_eq!(constant_velocity_n(w, 1), constant_velocity(w));
        assert_eq!(constant_velocity_n(w, 7), constant_velocity_avg(w));
    }
    let (n, val_sweep) = select_cv_n(&val).unwrap();
    assert_eq!(val.len(), 846);
    assert!((1..=7).contains(&n));
    assert!(val_sweep
        .iter()
        .all(|m| m.fde_k1 >= val_sweep[n - 1].fde_k1));
    for (i, (v, t)) in val_sweep.iter().zip(&sweep).enumerate() {
        println!(
            "CV n = {}: val ADE/FDE {:.2}/{:.2}, test {:.2}/{:.2}",
            i + 1,
            v.ade_k1,
            v.fde_k1,
            t.ade_k1,
            t.fde_k1
        );
    }
}
