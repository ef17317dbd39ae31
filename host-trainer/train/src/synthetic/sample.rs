//! The fixed-order synthetic pool, sampled so that it keeps the training set's type statistics
//! (paper: "we sample the RL and Newtonian trajectories in a fashion to keep the statistics …
//! similar"; "we always select the first k% from the fixed ordering").
//!
//! **Order.** Slot `i` of the pool gets the type `c` (among types with a non-zero training
//! share `p_c`, "other" excluded since the paper discards those) with the largest deficit
//! `p_c (i + 1) − count_c` (ties: table order): a deterministic schedule under which every
//! prefix of the pool has type counts within about one trajectory of `p_c × length`. The slot is
//! then filled by drawing from that type's generator until [`classify`] agrees (at most 10 000
//! draws). Everything comes from one ChaCha8 stream keyed by the seed, so the pool — and
//! hence every "first k %" — is reproducible.
//!
//! **Generators per type.** 7 (linear): successive type-7 slots cycle through Newtonian constant
//! velocity / constant acceleration / turn, an HMM playground agent and a policy-gradient agent
//! (greedy: mean action, in a random HMM playground), so each source fills 1/5 of them. 6: Newtonian
//! constant deceleration that reverses. 4: Newtonian full-circle turn. The other types are
//! annotation/drone artefacts in SDD and are synthesised as such: 1 a fixed point; 2 2–8 points
//! jittering in a 5-px box; 3 2–9 plateaus drifting within 100 px; 2F/3F the same plus one
//! 20–300 px jump; 5 a constant-velocity walk with 2–4 jumps. Every trajectory is translated into
//! the SDD pixel range.

use std::path::Path;

use anyhow::{bail, Context, Result};

use crate::data::{Window, SDD_FRAME_STEP, WINDOW};
use crate::mlp::Mlp;
use crate::rng::Rng;

use super::agent::{rollout, PLAYGROUND};
use super::classify::{classify, TrajType};
use super::hmm::simulate;
use super::newtonian::{generate, place, Kind, Motion};
use super::{Traj, DT};

/// Where a pool trajectory came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// A Newtonian generator.
    Newtonian,
    /// An HMM playground agent.
    Hmm,
    /// A policy-gradient agent.
    Rl,
    /// A synthesised annotation/drone artefact (types 1, 2, 2F, 3, 3F, 5).
    Artefact,
}

impl Source {
    /// Name used in the CSV.
    pub fn name(self) -> &'static str {
        match self {
            Source::Newtonian => "newtonian",
            Source::Hmm => "hmm",
            Source::Rl => "rl",
            Source::Artefact => "artefact",
        }
    }

    fn parse(s: &str) -> Option<Source> {
        [Source::Newtonian, Source::Hmm, Source::Rl, Source::Artefact]
            .into_iter()
            .find(|x| x.name() == s)
    }
}

/// One pool entry.
#[derive(Debug, Clone, PartialEq)]
pub struct PoolItem {
    /// Its type (by [`classify`]).
    pub ty: TrajType,
    /// Its generator.
    pub source: Source,
    /// The 20 points, px.
    pub traj: Traj,
}

fn jitter_levels(rng: &mut Rng, k: usize, spread: f32) -> Vec<[f32; 2]> {
    (0..k)
        .map(|_| [rng.uniform(0.0, spread), rng.uniform(0.0, spread)])
        .collect()
}

/// Piecewise-constant trajectory visiting `levels` in order (2+ steps each).
fn plateaus(levels: &[[f32; 2]]) -> Traj {
    let mut t = [[0.0; 2]; WINDOW];
    for (i, p) in t.iter_mut().enumerate() {
        *p = levels[(i * levels.len() / WINDOW).min(levels.len() - 1)];
    }
    t
}

/// A plateau track (types 2 and 3): `2 + rng.below(extra)` levels drawn within `spread` px,
/// then one jump when `jump` (the `F` variants).
fn plateau_track(rng: &mut Rng, extra: usize, spread: f32, jump: bool) -> Traj {
    let k = 2 + rng.below(extra);
    let mut t = plateaus(&jitter_levels(rng, k, spread));
    if jump {
        add_jumps(&mut t, 1, rng);
    }
    t
}

