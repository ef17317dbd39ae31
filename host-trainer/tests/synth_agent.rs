//! Policy-gradient agent: the reward formula by hand, the Gaussian log-density by hand,
//! candle's gradient of the REINFORCE loss against finite differences, and learning progress.

use candle_core::Tensor;
use gpecnet_trainer::rng::Rng;
use gpecnet_trainer::synth::agent::{
    advantages, log_prob, n_params, new_policy, policy_params, reinforce_loss, reward, rollout,
    train, Episode, POLICY_STD,
};
use gpecnet_trainer::synth::hmm::Attributes;
use gpecnet_trainer::synth::in_range;

/// One matmul thread, as `gpecnet rl-train` pins it (unset, candle reads the core count from
/// `/proc` for every matmul).
fn one_thread() {
    gpecnet_trainer::train::set_num_threads(1);
}

fn attrs(f: f32, p: f32, s: f32) -> Attributes {
    Attributes {
        fitness: f,
        patience: p,
        sociability: s,
    }
}

#[test]
fn reward_matches_hand_values() {
    // AF=0.5, t=2, n_ICS=3, AS+AP=1, dist 5: 0.25 · 4 / (4 · 6) = 1/24.
    let r = reward(2, &attrs(0.5, 0.5, 0.5), 3, 5.0);
    assert!((r - 1.0 / 24.0).abs() < 1e-15, "{r}");
    // t=1, no collision, at the goal: AF.
    assert!((reward(1, &attrs(0.8, 0.3, 0.9), 0, 0.0) - 0.8).abs() < 1e-7);
    // AF=1, t=3, n=1, AS=AP=1 → 2^2 / (9 · 2) = 2/9.
    assert!((reward(3, &attrs(1.0, 1.0, 1.0), 1, 1.0) - 2.0 / 9.0).abs() < 1e-15);
    // AF=0 gives 0 for every t ≥ 1.
    assert_eq!(reward(1, &attrs(0.0, 1.0, 1.0), 2, 3.0), 0.0);
}

#[test]
fn log_prob_is_the_gaussian_log_density() {
    let a = [[0.1, -0.2, 0.7, 1.5], [0.0, 0.0, 0.0, 0.0]];
    let mu = [[0.3, 0.1, 0.7, -0.5], [0.0, 0.0, 0.0, 0.0]];
    let lp = log_prob(
        &Tensor::new(&a, &candle_core::Device::Cpu).unwrap(),
        &Tensor::new(&mu, &candle_core::Device::Cpu).unwrap(),
    )
    .unwrap()
    .to_vec1::<f64>()
    .unwrap();
    for (r, lp) in lp.iter().enumerate() {
        let want: f64 = (0..4)
            .map(|j| {
                let z = (a[r][j] - mu[r][j]) / POLICY_STD;
                (-0.5 * z * z).exp() / (POLICY_STD * (2.0 * std::f64::consts::PI).sqrt())
            })
            .map(f64::ln)
            .sum();
        assert!((lp - want).abs() < 1e-12, "row {r}: {lp} vs {want}");
    }
}

/// A fresh policy from `seed` (one candle thread) and `n` sampled (not greedy) episodes of it.
fn policy_and_batch(seed: u64, n: usize) -> (gpecnet_trainer::mlp::Mlp, Vec<Episode>) {
    one_thread();
    let mut rng = Rng::new(seed);
    let net = new_policy(&mut rng).unwrap();
    let batch = (0..n)
        .map(|_| rollout(&net, &mut rng, false).unwrap())
        .collect();
    (net, batch)
}

#[test]
fn advantages_have_zero_mean_per_step_and_unit_rms() {
    let (_, batch) = policy_and_batch(3, 5);
    let adv = advantages(&batch);
    assert_eq!(adv.len(), 5 * 19);
    for t in 0..19 {
        let mean: f64 = (0..5).map(|e| adv[e * 19 + t]).sum::<f64>() / 5.0;
        assert!(mean.abs() < 1e-9, "step {t}: {mean}");
    }
    let rms = (adv.iter().map(|a| a * a).sum::<f64>() / adv.len() as f64).sqrt();
    assert!((rms - 1.0).abs() < 1e-9, "{rms}");
}

/// Writes flat parameters (the order of [`policy_params`]) into the policy's variables.
fn set_params(net: &gpecnet_trainer::mlp::Mlp, p: &[f64]) {
    let mut off = 0;
    for v in net.vars() {
        let n = v.elem_count();
        let t = Tensor::from_slice(&p[off..off + n], v.shape(), &candle_core::Device::Cpu).unwrap();
        v.set(&t).unwrap();
        off += n;
    }
    assert_eq!(off, p.len());
}

#[test]
fn candle_gradient_of_the_reinforce_loss_matches_finite_differences() {
    // J(φ) = −Σ_e Σ_t log π_φ(a_t|s_t) Â_t / B with Â fixed by the batch: candle's backward()
    // against central differences of the loss itself, for every parameter.
    let (net, batch) = policy_and_batch(9, 4);
    let params = policy_params(&net).unwrap();
    assert_eq!(params.len(), n_params());
    assert_eq!(n_params(), 8 * 16 + 16 + 16 * 8 + 8 + 8 * 4 + 4);
    let grads = reinforce_loss(&net, &batch).unwrap().backward().unwrap();
    let mut g = Vec::with_capacity(params.len());
    for v in net.vars() {
        let gv = grads
            .get(v.as_tensor())
            .expect("every parameter has a gradient");
        g.extend(gv.flatten_all().unwrap().to_vec1::<f64>().unwrap());
    }
    let j = |p: &[f64]| -> f64 {
        set_params(&net, p);
        reinforce_loss(&net, &batch)
            .unwrap()
            .to_scalar::<f64>()
            .unwrap()
    };
    let h = 1e-6;
    let mut nonzero = 0;
    for i in 0..params.len() {
        let (mut p, mut m) = (params.clone(), params.clone());
        p[i] += h;
        m[i] -= h;
        let fd = (j(&p) - j(&m)) / (2.0 * h);
        assert!(
            (fd - g[i]).abs() <= 1e-5 * (1.0 + fd.abs()),
            "param {i}: fd {fd} vs candle {}",
            g[i]
        );
        nonzero += usize::from(g[i] != 0.0);
    }
    set_params(&net, &params);
    assert!(nonzero > 100, "only {nonzero} non-zero gradient entries");
}

#[test]
fn training_is_reproducible_and_brings_agents_closer_to_the_goal() {
    one_thread();
    let a = train(3200, 16, 3e-3, 1).unwrap();
    let b = train(3200, 16, 3e-3, 1).unwrap();
    assert_eq!(
        policy_params(&a.net).unwrap(),
        policy_params(&b.net).unwrap()
    );
    let first: f64 = a.curve[..5].iter().map(|c| c.mean_final_dist).sum::<f64>() / 5.0;
    let last: f64 = a.curve[a.curve.len() - 5..]
        .iter()
        .map(|c| c.mean_final_dist)
        .sum::<f64>()
        / 5.0;
    assert!(last < 0.5 * first, "final distance {first} -> {last}");
    for (_, e) in &a.snapshots {
        assert!(e.track.iter().all(|p| p[0].is_finite() && p[1].is_finite()));
        assert!(in_range(&e.track));
    }
}
