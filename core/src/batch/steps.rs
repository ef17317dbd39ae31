//! Steps 1–3 of the parent module's docs for groups of tracks, `L` lanes
//! at a time: the private methods of [`Batch`] that encode a group
//! ([`Batch::encode`]), draw its samples chunk by chunk through the decoder
//! and the trajectory networks ([`Batch::run`]), or turn the point head's
//! output into trajectories ([`Batch::points_out`]).

use crate::backend::{in_exp, out_exp, Backend};
use crate::blob::{Layer, MAX_PAST};
use crate::frame::Frame;
use crate::output::{PredictError, Trajectory};
use crate::prng::Gaussian;

use super::{Batch, LaneOut, Lanes, Query, QueryError};

/// Runs `layers` on the first `width` rows of `src` (ping-pong with `dst`);
/// returns the output width and whether the output is in `src`.
fn run_lanes<'l, 'a: 'l, B: Backend, const L: usize, const W: usize>(
    layers: impl Iterator<Item = &'l Layer<'a>>,
    src: &mut Lanes<B::Act, L, W>,
    dst: &mut Lanes<B::Act, L, W>,
    width: usize,
    used: usize,
) -> (usize, bool) {
    let (mut s, mut d) = (src, dst);
    let mut width = width.min(W);
    let mut in_src = true;
    for layer in layers {
        let out = layer.out_dim().min(W);
        B::dense_lanes(layer, &s[..width], &mut d[..out], used);
        core::mem::swap(&mut s, &mut d);
        in_src = !in_src;
        width = out;
    }
    (width, in_src)
}

