//! The HMM interaction playground: agents whose motion is driven by a hidden Markov chain over
//! motion states, with circular proximity detection.
//!
//! * Hidden states [`State`]: walk, slow, stop, turn, with the transition matrix
//!   [`TRANSITIONS`] (row = current state, column = next state).
//! * Emissions: the state sets the speed factor (walk 1, slow 0.4, stop 0, turn 0.8 of the
//!   agent's preferred speed) and the heading (towards the goal with N(0, 0.1 rad) noise; in
//!   `turn`, the previous heading plus N(0, 0.6 rad)).
//! * Agents have fitness, patience and sociability drawn uniformly in `[0, 1]`; preferred speed
//!   `20 + 60·fitness` px/s.
//! * **Proximity detection**: an agent is in an *impending collision state* with every other
//!   agent closer than [`Playground::radius`] (circular, default 40 px); `n_ICS` counts them.
//! * **Interaction**: when `n_ICS > 0` the agent's transition row is mixed with a "yield" row
//!   (`slow` 0.5, `stop` 0.5) with weight `(sociability + patience) / 2`: considerate agents
//!   slow down or stop for others, reckless ones keep going.
//! * An agent within 10 px of its goal stops.

use crate::data::WINDOW;
use crate::rng::Rng;

use super::{Traj, DT};

/// Hidden motion state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum State {
    /// Walk at the preferred speed towards the goal.
    Walk,
    /// Walk at 0.4 × the preferred speed.
    Slow,
    /// Stand still.
    Stop,
    /// Wander: heading changes randomly.
    Turn,
}

impl State {
    const ALL: [State; 4] = [State::Walk, State::Slow, State::Stop, State::Turn];

    fn index(self) -> usize {
        self as usize
    }

    /// Speed factor emitted by this state.
    pub fn speed_factor(self) -> f32 {
        match self {
            State::Walk => 1.0,
            State::Slow => 0.4,
            State::Stop => 0.0,
            State::Turn => 0.8,
        }
    }
}

/// Transition matrix `P[next | current]`, rows in the order walk, slow, stop, turn.
pub const TRANSITIONS: [[f32; 4]; 4] = [
    [0.85, 0.07, 0.03, 0.05],
    [0.30, 0.55, 0.10, 0.05],
    [0.25, 0.15, 0.55, 0.05],
    [0.60, 0.10, 0.05, 0.25],
];

const YIELD: [f32; 4] = [0.0, 0.5, 0.5, 0.0];

/// Personality of an agent, each in `[0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Attributes {
    /// AF: drives the preferred speed (and, for RL agents, discounting of the reward).
    pub fitness: f32,
    /// AP.
    pub patience: f32,
    /// AS.
    pub sociability: f32,
}

impl Attributes {
    /// Uniform in `[0, 1]³`.
    pub fn random(rng: &mut Rng) -> Attributes {
        Attributes {
            fitness: rng.unit_f32(),
            patience: rng.unit_f32(),
            sociability: rng.unit_f32(),
        }
    }
}

/// One HMM-driven agent.
#[derive(Debug, Clone, PartialEq)]
pub struct HmmAgent {
    /// Current position, px.
    pub pos: [f32; 2],
    /// Goal, px.
    pub goal: [f32; 2],
    /// Heading, rad.
    pub heading: f32,
    /// Hidden state.
    pub state: State,
    /// Personality.
    pub attrs: Attributes,
    /// Positions so far (starting with the initial one).
    pub track: Vec<[f32; 2]>,
}

/// Number of positions in `others` strictly closer than `radius` to `p` (impending collision
/// states).
pub fn n_ics(p: [f32; 2], others: &[[f32; 2]], radius: f32) -> usize {
    others
        .iter()
        .filter(|o| (o[0] - p[0]).hypot(o[1] - p[1]) < radius)
        .count()
}

/// Draw a categorical index from probabilities (that sum to ~1).
fn categorical(p: &[f32; 4], rng: &mut Rng) -> usize {
    let u = rng.unit_f32() * p.iter().sum::<f32>();
    let mut acc = 0.0;
    for (i, &q) in p.iter().enumerate() {
        acc += q;
        if u < acc {
            return i;
        }
    }
    3
}

/// A square playground `[0, size]²` of HMM agents.
#[derive(Debug, Clone)]
pub struct Playground {
    /// Side, px.
    pub size: f32,
    /// Proximity radius, px.
    pub radius: f32,
    /// The agents.
    pub agents: Vec<HmmAgent>,
}

