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
//!   (a per-step baseline), divided by the batch standard deviation ([`reinforce_loss`]).
//!
//! The network is the trainer's [`Mlp`] (ReLU) with f64 weights; the gradient of `J` is
//! candle's `backward()` and the update the crate's [`Adam`] (`Adam<f64>`). All arithmetic is
//! f64; `tests/synth_agent.rs` checks candle's gradient against central finite differences of
//! the loss. (Earlier the network, its backward pass and a second Adam were
//! hand-written, last at commit a4cb468. Compared with that code, `train(3200, 16, 3e-3, 1)`
//! gives the same learning curve to the last bit and parameters within 4e-16, and 5000 greedy
//! rollouts of the trained policy the same tracks; bit-identity is not guaranteed in general.)

use candle_core::{DType, Device, Tensor, Var};

use crate::data::WINDOW;
use crate::mlp::{Dense, Mlp};
use crate::network::Act;
use crate::optim::{Adam, AdamParams};
use crate::rng::Rng;

use super::hmm::{n_ics, random_goal, random_point, Attributes, Playground};
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

/// Number of policy parameters: 8·16+16 + 16·8+8 + 8·4+4 = 316.
pub fn n_params() -> usize {
    LAYERS.windows(2).map(|w| w[0] * w[1] + w[1]).sum()
}

/// A new policy: the 8 → 16 → 8 → 4 ReLU [`Mlp`] in f64, He-normal weights
/// (`std = sqrt(2/fan_in)`, last layer × 0.1) drawn layer by layer, row-major (out × in), and
/// zero biases.
pub fn new_policy(rng: &mut Rng) -> candle_core::Result<Mlp> {
    let dev = Device::Cpu;
    let mut layers = Vec::with_capacity(LAYERS.len() - 1);
    for (l, w) in LAYERS.windows(2).enumerate() {
        let last = l == LAYERS.len() - 2;
        let std = (2.0 / w[0] as f64).sqrt() * if last { 0.1 } else { 1.0 };
        let weight: Vec<f64> = (0..w[0] * w[1])
            .map(|_| rng.normal() as f64 * std)
            .collect();
        layers.push(Dense {
            weight: Var::from_vec(weight, (w[1], w[0]), &dev)?,
            bias: Var::zeros(w[1], DType::F64, &dev)?,
        });
    }
    Ok(Mlp::from_layers(layers, Act::Relu))
}

/// The policy's parameters, flat: per layer `W` (row-major, out × in) then `b`.
pub fn policy_params(net: &Mlp) -> candle_core::Result<Vec<f64>> {
    let mut out = Vec::with_capacity(n_params());
    for v in net.vars() {
        out.extend(v.as_tensor().flatten_all()?.to_vec1::<f64>()?);
    }
    Ok(out)
}

/// `log N(a; μ, σ² I)` per row: `a`, `mu` `[n, 4]` → `[n]`.
pub fn log_prob(a: &Tensor, mu: &Tensor) -> candle_core::Result<Tensor> {
    let s2 = POLICY_STD * POLICY_STD;
    let c = POLICY_STD.ln() + 0.5 * (2.0 * std::f64::consts::PI).ln();
    (a - mu)?.sqr()?.affine(-1.0 / (2.0 * s2), -c)?.sum(1)
}

