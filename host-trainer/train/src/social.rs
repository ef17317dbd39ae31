//! PECNet's optional non-local social pooling: grouping, masks and the pooling networks.
//!
//! Off by default (`social_pooling = false`): G-PECNet and every shipped model run without it.
//! It exists so that PECNet's own variant (with pooling) can be trained and its numbers
//! reproduced **on the host**. It needs the other pedestrians of the scene at inference, which
//! the embedded core does not have, so a model trained with it cannot be exported
//! ([`crate::model::Model::export_networks`] refuses it).
//!
//! * **Grouping** ([`group_windows`], PECNet's `utils/social_utils.py: collect_data`): within
//!   one file (our windows' `scene`), in file order, the first remaining trajectory is the
//!   anchor; every other remaining trajectory of the same file that passes the filter **against
//!   the anchor** joins its group (a star test, not a transitive closure); the group is removed
//!   and the loop repeats. The filter ([`social_and_temporal`]) uses only the 8 observed steps:
//!   `find_min_time` (min over |start frame of one − observed frames of the other|, both ways)
//!   `<= time_thresh` and `find_min_dist` (min over all pairs of observed points, raw units)
//!   `<= dist_thresh`. PECNet's shipped data uses `time_thresh = 0`, `dist_thresh = 100` px.
//! * **Batches** ([`pack_groups`]): groups are appended to a batch; a new batch starts before
//!   adding a group once the batch holds `>= batch_size` trajectories, so groups are never
//!   split. **Masks** ([`block_mask`]): `n × n`, 1 where two rows are in the same group
//!   (including the diagonal), 0 elsewhere.
//! * **Pooling** ([`SocialPooling::pool`], PECNet's `non_local_social_pooling`), repeated
//!   `nonlocal_pools` times with the same three MLPs on `feat` `[N, D]`, `D = 2 fdim + 2`:
//!   `f = theta(feat) · phi(feat)ᵀ`, `w = softmax(f, dim = 1) ⊙ mask`, `w = w / max(Σ_row |w|,
//!   1e-12)` (`F.normalize(p = 1)`), `feat = w · g(feat) + feat`.

use candle_core::{Device, Tensor, Var, D};

use crate::config::TrainConfig;
use crate::data::{Window, PAST};
use crate::mlp::Mlp;
use crate::rng::Rng;

/// PECNet's `find_min_time` on the observed steps: the minimum of |start frame of one
/// trajectory − each observed frame of the other|, taken both ways.
pub fn min_time(a: &Window, b: &Window) -> i64 {
    let one = |x: &Window, y: &Window| {
        y.frames[..PAST]
            .iter()
            .map(|&t| (x.frames[0] - t).abs())
            .min()
            .unwrap_or(i64::MAX)
    };
    one(a, b).min(one(b, a))
}

/// PECNet's `find_min_dist` on the observed steps: the minimum Euclidean distance over all
/// pairs of observed points (raw units), computed in f64.
pub fn min_dist(a: &Window, b: &Window) -> f64 {
    let mut best = f64::INFINITY;
    for p in &a.pos[..PAST] {
        for q in &b.pos[..PAST] {
            let dx = f64::from(q[0]) - f64::from(p[0]);
            let dy = f64::from(q[1]) - f64::from(p[1]);
            best = best.min((dx * dx + dy * dy).sqrt());
        }
    }
    best
}

/// PECNet's `social_and_temporal_filter`: `min_time <= time_thresh && min_dist <= dist_thresh`.
pub fn social_and_temporal(a: &Window, b: &Window, time_thresh: i64, dist_thresh: f64) -> bool {
    min_time(a, b) <= time_thresh && min_dist(a, b) <= dist_thresh
}

/// Greedy star grouping of `windows` (see the module docs). Only windows with the same
/// `scene` (= the same file) can share a group. Returns groups of indices into `windows`; the
/// groups come in order of their anchors and each group lists the anchor first, then its
/// members in file order. Every index appears in exactly one group.
pub fn group_windows(windows: &[Window], time_thresh: i64, dist_thresh: f64) -> Vec<Vec<usize>> {
    // Files in order of first appearance; windows of a file in their order.
    let mut files: Vec<(&str, Vec<usize>)> = Vec::new();
    for (i, w) in windows.iter().enumerate() {
        match files.iter_mut().find(|(s, _)| *s == w.scene) {
            Some((_, v)) => v.push(i),
            None => files.push((&w.scene, vec![i])),
        }
    }
    let mut groups = Vec::new();
    for (_, members) in files {
        let mut remaining = members;
        while let Some((&anchor, rest)) = remaining.split_first() {
            let mut group = vec![anchor];
            let mut left = Vec::with_capacity(rest.len());
            for &j in rest {
                if social_and_temporal(&windows[anchor], &windows[j], time_thresh, dist_thresh) {
                    group.push(j);
                } else {
                    left.push(j);
                }
            }
            groups.push(group);
            remaining = left;
        }
    }
    groups
}

