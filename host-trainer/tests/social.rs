//! PECNet's optional social pooling on the real SDD data: grouping rules, masks, batches that
//! never split groups, the pooling arithmetic against a hand computation, a 2-epoch run with
//! exact resume, and the export refusal.

use crate::common;

use std::path::PathBuf;

use candle_core::{Device, Tensor};
use common::tiny_train_config;
use gpecnet_trainer::checkpoint;
use gpecnet_trainer::config::TrainConfig;
use gpecnet_trainer::data::{self, Window, PAST};
use gpecnet_trainer::model::Model;
use gpecnet_trainer::network::{Act, Layer};
use gpecnet_trainer::rng::Rng;
use gpecnet_trainer::social::{block_mask_values, group_windows, pack_groups, SocialPooling};
use gpecnet_trainer::train::{train_new, train_resume, TrainOptions};

/// Independent re-implementation of PECNet's filter (`find_min_time`, `find_min_dist`).
fn pecnet_filter(a: &Window, b: &Window, time_thresh: i64, dist_thresh: f64) -> bool {
    let mut min_t = i64::MAX;
    for t in &b.frames[..PAST] {
        min_t = min_t.min((a.frames[0] - t).abs());
    }
    for t in &a.frames[..PAST] {
        min_t = min_t.min((b.frames[0] - t).abs());
    }
    if min_t > time_thresh {
        return false;
    }
    let mut min_d = 9e4f64;
    for i in 0..PAST {
        for j in 0..PAST {
            let dx = f64::from(b.pos[i][0]) - f64::from(a.pos[j][0]);
            let dy = f64::from(b.pos[i][1]) - f64::from(a.pos[j][1]);
            min_d = min_d.min((dx * dx + dy * dy).sqrt());
        }
    }
    min_d <= dist_thresh
}

fn sdd_file(name: &str) -> Vec<Window> {
    let p = data::default_data_root()
        .join("sdd")
        .join("train")
        .join(name);
    data::parse_sdd_file(&p).unwrap()
}

#[test]
fn grouping_follows_pecnet_rules_on_one_sdd_file() {
    let w = sdd_file("bookstore_0.txt");
    assert!(w.len() > 50);
    let groups = group_windows(&w, 0, 100.0);

    // A partition of the file's windows.
    let mut seen = vec![false; w.len()];
    for g in &groups {
        for &i in g {
            assert!(!seen[i], "window {i} in two groups");
            seen[i] = true;
        }
    }
    assert!(seen.iter().all(|&s| s));

    // Greedy star test: the anchor is the first remaining window; members pass the filter
    // against the anchor; every window still remaining but left out fails it.
    let mut remaining: Vec<usize> = (0..w.len()).collect();
    for g in &groups {
        let anchor = g[0];
        assert_eq!(anchor, remaining[0], "anchor is the first remaining window");
        for &j in &remaining[1..] {
            let passes = pecnet_filter(&w[anchor], &w[j], 0, 100.0);
            assert_eq!(passes, g.contains(&j), "anchor {anchor}, window {j}");
        }
        // Members in file order after the anchor.
        assert!(g.windows(2).all(|p| p[0] < p[1]));
        remaining.retain(|i| !g.contains(i));
    }
    assert!(remaining.is_empty());
    let multi = groups.iter().filter(|g| g.len() > 1).count();
    assert!(multi > 0, "some pedestrians share a group");
    assert!(groups.len() < w.len());

    // It is a star test, not a transitive closure: with thresholds that pass everything, one
    // group; with impossible ones (negative time), singletons.
    assert_eq!(group_windows(&w, i64::MAX / 4, f64::INFINITY).len(), 1);
    assert_eq!(group_windows(&w, -1, 100.0).len(), w.len());

    // Windows of different files never share a group.
    let mut two = w.clone();
    let mut other = sdd_file("bookstore_1.txt");
    let n0 = two.len();
    two.append(&mut other);
    for g in group_windows(&two, 0, 100.0) {
        assert!(g.iter().all(|&i| i < n0) || g.iter().all(|&i| i >= n0));
    }

    // Batches: groups never split; a batch closes only once it holds >= batch_size rows.
    let groups32: Vec<Vec<u32>> = groups
        .iter()
        .map(|g| g.iter().map(|&i| i as u32).collect())
        .collect();
    let bs = 16;
    let batches = pack_groups(&groups32, bs);
    let flat: Vec<&[u32]> = batches.iter().flatten().copied().collect();
    assert_eq!(
        flat.len(),
        groups32.len(),
        "every group exactly once, whole"
    );
    for (b, batch) in batches.iter().enumerate() {
        let n: usize = batch.iter().map(|g| g.len()).sum();
        let without_last = n - batch.last().unwrap().len();
        assert!(without_last < bs, "batch {b} should have closed earlier");
        if b + 1 < batches.len() {
            assert!(n >= bs, "batch {b} closed too early");
        }
        // Mask: n x n, symmetric, ones on the diagonal, ones exactly within groups.
        let sizes: Vec<usize> = batch.iter().map(|g| g.len()).collect();
        let m = block_mask_values(&sizes);
        assert_eq!(m.len(), n * n);
        let gid: Vec<usize> = sizes
            .iter()
            .enumerate()
            .flat_map(|(k, &s)| std::iter::repeat_n(k, s))
            .collect();
        for r in 0..n {
            assert_eq!(m[r * n + r], 1.0);
            for c in 0..n {
                assert_eq!(m[r * n + c], m[c * n + r]);
                assert_eq!(m[r * n + c], f32::from(u8::from(gid[r] == gid[c])));
            }
        }
    }
}

