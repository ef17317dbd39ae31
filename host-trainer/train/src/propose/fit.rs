//! The proposal's training step and its validation pass: tensors of the frozen model's
//! features and true endpoints, the soft-min best-of-K loss through the frozen decoder; and
//! the point head's, when it is trained beside the proposal: its inputs, the true futures,
//! its loss and its validation FDE; and a teacher's endpoints, when the proposal is
//! distilled from a larger one.

use anyhow::{bail, Result};
use candle_core::{DType, Device, Tensor, Var};

use crate::data::{Window, FUTURE, PAST};
use crate::mlp::{Dense, Mlp};
use crate::network::{Act, Layer};
use crate::reference::{RefModel, SineKind};

/// The frozen model's view of a set of windows: features `f` (`[n, fdim]`, exactly the
/// reference path's `encoder_past` output) and true endpoints in the networks' normalised
/// frame (`[n, 2]`); and, when the point head is trained, its inputs and targets.
pub struct Encoded {
    /// `[n, fdim]`.
    pub features: Tensor,
    /// `[n, 2]`.
    pub targets: Tensor,
    /// The point head's batch data (only when asked for: a run that trains the head).
    pub point: Option<PointData>,
    /// Each window's weight in the loss (`[n]`), `None` = all 1.
    pub weights: Option<Tensor>,
    /// The teacher's K endpoints of each window (`[n, k, 2]`, normalised frame), `None`
    /// without distillation.
    pub teacher: Option<Tensor>,
    /// Windows.
    pub n: usize,
}

/// The point head's view of a set of windows, in the networks' normalised frame.
pub struct PointData {
    /// `[n, 2 · PAST]`: the observed positions as the networks see them.
    pub inputs: Tensor,
    /// `[n, FUTURE, 2]`: the true future positions.
    pub futures: Tensor,
}

impl Encoded {
    /// Encodes `windows` with the frozen `model` (f32 reference arithmetic, libm sine), with
    /// the point head's [`PointData`] when `point` is set.
    pub fn of(model: &RefModel, windows: &[Window], point: bool) -> Result<Self> {
        let c = &model.config;
        let (mut feats, mut targets) = (Vec::new(), Vec::new());
        let (mut inputs, mut futures) = (Vec::new(), Vec::new());
        for w in windows {
            let past = &w.pos[..PAST];
            let (fr, f) = model.features(past, SineKind::Libm);
            if point {
                for p in past {
                    inputs.extend_from_slice(&fr.input(*p, c.data_scale));
                }
                for p in &w.pos[PAST..PAST + FUTURE] {
                    futures.extend_from_slice(&fr.input(*p, c.data_scale));
                }
            }
            if f.len() != c.fdim {
                bail!(
                    "the encoder gives {} features, the config says {}",
                    f.len(),
                    c.fdim
                );
            }
            feats.extend_from_slice(&f);
            targets.extend_from_slice(&fr.input(w.pos[PAST + FUTURE - 1], c.data_scale));
        }
        let n = windows.len();
        Ok(Self {
            features: Tensor::from_vec(feats, (n, c.fdim), &Device::Cpu)?,
            targets: Tensor::from_vec(targets, (n, 2), &Device::Cpu)?,
            point: match point {
                true => Some(PointData {
                    inputs: Tensor::from_vec(inputs, (n, 2 * PAST), &Device::Cpu)?,
                    futures: Tensor::from_vec(futures, (n, FUTURE, 2), &Device::Cpu)?,
                }),
                false => None,
            },
            weights: None,
            teacher: None,
            n,
        })
    }

    /// The same windows with `teacher`'s endpoints of each ([`Teacher::endpoints`]).
    pub fn with_teacher(self, teacher: &Teacher) -> Result<Self> {
        Ok(Self {
            teacher: Some(teacher.endpoints(&self.features)?),
            ..self
        })
    }

    /// Rows `idx` of the teacher's endpoints (`None` without a teacher).
    pub fn teacher_rows(&self, idx: &[u32]) -> Result<Option<Tensor>> {
        let i = Tensor::from_slice(idx, idx.len(), &Device::Cpu)?;
        Ok(self
            .teacher
            .as_ref()
            .map(|t| t.index_select(&i, 0))
            .transpose()?)
    }

    /// The same windows, each weighing `weights[i]` in the loss (one weight per window).
    pub fn with_weights(self, weights: Vec<f32>) -> Result<Self> {
        if weights.len() != self.n {
            bail!("{} weights for {} windows", weights.len(), self.n);
        }
        let n = self.n;
        Ok(Self {
            weights: Some(Tensor::from_vec(weights, n, &Device::Cpu)?),
            ..self
        })
    }

    /// Rows `idx` of the features and targets, and of the weights if there are any.
    pub fn rows(&self, idx: &[u32]) -> Result<(Tensor, Tensor, Option<Tensor>)> {
        self.select(&self.features, &self.targets, idx)
    }

