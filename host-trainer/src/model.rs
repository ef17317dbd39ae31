//! PECNet / G-PECNet (conditional VAE over the endpoint) on candle, CPU, with PECNet's
//! optional non-local social pooling ([`crate::social`], off by default, host only).
//!
//! Networks (PECNet names and order):
//! * `encoder_past`: `2 * past_length` (x0, y0, x1, y1, ...) -> `fdim`
//! * `encoder_dest`: 2 -> `fdim`
//! * `encoder_latent`: `2 * fdim` -> `2 * zdim` (mu, logvar); training only
//! * `decoder`: `fdim + zdim` -> 2 (the endpoint)
//! * `predictor`: `2 * fdim + 2` (features, encoded endpoint, initial_pos) ->
//!   `2 * (future_length - 1)` (the 11 intermediate points, x/y interleaved)
//! * only with `social_pooling`: `non_local_theta`, `non_local_phi`, `non_local_g`, applied
//!   `nonlocal_pools` times to the predictor's input features (masked by social groups). They
//!   are initialised and stored after all other networks, so configs without pooling keep
//!   their exact initialisation and checkpoint layout.
//!
//! Every MLP is `Linear -> act -> ... -> Linear` (activation after every layer but the last),
//! with `act = sin(w0 * .)` (SIREN, G-PECNet) or ReLU (PECNet). All weights are initialised
//! from the crate's seeded [`Rng`]; no candle randomness is used.
//!
//! Each dense layer is one fused candle op ([`Linear`]: candle's own matmul, then the bias) and
//! the sine activation another ([`SineOp`]: candle's `x.affine(w0, 0).sin()` in one pass), or,
//! inside a sine MLP, both are one op ([`LinearSine`]). Their
//! forward and backward passes perform the very f32 operations of the unfused candle graph, so
//! training is bit-identical to it, but without its intermediate tensors and zero-filled
//! gradient accumulators, and the elementwise work is split over the run's threads
//! (`for_each_job`).

use candle_core::{CpuStorage, CustomOp1, CustomOp2, DType, Device, Layout, Shape, Tensor, Var};

use crate::config::TrainConfig;
use crate::data::{Sample, FUTURE, PAST};
use crate::network::{Act, Layer, Networks};
use crate::rng::Rng;
use crate::social::SocialPooling;

/// One affine layer; weight `[out, in]` (PyTorch layout), bias `[out]`.
#[derive(Clone, Debug)]
pub struct Dense {
    /// `[out, in]`.
    pub weight: Var,
    /// `[out]`.
    pub bias: Var,
}

/// A multi-layer perceptron with an activation after every layer but the last.
#[derive(Clone, Debug)]
pub struct Mlp {
    layers: Vec<Dense>,
    activation: Act,
    w0: f32,
    /// Inputs are multiplied by `1 / in_scale` before the first layer.
    in_scale: f32,
    /// Outputs are multiplied by `out_scale` after the last layer.
    out_scale: f32,
}

fn uniform_vec(rng: &mut Rng, n: usize, bound: f32) -> Vec<f32> {
    (0..n).map(|_| rng.uniform(-bound, bound)).collect()
}

impl Mlp {
    /// Build `input -> hidden... -> output` and initialise it from `rng`.
    ///
    /// Sine: first layer `W ~ U(-1/n, 1/n)`, later layers `W ~ U(-sqrt(6/n)/w0, sqrt(6/n)/w0)`
    /// (SIREN); ReLU: `W ~ U(-1/sqrt(n), 1/sqrt(n))` (PyTorch's default). Bias always
    /// `U(-1/sqrt(n), 1/sqrt(n))`. `n` is the fan-in. Weights are drawn before biases, layer by
    /// layer, row-major.
    pub fn new(
        input: usize,
        hidden: &[usize],
        output: usize,
        activation: Act,
        w0: f32,
        rng: &mut Rng,
    ) -> candle_core::Result<Self> {
        let dev = Device::Cpu;
        let mut layers = Vec::new();
        let mut prev = input;
        for (i, &out) in hidden.iter().chain(std::iter::once(&output)).enumerate() {
            let n = prev as f32;
            let wb = match activation {
                Act::Sine if i == 0 => 1.0 / n,
                Act::Sine => (6.0 / n).sqrt() / w0,
                Act::Relu | Act::Linear => 1.0 / n.sqrt(),
            };
            let w = uniform_vec(rng, out * prev, wb);
            let b = uniform_vec(rng, out, 1.0 / n.sqrt());
            layers.push(Dense {
                weight: Var::from_vec(w, (out, prev), &dev)?,
                bias: Var::from_vec(b, out, &dev)?,
            });
            prev = out;
        }
        Ok(Self {
            layers,
            activation,
            w0,
            in_scale: 1.0,
            out_scale: 1.0,
        })
    }

    /// An MLP over the given layers (ReLU or sine with `w0 = 1` after every layer but the last),
    /// without scales. The layers may hold f64 weights (the synthetic-data RL policy's,
    /// [`crate::synth::agent`]): [`linear`] and [`add_bias`] then run candle's own ops.
    pub fn from_layers(layers: Vec<Dense>, activation: Act) -> Self {
        Self {
            layers,
            activation,
            w0: 1.0,
            in_scale: 1.0,
            out_scale: 1.0,
        }
    }

    /// Sets fixed input/output scales: the network sees `x / in_scale` and
    /// returns `out_scale · y`. They keep SIREN's first layer in its intended
    /// O(1) input range (PECNet's coordinates reach hundreds) and are folded
    /// into the first and last layers at export, so the shipped blob needs no
    /// extra step.
    pub fn with_scales(mut self, in_scale: f32, out_scale: f32) -> Self {
        self.in_scale = in_scale;
        self.out_scale = out_scale;
        self
    }