fn tiny_social() -> TrainConfig {
    TrainConfig {
        num_epochs: 2,
        batch_size: 512,
        activation: Act::Relu,
        social_pooling: true,
        nonlocal_pools: 3,
        non_local_dim: 8,
        non_local_theta_size: vec![16],
        non_local_phi_size: vec![16],
        non_local_g_size: vec![16],
        ..tiny_train_config()
    }
}

fn mlp_f64(layers: &[Layer], x: &[f64]) -> Vec<f64> {
    let mut h = x.to_vec();
    for l in layers {
        h = (0..l.out_dim)
            .map(|o| {
                let s = f64::from(l.b[o])
                    + (0..l.in_dim)
                        .map(|i| f64::from(l.w[o * l.in_dim + i]) * h[i])
                        .sum::<f64>();
                match l.act {
                    Act::Relu => s.max(0.0),
                    Act::Sine => s.sin(),
                    Act::Linear => s,
                }
            })
            .collect();
    }
    h
}

/// `feat + normalize_L1(mask ⊙ softmax(theta phiᵀ)) · g(feat)`, by hand in f64.
fn pool_by_hand(sp: &SocialPooling, feat: &[Vec<f64>], mask: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let (th, ph, g) = (
        sp.theta.export().unwrap(),
        sp.phi.export().unwrap(),
        sp.g.export().unwrap(),
    );
    let t: Vec<Vec<f64>> = feat.iter().map(|f| mlp_f64(&th, f)).collect();
    let p: Vec<Vec<f64>> = feat.iter().map(|f| mlp_f64(&ph, f)).collect();
    let gv: Vec<Vec<f64>> = feat.iter().map(|f| mlp_f64(&g, f)).collect();
    let n = feat.len();
    (0..n)
        .map(|r| {
            let logits: Vec<f64> = (0..n)
                .map(|c| t[r].iter().zip(&p[c]).map(|(a, b)| a * b).sum())
                .collect();
            let mx = logits.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let e: Vec<f64> = logits.iter().map(|l| (l - mx).exp()).collect();
            let s: f64 = e.iter().sum();
            let w: Vec<f64> = (0..n).map(|c| e[c] / s * mask[r][c]).collect();
            let l1 = w.iter().map(|x| x.abs()).sum::<f64>().max(1e-12);
            (0..feat[r].len())
                .map(|d| feat[r][d] + (0..n).map(|c| w[c] / l1 * gv[c][d]).sum::<f64>())
                .collect()
        })
        .collect()
}