impl<'a, B: Backend, const W: usize, const L: usize> Batch<'a, B, W, L> {
    /// Step 1 for `group` (at most `L` tracks, `base` = index of the first):
    /// frames, samplers, and `encoder_past` (or, for `point`, the point head)
    /// side by side. Returns the network's output width and whether its
    /// output is in `a`; fails with the first failing track's guard error.
    pub(super) fn encode(
        &mut self,
        group: &[Query<'_>],
        base: usize,
        point: bool,
    ) -> Result<(usize, bool), QueryError> {
        let m = &self.model;
        let net = if point {
            m.point_head()
        } else {
            m.encoder_past()
        };
        let e = in_exp(m.encoder_past());
        for row in self.a.iter_mut().take(2 * MAX_PAST) {
            *row = [B::Act::default(); L];
        }
        let mut n = 0;
        for (l, q) in group.iter().enumerate().take(L) {
            let (frame, pts) = Frame::inputs(q.past, m).map_err(|error| QueryError {
                index: base + l,
                error,
            })?;
            n = 2 * q.past.len();
            for (t, p) in pts.iter().take(q.past.len()).enumerate() {
                if let Some(r) = self.a.get_mut(2 * t..2 * t + 2) {
                    r[0][l] = B::from_f32(p[0], e);
                    r[1][l] = B::from_f32(p[1], e);
                }
            }
            self.frames[l] = frame;
            self.lasts[l] = q.past.last().copied().unwrap_or([0.0; 2]);
            self.gauss[l] = Gaussian::new(q.seed);
        }
        let used = group.len().min(L);
        Ok(run_lanes::<B, L, W>(
            net.layers(),
            &mut self.a,
            &mut self.b,
            n,
            used,
        ))
    }

    /// Steps 1–3 for `queries`, `k` samples each: calls `emit(track,
    /// sample, lane)` in track-major order. Stops at the first error (of
    /// `emit`, or a track's, reported with the lowest failing index).
    pub(super) fn run(
        &mut self,
        queries: &[Query<'_>],
        k: usize,
        trajectories: bool,
        mut emit: impl FnMut(usize, usize, LaneOut<'_>) -> Result<(), PredictError>,
    ) -> Result<(), QueryError> {
        if k == 0 {
            return Err(QueryError::of_call(PredictError::BadSampleCount));
        }
        if trajectories && !self.model.has_predictor() {
            return Err(QueryError::of_call(PredictError::NoPredictor));
        }
        // A proposal's stream has K latents: more is refused before any track runs.
        if self.model.has_proposal() && k > crate::sampling::stream_bound(&self.model) {
            return Err(QueryError::of_call(PredictError::BadSampleCount));
        }
        for (gi, group) in queries.chunks(L).enumerate() {
            let base = gi * L;
            // A guard error of track `base + bad` ends the call after the
            // tracks before it (so the lowest failing index is reported).
            let (n, enc, guard) = match self.encode(group, base, false) {
                Ok(enc) => (group.len(), enc, None),
                Err(e) => {
                    let ok = e.index - base;
                    match group.get(..ok) {
                        Some(g) if ok > 0 => (ok, self.encode(g, base, false)?, Some(e)),
                        _ => return Err(e),
                    }
                }
            };
            self.group_samples(n, enc, base, k, trajectories, &mut emit)?;
            if let Some(e) = guard {
                return Err(e);
            }
        }
        Ok(())
    }

    /// Steps 2–3 for the `n` encoded tracks of a group (`encoder_past`'s
    /// output: width and whether in `a`): their `n·k` samples, `L` at a
    /// time.
    fn group_samples(
        &mut self,
        n: usize,
        (f_width, f_in_a): (usize, bool),
        base: usize,
        k: usize,
        trajectories: bool,
        emit: &mut impl FnMut(usize, usize, LaneOut<'_>) -> Result<(), PredictError>,
    ) -> Result<(), QueryError> {
        let fdim = (self.model.config().fdim as usize).min(f_width);
        let src = if f_in_a { &self.a } else { &self.b };
        self.feat[..fdim].copy_from_slice(&src[..fdim]);
        if self.model.has_proposal() {
            self.latent_rows(n, fdim, k);
        }
        let total = n * k;
        let mut idx = 0;
        while idx < total {
            let lanes = (total - idx).min(L);
            let mut slots = [0usize; L];
            for (l, s) in slots.iter_mut().enumerate().take(lanes) {
                *s = (idx + l) / k;
            }
            self.chunk(fdim, &slots, lanes, idx, k, base, trajectories, emit)?;
            idx += lanes;
        }
        Ok(())
    }

    /// A proposal model's latents for the group's first `n` tracks, `k`
    /// samples each: the proposal's hidden layers on the features in lanes,
    /// then its last layer's rows `0 .. k·zdim` in lanes into
    /// [`Batch::latents`] when they fit `W`; else each track's `h` into
    /// [`Batch::hidden`] for [`Batch::proposed_latent`] to compute its
    /// lanes' rows one at a time. Each row's sum has the scalar engine's
    /// order either way.
    fn latent_rows(&mut self, n: usize, fdim: usize, k: usize) {
        let model = self.model;
        let prop = model.proposal();
        let hidden = prop.len().saturating_sub(1);
        self.a[..fdim].copy_from_slice(&self.feat[..fdim]);
        let (hw, in_a) = run_lanes::<B, L, W>(
            prop.layers().take(hidden),
            &mut self.a,
            &mut self.b,
            fdim,
            n,
        );
        let h = if in_a { &self.a } else { &self.b };
        let zdim = model.config().zdim as usize;
        let rows = k
            .checked_mul(zdim)
            .filter(|&r| r <= W)
            .and_then(|r| prop.layers().last()?.rows(0, r));
        self.latents_ready = rows.is_some();
        if let Some(rows) = rows {
            B::dense_lanes(&rows, &h[..hw], &mut self.latents[..rows.out_dim()], n);
            return;
        }
        self.hidden_dim = hw;
        for (t, row) in self.hidden.iter_mut().enumerate().take(n.min(L)) {
            for (hv, hr) in row.iter_mut().zip(&h[..hw]) {
                *hv = hr[t];
            }
        }
    }

    /// Lane `l`'s latent from the proposal: rows `s·zdim .. (s + 1)·zdim` of
    /// its last layer on track `t`'s hidden activations (from
    /// [`Batch::latents`], or computed here), each value as f32
    /// (the layer's output exponent), clamped to `±latent_bound` (NaN stays
    /// NaN), converted with the decoder's input exponent `ez`, into rows
    /// `fdim ..` of `a`, lane `l`. As [`crate::Engine::next_endpoint`].
    fn proposed_latent(
        &mut self,
        (t, s, l): (usize, usize, usize),
        fdim: usize,
        zdim: usize,
        ez: i8,
    ) -> Result<(), PredictError> {
        let rows = self
            .model
            .proposal()
            .layers()
            .last()
            .and_then(|layer| layer.rows(s.checked_mul(zdim)?, zdim))
            .ok_or(PredictError::BadSampleCount)?;
        if self.latents_ready {
            for (i, zi) in self.row_a.iter_mut().enumerate().take(zdim) {
                *zi = self.latents[s * zdim + i][t];
            }
        } else {
            let h = &self.hidden[t][..self.hidden_dim.min(W)];
            B::dense(&rows, h, &mut self.row_a[..zdim]);
        }
        let (eo, bound) = (rows.out_exp(), self.model.latent_bound());
        for (row, &zi) in self.a[fdim..fdim + zdim].iter_mut().zip(&self.row_a) {
            let v = B::to_f32(zi, eo);
            let v = if v > bound {
                bound
            } else if v < -bound {
                -bound
            } else {
                v
            };
            row[l] = B::from_f32(v, ez);
        }
        Ok(())
    }

    /// One chunk: `lanes` samples starting at group sample `idx` (lane `l` =
    /// track `slots[l]`), through the decoder and, when asked, the
    /// trajectory networks; then `emit` per lane in order.
    #[allow(clippy::too_many_arguments)]
    fn chunk(
        &mut self,
        fdim: usize,
        slots: &[usize; L],
        lanes: usize,
        idx: usize,
        k: usize,
        base: usize,
        trajectories: bool,
        emit: &mut impl FnMut(usize, usize, LaneOut<'_>) -> Result<(), PredictError>,
    ) -> Result<(), QueryError> {
        let fail = |l: usize, error| QueryError {
            index: base + (idx + l) / k,
            error,
        };
        let c = *self.model.config();
        let zdim = (c.zdim as usize).min(W.saturating_sub(fdim));
        let model = self.model;
        let dec = model.decoder();
        let ez = in_exp(dec);
        // Decoder input [f, z], lane by lane.
        let proposal = self.model.has_proposal();
        for (l, &t) in slots.iter().enumerate() {
            let used = l < lanes;
            for (ar, fr) in self.a.iter_mut().zip(&self.feat).take(fdim) {
                ar[l] = if used { fr[t] } else { B::Act::default() };
            }
            if used && proposal {
                self.proposed_latent((t, (idx + l) % k, l), fdim, zdim, ez)
                    .map_err(|e| fail(l, e))?;
            } else if used {
                let g = &mut self.gauss[t];
                for row in self.a[fdim..fdim + zdim].iter_mut() {
                    row[l] = B::from_f32(c.sigma * g.next(), ez);
                }
            } else {
                for row in self.a[fdim..fdim + zdim].iter_mut() {
                    row[l] = B::Act::default();
                }
            }
        }
        if dec.is_empty() {
            return Err(fail(0, PredictError::NonFiniteOutput));
        }
        let (dw, d_in_a) =
            run_lanes::<B, L, W>(dec.layers(), &mut self.a, &mut self.b, fdim + zdim, lanes);
        if dw < 2 {
            return Err(fail(0, PredictError::NonFiniteOutput));
        }
        let d: [[B::Act; L]; 2] = if d_in_a {
            [self.a[0], self.a[1]]
        } else {
            [self.b[0], self.b[1]]
        };
        let eo = out_exp(dec);
        // Trajectories: g = encoder_dest(d), then the predictor on [f, g, pos].
        let mut q_rows = (0, true);
        if trajectories {
            let (dest, pred) = (self.model.encoder_dest(), self.model.predictor());
            self.a[0] = d[0];
            self.a[1] = d[1];
            let (ddim, g_in_a) =
                run_lanes::<B, L, W>(dest.layers(), &mut self.a, &mut self.b, 2, lanes);
            let n_in = fdim + ddim + 2;
            if n_in > W {
                return Err(fail(0, PredictError::CapacityExceeded));
            }
            let (x, y) = if g_in_a {
                (&mut self.a, &mut self.b)
            } else {
                (&mut self.b, &mut self.a)
            };
            x.copy_within(0..ddim, fdim);
            let ef = out_exp(self.model.encoder_past());
            for (l, &t) in slots.iter().enumerate() {
                for (xr, fr) in x.iter_mut().zip(&self.feat).take(fdim) {
                    xr[l] = fr[t];
                }
                let pos = self.frames[t].predictor_position(self.lasts[t]);
                x[fdim + ddim][l] = B::from_f32(pos[0] / c.initial_pos_divisor, ef);
                x[fdim + ddim + 1][l] = B::from_f32(pos[1] / c.initial_pos_divisor, ef);
            }
            let (qw, q_in_x) = run_lanes::<B, L, W>(pred.layers(), x, y, n_in, lanes);
            q_rows = (qw, q_in_x == g_in_a);
        }
        let po = out_exp(self.model.predictor());
        for (l, &t) in slots.iter().enumerate().take(lanes) {
            let frame = &self.frames[t];
            let e = frame.output(
                [B::to_f32(d[0][l], eo), B::to_f32(d[1][l], eo)],
                c.data_scale,
            );
            let e = crate::frame::check_output(e).map_err(|err| fail(l, err))?;
            let traj = if trajectories {
                let q = if q_rows.1 { &self.a } else { &self.b };
                let pairs = q[..q_rows.0]
                    .chunks_exact(2)
                    .map(|p| [B::to_f32(p[0][l], po), B::to_f32(p[1][l], po)]);
                let mut tr = frame.points(pairs, c.data_scale).map_err(|e| fail(l, e))?;
                tr.push(e)
                    .map_err(|_| fail(l, PredictError::CapacityExceeded))?;
                Some(tr)
            } else {
                None
            };
            let (track, sample) = ((idx + l) / k, (idx + l) % k);
            emit(
                base + track,
                sample,
                LaneOut {
                    endpoint: e,
                    trajectory: traj.as_ref(),
                },
            )
            .map_err(|e| fail(l, e))?;
        }
        Ok(())
    }

    /// The point head's output (width `w`, in `a` or `b`) as trajectories.
    pub(super) fn points_out(
        &self,
        w: usize,
        in_a: bool,
        eo: i8,
        scale: f32,
        base: usize,
        outs: &mut [Trajectory],
    ) -> Result<(), QueryError> {
        let q = if in_a { &self.a } else { &self.b };
        for (l, o) in outs.iter_mut().enumerate() {
            let pairs = q[..w]
                .chunks_exact(2)
                .map(|p| [B::to_f32(p[0][l], eo), B::to_f32(p[1][l], eo)]);
            *o = self.frames[l]
                .points(pairs, scale)
                .map_err(|error| QueryError {
                    index: base + l,
                    error,
                })?;
        }
        Ok(())
    }
}