    /// `x`: `[batch, in]` -> `[batch, out]`.
    pub fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        let mut h = if self.in_scale == 1.0 {
            x.clone()
        } else {
            x.affine(f64::from(1.0 / self.in_scale), 0.0)?
        };
        let last = self.layers.len() - 1;
        for (i, l) in self.layers.iter().enumerate() {
            let (w, b) = (l.weight.as_tensor(), l.bias.as_tensor());
            h = match self.activation {
                Act::Sine if i < last => linear_sine(&h, w, b, self.w0)?,
                Act::Relu if i < last => linear(&h, w, b)?.relu()?,
                _ => linear(&h, w, b)?,
            };
        }
        if self.out_scale != 1.0 {
            h = h.affine(f64::from(self.out_scale), 0.0)?;
        }
        Ok(h)
    }

    /// Parameters in order `w0, b0, w1, b1, ...`.
    pub fn vars(&self) -> Vec<Var> {
        self.layers
            .iter()
            .flat_map(|l| [l.weight.clone(), l.bias.clone()])
            .collect()
    }

    /// The layers.
    pub fn layers(&self) -> &[Dense] {
        &self.layers
    }

    /// Export with `w0` folded into sine layers (see [`Layer`]).
    pub fn export(&self) -> candle_core::Result<Vec<Layer>> {
        let last = self.layers.len() - 1;
        let mut out = Vec::with_capacity(self.layers.len());
        for (i, l) in self.layers.iter().enumerate() {
            let (out_dim, in_dim) = l.weight.as_tensor().dims2()?;
            let mut weight = l.weight.as_tensor().flatten_all()?.to_vec1::<f32>()?;
            let mut bias = l.bias.as_tensor().to_vec1::<f32>()?;
            if i == 0 && self.in_scale != 1.0 {
                let inv = 1.0 / self.in_scale;
                weight.iter_mut().for_each(|x| *x *= inv);
            }
            if i == last && self.out_scale != 1.0 {
                weight.iter_mut().for_each(|x| *x *= self.out_scale);
                bias.iter_mut().for_each(|x| *x *= self.out_scale);
            }
            let activation = if i == last {
                Act::Linear
            } else {
                if self.activation == Act::Sine {
                    weight.iter_mut().for_each(|x| *x *= self.w0);
                    bias.iter_mut().for_each(|x| *x *= self.w0);
                }
                self.activation
            };
            out.push(Layer::new(in_dim, out_dim, activation, weight, bias));
        }
        Ok(out)
    }
}

/// Elements per job below which an elementwise pass is not split across threads.
pub(crate) const PAR_MIN_CHUNK: usize = 32 * 1024;

/// Length of the contiguous chunks an elementwise pass over `n` elements is split into: one
/// chunk per thread of the run (`RAYON_NUM_THREADS`, see [`crate::train::set_num_threads`]),
/// none shorter than [`PAR_MIN_CHUNK`]. Every element is computed on its own, so the result
/// does not depend on the split.
pub(crate) fn chunk_len(n: usize) -> usize {
    let threads = candle_core::utils::get_num_threads().max(1);
    n.div_ceil(threads).max(PAR_MIN_CHUNK).max(1)
}

/// Runs `f` on every job, the first on the calling thread and the others on scoped threads
/// (inline when a thread cannot be started). Returns when all are done.
pub(crate) fn for_each_job<T: Send, F: Fn(T) + Sync>(jobs: impl IntoIterator<Item = T>, f: F) {
    let mut jobs = jobs.into_iter();
    let Some(first) = jobs.next() else {
        return;
    };
    let f = &f;
    std::thread::scope(|s| {
        let mut inline = Vec::new();
        for job in jobs {
            // A job the OS refuses a thread for runs on this thread instead.
            let (tx, rx) = std::sync::mpsc::channel::<T>();
            let spawned = std::thread::Builder::new().spawn_scoped(s, move || {
                if let Ok(job) = rx.recv() {
                    f(job);
                }
            });
            match spawned {
                Ok(_) => {
                    if let Err(std::sync::mpsc::SendError(job)) = tx.send(job) {
                        inline.push(job);
                    }
                }
                Err(_) => inline.push(job),
            }
        }
        f(first);
        inline.into_iter().for_each(f);
    });
}

/// A new vector of `n` elements filled by `fill(range, out)` over contiguous ranges (each
/// `out` is the vector's `range`, its length a multiple of `align` but for the last), split
/// over threads as [`chunk_len`] says.
fn map_elements<F: Fn(std::ops::Range<usize>, &mut [f32]) + Sync>(
    n: usize,
    align: usize,
    fill: F,
) -> Vec<f32> {
    let mut out = vec![0f32; n];
    let align = align.max(1);
    let chunk = chunk_len(n).div_ceil(align) * align;
    let jobs = out
        .chunks_mut(chunk)
        .enumerate()
        .map(|(i, o)| (i * chunk..i * chunk + o.len(), o));
    for_each_job(jobs, |(range, o)| fill(range, o));
    out
}

/// `x Wᵀ + b` for `x` `[rows, in]`, `W` `[out, in]`, `b` `[out]`, as one differentiable op
/// ([`Linear`]); the same bits as candle's `x.matmul(&w.t()).broadcast_add(b)` and its
/// gradients. Empty or other shapes, and dtypes other than f32, fall back to that graph.
pub fn linear(x: &Tensor, w: &Tensor, b: &Tensor) -> candle_core::Result<Tensor> {
    let f32s = [x, w, b].iter().all(|t| t.dtype() == DType::F32);
    match (x.dims(), w.dims(), b.dims()) {
        (&[m, k], &[n, k2], &[n2]) if f32s && k == k2 && n == n2 && m * n * k > 0 => {
            x.apply_op3(w, b, Linear)
        }
        _ => add_bias(&x.matmul(&w.t()?)?, b),
    }
}

/// A dense layer `y = x Wᵀ + b` as one node of the graph. Forward: candle's own CPU matmul on
/// the same layouts `x.matmul(&w.t())` passes it, then `y[i][j] + b[j]`. Backward, with
/// `G = 0 + dy` (candle's zero-filled accumulator of the matmul output):
/// `dx = G.matmul(&w.t().t())`, `dW = (x.t().matmul(&G)).t()`, `db` as [`BiasAdd`]'s — the
/// operations and operands candle's matmul, transpose and broadcast-add nodes use, so the bits
/// are the same, without three of their zero-filled accumulators and copies.
#[derive(Clone, Copy, Debug)]
pub struct Linear;

impl candle_core::CustomOp3 for Linear {
    fn name(&self) -> &'static str {
        "gpecnet-linear"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
        s3: &CpuStorage,
        l3: &Layout,
    ) -> candle_core::Result<(CpuStorage, Shape)> {
        let (y, m, n) = linear_forward(s1, l1, s2, l2, s3, l3)?;
        Ok((CpuStorage::F32(y), Shape::from((m, n))))
    }

    fn bwd(
        &self,
        x: &Tensor,
        w: &Tensor,
        b: &Tensor,
        _res: &Tensor,
        grad: &Tensor,
    ) -> candle_core::Result<(Option<Tensor>, Option<Tensor>, Option<Tensor>)> {
        // `0 + dy` is `dy` itself unless `dy` holds a -0.0 (or is strided).
        let g = if grad.is_contiguous() && !has_negative_zero(grad)? {
            grad.clone()
        } else {
            grad.affine(1.0, 0.0)?
        };
        linear_backward(x, w, b, &g)
    }
}