#[test]
fn pooling_matches_hand_computation() {
    let cfg = TrainConfig {
        nonlocal_pools: 1,
        ..tiny_social()
    };
    let sp = SocialPooling::new(&cfg, &mut Rng::new(7)).unwrap();
    let d = 2 * cfg.fdim + 2;
    let n = 4;
    let mut rng = Rng::new(3);
    let feat: Vec<Vec<f64>> = (0..n)
        .map(|_| (0..d).map(|_| f64::from(rng.uniform(-1.0, 1.0))).collect())
        .collect();
    let ft = Tensor::from_vec(
        feat.iter()
            .flatten()
            .map(|&x| x as f32)
            .collect::<Vec<f32>>(),
        (n, d),
        &Device::Cpu,
    )
    .unwrap();
    // Identity mask (each pedestrian alone) and a {0,1,2},{3} grouping.
    for sizes in [vec![1, 1, 1, 1], vec![3, 1]] {
        let mv = block_mask_values(&sizes);
        let mask: Vec<Vec<f64>> = (0..n)
            .map(|r| (0..n).map(|c| f64::from(mv[r * n + c])).collect())
            .collect();
        let mt = Tensor::from_vec(mv, (n, n), &Device::Cpu).unwrap();
        let got = sp.pool(&ft, &mt).unwrap().to_vec2::<f32>().unwrap();
        let want = pool_by_hand(&sp, &feat, &mask);
        for (gr, wr) in got.iter().zip(&want) {
            for (a, b) in gr.iter().zip(wr) {
                assert!((f64::from(*a) - b).abs() < 1e-4, "{sizes:?}: {a} vs {b}");
            }
        }
        if sizes == [1, 1, 1, 1] {
            // Alone: the weights are exactly 1 on the diagonal, so pooled = feat + g(feat).
            let g = sp.g.export().unwrap();
            for (r, f) in feat.iter().enumerate() {
                let gf = mlp_f64(&g, f);
                for k in 0..d {
                    assert!((f64::from(got[r][k]) - (f[k] + gf[k])).abs() < 1e-4);
                }
            }
        }
    }
    // Three rounds = three applications of one round, same networks.
    let sp3 = SocialPooling {
        pools: 3,
        ..sp.clone()
    };
    let mt = Tensor::from_vec(block_mask_values(&[3, 1]), (n, n), &Device::Cpu).unwrap();
    let mut once = ft.clone();
    for _ in 0..3 {
        once = sp.pool_once(&once, &mt).unwrap();
    }
    let diff = (sp3.pool(&ft, &mt).unwrap() - once)
        .unwrap()
        .abs()
        .unwrap()
        .max_all()
        .unwrap()
        .to_scalar::<f32>()
        .unwrap();
    assert_eq!(diff, 0.0);
}

#[test]
fn social_model_keeps_old_layout_and_refuses_export() {
    let plain = TrainConfig {
        social_pooling: false,
        ..tiny_social()
    };
    let a = Model::new(&plain, &mut Rng::new(5)).unwrap();
    let b = Model::new(&tiny_social(), &mut Rng::new(5)).unwrap();
    let (wa, wb) = (a.weights().unwrap(), b.weights().unwrap());
    assert!(wb.len() > wa.len());
    assert_eq!(
        &wb[..wa.len()],
        &wa[..],
        "pooling vars come after the existing ones"
    );
    assert!(a.export_networks().is_ok());
    let e = b.export_networks().unwrap_err().to_string();
    assert!(e.contains("social pooling"), "{e}");
    // Without a mask the forward pass of a social model is a clear error.
    let obs = Tensor::zeros((2, 2 * PAST), candle_core::DType::F32, &Device::Cpu).unwrap();
    let init = Tensor::zeros((2, 2), candle_core::DType::F32, &Device::Cpu).unwrap();
    let z = Tensor::zeros((2, 4), candle_core::DType::F32, &Device::Cpu).unwrap();
    assert!(b.sample_future(&obs, &init, &z, None).is_err());
}

fn run_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gpecnet-social-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn opts(dir: &std::path::Path, stop_after: Option<usize>) -> TrainOptions {
    TrainOptions {
        data_root: data::default_data_root(),
        run_dir: dir.to_path_buf(),
        epochs: None,
        quiet: true,
        stop_after,
        force: false,
    }
}

#[test]
fn two_epochs_with_social_pooling_train_validate_and_resume() {
    let straight = run_dir("straight");
    let s = train_new(tiny_social(), &opts(&straight, None)).unwrap();
    assert_eq!(s.epochs_done, 2);
    let v = s.last_val.expect("validated");
    assert!(v.min_ade.is_finite() && v.min_fde.is_finite() && v.min_fde > 0.0);
    assert!(v.fde_k1 >= v.min_fde);

    let killed = run_dir("killed");
    train_new(tiny_social(), &opts(&killed, Some(1))).unwrap();
    let s2 = train_resume(&opts(&killed, None)).unwrap();
    assert_eq!(s2.epochs_done, 2);
    let (a, b) = (
        checkpoint::load(&straight).unwrap(),
        checkpoint::load(&killed).unwrap(),
    );
    assert_eq!(a.weights, b.weights, "social run resumes bit-exactly");
    assert_eq!(a.rng, b.rng);
    assert!(a.config_toml.contains("social_pooling = true"));
    for d in [straight, killed] {
        let _ = std::fs::remove_dir_all(d);
    }
}