fn add_jumps(t: &mut Traj, n: usize, rng: &mut Rng) {
    for _ in 0..n {
        let at = 1 + rng.below(WINDOW - 1);
        let len = rng.uniform(20.0, 300.0);
        let h = rng.uniform(0.0, std::f32::consts::TAU);
        for p in t.iter_mut().skip(at) {
            p[0] += len * h.cos();
            p[1] += len * h.sin();
        }
    }
}

fn from_track(track: &Traj, rng: &mut Rng) -> Traj {
    place(track, rng)
}

/// Draw one candidate for type `ty` (`turn` rotates the type-7 sources).
fn candidate(ty: TrajType, policy: &Mlp, turn: usize, rng: &mut Rng) -> Result<(Source, Traj)> {
    Ok(match ty {
        TrajType::T1 => (Source::Artefact, place(&[[0.0; 2]; WINDOW], rng)),
        TrajType::T2 | TrajType::T2F => {
            let t = plateau_track(rng, 7, 5.0, ty == TrajType::T2F);
            (Source::Artefact, place(&t, rng))
        }
        TrajType::T3 | TrajType::T3F => {
            let t = plateau_track(rng, 8, 100.0, ty == TrajType::T3F);
            (Source::Artefact, place(&t, rng))
        }
        TrajType::T4 => {
            let speed = rng.uniform(10.0, 80.0);
            let omega =
                std::f32::consts::TAU / (19.0 * DT) * if rng.unit_f32() < 0.5 { -1.0 } else { 1.0 };
            let heading = rng.uniform(0.0, std::f32::consts::TAU);
            let m = Motion::Turn {
                speed,
                heading,
                omega,
            };
            (Source::Newtonian, place(&m.integrate(), rng))
        }
        TrajType::T5 => {
            let mut t = Motion::random(Kind::ConstVel, rng).integrate();
            let n = 2 + rng.below(3);
            add_jumps(&mut t, n, rng);
            (Source::Artefact, place(&t, rng))
        }
        TrajType::T6 => {
            let speed = rng.uniform(10.0, 100.0);
            let h = rng.uniform(0.0, std::f32::consts::TAU);
            let t_rev = rng.uniform(2.4, 4.4); // reversal time, s
            let a = speed / t_rev;
            let (c, s) = (h.cos(), h.sin());
            let m = Motion::ConstAcc {
                v: [speed * c, speed * s],
                a: [-a * c, -a * s],
            };
            (Source::Newtonian, place(&m.integrate(), rng))
        }
        _ => match turn % 5 {
            0 => (Source::Newtonian, generate(Kind::ConstVel, rng)),
            1 => (Source::Newtonian, generate(Kind::ConstAcc, rng)),
            2 => (Source::Newtonian, generate(Kind::Turn, rng)),
            3 => {
                let (trajs, _) = simulate(8, PLAYGROUND, rng);
                (Source::Hmm, from_track(&trajs[0], rng))
            }
            _ => {
                let ep = rollout(policy, rng, true)?;
                (Source::Rl, from_track(&ep.track, rng))
            }
        },
    })
}

/// Training shares `p_c` from type counts (indexed like [`TrajType::ALL`]); "other" gets 0.
pub fn shares(counts: &[usize; 10]) -> [f64; 10] {
    let mut p = [0.0; 10];
    let n: usize = counts[..9].iter().sum();
    if n == 0 {
        return p;
    }
    for i in 0..9 {
        p[i] = counts[i] as f64 / n as f64;
    }
    p
}