/// [`Linear`]'s forward pass: `(x Wᵀ + b, rows, out)`.
fn linear_forward(
    s1: &CpuStorage,
    l1: &Layout,
    s2: &CpuStorage,
    l2: &Layout,
    s3: &CpuStorage,
    l3: &Layout,
) -> candle_core::Result<(Vec<f32>, usize, usize)> {
    use candle_core::backend::BackendStorage;
    let (m, k) = l1.shape().dims2()?;
    let (n, k2) = l2.shape().dims2()?;
    let b = f32_slice(s3, l3)?;
    if k != k2 || b.len() != n || n == 0 {
        candle_core::bail!("linear: [{m}, {k}] x [{n}, {k2}]ᵀ + [{}]", b.len());
    }
    let y = s1.matmul(s2, (1, m, n, k), l1, &l2.transpose(0, 1)?)?;
    let CpuStorage::F32(mut y) = y else {
        candle_core::bail!("linear: f32 only");
    };
    if y.len() != m * n {
        candle_core::bail!("linear: matmul returned {} values for [{m}, {n}]", y.len());
    }
    let chunk = chunk_len(y.len()).div_ceil(n) * n;
    for_each_job(y.chunks_mut(chunk), |y| {
        for y in y.chunks_mut(n) {
            for (y, &b) in y.iter_mut().zip(b) {
                *y += b;
            }
        }
    });
    Ok((y, m, n))
}

/// [`Linear`]'s backward pass from `G`, the gradient of its output after candle's accumulator
/// (`0 + dy`): `(dx, dW, db)`.
fn linear_backward(
    x: &Tensor,
    w: &Tensor,
    b: &Tensor,
    g: &Tensor,
) -> candle_core::Result<(Option<Tensor>, Option<Tensor>, Option<Tensor>)> {
    let dx = g.matmul(&w.t()?.t()?)?;
    let dw = weight_gradient(x, g)?;
    let db = g.apply_op1_no_bwd(&ColumnSum(b.elem_count()))?;
    Ok((Some(dx), Some(dw), Some(db)))
}

/// `sin(w0 · (x Wᵀ + b))`, a dense layer and its SIREN activation, as one differentiable op
/// ([`LinearSine`]); the same bits as [`linear`] followed by [`sine`], and the same gradients.
/// Shapes and dtypes [`linear`] does not fuse fall back to the two ops.
pub fn linear_sine(x: &Tensor, w: &Tensor, b: &Tensor, w0: f32) -> candle_core::Result<Tensor> {
    let f32s = [x, w, b].iter().all(|t| t.dtype() == DType::F32);
    match (x.dims(), w.dims(), b.dims()) {
        (&[m, k], &[n, k2], &[n2]) if f32s && k == k2 && n == n2 && m * n * k > 0 => {
            x.apply_op3(w, b, LinearSine::new(w0))
        }
        _ => sine(&linear(x, w, b)?, w0),
    }
}

/// [`Linear`] then [`SineOp`] in one node of the graph. Forward: [`Linear`]'s `h = x Wᵀ + b`,
/// then `sin(h · w0 + 0)`; `h` is kept in the op for the backward pass. Backward, from the
/// accumulated `dy`: `G = 0 + (((0 + dy · cos(h · w0 + 0)) · w0) + 0)` — `SineBackward`'s
/// operations followed by the zero-filled accumulator candle would add `h`'s gradient to —
/// then [`Linear`]'s backward from `G`. The same bits as the two ops, without the graph node of
/// `h`, its accumulator (an allocation, a fill and an add over `[rows, out]`) and a scan.
#[derive(Debug)]
pub struct LinearSine {
    sine: SineOp,
    /// `h = x Wᵀ + b` of the forward pass.
    pre: std::sync::OnceLock<Vec<f32>>,
}

impl LinearSine {
    /// The op for the SIREN factor `w0`.
    pub fn new(w0: f32) -> Self {
        Self {
            sine: SineOp { w0 },
            pre: std::sync::OnceLock::new(),
        }
    }
}

impl candle_core::CustomOp3 for LinearSine {
    fn name(&self) -> &'static str {
        "gpecnet-linear-sine"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
        s3: &CpuStorage,
        l3: &Layout,
    ) -> candle_core::Result<(CpuStorage, Shape)> {
        let (h, m, n) = linear_forward(s1, l1, s2, l2, s3, l3)?;
        let op = self.sine;
        let y = map_elements(h.len(), 1, |range, y| {
            for (y, &h) in y.iter_mut().zip(&h[range]) {
                *y = op.arg(h).sin();
            }
        });
        if self.pre.set(h).is_err() {
            candle_core::bail!("linear-sine: one op instance per forward pass");
        }
        Ok((CpuStorage::F32(y), Shape::from((m, n))))
    }

    fn bwd(
        &self,
        x: &Tensor,
        w: &Tensor,
        b: &Tensor,
        res: &Tensor,
        grad: &Tensor,
    ) -> candle_core::Result<(Option<Tensor>, Option<Tensor>, Option<Tensor>)> {
        let Some(h) = self.pre.get() else {
            candle_core::bail!("linear-sine: backward pass without a forward pass");
        };
        let grad = grad.contiguous()?;
        let (storage, layout) = grad.storage_and_layout();
        let dy = match &*storage {
            candle_core::Storage::Cpu(cpu) => f32_slice(cpu, layout)?,
            _ => candle_core::bail!("linear-sine: CPU tensors only"),
        };
        if dy.len() != h.len() {
            candle_core::bail!("linear-sine: {} outputs, {} gradients", h.len(), dy.len());
        }
        let op = self.sine;
        let g = map_elements(h.len(), 1, |range, g| {
            for ((g, &h), &dy) in g.iter_mut().zip(&h[range.clone()]).zip(&dy[range]) {
                let d_arg = 0.0 + dy * op.arg(h).cos();
                *g = 0.0 + (d_arg * op.w0 + 0.0);
            }
        });
        drop(storage);
        let g = Tensor::from_vec(g, res.shape(), &Device::Cpu)?;
        linear_backward(x, w, b, &g)
    }
}

/// `dW = (xᵀ G)ᵀ`, `[out, in]`, for `x` `[rows, in]` and `G` `[rows, out]`, in the bits of
/// candle's `x.t().matmul(&G).t()` but laid out row-major, so that the gradient accumulator
/// candle adds it to reads it contiguously instead of through a transposed view.
///
/// It is computed as `Gᵀ x`: the `gemm` crate computes every output element as one fused
/// multiply-add chain over the rows, in row order, in blocks whose size depends only on `rows`
/// (`kc`; the other cache parameters and the thread split only tile the output), so the
/// transposed product has the same bits in every element. The exceptions are its special
/// paths for `in` or `out` of 1 (matrix-vector) and `rows` ≤ 2 (outer products), which are
/// not symmetric in the two operands: those shapes keep candle's form.
fn weight_gradient(x: &Tensor, g: &Tensor) -> candle_core::Result<Tensor> {
    let (rows, cols_in) = x.dims2()?;
    let cols_out = g.dims2()?.1;
    if rows > 2 && cols_in > 1 && cols_out > 1 {
        g.t()?.matmul(x)
    } else {
        x.t()?.matmul(g)?.t()
    }
}

