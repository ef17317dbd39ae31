//! Policy-gradient agent: the reward formula by hand, the hand-written gradient against finite
//! differences, and learning progress.
#![allow(clippy::needless_range_loop)]

use gpecnet_trainer::rng::Rng;
use gpecnet_trainer::synth::agent::{
    grad_log_prob, log_prob, reinforce_grad, reward, rollout, train, Mlp,
};
use gpecnet_trainer::synth::hmm::Attributes;
use gpecnet_trainer::synth::in_range;

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
fn grad_log_prob_matches_finite_differences() {
    let mut rng = Rng::new(5);
    let net = Mlp::new(&mut rng);
    assert_eq!(net.params.len(), 8 * 16 + 16 + 16 * 8 + 8 + 8 * 4 + 4);
    let s: Vec<f64> = (0..8).map(|_| rng.uniform(0.0, 1.0) as f64).collect();
    let a: Vec<f64> = (0..4).map(|_| rng.normal() as f64).collect();
    let mut g = vec![0.0; net.params.len()];
    grad_log_prob(&net, &s, &a, 1.0, &mut g);
    let f = |n: &Mlp| log_prob(&a, &n.forward(&s).0);
    let h = 1e-6;
    let mut checked = 0;
    for i in 0..net.params.len() {
        let (mut p, mut m) = (net.clone(), net.clone());
        p.params[i] += h;
        m.params[i] -= h;
        let fd = (f(&p) - f(&m)) / (2.0 * h);
        assert!(
            (fd - g[i]).abs() <= 1e-5 * (1.0 + fd.abs()),
            "param {i}: fd {fd} vs {}",
            g[i]
        );
        checked += usize::from(g[i] != 0.0);
    }
    assert!(checked > 100, "only {checked} non-zero gradient entries");
}

#[test]
fn reinforce_surrogate_gradient_matches_finite_differences() {
    // J(φ) = −Σ_e Σ_t log π_φ(a_t|s_t) Â_t / B with Â fixed by the batch: check by FD.
    let mut rng = Rng::new(9);
    let net = Mlp::new(&mut rng);
    let batch: Vec<_> = (0..4).map(|_| rollout(&net, &mut rng, false)).collect();
    let g = reinforce_grad(&net, &batch);
    // Recompute the advantages the same way to define J.
    let steps = 19;
    let rtg: Vec<Vec<f64>> = batch
        .iter()
        .map(|e| (0..steps).map(|t| e.rewards[t..].iter().sum()).collect())
        .collect();
    let base: Vec<f64> = (0..steps)
        .map(|t| rtg.iter().map(|r| r[t]).sum::<f64>() / 4.0)
        .collect();
    let adv: Vec<Vec<f64>> = rtg
        .iter()
        .map(|r| r.iter().zip(&base).map(|(a, b)| a - b).collect())
        .collect();
    let std = (adv.iter().flatten().map(|a| a * a).sum::<f64>() / (4.0 * steps as f64)).sqrt();
    let j = |n: &Mlp| -> f64 {
        let mut s = 0.0;
        for (e, a) in batch.iter().zip(&adv) {
            for t in 0..steps {
                s -= log_prob(&e.actions[t], &n.forward(&e.states[t]).0) * a[t] / std / 4.0;
            }
        }
        s
    };
    for i in (0..net.params.len()).step_by(7) {
        let (mut p, mut m) = (net.clone(), net.clone());
        p.params[i] += 1e-6;
        m.params[i] -= 1e-6;
        let fd = (j(&p) - j(&m)) / 2e-6;
        assert!(
            (fd - g[i]).abs() <= 1e-4 * (1.0 + fd.abs()),
            "param {i}: fd {fd} vs {}",
            g[i]
        );
    }
}

#[test]
fn training_is_reproducible_and_brings_agents_closer_to_the_goal() {
    let a = train(3200, 16, 3e-3, 1);
    let b = train(3200, 16, 3e-3, 1);
    assert_eq!(a.net, b.net);
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
