//! Policy-gradient agents (paper: "Deep Policy Gradient Network"): an 8 → 16 → 8 → 4 ReLU MLP
//! with a Gaussian policy, trained with REINFORCE in the HMM playground on the paper's reward.
//!
//! * **State** (8 inputs): `x/S, y/S, goal x/S, goal y/S, fitness, patience, sociability,
//!   min(distance to nearest agent / S, 1)` with `S` the playground side (400 px).
//! * **Action** (4 outputs, Gaussian policy `a ~ N(μ(s), σ² I)`, σ = [`POLICY_STD`]):
//!   speed `= 100 px/s · clamp(a₀, 0, 1)`, direction `= bearing to goal + π a₁`,
//!   acceleration magnitude `= 50 px/s² · clamp(a₂, 0, 1)`, acceleration direction
//!   `= bearing to goal + π a₃`. One 0.4 s step moves by `v Δt + ½ acc Δt²`. Directions are
//!   relative to the goal bearing so that a small network can express "walk to the goal".
//! * **Reward** ([`reward`]), exactly the paper's
//!   `R_t = AF^t (n_ICS + 1)^(AS + AP) / (t² (1 + ‖G − x_t‖₂))`, `t = 1..19`, distances in px,
//!   `n_ICS` = HMM agents within the proximity radius of the new position. (Note that as
//!   written the collision factor is ≥ 1: it *raises* the reward of reckless agents; the
//!   formula is implemented as published.)
//! * **REINFORCE**: `J(φ) = −Σ_t log π_φ(a_t | s_t) Â_t`, averaged over a batch of episodes,
//!   where `Â_t` is the reward-to-go `Σ_{k ≥ t} R_k` minus its batch mean at the same `t`
//!   (a per-step baseline), divided by the batch standard deviation. Adam, hand-written.
//!
//! All arithmetic is f64; the gradient is hand-written and checked against finite differences
//! in `tests/synth_agent.rs`.

use crate::data::WINDOW;
use crate::rng::Rng;

use super::hmm::{n_ics, random_point, Attributes, Playground};
use super::Traj;

/// Layer widths.
pub const LAYERS: [usize; 4] = [8, 16, 8, 4];
/// Standard deviation of the Gaussian policy.
pub const POLICY_STD: f64 = 0.3;
/// Playground side, px.
pub const PLAYGROUND: f32 = 400.0;
/// Number of HMM agents in an episode.
pub const HMM_AGENTS: usize = 6;
/// Maximum speed, px/s.
pub const VMAX: f64 = 100.0;
/// Maximum acceleration, px/s².
pub const AMAX: f64 = 50.0;

/// The paper's reward `R_t = AF^t (n_ICS + 1)^(AS + AP) / (t² (1 + dist))` (`t ≥ 1`).
pub fn reward(t: usize, attrs: &Attributes, n_ics: usize, dist_to_goal: f64) -> f64 {
    let t = t as f64;
    (attrs.fitness as f64).powf(t)
        * ((n_ics + 1) as f64).powf(attrs.sociability as f64 + attrs.patience as f64)
        / (t * t * (1.0 + dist_to_goal))
}

/// The 8 → 16 → 8 → 4 MLP; parameters stored flat, per layer `W` (row-major, out × in) then `b`.
#[derive(Debug, Clone, PartialEq)]
pub struct Mlp {
    /// All parameters.
    pub params: Vec<f64>,
}

/// Activations kept by [`Mlp::forward`] for the backward pass.
#[derive(Debug, Clone)]
pub struct Cache {
    /// Input and post-activation output of every layer (`acts[0]` = input).
    pub acts: Vec<Vec<f64>>,
}

impl Mlp {
    /// Number of parameters: 8·16+16 + 16·8+8 + 8·4+4 = 316.
    pub fn n_params() -> usize {
        LAYERS.windows(2).map(|w| w[0] * w[1] + w[1]).sum()
    }

    /// He-normal weights (`std = sqrt(2/fan_in)`, last layer × 0.1), zero biases.
    pub fn new(rng: &mut Rng) -> Mlp {
        let mut params = Vec::with_capacity(Self::n_params());
        for (l, w) in LAYERS.windows(2).enumerate() {
            let last = l == LAYERS.len() - 2;
            let std = (2.0 / w[0] as f64).sqrt() * if last { 0.1 } else { 1.0 };
            for _ in 0..w[0] * w[1] {
                params.push(rng.normal() as f64 * std);
            }
            params.extend(std::iter::repeat_n(0.0, w[1]));
        }
        Mlp { params }
    }