/// Whether a contiguous f32 tensor holds a negative zero.
fn has_negative_zero(t: &Tensor) -> candle_core::Result<bool> {
    let (storage, layout) = t.storage_and_layout();
    match &*storage {
        candle_core::Storage::Cpu(cpu) => {
            let v = f32_slice(cpu, layout)?;
            Ok(v.iter().any(|v| v.to_bits() == 0x8000_0000))
        }
        _ => candle_core::bail!("linear: CPU tensors only"),
    }
}

/// `h + b` for `h` `[rows, out]` and a bias `b` `[out]`, as one differentiable op
/// ([`BiasAdd`]); the same bits as candle's `h.broadcast_add(b)` and its gradients. Other
/// shapes and other dtypes fall back to `broadcast_add`.
pub fn add_bias(h: &Tensor, b: &Tensor) -> candle_core::Result<Tensor> {
    let f32s = h.dtype() == DType::F32 && b.dtype() == DType::F32;
    match (h.dims(), b.dims()) {
        (&[rows, out], &[bout]) if f32s && out == bout && rows * out > 0 => {
            h.contiguous()?.apply_op2(&b.contiguous()?, BiasAdd)
        }
        _ => h.broadcast_add(b),
    }
}

/// Adds a bias row to every row: forward `y[i][j] = h[i][j] + b[j]` (candle's broadcast add);
/// backward `dh = dy` and `db[j] = Σ_i (0 + dy[i][j])` summed from 0 over the rows in order,
/// which is what candle computes through its broadcast node (a zero-filled accumulator, then
/// a row-ordered sum over dimension 0), so the bits are the same, without the
/// `[rows, out]`-sized temporaries and in a loop that vectorises.
#[derive(Clone, Copy, Debug)]
pub struct BiasAdd;

impl CustomOp2 for BiasAdd {
    fn name(&self) -> &'static str {
        "gpecnet-bias-add"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
    ) -> candle_core::Result<(CpuStorage, Shape)> {
        let (h, b) = (f32_slice(s1, l1)?, f32_slice(s2, l2)?);
        let cols = b.len();
        if cols == 0 || h.len() % cols != 0 {
            candle_core::bail!("bias add: {} values, bias of {cols}", h.len());
        }
        // Whole rows per job.
        let y = map_elements(h.len(), cols, |range, y| {
            for (y, h) in y.chunks_mut(cols).zip(h[range].chunks(cols)) {
                for ((y, &h), &b) in y.iter_mut().zip(h).zip(b) {
                    *y = h + b;
                }
            }
        });
        Ok((CpuStorage::F32(y), l1.shape().clone()))
    }

    fn bwd(
        &self,
        _h: &Tensor,
        b: &Tensor,
        _res: &Tensor,
        grad: &Tensor,
    ) -> candle_core::Result<(Option<Tensor>, Option<Tensor>)> {
        let grad = grad.contiguous()?;
        let db = grad.apply_op1_no_bwd(&ColumnSum(b.elem_count()))?;
        Ok((Some(grad), Some(db)))
    }
}

/// `[rows, cols] -> [cols]`: `Σ_i (0 + g[i][j])`, from 0, rows in order (see [`BiasAdd`]).
#[derive(Clone, Copy, Debug)]
struct ColumnSum(usize);

impl CustomOp1 for ColumnSum {
    fn name(&self) -> &'static str {
        "gpecnet-column-sum"
    }

    fn cpu_fwd(&self, s: &CpuStorage, l: &Layout) -> candle_core::Result<(CpuStorage, Shape)> {
        let g = f32_slice(s, l)?;
        let cols = self.0;
        if cols == 0 || g.len() % cols != 0 {
            candle_core::bail!("bias gradient: {} values, bias of {cols}", g.len());
        }
        // Split by columns (each column still summed over the rows in order): one range of
        // columns per thread when the gradient is large enough to be worth it.
        let jobs = if g.len() >= PAR_MIN_CHUNK {
            candle_core::utils::get_num_threads().clamp(1, cols)
        } else {
            1
        };
        let chunk = cols.div_ceil(jobs);
        let mut sum = vec![0f32; cols];
        for_each_job(sum.chunks_mut(chunk).enumerate(), |(i, sum)| {
            let columns = i * chunk..i * chunk + sum.len();
            for row in g.chunks_exact(cols) {
                for (s, &r) in sum.iter_mut().zip(&row[columns.clone()]) {
                    *s += 0.0 + r;
                }
            }
        });
        Ok((CpuStorage::F32(sum), Shape::from(cols)))
    }
}

/// The SIREN activation `sin(w0 · x)` as one differentiable op (see [`SineOp`]); `x` must be
/// f32.
pub fn sine(x: &Tensor, w0: f32) -> candle_core::Result<Tensor> {
    if x.elem_count() == 0 {
        // candle's affine and sin return an empty input as it is.
        return Ok(x.clone());
    }
    x.contiguous()?.apply_op1(SineOp { w0 })
}

/// `sin(w0 · x)` fused: forward `y = sin(x · w0 + 0)`, backward
/// `dx = ((0 + dy · cos(x · w0 + 0)) · w0) + 0`, exactly the f32 operations candle performs for
/// `x.affine(w0, 0).sin()` and its two backward steps (including the additions to zero-filled
/// gradient accumulators), so the results are bit-identical to the unfused graph. Elements are
/// independent, so the multi-threaded split (`chunk_len`) does not change any bit.
#[derive(Clone, Copy, Debug)]
pub struct SineOp {
    /// The SIREN factor.
    pub w0: f32,
}

/// The contiguous f32 data of a storage under `layout`.
fn f32_slice<'a>(s: &'a CpuStorage, layout: &Layout) -> candle_core::Result<&'a [f32]> {
    let data = s.as_slice::<f32>()?;
    match layout.contiguous_offsets() {
        Some((a, b)) => data
            .get(a..b)
            .ok_or_else(|| candle_core::Error::Msg("sine: layout out of range".into())),
        None => candle_core::bail!("sine: needs a contiguous input"),
    }
}

impl SineOp {
    /// candle's `affine(w0, 0)` on one element (`v * mul + add` in f32).
    #[inline(always)]
    fn arg(self, v: f32) -> f32 {
        v * self.w0 + 0.0
    }
}

impl CustomOp1 for SineOp {
    fn name(&self) -> &'static str {
        "gpecnet-sine"
    }

    fn cpu_fwd(&self, s: &CpuStorage, l: &Layout) -> candle_core::Result<(CpuStorage, Shape)> {
        let x = f32_slice(s, l)?;
        let op = *self;
        let y = map_elements(x.len(), 1, |range, y| {
            for (y, &x) in y.iter_mut().zip(&x[range]) {
                *y = op.arg(x).sin();
            }
        });
        Ok((CpuStorage::F32(y), l.shape().clone()))
    }

    fn bwd(
        &self,
        arg: &Tensor,
        _res: &Tensor,
        grad: &Tensor,
    ) -> candle_core::Result<Option<Tensor>> {
        let grad = grad.contiguous()?;
        Ok(Some(arg.apply_op2_no_bwd(&grad, &SineBackward(*self))?))
    }
}