/// The policy's mean action `μ(s)` for one state.
pub fn mean_action(net: &Mlp, s: &[f64; 8]) -> candle_core::Result<[f64; 4]> {
    let x = Tensor::from_slice(s, (1, 8), &Device::Cpu)?;
    let mu = net.forward(&x)?.flatten_all()?.to_vec1::<f64>()?;
    mu.try_into()
        .map_err(|_| candle_core::Error::Msg("policy: expected 4 outputs".into()))
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
pub fn rollout(net: &Mlp, rng: &mut Rng, greedy: bool) -> candle_core::Result<Episode> {
    let mut pg = Playground::new(HMM_AGENTS, PLAYGROUND, rng);
    let attrs = Attributes::random(rng);
    let mut pos = random_point(PLAYGROUND, rng);
    let goal = random_goal(pos, PLAYGROUND, 150.0..=300.0, 50, rng);
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
        let mu = mean_action(net, &s)?;
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
    ep.others = pg.trajectories();
    Ok(ep)
}

/// The normalised advantages `Â_t / std` of a batch, episode by episode (`t = 0..18`): the
/// reward-to-go minus its batch mean at the same step, divided by the batch standard
/// deviation of those differences (see the module docs).
pub fn advantages(batch: &[Episode]) -> Vec<f64> {
    let steps = WINDOW - 1;
    let rtg: Vec<Vec<f64>> = batch
        .iter()
        .map(|e| {
            let mut g = vec![0.0; steps];
            let mut acc = 0.0;
            for (g, r) in g.iter_mut().zip(&e.rewards).rev() {
                acc += r;
                *g = acc;
            }
            g
        })
        .collect();
    let nb = batch.len().max(1) as f64;
    let base: Vec<f64> = (0..steps)
        .map(|t| rtg.iter().map(|g| g[t]).sum::<f64>() / nb)
        .collect();
    let adv: Vec<f64> = rtg
        .iter()
        .flat_map(|g| g.iter().zip(&base).map(|(a, b)| a - b))
        .collect();
    let n = adv.len().max(1) as f64;
    let std = (adv.iter().map(|a| a * a).sum::<f64>() / n)
        .sqrt()
        .max(1e-12);
    adv.into_iter().map(|a| a / std).collect()
}

/// The REINFORCE loss `J = −Σ_t log π(a_t | s_t) Â_t / (std · B)` of a batch (to be
/// *minimised*; the advantages are constants, see [`advantages`]) as a scalar tensor whose
/// `backward()` gives the policy gradient. All steps of all episodes go through the network
/// as one `[19 B, 8]` batch.
pub fn reinforce_loss(net: &Mlp, batch: &[Episode]) -> candle_core::Result<Tensor> {
    let dev = Device::Cpu;
    let states: Vec<f64> = batch.iter().flat_map(|e| e.states.concat()).collect();
    let actions: Vec<f64> = batch.iter().flat_map(|e| e.actions.concat()).collect();
    let n = states.len() / 8;
    if n == 0 {
        return Tensor::new(0f64, &dev);
    }
    if actions.len() != 4 * n {
        candle_core::bail!("reinforce: {} action values for {n} states", actions.len());
    }
    let nb = batch.len() as f64;
    let weights: Vec<f64> = advantages(batch).iter().map(|a| -a / nb).collect();
    if weights.len() != n {
        candle_core::bail!("reinforce: {} advantages for {n} steps", weights.len());
    }
    let mu = net.forward(&Tensor::from_vec(states, (n, 8), &dev)?)?;
    let lp = log_prob(&Tensor::from_vec(actions, (n, 4), &dev)?, &mu)?;
    (lp * Tensor::from_vec(weights, n, &dev)?)?.sum_all()
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

impl CurvePoint {
    /// The point after `episodes` episodes in all: the means over `batch`, the last update's
    /// episodes.
    pub fn of(episodes: usize, batch: &[Episode]) -> CurvePoint {
        let mean = |f: fn(&Episode) -> f64| batch.iter().map(f).sum::<f64>() / batch.len() as f64;
        CurvePoint {
            episodes,
            mean_reward: mean(Episode::total_reward),
            mean_final_dist: mean(Episode::final_distance),
            mean_ics: mean(|e| e.n_ics.iter().sum::<usize>() as f64),
        }
    }
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

/// Train with REINFORCE for `episodes` episodes in batches of `batch` (the crate's [`Adam`],
/// `lr`, on gradients from candle's `backward()`), seeded.
pub fn train(episodes: usize, batch: usize, lr: f64, seed: u64) -> candle_core::Result<Trained> {
    let mut rng = Rng::with_stream(seed, 10);
    let net = new_policy(&mut rng)?;
    let mut opt = Adam::<f64>::new(net.vars(), AdamParams::with_lr(lr));
    let batch = batch.max(1);
    let updates = episodes.div_ceil(batch);
    let snap_at = [0, updates / 4, updates / 2, updates];
    let snap = |net: &Mlp| rollout(net, &mut Rng::with_stream(seed, 11), true);
    let mut snapshots = vec![(0, snap(&net)?)];
    let mut curve = Vec::with_capacity(updates);
    for u in 1..=updates {
        let eps = (0..batch)
            .map(|_| rollout(&net, &mut rng, false))
            .collect::<candle_core::Result<Vec<Episode>>>()?;
        opt.backward_step(&reinforce_loss(&net, &eps)?)?;
        curve.push(CurvePoint::of(u * batch, &eps));
        if snap_at[1..].contains(&u) && snapshots.last().map(|s| s.0) != Some(u * batch) {
            snapshots.push((u * batch, snap(&net)?));
        }
    }
    Ok(Trained {
        net,
        curve,
        snapshots,
    })
}