/// Build a pool of `n` trajectories with type shares `p` (see module docs).
pub fn build_pool(n: usize, p: &[f64; 10], policy: &Mlp, seed: u64) -> Result<Vec<PoolItem>> {
    let mut rng = Rng::with_stream(seed, 20);
    let mut count = [0usize; 10];
    let mut out = Vec::with_capacity(n);
    let mut turn7 = 0usize;
    for slot in 0..n {
        let Some(ci) = (0..9).filter(|&i| p[i] > 0.0).max_by(|&a, &b| {
            let da = p[a] * (slot + 1) as f64 - count[a] as f64;
            let db = p[b] * (slot + 1) as f64 - count[b] as f64;
            da.total_cmp(&db).then(b.cmp(&a))
        }) else {
            bail!("no type has a positive share");
        };
        let ty = TrajType::ALL[ci];
        let mut found = None;
        for _ in 0..10_000 {
            let (src, t) = candidate(ty, policy, turn7, &mut rng)?;
            if super::in_range(&t) && classify(&t) == ty {
                found = Some((src, t));
                break;
            }
        }
        let Some((source, traj)) = found else {
            bail!(
                "could not generate a type {} trajectory in 10000 draws",
                ty.label()
            );
        };
        count[ci] += 1;
        if ty == TrajType::T7 {
            turn7 += 1;
        }
        out.push(PoolItem { ty, source, traj });
    }
    Ok(out)
}

/// CSV: `index,type,source,x0,y0,…,x19,y19` (one header line).
pub fn pool_csv(pool: &[PoolItem]) -> Result<String> {
    let coords: Vec<String> = (0..WINDOW)
        .flat_map(|k| [format!("x{k}"), format!("y{k}")])
        .collect();
    let header: Vec<&str> = ["index", "type", "source"]
        .into_iter()
        .chain(coords.iter().map(String::as_str))
        .collect();
    crate::csvfile::to_csv(
        &header,
        pool.iter().enumerate().map(|(i, it)| {
            [
                i.to_string(),
                it.ty.label().to_string(),
                it.source.name().to_string(),
            ]
            .into_iter()
            .chain(it.traj.iter().flatten().map(f32::to_string))
        }),
    )
}

/// Read a pool written by [`pool_csv`].
pub fn read_pool(path: &Path) -> Result<Vec<PoolItem>> {
    let bytes = crate::inpath::read_limited(path, crate::inpath::FileKind::Data)
        .with_context(|| format!("{}: cannot read pool", path.display()))?;
    let mut out = Vec::new();
    for rec in crate::csvfile::records(&bytes).skip(1) {
        let (line, rec) = rec.with_context(|| format!("{}: bad CSV", path.display()))?;
        let f = rec
            .iter()
            .map(std::str::from_utf8)
            .collect::<Result<Vec<&str>, _>>()
            .with_context(|| format!("{}:{line}: not UTF-8", path.display()))?;
        if f.len() != 3 + 2 * WINDOW {
            bail!(
                "{}:{line}: expected {} fields, found {}",
                path.display(),
                3 + 2 * WINDOW,
                f.len()
            );
        }
        let ty = TrajType::from_label(f[1])
            .with_context(|| format!("{}:{line}: bad type {:?}", path.display(), f[1]))?;
        let source = Source::parse(f[2])
            .with_context(|| format!("{}:{line}: bad source {:?}", path.display(), f[2]))?;
        let mut traj = [[0.0f32; 2]; WINDOW];
        for (k, p) in traj.iter_mut().enumerate() {
            for c in 0..2 {
                let v: f32 = f[3 + 2 * k + c]
                    .parse()
                    .with_context(|| format!("{}:{line}: bad number", path.display()))?;
                if !v.is_finite() {
                    bail!("{}:{line}: non-finite coordinate", path.display());
                }
                p[c] = v;
            }
        }
        out.push(PoolItem { ty, source, traj });
    }
    Ok(out)
}

/// The first `round(pct/100 · n_train)` pool trajectories as windows (scene `synthetic`, ped id
/// = pool index, frames `0, 12, 24, …`). Errors if the pool is too small.
pub fn take_first_pct(pool: &[PoolItem], pct: f64, n_train: usize) -> Result<Vec<Window>> {
    let k = (pct / 100.0 * n_train as f64).round() as usize;
    if k > pool.len() {
        bail!(
            "{pct}% of {n_train} needs {k} synthetic trajectories; the pool has {}",
            pool.len()
        );
    }
    Ok(pool[..k]
        .iter()
        .enumerate()
        .map(|(i, it)| Window {
            scene: "synthetic".into(),
            ped_id: i as f64,
            frames: std::array::from_fn(|t| t as i64 * SDD_FRAME_STEP),
            pos: it.traj,
        })
        .collect())
}