/// The backward pass of [`SineOp`]: `(x, dy) -> dx`.
#[derive(Clone, Copy, Debug)]
struct SineBackward(SineOp);

impl CustomOp2 for SineBackward {
    fn name(&self) -> &'static str {
        "gpecnet-sine-backward"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
    ) -> candle_core::Result<(CpuStorage, Shape)> {
        let (x, g) = (f32_slice(s1, l1)?, f32_slice(s2, l2)?);
        if x.len() != g.len() {
            candle_core::bail!("sine backward: {} inputs, {} gradients", x.len(), g.len());
        }
        let op = self.0;
        let dx = map_elements(x.len(), 1, |range, dx| {
            for ((dx, &x), &g) in dx.iter_mut().zip(&x[range.clone()]).zip(&g[range]) {
                // sin's backward into a zero-filled accumulator, then affine's backward.
                let d_arg = 0.0 + g * op.arg(x).cos();
                *dx = d_arg * op.w0 + 0.0;
            }
        });
        Ok((CpuStorage::F32(dx), l1.shape().clone()))
    }
}

/// A minibatch in model space (see [`crate::data::normalize`]).
#[derive(Clone, Debug)]
pub struct Batch {
    /// `[B, 2 * PAST]`, x/y interleaved.
    pub obs: Tensor,
    /// `[B, 2]`: the endpoint (future step 12).
    pub dest: Tensor,
    /// `[B, 2 * (FUTURE - 1)]`: future steps 1..=11, x/y interleaved.
    pub future: Tensor,
    /// `[B, 2]`: raw last observed position / 1000.
    pub initial_pos: Tensor,
}

impl Batch {
    /// Stack samples into tensors.
    pub fn from_samples<'a, I>(samples: I) -> candle_core::Result<Self>
    where
        I: IntoIterator<Item = &'a Sample>,
    {
        let (mut obs, mut dest, mut fut, mut init): (Vec<f32>, Vec<f32>, Vec<f32>, Vec<f32>) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut n = 0;
        for s in samples {
            obs.extend(s.obs.iter().flatten());
            dest.extend(s.future[FUTURE - 1]);
            fut.extend(s.future[..FUTURE - 1].iter().flatten());
            init.extend(s.initial_pos);
            n += 1;
        }
        let dev = Device::Cpu;
        Ok(Self {
            obs: Tensor::from_vec(obs, (n, 2 * PAST), &dev)?,
            dest: Tensor::from_vec(dest, (n, 2), &dev)?,
            future: Tensor::from_vec(fut, (n, 2 * (FUTURE - 1)), &dev)?,
            initial_pos: Tensor::from_vec(init, (n, 2), &dev)?,
        })
    }

    /// Batch size.
    pub fn len(&self) -> usize {
        self.obs.dims()[0]
    }

    /// `true` for an empty batch.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The training loss and its parts (parts as plain numbers, for logging).
#[derive(Debug)]
pub struct Loss {
    /// `rcl + kld_reg * kld + adl_reg * adl` (differentiable scalar).
    pub total: Tensor,
    /// Endpoint reconstruction MSE (mean over elements).
    pub rcl: f32,
    /// KL divergence, summed over the batch (PECNet's convention).
    pub kld: f32,
    /// Intermediate-points MSE (mean over elements).
    pub adl: f32,
    /// Point head: mean Euclidean displacement over the 12 steps plus the endpoint's
    /// (model units; 0 without a head).
    pub point: f32,
}

/// Outputs of the training-mode forward pass.
#[derive(Debug)]
pub struct TrainForward {
    /// `[B, 2]`.
    pub dest_recon: Tensor,
    /// `[B, zdim]`.
    pub mu: Tensor,
    /// `[B, zdim]`.
    pub logvar: Tensor,
    /// `[B, 2 * (FUTURE - 1)]`.
    pub pred_future: Tensor,
}

/// PECNet, with sine or ReLU MLPs and optional social pooling.
#[derive(Clone, Debug)]
pub struct Model {
    /// Past-trajectory encoder.
    pub encoder_past: Mlp,
    /// Endpoint encoder.
    pub encoder_dest: Mlp,
    /// Latent encoder (training only).
    pub encoder_latent: Mlp,
    /// Endpoint decoder.
    pub decoder: Mlp,
    /// Intermediate-points predictor.
    pub predictor: Mlp,
    /// Non-local social pooling (only with `social_pooling = true`).
    pub social: Option<SocialPooling>,
    /// The point-forecast head (only with a non-empty `point_head_size`).
    pub point_head: Option<Mlp>,
    zdim: usize,
    point_reg: f32,
    kld_reg: f32,
    adl_reg: f32,
}

impl Model {
    /// Build and initialise from `rng` (networks in PECNet's constructor order).
    pub fn new(cfg: &TrainConfig, rng: &mut Rng) -> candle_core::Result<Self> {
        let (a, w0) = (cfg.activation, cfg.w0);
        let cs = cfg.coord_scale;
        let encoder_past =
            Mlp::new(2 * PAST, &cfg.enc_past_size, cfg.fdim, a, w0, rng)?.with_scales(cs, 1.0);
        let encoder_dest =
            Mlp::new(2, &cfg.enc_dest_size, cfg.fdim, a, w0, rng)?.with_scales(cs, 1.0);
        let encoder_latent =
            Mlp::new(2 * cfg.fdim, &cfg.enc_latent_size, 2 * cfg.zdim, a, w0, rng)?;
        let decoder =
            Mlp::new(cfg.fdim + cfg.zdim, &cfg.dec_size, 2, a, w0, rng)?.with_scales(1.0, cs);
        let predictor = Mlp::new(
            2 * cfg.fdim + 2,
            &cfg.predictor_hidden_size,
            2 * (FUTURE - 1),
            a,
            w0,
            rng,
        )?
        .with_scales(1.0, cs);
        // Drawn after everything else: configs without pooling keep their initialisation.
        let social = if cfg.social_pooling {
            Some(SocialPooling::new(cfg, rng)?)
        } else {
            None
        };
        // Drawn last: configs without a head keep their initialisation.
        let point_head = if cfg.point_head_size.is_empty() {
            None
        } else {
            Some(
                Mlp::new(2 * PAST, &cfg.point_head_size, 2 * FUTURE, a, w0, rng)?
                    .with_scales(cs, cs),
            )
        };
        Ok(Self {
            encoder_past,
            encoder_dest,
            encoder_latent,
            decoder,
            predictor,
            social,
            point_head,
            point_reg: cfg.point_reg,
            zdim: cfg.zdim,
            kld_reg: cfg.kld_reg,
            adl_reg: cfg.adl_reg,
        })
    }

    /// Latent dimension.
    pub fn zdim(&self) -> usize {
        self.zdim
    }