    /// Forward pass: ReLU on hidden layers, linear output.
    pub fn forward(&self, x: &[f64]) -> (Vec<f64>, Cache) {
        let mut acts = vec![x.to_vec()];
        let mut off = 0;
        for (l, w) in LAYERS.windows(2).enumerate() {
            let (nin, nout) = (w[0], w[1]);
            let input = &acts[l];
            let (wm, b) = (
                &self.params[off..off + nin * nout],
                &self.params[off + nin * nout..off + nin * nout + nout],
            );
            let mut out = vec![0.0; nout];
            for j in 0..nout {
                let mut s = b[j];
                for i in 0..nin {
                    s += wm[j * nin + i] * input[i];
                }
                out[j] = if l < LAYERS.len() - 2 { s.max(0.0) } else { s };
            }
            off += nin * nout + nout;
            acts.push(out);
        }
        (acts[acts.len() - 1].clone(), Cache { acts })
    }

    /// Accumulate `∂(g · output)/∂params` into `grad` given `g = ∂L/∂output`.
    pub fn backward(&self, cache: &Cache, g_out: &[f64], grad: &mut [f64]) {
        let nl = LAYERS.len() - 1;
        let mut offs = Vec::with_capacity(nl);
        let mut off = 0;
        for w in LAYERS.windows(2) {
            offs.push(off);
            off += w[0] * w[1] + w[1];
        }
        let mut g = g_out.to_vec();
        for l in (0..nl).rev() {
            let (nin, nout) = (LAYERS[l], LAYERS[l + 1]);
            if l < nl - 1 {
                for (gj, &a) in g.iter_mut().zip(&cache.acts[l + 1]) {
                    if a <= 0.0 {
                        *gj = 0.0;
                    }
                }
            }
            let o = offs[l];
            let input = &cache.acts[l];
            let mut g_in = vec![0.0; nin];
            for j in 0..nout {
                for i in 0..nin {
                    grad[o + j * nin + i] += g[j] * input[i];
                    g_in[i] += self.params[o + j * nin + i] * g[j];
                }
                grad[o + nin * nout + j] += g[j];
            }
            g = g_in;
        }
    }
}

/// `log N(a; μ, σ² I)`.
pub fn log_prob(a: &[f64], mu: &[f64]) -> f64 {
    let s2 = POLICY_STD * POLICY_STD;
    a.iter()
        .zip(mu)
        .map(|(a, m)| {
            -(a - m) * (a - m) / (2.0 * s2)
                - POLICY_STD.ln()
                - 0.5 * (2.0 * std::f64::consts::PI).ln()
        })
        .sum()
}

/// `∇_params log π(a | s)` (added into `grad`, scaled by `scale`).
pub fn grad_log_prob(net: &Mlp, s: &[f64], a: &[f64], scale: f64, grad: &mut [f64]) {
    let (mu, cache) = net.forward(s);
    let g: Vec<f64> = a
        .iter()
        .zip(&mu)
        .map(|(a, m)| scale * (a - m) / (POLICY_STD * POLICY_STD))
        .collect();
    net.backward(&cache, &g, grad);
}

/// The RL agent's state vector.
pub fn state(pos: [f32; 2], goal: [f32; 2], attrs: &Attributes, nearest: f32) -> [f64; 8] {
    let s = PLAYGROUND as f64;
    [
        pos[0] as f64 / s,
        pos[1] as f64 / s,
        goal[0] as f64 / s,
        goal[1] as f64 / s,
        attrs.fitness as f64,
        attrs.patience as f64,
        attrs.sociability as f64,
        (nearest as f64 / s).min(1.0),
    ]
}

/// Displacement of one step for an action (see the module docs).
pub fn displacement(pos: [f32; 2], goal: [f32; 2], a: &[f64]) -> [f64; 2] {
    let dt = super::DT as f64;
    let bearing = (goal[1] as f64 - pos[1] as f64).atan2(goal[0] as f64 - pos[0] as f64);
    let pi = std::f64::consts::PI;
    let speed = VMAX * a[0].clamp(0.0, 1.0);
    let dir = bearing + pi * a[1];
    let acc = AMAX * a[2].clamp(0.0, 1.0);
    let adir = bearing + pi * a[3];
    [
        speed * dir.cos() * dt + 0.5 * acc * adir.cos() * dt * dt,
        speed * dir.sin() * dt + 0.5 * acc * adir.sin() * dt * dt,
    ]
}