/// Pack groups (in the given order) into batches: a new batch starts before adding a group
/// once the current one holds `>= batch_size` rows, so no group is ever split. Each batch is
/// returned as its groups.
pub fn pack_groups<G: AsRef<[u32]>>(groups: &[G], batch_size: usize) -> Vec<Vec<&[u32]>> {
    let mut batches: Vec<Vec<&[u32]>> = Vec::new();
    let mut cur: Vec<&[u32]> = Vec::new();
    let mut size = 0usize;
    for g in groups {
        if size >= batch_size && !cur.is_empty() {
            batches.push(std::mem::take(&mut cur));
            size = 0;
        }
        cur.push(g.as_ref());
        size += g.as_ref().len();
    }
    if !cur.is_empty() {
        batches.push(cur);
    }
    batches
}

/// The `n × n` 0/1 mask (row-major) of consecutive groups of the given sizes: 1 where two rows
/// belong to the same group, diagonal included.
pub fn block_mask_values(sizes: &[usize]) -> Vec<f32> {
    let n: usize = sizes.iter().sum();
    let mut m = vec![0.0f32; n * n];
    let mut start = 0;
    for &s in sizes {
        for r in start..start + s {
            m[r * n + start..r * n + start + s].fill(1.0);
        }
        start += s;
    }
    m
}

/// [`block_mask_values`] as a `[n, n]` tensor.
pub fn block_mask(sizes: &[usize]) -> candle_core::Result<Tensor> {
    let n: usize = sizes.iter().sum();
    Tensor::from_vec(block_mask_values(sizes), (n, n), &Device::Cpu)
}

/// The three non-local networks, shared by all `pools` rounds.
#[derive(Clone, Debug)]
pub struct SocialPooling {
    /// `D -> non_local_dim`.
    pub theta: Mlp,
    /// `D -> non_local_dim`.
    pub phi: Mlp,
    /// `D -> D`.
    pub g: Mlp,
    /// Rounds of pooling (`nonlocal_pools`).
    pub pools: usize,
}

impl SocialPooling {
    /// Build (theta, phi, g, in PECNet's constructor order) for features of width
    /// `2 * fdim + 2`, with the model's activation and initialisation.
    pub fn new(cfg: &TrainConfig, rng: &mut Rng) -> candle_core::Result<Self> {
        let d = 2 * cfg.fdim + 2;
        let (a, w0) = (cfg.activation, cfg.w0);
        Ok(Self {
            theta: Mlp::new(d, &cfg.non_local_theta_size, cfg.non_local_dim, a, w0, rng)?,
            phi: Mlp::new(d, &cfg.non_local_phi_size, cfg.non_local_dim, a, w0, rng)?,
            g: Mlp::new(d, &cfg.non_local_g_size, d, a, w0, rng)?,
            pools: cfg.nonlocal_pools,
        })
    }

    /// Parameters: theta, phi, g (each `w0, b0, w1, b1, ...`).
    pub fn vars(&self) -> Vec<Var> {
        [&self.theta, &self.phi, &self.g]
            .iter()
            .flat_map(|m| m.vars())
            .collect()
    }

    /// One round of PECNet's `non_local_social_pooling`: `feat` `[N, D]`, `mask` `[N, N]`.
    pub fn pool_once(&self, feat: &Tensor, mask: &Tensor) -> candle_core::Result<Tensor> {
        let theta = self.theta.forward(feat)?;
        let phi = self.phi.forward(feat)?;
        let f = theta.matmul(&phi.t()?)?;
        let w = softmax_last(&f)?.mul(mask)?;
        // F.normalize(p=1, dim=1): x / max(||x||_1, 1e-12).
        let norm = w.abs()?.sum_keepdim(1)?.maximum(1e-12)?;
        let w = w.broadcast_div(&norm)?;
        w.matmul(&self.g.forward(feat)?)? + feat
    }

    /// `pools` rounds of [`SocialPooling::pool_once`].
    pub fn pool(&self, feat: &Tensor, mask: &Tensor) -> candle_core::Result<Tensor> {
        let mut f = feat.clone();
        for _ in 0..self.pools {
            f = self.pool_once(&f, mask)?;
        }
        Ok(f)
    }
}

/// Numerically stable softmax over the last dimension (`exp(x - max) / sum`). Not
/// `candle_nn::ops::softmax`: the subtracted maximum is detached here (the gradient does not
/// flow through it), which the trained bits depend on.
fn softmax_last(x: &Tensor) -> candle_core::Result<Tensor> {
    let max = x.max_keepdim(D::Minus1)?.detach();
    let e = x.broadcast_sub(&max)?.exp()?;
    let s = e.sum_keepdim(D::Minus1)?;
    e.broadcast_div(&s)
}