    /// All trainable parameters, in a fixed order (the checkpoint / optimizer order).
    pub fn vars(&self) -> Vec<Var> {
        [
            &self.encoder_past,
            &self.encoder_dest,
            &self.encoder_latent,
            &self.decoder,
            &self.predictor,
        ]
        .iter()
        .flat_map(|m| m.vars())
        .chain(self.social.iter().flat_map(|s| s.vars()))
        .chain(self.point_head.iter().flat_map(|h| h.vars()))
        .collect()
    }

    /// Number of tensors of the point head at the end of [`Model::vars`] (0 without one).
    pub fn point_head_tensors(&self) -> usize {
        self.point_head.as_ref().map_or(0, |h| h.vars().len())
    }

    /// The point forecast `[B, FUTURE, 2]` in model space from `obs` `[B, 2 * PAST]`, or
    /// `None` without a head.
    pub fn point_forecast(&self, obs: &Tensor) -> candle_core::Result<Option<Tensor>> {
        match &self.point_head {
            Some(h) => {
                let b = obs.dims()[0];
                Ok(Some(h.forward(obs)?.reshape((b, FUTURE, 2))?))
            }
            None => Ok(None),
        }
    }

    /// `true` when the model has social pooling (its forward passes need a group mask).
    pub fn has_social(&self) -> bool {
        self.social.is_some()
    }

    /// Number of scalar parameters.
    pub fn param_count(&self) -> usize {
        self.vars().iter().map(|v| v.elem_count()).sum()
    }

    /// Copy of every parameter, flattened, in [`Model::vars`] order.
    pub fn weights(&self) -> candle_core::Result<Vec<Vec<f32>>> {
        self.vars()
            .iter()
            .map(|v| v.as_tensor().flatten_all()?.to_vec1::<f32>())
            .collect()
    }

    /// Overwrite every parameter (inverse of [`Model::weights`]).
    pub fn set_weights(&self, weights: &[Vec<f32>]) -> candle_core::Result<()> {
        let vars = self.vars();
        if vars.len() != weights.len() {
            candle_core::bail!(
                "weight count mismatch: model has {} tensors, got {}",
                vars.len(),
                weights.len()
            );
        }
        for (v, w) in vars.iter().zip(weights) {
            if v.elem_count() != w.len() {
                candle_core::bail!(
                    "weight shape mismatch: {:?} vs {} values",
                    v.shape(),
                    w.len()
                );
            }
            v.set(&Tensor::from_slice(w, v.shape(), &Device::Cpu)?)?;
        }
        Ok(())
    }

    /// Training forward pass; `eps ~ N(0, 1)` of shape `[B, zdim]` (from the caller's RNG);
    /// `mask` is the social mask `[B, B]` of the batch (required when the model has social
    /// pooling, ignored otherwise).
    pub fn forward_train(
        &self,
        batch: &Batch,
        eps: &Tensor,
        mask: Option<&Tensor>,
    ) -> candle_core::Result<TrainForward> {
        let features = self.encoder_past.forward(&batch.obs)?;
        let dest_features = self.encoder_dest.forward(&batch.dest)?;
        let latent = self
            .encoder_latent
            .forward(&Tensor::cat(&[&features, &dest_features], 1)?)?;
        let mu = latent.narrow(1, 0, self.zdim)?;
        let logvar = latent.narrow(1, self.zdim, self.zdim)?;
        let std = logvar.affine(0.5, 0.0)?.exp()?;
        let z = (&mu + std.mul(eps)?)?;
        let dest_recon = self.decoder.forward(&Tensor::cat(&[&features, &z], 1)?)?;
        let pred_future = self.predict_future(&features, &dest_recon, &batch.initial_pos, mask)?;
        Ok(TrainForward {
            dest_recon,
            mu,
            logvar,
            pred_future,
        })
    }

    /// PECNet's loss: `MSE(dest, dest_recon) + kld_reg * KLD + adl_reg * MSE(future, pred)`,
    /// with the batch's social mask (see [`Model::forward_train`]).
    pub fn loss(
        &self,
        batch: &Batch,
        eps: &Tensor,
        mask: Option<&Tensor>,
    ) -> candle_core::Result<Loss> {
        let f = self.forward_train(batch, eps, mask)?;
        let rcl = (&batch.dest - &f.dest_recon)?.sqr()?.mean_all()?;
        let adl = (&batch.future - &f.pred_future)?.sqr()?.mean_all()?;
        // -0.5 * sum(1 + logvar - mu^2 - exp(logvar))
        let kld_terms = ((f.logvar.affine(1.0, 1.0)? - f.mu.sqr()?)? - f.logvar.exp()?)?;
        let kld = kld_terms.sum_all()?.affine(-0.5, 0.0)?;
        let mut total = ((&rcl + kld.affine(f64::from(self.kld_reg), 0.0)?)?
            + adl.affine(f64::from(self.adl_reg), 0.0)?)?;
        let mut point = 0.0;
        if let Some(pred) = self.point_forecast(&batch.obs)? {
            let b = batch.len();
            let truth = Tensor::cat(&[&batch.future, &batch.dest], 1)?.reshape((b, FUTURE, 2))?;
            // Euclidean distance per step; the tiny offset keeps the gradient finite at 0.
            let dist = (&pred - &truth)?
                .sqr()?
                .sum(2)?
                .affine(1.0, POINT_LOSS_EPS)?
                .sqrt()?;
            let last = dist.narrow(1, FUTURE - 1, 1)?;
            let l = (dist.mean_all()? + last.mean_all()?)?;
            point = l.to_scalar::<f32>()?;
            total = (total + l.affine(f64::from(self.point_reg), 0.0)?)?;
        }
        Ok(Loss {
            total,
            rcl: rcl.to_scalar::<f32>()?,
            kld: kld.to_scalar::<f32>()?,
            adl: adl.to_scalar::<f32>()?,
            point,
        })
    }

    /// Past features `[B, fdim]` from `obs` `[B, 2 * PAST]`.
    pub fn encode_past(&self, obs: &Tensor) -> candle_core::Result<Tensor> {
        self.encoder_past.forward(obs)
    }

    /// Endpoint `[B, 2]` from past features and a latent `z` `[B, zdim]`.
    pub fn decode_dest(&self, features: &Tensor, z: &Tensor) -> candle_core::Result<Tensor> {
        self.decoder.forward(&Tensor::cat(&[features, z], 1)?)
    }

    /// The 11 intermediate points `[B, 22]` given features, an endpoint and `initial_pos`,
    /// with social pooling of the predictor's input features over `mask` `[B, B]` when the
    /// model has it (then `mask` is required; ignored otherwise).
    pub fn predict_future(
        &self,
        features: &Tensor,
        dest: &Tensor,
        initial_pos: &Tensor,
        mask: Option<&Tensor>,
    ) -> candle_core::Result<Tensor> {
        let dest_features = self.encoder_dest.forward(dest)?;
        let mut feat = Tensor::cat(&[features, &dest_features, initial_pos], 1)?;
        if let Some(social) = &self.social {
            let Some(mask) = mask else {
                candle_core::bail!(
                    "this model has social pooling: its forward pass needs the batch's group mask"
                );
            };
            feat = social.pool(&feat, mask)?;
        }
        self.predictor.forward(&feat)
    }