/// One recorded episode.
#[derive(Debug, Clone)]
pub struct Episode {
    /// Attributes of the RL agent.
    pub attrs: Attributes,
    /// Goal.
    pub goal: [f32; 2],
    /// The RL agent's 20 positions (playground coordinates).
    pub track: Traj,
    /// The HMM agents' 20 positions.
    pub others: Vec<Traj>,
    /// States `s_0..s_18`.
    pub states: Vec<[f64; 8]>,
    /// Actions `a_0..a_18`.
    pub actions: Vec<[f64; 4]>,
    /// Rewards `R_1..R_19`.
    pub rewards: Vec<f64>,
    /// `n_ICS` at each step.
    pub n_ics: Vec<usize>,
}

impl Episode {
    /// Sum of rewards.
    pub fn total_reward(&self) -> f64 {
        self.rewards.iter().sum()
    }

    /// Distance from the last position to the goal, px.
    pub fn final_distance(&self) -> f64 {
        let p = self.track[WINDOW - 1];
        (p[0] as f64 - self.goal[0] as f64).hypot(p[1] as f64 - self.goal[1] as f64)
    }
}

/// Run one 19-step episode in a fresh HMM playground. `greedy` uses the mean action.
pub fn rollout(net: &Mlp, rng: &mut Rng, greedy: bool) -> Episode {
    let mut pg = Playground::new(HMM_AGENTS, PLAYGROUND, rng);
    let attrs = Attributes::random(rng);
    let mut pos = random_point(PLAYGROUND, rng);
    let mut goal = random_point(PLAYGROUND, rng);
    for _ in 0..50 {
        let d = (goal[0] - pos[0]).hypot(goal[1] - pos[1]);
        if (150.0..=300.0).contains(&d) {
            break;
        }
        goal = random_point(PLAYGROUND, rng);
    }
    let mut ep = Episode {
        attrs,
        goal,
        track: [[0.0; 2]; WINDOW],
        others: Vec::new(),
        states: Vec::new(),
        actions: Vec::new(),
        rewards: Vec::new(),
        n_ics: Vec::new(),
    };
    ep.track[0] = pos;
    for t in 1..WINDOW {
        let nearest = pg
            .agents
            .iter()
            .map(|a| (a.pos[0] - pos[0]).hypot(a.pos[1] - pos[1]))
            .fold(f32::MAX, f32::min);
        let s = state(pos, goal, &attrs, nearest);
        let (mu, _) = net.forward(&s);
        let mut a = [0.0; 4];
        for (ai, m) in a.iter_mut().zip(&mu) {
            *ai = if greedy {
                *m
            } else {
                m + POLICY_STD * rng.normal() as f64
            };
        }
        let d = displacement(pos, goal, &a);
        pos = [
            (pos[0] as f64 + d[0]).clamp(0.0, PLAYGROUND as f64) as f32,
            (pos[1] as f64 + d[1]).clamp(0.0, PLAYGROUND as f64) as f32,
        ];
        pg.step(&[pos], rng);
        let others: Vec<[f32; 2]> = pg.agents.iter().map(|a| a.pos).collect();
        let n = n_ics(pos, &others, pg.radius);
        let dist = (pos[0] as f64 - goal[0] as f64).hypot(pos[1] as f64 - goal[1] as f64);
        ep.states.push(s);
        ep.actions.push(a);
        ep.rewards.push(reward(t, &attrs, n, dist));
        ep.n_ics.push(n);
        ep.track[t] = pos;
    }
    ep.others = pg
        .agents
        .iter()
        .map(|a| {
            let mut t = [[0.0; 2]; WINDOW];
            t.copy_from_slice(&a.track[..WINDOW]);
            t
        })
        .collect();
    ep
}