    /// Rows `idx` of the networks' inputs and the true futures, and of the weights if there
    /// are any (the point head's batch); an error for windows encoded without them.
    pub fn point_rows(&self, idx: &[u32]) -> Result<(Tensor, Tensor, Option<Tensor>)> {
        let Some(p) = &self.point else {
            bail!("these windows were encoded without the point head's data");
        };
        self.select(&p.inputs, &p.futures, idx)
    }

    fn select(
        &self,
        x: &Tensor,
        y: &Tensor,
        idx: &[u32],
    ) -> Result<(Tensor, Tensor, Option<Tensor>)> {
        let i = Tensor::from_slice(idx, idx.len(), &Device::Cpu)?;
        Ok((
            x.index_select(&i, 0)?,
            y.index_select(&i, 0)?,
            self.weights
                .as_ref()
                .map(|w| w.index_select(&i, 0))
                .transpose()?,
        ))
    }
}

/// A network of exported (w0-folded) layers as a candle MLP. Its parameters are trained only
/// when given to an optimiser (the decoder under joint training, the point head beside the
/// proposal); otherwise it stays frozen. `what` names the network in the error.
pub fn mlp_of(layers: &[Layer], what: &str) -> Result<Mlp> {
    let hidden = layers
        .first()
        .filter(|_| layers.len() > 1)
        .map_or(Act::Linear, |l| l.act);
    if layers.iter().rev().skip(1).any(|l| l.act != hidden)
        || layers.last().is_none_or(|l| l.act != Act::Linear)
    {
        bail!("the {what}'s hidden layers must share one activation and its last be linear");
    }
    let dense = layers
        .iter()
        .map(|l| -> Result<Dense> {
            Ok(Dense {
                weight: Var::from_tensor(&Tensor::from_slice(
                    &l.w,
                    (l.out_dim, l.in_dim),
                    &Device::Cpu,
                )?)?,
                bias: Var::from_tensor(&Tensor::from_slice(&l.b, l.out_dim, &Device::Cpu)?)?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(Mlp::from_layers(dense, hidden))
}

/// The loss settings (all lengths in the networks' normalised units).
#[derive(Clone, Copy, Debug)]
pub struct LossSpec {
    /// Latents per window.
    pub k: usize,
    /// Latent width.
    pub zdim: usize,
    /// Each latent component is clamped to `±bound` (as the core does).
    pub bound: f32,
    /// Soft-min temperature.
    pub temperature: f32,
    /// Weight of `½‖z‖²` (the prior's log-density up to a constant).
    pub prior_weight: f32,
    /// Weight of the mean distance to the teacher's endpoints (0 without one).
    pub distill_weight: f32,
}

/// A teacher for distillation: another blob's proposal on the same frozen encoder and
/// decoder, with its own latent clamp. Its networks stay frozen (no optimiser sees them),
/// and its decoder is its own copy, so it does not move when the student's decoder is
/// tuned.
pub struct Teacher {
    proposal: Mlp,
    decoder: Mlp,
    spec: LossSpec,
    /// The frozen networks' fingerprint it was checked against.
    fingerprint: u32,
}

impl Teacher {
    /// The teacher in `teacher` for a student of `k` latents on `student`'s frozen
    /// networks: an error unless `teacher` has a proposal of `k` latents and the same
    /// encoder, decoder, data scale and heading frame
    /// ([`crate::proposal_file::frozen_fingerprint`]).
    pub fn of(teacher: &RefModel, student: &RefModel, k: usize) -> Result<Self> {
        use crate::proposal_file::frozen_fingerprint;
        if teacher.nets.proposal.is_empty() {
            bail!("the teacher has no learned proposal to distil from");
        }
        if teacher.proposal_latents() != k {
            bail!(
                "the teacher's proposal gives {} latents, the student {k}: they must be the same K",
                teacher.proposal_latents()
            );
        }
        let fingerprint = frozen_fingerprint(teacher);
        if fingerprint != frozen_fingerprint(student) {
            bail!(
                "the teacher's encoder, decoder, data scale or heading frame differ from the blob's: a teacher must be a proposal on the same CVAE"
            );
        }
        let c = &teacher.config;
        Ok(Self {
            proposal: mlp_of(&teacher.nets.proposal, "teacher's proposal")?,
            decoder: mlp_of(&teacher.nets.decoder, "teacher's decoder")?,
            spec: LossSpec {
                k,
                zdim: c.zdim,
                bound: c.latent_bound,
                temperature: 1.0,
                prior_weight: 0.0,
                distill_weight: 0.0,
            },
            fingerprint,
        })
    }

    /// An error unless the teacher fits a student of `k` latents on `student`'s frozen
    /// networks (what [`Teacher::of`] checked, for a teacher built elsewhere).
    pub fn check_fits(&self, student: &RefModel, k: usize) -> Result<()> {
        if self.spec.k != k || self.fingerprint != crate::proposal_file::frozen_fingerprint(student)
        {
            bail!("the teacher was built for another K or another CVAE than this run's");
        }
        Ok(())
    }

    /// Its K endpoints for the features `f` (`[n, fdim]` to `[n, k, 2]`), in chunks. A
    /// scored teacher's logits (after its `K·zdim` latent components) are not used.
    pub fn endpoints(&self, f: &Tensor) -> Result<Tensor> {
        let n = f.dims2()?.0;
        let mut parts = Vec::new();
        for start in (0..n).step_by(1024) {
            let chunk = f.narrow(0, start, 1024.min(n - start))?;
            // Detached: the loss's gradient must not flow back into the teacher (nor walk
            // its graph over every window at each step).
            parts.push(
                endpoints(&self.proposal, &self.decoder, &chunk, &self.spec)?
                    .0
                    .detach(),
            );
        }
        if parts.is_empty() {
            return Ok(Tensor::zeros(
                (0, self.spec.k, 2),
                DType::F32,
                &Device::Cpu,
            )?);
        }
        Ok(Tensor::cat(&parts, 0)?)
    }
}

/// The K endpoints of a batch (`[b, k, 2]`) and its clamped latents (`[b·k, zdim]`): the
/// proposal's first `K·zdim` outputs (a scored proposal's logits follow them).
pub fn endpoints(
    proposal: &Mlp,
    decoder: &Mlp,
    f: &Tensor,
    spec: &LossSpec,
) -> Result<(Tensor, Tensor)> {
    let (b, fdim) = f.dims2()?;
    let z = proposal
        .forward(f)?
        .narrow(1, 0, spec.k * spec.zdim)?
        .reshape((b * spec.k, spec.zdim))?
        .clamp(-spec.bound, spec.bound)?;
    let fk = f
        .unsqueeze(1)?
        .broadcast_as((b, spec.k, fdim))?
        .reshape((b * spec.k, fdim))?;
    let input = Tensor::cat(&[&fk, &z], 1)?.contiguous()?;
    let d = decoder.forward(&input)?.reshape((b, spec.k, 2))?;
    Ok((d, z))
}

/// Distances `[b, k]` of the K endpoints to the truth `t` (`[b, 2]`).
pub fn distances(d: &Tensor, t: &Tensor) -> Result<Tensor> {
    let diff = d.broadcast_sub(&t.unsqueeze(1)?)?;
    Ok((diff.sqr()?.sum(2)? + 1e-8)?.sqrt()?)
}

/// The training loss of one batch: the soft minimum over the K endpoint errors
/// (`m − T·ln Σ_k exp(−(d_k − m)/T)`, `m` the hard minimum, not differentiated), averaged
/// over the windows (weighted by `w` when given: `Σ wᵢ sᵢ / Σ wᵢ`), plus
/// `prior_weight · ½‖z‖²` averaged over the latents; with a teacher's endpoints
/// `teacher` (`[b, k, 2]`), plus `distill_weight` times the distance between each endpoint
/// and the teacher's of the same index, averaged over the K and then over the windows
/// (weighted alike).
pub fn loss(
    proposal: &Mlp,
    decoder: &Mlp,
    f: &Tensor,
    t: &Tensor,
    w: Option<&Tensor>,
    teacher: Option<&Tensor>,
    spec: &LossSpec,
) -> Result<Tensor> {
    let (d, z) = endpoints(proposal, decoder, f, spec)?;
    let dist = distances(&d, t)?;
    let m = dist.min_keepdim(1)?.detach();
    let temp = f64::from(spec.temperature);
    let soft = (m.squeeze(1)?
        - (dist
            .broadcast_sub(&m)?
            .affine(-1.0 / temp, 0.0)?
            .exp()?
            .sum(1)?
            .log()?
            * temp)?)?;
    let prior = (z.sqr()?.sum(1)?.mean_all()? * (0.5 * f64::from(spec.prior_weight)))?;
    let total = (weighted_mean(&soft, w)? + prior)?;
    Ok(match teacher {
        Some(te) => {
            let gap = ((d - te)?.sqr()?.sum(2)? + 1e-8)?.sqrt()?.mean(1)?;
            (total + (weighted_mean(&gap, w)? * f64::from(spec.distill_weight))?)?
        }
        None => total,
    })
}

/// The mean of the per-window values `v` (`[b]`), weighted by `w` when given:
/// `Σ wᵢ vᵢ / Σ wᵢ` (differentiable: the training losses).
fn weighted_mean(v: &Tensor, w: Option<&Tensor>) -> Result<Tensor> {
    Ok(match w {
        Some(w) => (v.mul(w)?.sum_all()? / f64::from(w.sum_all()?.to_scalar::<f32>()?))?,
        None => v.mean_all()?,
    })
}

/// `(Σ wᵢ vᵢ, Σ wᵢ)` of the per-window values `v` (`[b]`), every weight 1 without `w`, in
/// f64 (a validation pass sums these over its chunks).
fn weighted_total(v: &Tensor, w: Option<&Tensor>) -> Result<(f64, f64)> {
    let (v, weight) = match w {
        Some(w) => (v.mul(w)?, f64::from(w.sum_all()?.to_scalar::<f32>()?)),
        None => (v.clone(), v.dims1()? as f64),
    };
    Ok((
        v.to_dtype(DType::F64)?.sum_all()?.to_scalar::<f64>()?,
        weight,
    ))
}

/// Validation numbers of one pass (normalised units; divide by `data_scale` for the
/// caller's).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ValScore {
    /// Mean over windows of the smallest endpoint error (weighted, if the windows are).
    pub min_fde: f64,
    /// Share of latent components at the clamp.
    pub clamped: f64,
    /// Mean latent norm.
    pub z_norm: f64,
}

/// Best-of-K endpoint error of `proposal` on all of `enc`, in chunks; with weights, the
/// weighted mean `Σ wᵢ dᵢ / Σ wᵢ`.
pub fn validate(proposal: &Mlp, decoder: &Mlp, enc: &Encoded, spec: &LossSpec) -> Result<ValScore> {
    let (mut fde, mut weight, mut clamped, mut norm, mut comps) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0usize);
    let idx: Vec<u32> = (0..enc.n as u32).collect();
    for chunk in idx.chunks(1024) {
        let (f, t, w) = enc.rows(chunk)?;
        let (d, z) = endpoints(proposal, decoder, &f, spec)?;
        let (sum, w) = weighted_total(&distances(&d, &t)?.min(1)?, w.as_ref())?;
        fde += sum;
        weight += w;
        let zv = z.flatten_all()?.to_vec1::<f32>()?;
        clamped += zv.iter().filter(|v| v.abs() >= spec.bound).count() as f64;
        comps += zv.len();
        norm += z
            .sqr()?
            .sum(1)?
            .sqrt()?
            .to_dtype(DType::F64)?
            .sum_all()?
            .to_scalar::<f64>()?;
    }
    let n = enc.n.max(1) as f64;
    Ok(ValScore {
        min_fde: fde / weight.max(f64::MIN_POSITIVE),
        clamped: clamped / comps.max(1) as f64,
        z_norm: norm / (n * spec.k as f64),
    })
}

/// The point head's loss on one batch, as `gpecnet train` trains it: the mean Euclidean
/// displacement over the `FUTURE` steps plus the displacement at the horizon, per window
/// (weighted by `w` when given: `Σ wᵢ sᵢ / Σ wᵢ`), averaged over the windows.
pub fn point_loss(head: &Mlp, x: &Tensor, y: &Tensor, w: Option<&Tensor>) -> Result<Tensor> {
    let dist = point_distances(head, x, y, crate::model::POINT_LOSS_EPS)?;
    let per = (dist.mean(1)? + dist.narrow(1, FUTURE - 1, 1)?.squeeze(1)?)?;
    weighted_mean(&per, w)
}

/// Distances `[b, FUTURE]` of the point head's forecast to the truth `y` (`[b, FUTURE, 2]`),
/// `√(d² + eps)`: in the loss `eps` is `gpecnet train`'s offset that keeps the gradient
/// finite at 0, in validation 0.
fn point_distances(head: &Mlp, x: &Tensor, y: &Tensor, eps: f64) -> Result<Tensor> {
    let b = x.dims2()?.0;
    let pred = head.forward(x)?.reshape((b, FUTURE, 2))?;
    Ok((pred - y)?.sqr()?.sum(2)?.affine(1.0, eps)?.sqrt()?)
}

/// The point head's mean FDE on all of `enc` (normalised units), in chunks; with weights,
/// the weighted mean `Σ wᵢ dᵢ / Σ wᵢ`.
pub fn validate_point(head: &Mlp, enc: &Encoded) -> Result<f64> {
    let (mut fde, mut weight) = (0.0f64, 0.0f64);
    let idx: Vec<u32> = (0..enc.n as u32).collect();
    for chunk in idx.chunks(1024) {
        let (x, y, w) = enc.point_rows(chunk)?;
        let last = point_distances(head, &x, &y, 0.0)?
            .narrow(1, FUTURE - 1, 1)?
            .squeeze(1)?;
        let (sum, w) = weighted_total(&last, w.as_ref())?;
        fde += sum;
        weight += w;
    }
    Ok(fde / weight.max(f64::MIN_POSITIVE))
}