    /// Inference: full 12-step futures in model space, `[B, FUTURE, 2]`, for latents `z`
    /// `[B, zdim]` (PECNet draws `z ~ N(0, sigma^2)`): 11 predicted points + the endpoint;
    /// `mask` is the social mask `[B, B]` of the rows (see [`Model::predict_future`]).
    pub fn sample_future(
        &self,
        obs: &Tensor,
        initial_pos: &Tensor,
        z: &Tensor,
        mask: Option<&Tensor>,
    ) -> candle_core::Result<Tensor> {
        let features = self.encode_past(obs)?;
        let dest = self.decode_dest(&features, z)?;
        let inter = self.predict_future(&features, &dest, initial_pos, mask)?;
        let b = obs.dims()[0];
        Tensor::cat(&[&inter, &dest], 1)?.reshape((b, FUTURE, 2))
    }

    /// The embedded networks with `w0` folded in (see [`Layer`]). Refuses a model
    /// with social pooling: it needs the other pedestrians at inference, which the embedded
    /// core does not support (such models exist to reproduce PECNet on the host).
    pub fn export_networks(&self) -> candle_core::Result<Networks> {
        if self.has_social() {
            candle_core::bail!(
                "this model uses social pooling (social_pooling = true), which needs the other \
                 pedestrians of the scene at inference; the embedded core does not support it, \
                 so it cannot be exported (it is for reproducing PECNet on the host)"
            );
        }
        Ok(Networks {
            encoder_past: self.encoder_past.export()?,
            decoder: self.decoder.export()?,
            encoder_dest: self.encoder_dest.export()?,
            predictor: self.predictor.export()?,
            point_head: match &self.point_head {
                Some(h) => h.export()?,
                None => Vec::new(),
            },
            proposal: Vec::new(),
        })
    }
}

/// Added under the square root of the point head's per-step squared distance (model units²),
/// so the loss stays differentiable at zero error.
pub const POINT_LOSS_EPS: f64 = 1e-4;

/// `DType` of every tensor in the model.
pub const DTYPE: DType = DType::F32;

#[cfg(test)]
mod tests {
    use super::*;

    fn tiny() -> TrainConfig {
        TrainConfig {
            enc_past_size: vec![8],
            enc_dest_size: vec![4],
            enc_latent_size: vec![8],
            dec_size: vec![8],
            predictor_hidden_size: vec![8],
            fdim: 4,
            zdim: 3,
            ..TrainConfig::default()
        }
    }

    #[test]
    fn export_folds_w0_and_matches_forward() {
        let cfg = tiny();
        let m = Model::new(&cfg, &mut Rng::new(3)).unwrap();
        let ex = m.export_networks().unwrap();
        assert_eq!(ex.encoder_past[0].act, Act::Sine);
        assert_eq!(ex.encoder_past.last().unwrap().act, Act::Linear);
        let x: Vec<f32> = (0..16).map(|i| i as f32 * 0.37 - 2.0).collect();
        // Reference forward of the exported layers in f64.
        let mut h: Vec<f64> = x.iter().map(|&v| v as f64).collect();
        for l in &ex.encoder_past {
            let mut y = vec![0.0f64; l.out_dim];
            for (o, yo) in y.iter_mut().enumerate() {
                let mut s = l.b[o] as f64;
                for (i, hi) in h.iter().enumerate() {
                    s += l.w[o * l.in_dim + i] as f64 * hi;
                }
                *yo = match l.act {
                    Act::Sine => s.sin(),
                    Act::Relu => s.max(0.0),
                    Act::Linear => s,
                };
            }
            h = y;
        }
        let t = Tensor::from_vec(x, (1, 16), &Device::Cpu).unwrap();
        let got = m
            .encode_past(&t)
            .unwrap()
            .flatten_all()
            .unwrap()
            .to_vec1::<f32>()
            .unwrap();
        for (a, b) in got.iter().zip(&h) {
            assert!((*a as f64 - b).abs() < 1e-3, "{a} vs {b}");
        }
    }

    /// Bits of a tensor.
    fn bits(t: &Tensor) -> Vec<u32> {
        t.flatten_all()
            .unwrap()
            .to_vec1::<f32>()
            .unwrap()
            .iter()
            .map(|v| v.to_bits())
            .collect()
    }

    /// Asserts that `fused` and `plain`, the same values computed from `vars` by a fused op
    /// and by candle's plain graph, have the same bits, and so do the gradients of every var
    /// for the loss `Σ out · g`. `what` names the case in a failure.
    fn assert_same_bits_and_gradients(
        fused: &Tensor,
        plain: &Tensor,
        g: &Tensor,
        vars: &[(&str, &Var)],
        what: &str,
    ) {
        assert_eq!(bits(fused), bits(plain), "forward, {what}");
        let grads = |out: &Tensor| (out * g).unwrap().sum_all().unwrap().backward().unwrap();
        let (gf, gp) = (grads(fused), grads(plain));
        for (name, v) in vars {
            let (a, b) = (
                gf.get(v.as_tensor()).unwrap(),
                gp.get(v.as_tensor()).unwrap(),
            );
            assert_eq!(bits(a), bits(b), "gradient of {name}, {what}");
        }
    }

    #[test]
    fn fused_sine_is_bit_identical_to_candles_affine_sin() {
        // Large enough to be split into several chunks on any thread count.
        let n = 3 * PAR_MIN_CHUNK + 17;
        let mut rng = Rng::new(9);
        let mut x: Vec<f32> = (0..n).map(|_| rng.uniform(-40.0, 40.0)).collect();
        x[..4].copy_from_slice(&[0.0, -0.0, 1e-30, -1e-30]);
        let g: Vec<f32> = (0..n).map(|_| rng.uniform(-3.0, 3.0)).collect();
        for w0 in [1.0f32, 30.0, 0.5] {
            let xv = Var::from_vec(x.clone(), (n, 1), &Device::Cpu).unwrap();
            let gt = Tensor::from_vec(g.clone(), xv.shape(), &Device::Cpu).unwrap();
            let fused = sine(xv.as_tensor(), w0).unwrap();
            let plain = xv
                .as_tensor()
                .affine(f64::from(w0), 0.0)
                .unwrap()
                .sin()
                .unwrap();
            let what = format!("w0 = {w0}");
            assert_same_bits_and_gradients(&fused, &plain, &gt, &[("x", &xv)], &what);
        }
    }