/// REINFORCE gradient of `J` (to be *minimised*) for a batch of episodes (see module docs).
#[allow(clippy::needless_range_loop)]
pub fn reinforce_grad(net: &Mlp, batch: &[Episode]) -> Vec<f64> {
    let steps = WINDOW - 1;
    let rtg: Vec<Vec<f64>> = batch
        .iter()
        .map(|e| {
            let mut g = vec![0.0; steps];
            let mut acc = 0.0;
            for t in (0..steps).rev() {
                acc += e.rewards[t];
                g[t] = acc;
            }
            g
        })
        .collect();
    let nb = batch.len().max(1) as f64;
    let base: Vec<f64> = (0..steps)
        .map(|t| rtg.iter().map(|g| g[t]).sum::<f64>() / nb)
        .collect();
    let adv: Vec<Vec<f64>> = rtg
        .iter()
        .map(|g| g.iter().zip(&base).map(|(a, b)| a - b).collect())
        .collect();
    let n = (adv.len() * steps).max(1) as f64;
    let var = adv.iter().flatten().map(|a| a * a).sum::<f64>() / n;
    let std = var.sqrt().max(1e-12);
    let mut grad = vec![0.0; Mlp::n_params()];
    for (e, a) in batch.iter().zip(&adv) {
        for t in 0..steps {
            // ∂J/∂φ = −Σ ∇log π · Â / B
            grad_log_prob(
                net,
                &e.states[t],
                &e.actions[t],
                -a[t] / std / nb,
                &mut grad,
            );
        }
    }
    grad
}

/// Hand-written Adam.
#[derive(Debug, Clone)]
pub struct Adam {
    m: Vec<f64>,
    v: Vec<f64>,
    t: i32,
    /// Learning rate.
    pub lr: f64,
}

impl Adam {
    /// Zero state for `n` parameters.
    pub fn new(n: usize, lr: f64) -> Adam {
        Adam {
            m: vec![0.0; n],
            v: vec![0.0; n],
            t: 0,
            lr,
        }
    }

    /// One descent step on `params` with gradient `g` (β = 0.9, 0.999, ε = 1e-8).
    pub fn step(&mut self, params: &mut [f64], g: &[f64]) {
        self.t += 1;
        let (b1, b2) = (0.9f64, 0.999f64);
        let c1 = 1.0 - b1.powi(self.t);
        let c2 = 1.0 - b2.powi(self.t);
        for i in 0..params.len() {
            self.m[i] = b1 * self.m[i] + (1.0 - b1) * g[i];
            self.v[i] = b2 * self.v[i] + (1.0 - b2) * g[i] * g[i];
            params[i] -= self.lr * (self.m[i] / c1) / ((self.v[i] / c2).sqrt() + 1e-8);
        }
    }
}

/// One point of the learning curve (per update).
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct CurvePoint {
    /// Episodes seen so far.
    pub episodes: usize,
    /// Mean Σ R_t over the batch.
    pub mean_reward: f64,
    /// Mean final distance to the goal over the batch, px.
    pub mean_final_dist: f64,
    /// Mean number of impending collision states per episode.
    pub mean_ics: f64,
}

/// Training result.
#[derive(Debug, Clone)]
pub struct Trained {
    /// The final policy.
    pub net: Mlp,
    /// One point per update.
    pub curve: Vec<CurvePoint>,
    /// Greedy episodes on the same fixed evaluation seed at 0 %, 25 %, 50 %, 100 % of training.
    pub snapshots: Vec<(usize, Episode)>,
}

/// Train with REINFORCE for `episodes` episodes in batches of `batch` (Adam, `lr`), seeded.
pub fn train(episodes: usize, batch: usize, lr: f64, seed: u64) -> Trained {
    let mut rng = Rng::with_stream(seed, 10);
    let mut net = Mlp::new(&mut rng);
    let mut opt = Adam::new(Mlp::n_params(), lr);
    let batch = batch.max(1);
    let updates = episodes.div_ceil(batch);
    let snap_at = [0, updates / 4, updates / 2, updates];
    let snap = |net: &Mlp| rollout(net, &mut Rng::with_stream(seed, 11), true);
    let mut snapshots = vec![(0, snap(&net))];
    let mut curve = Vec::with_capacity(updates);
    for u in 1..=updates {
        let eps: Vec<Episode> = (0..batch).map(|_| rollout(&net, &mut rng, false)).collect();
        let g = reinforce_grad(&net, &eps);
        opt.step(&mut net.params, &g);
        let nb = eps.len() as f64;
        curve.push(CurvePoint {
            episodes: u * batch,
            mean_reward: eps.iter().map(Episode::total_reward).sum::<f64>() / nb,
            mean_final_dist: eps.iter().map(Episode::final_distance).sum::<f64>() / nb,
            mean_ics: eps
                .iter()
                .map(|e| e.n_ics.iter().sum::<usize>() as f64)
                .sum::<f64>()
                / nb,
        });
        if snap_at[1..].contains(&u) && snapshots.last().map(|s| s.0) != Some(u * batch) {
            snapshots.push((u * batch, snap(&net)));
        }
    }
    Trained {
        net,
        curve,
        snapshots,
    }
}