/// A random point of `[margin, size − margin]²`.
pub fn random_point(size: f32, rng: &mut Rng) -> [f32; 2] {
    let m = 0.1 * size;
    [rng.uniform(m, size - m), rng.uniform(m, size - m)]
}

/// A goal for an agent at `pos`: a [`random_point`], redrawn up to `tries` times until its
/// distance from `pos` is in `dist` (the last draw when none is).
pub fn random_goal(
    pos: [f32; 2],
    size: f32,
    dist: std::ops::RangeInclusive<f32>,
    tries: usize,
    rng: &mut Rng,
) -> [f32; 2] {
    let mut goal = random_point(size, rng);
    for _ in 0..tries {
        if dist.contains(&(goal[0] - pos[0]).hypot(goal[1] - pos[1])) {
            break;
        }
        goal = random_point(size, rng);
    }
    goal
}

impl Playground {
    /// `n` agents with random attributes, starts and goals (goals 150–400 px from the start when
    /// the playground allows it) in a `size`-px square.
    pub fn new(n: usize, size: f32, rng: &mut Rng) -> Playground {
        let agents = (0..n)
            .map(|_| {
                let pos = random_point(size, rng);
                let goal = random_goal(pos, size, 150.0..=400.0, 20, rng);
                HmmAgent {
                    pos,
                    goal,
                    heading: (goal[1] - pos[1]).atan2(goal[0] - pos[0]),
                    state: State::Walk,
                    attrs: Attributes::random(rng),
                    track: vec![pos],
                }
            })
            .collect();
        Playground {
            size,
            radius: 40.0,
            agents,
        }
    }

    /// Advance every agent by one 0.4 s step. `extra` are positions of agents not driven by the
    /// HMM (the RL agent) that also count for proximity detection. Returns each agent's `n_ICS`
    /// (computed before moving).
    pub fn step(&mut self, extra: &[[f32; 2]], rng: &mut Rng) -> Vec<usize> {
        let positions: Vec<[f32; 2]> = self.agents.iter().map(|a| a.pos).collect();
        let mut counts = Vec::with_capacity(self.agents.len());
        for (i, a) in self.agents.iter_mut().enumerate() {
            let others: Vec<[f32; 2]> = positions
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, p)| *p)
                .chain(extra.iter().copied())
                .collect();
            let n = n_ics(a.pos, &others, self.radius);
            counts.push(n);
            let mut row = TRANSITIONS[a.state.index()];
            if n > 0 {
                let w = 0.5 * (a.attrs.sociability + a.attrs.patience);
                for (r, y) in row.iter_mut().zip(YIELD) {
                    *r = (1.0 - w) * *r + w * y;
                }
            }
            a.state = State::ALL[categorical(&row, rng)];
            let to_goal = (a.goal[0] - a.pos[0]).hypot(a.goal[1] - a.pos[1]);
            if to_goal < 10.0 {
                a.state = State::Stop;
            }
            let noise = rng.normal();
            a.heading = match a.state {
                State::Turn => a.heading + 0.6 * noise,
                _ => (a.goal[1] - a.pos[1]).atan2(a.goal[0] - a.pos[0]) + 0.1 * noise,
            };
            let speed = (20.0 + 60.0 * a.attrs.fitness) * a.state.speed_factor();
            let stepl = (speed * DT).min(to_goal.max(0.0));
            a.pos = [
                (a.pos[0] + stepl * a.heading.cos()).clamp(0.0, self.size),
                (a.pos[1] + stepl * a.heading.sin()).clamp(0.0, self.size),
            ];
            a.track.push(a.pos);
        }
        counts
    }

    /// Every agent's first [`WINDOW`] positions (its trajectory once the playground has been
    /// stepped 19 times; positions not reached yet are `[0, 0]`).
    pub fn trajectories(&self) -> Vec<Traj> {
        self.agents
            .iter()
            .map(|a| {
                let mut t = [[0.0; 2]; WINDOW];
                for (d, p) in t.iter_mut().zip(&a.track) {
                    *d = *p;
                }
                t
            })
            .collect()
    }
}

/// Simulate `n` HMM agents for 19 steps in a `size` playground and return their 20-point
/// trajectories (playground coordinates) and the total number of impending collision states.
pub fn simulate(n: usize, size: f32, rng: &mut Rng) -> (Vec<Traj>, usize) {
    let mut pg = Playground::new(n, size, rng);
    let mut total = 0;
    for _ in 1..WINDOW {
        total += pg.step(&[], rng).iter().sum::<usize>();
    }
    (pg.trajectories(), total)
}