    #[test]
    fn fused_bias_add_is_bit_identical_to_candles_broadcast_add() {
        let mut rng = Rng::new(11);
        // Rows x columns large enough for several jobs; a second, odd shape.
        for (rows, cols) in [(300, 257), (5, 3)] {
            let h: Vec<f32> = (0..rows * cols).map(|_| rng.uniform(-5.0, 5.0)).collect();
            let b: Vec<f32> = (0..cols).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let g: Vec<f32> = (0..rows * cols).map(|_| rng.uniform(-3.0, 3.0)).collect();
            let hv = Var::from_vec(h, (rows, cols), &Device::Cpu).unwrap();
            let bv = Var::from_vec(b, cols, &Device::Cpu).unwrap();
            let gt = Tensor::from_vec(g, (rows, cols), &Device::Cpu).unwrap();
            let fused = add_bias(hv.as_tensor(), bv.as_tensor()).unwrap();
            let plain = hv.as_tensor().broadcast_add(bv.as_tensor()).unwrap();
            let vars = [("h", &hv), ("b", &bv)];
            let what = format!("{rows}x{cols}");
            assert_same_bits_and_gradients(&fused, &plain, &gt, &vars, &what);
        }
    }

    #[test]
    fn fused_linear_is_bit_identical_to_candles_matmul_and_broadcast_add() {
        let mut rng = Rng::new(12);
        let dev = Device::Cpu;
        let mut vec =
            |n: usize, r: f32| -> Vec<f32> { (0..n).map(|_| rng.uniform(-r, r)).collect() };
        // x feeds two layers and the second layer is used twice (like `encoder_dest`): the
        // gradients of shared tensors are accumulated from several nodes.
        let (m, k, n) = (300, 33, 130);
        let x = Var::from_vec(vec(m * k, 2.0), (m, k), &dev).unwrap();
        let w1 = Var::from_vec(vec(n * k, 0.5), (n, k), &dev).unwrap();
        let b1 = Var::from_vec(vec(n, 0.5), n, &dev).unwrap();
        let w2 = Var::from_vec(vec(n * k, 0.5), (n, k), &dev).unwrap();
        let b2 = Var::from_vec(vec(n, 0.5), n, &dev).unwrap();
        let mut g = vec(m * n, 3.0);
        g[..3].copy_from_slice(&[-0.0, 0.0, -0.0]);
        let g = Tensor::from_vec(g, (m, n), &dev).unwrap();
        let out = |fused: bool| {
            let lin = |x: &Tensor, w: &Var, b: &Var| {
                if fused {
                    linear(x, w.as_tensor(), b.as_tensor()).unwrap()
                } else {
                    x.matmul(&w.as_tensor().t().unwrap())
                        .unwrap()
                        .broadcast_add(b.as_tensor())
                        .unwrap()
                }
            };
            let y1 = lin(x.as_tensor(), &w1, &b1);
            let y2 = lin(x.as_tensor(), &w2, &b2);
            let y3 = lin(&x.as_tensor().affine(0.5, 0.0).unwrap(), &w2, &b2);
            ((y1 + y2).unwrap() + y3).unwrap()
        };
        let vars = [
            ("x", &x),
            ("w1", &w1),
            ("b1", &b1),
            ("w2", &w2),
            ("b2", &b2),
        ];
        assert_same_bits_and_gradients(&out(true), &out(false), &g, &vars, "linear");
    }

    #[test]
    fn fused_linear_sine_is_bit_identical_to_linear_then_sine() {
        let mut rng = Rng::new(14);
        let dev = Device::Cpu;
        // Large enough for several elementwise jobs; a small odd shape; w0 = 1, 30, 0.5.
        for ((m, k, n), w0) in [
            ((300, 33, 257), 1.0f32),
            ((5, 3, 4), 30.0),
            ((64, 8, 16), 0.5),
        ] {
            let mut vec =
                |len: usize, r: f32| -> Vec<f32> { (0..len).map(|_| rng.uniform(-r, r)).collect() };
            let x = Var::from_vec(vec(m * k, 2.0), (m, k), &dev).unwrap();
            let w = Var::from_vec(vec(n * k, 0.5), (n, k), &dev).unwrap();
            let b = Var::from_vec(vec(n, 0.5), n, &dev).unwrap();
            let mut g = vec(m * n, 3.0);
            g[..3].copy_from_slice(&[-0.0, 0.0, -0.0]);
            let g = Tensor::from_vec(g, (m, n), &dev).unwrap();
            // The layer is applied twice to x (shared weights, accumulated gradients).
            let out = |fused: bool| {
                let layer = |x: &Tensor| {
                    if fused {
                        linear_sine(x, w.as_tensor(), b.as_tensor(), w0).unwrap()
                    } else {
                        sine(&linear(x, w.as_tensor(), b.as_tensor()).unwrap(), w0).unwrap()
                    }
                };
                let x2 = x.as_tensor().affine(0.5, 0.0).unwrap();
                (layer(x.as_tensor()) + layer(&x2)).unwrap()
            };
            let vars = [("x", &x), ("w", &w), ("b", &b)];
            let what = format!("{m}x{k} -> {n}, w0 = {w0}");
            assert_same_bits_and_gradients(&out(true), &out(false), &g, &vars, &what);
        }
    }

    #[test]
    fn weight_gradient_is_bit_identical_to_candles_transposed_product() {
        let mut rng = Rng::new(13);
        // Paper-size layers (the last batch of an epoch too), more rows than one `kc` block of
        // the gemm crate (512), and the shapes that keep candle's form.
        let shapes = [
            (512, 1024, 512),
            (448, 512, 1024),
            (512, 34, 1024),
            (1000, 40, 70),
            (300, 2, 8),
            (7, 5, 3),
            (3, 9, 4),
            (2, 9, 4),
            (1, 9, 4),
            (50, 1, 6),
            (50, 6, 1),
        ];
        for (rows, cols_in, cols_out) in shapes {
            let mut vec =
                |n: usize| -> Vec<f32> { (0..n).map(|_| rng.uniform(-2.0, 2.0)).collect() };
            let x = Tensor::from_vec(vec(rows * cols_in), (rows, cols_in), &Device::Cpu).unwrap();
            let g = Tensor::from_vec(vec(rows * cols_out), (rows, cols_out), &Device::Cpu).unwrap();
            let ours = weight_gradient(&x, &g).unwrap();
            let candle = x.t().unwrap().matmul(&g).unwrap().t().unwrap();
            assert_eq!(ours.dims(), &[cols_out, cols_in]);
            assert_eq!(
                bits(&ours),
                bits(&candle),
                "{rows} rows, {cols_in} -> {cols_out}"
            );
        }
    }

    #[test]
    fn init_is_seeded() {
        let cfg = tiny();
        let a = Model::new(&cfg, &mut Rng::new(5))
            .unwrap()
            .weights()
            .unwrap();
        let b = Model::new(&cfg, &mut Rng::new(5))
            .unwrap()
            .weights()
            .unwrap();
        let c = Model::new(&cfg, &mut Rng::new(6))
            .unwrap()
            .weights()
            .unwrap();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }
}
