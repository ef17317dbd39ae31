//! Fused candle ops with their backward passes. Each dense layer is one op ([`Dense`]:
//! candle's own matmul, then the bias) and the sine activation another ([`SineOp`]: candle's
//! `x.affine(w0, 0).sin()` in one pass), or, inside a sine MLP, both are one op ([`Dense`]
//! with its sine). Their forward and backward passes perform the very f32 operations of the
//! unfused candle graph, so training is bit-identical to it, but without its intermediate
//! tensors and zero-filled gradient accumulators, and the elementwise work is split over the
//! run's threads ([`crate::pool::for_each_job`]).

use candle_core::{CpuStorage, CustomOp1, CustomOp2, DType, Device, Layout, Shape, Tensor};

use crate::pool::{chunk_len, for_each_job, map_elements, PAR_MIN_CHUNK};

/// `x Wᵀ + b` for `x` `[rows, in]`, `W` `[out, in]`, `b` `[out]`, as one differentiable op
/// ([`Dense`] without a sine); the same bits as candle's `x.matmul(&w.t()).broadcast_add(b)`
/// and its gradients. Empty or other shapes, and dtypes other than f32, fall back to that
/// graph.
pub fn linear(x: &Tensor, w: &Tensor, b: &Tensor) -> candle_core::Result<Tensor> {
    if fusable(x, w, b) {
        x.apply_op3(w, b, Dense::new(None))
    } else {
        add_bias(&x.matmul(&w.t()?)?, b)
    }
}

/// `sin(w0 · (x Wᵀ + b))`, a dense layer and its SIREN activation, as one differentiable op
/// ([`Dense`] with a sine); the same bits as [`linear`] followed by [`sine`], and the same
/// gradients. Shapes and dtypes [`linear`] does not fuse fall back to the two ops.
pub fn linear_sine(x: &Tensor, w: &Tensor, b: &Tensor, w0: f32) -> candle_core::Result<Tensor> {
    if fusable(x, w, b) {
        x.apply_op3(w, b, Dense::new(Some(SineOp { w0 })))
    } else {
        sine(&linear(x, w, b)?, w0)
    }
}

/// Whether [`Dense`] takes `x`, `W`, `b`: f32, `[rows, in]`, `[out, in]`, `[out]`, none empty.
fn fusable(x: &Tensor, w: &Tensor, b: &Tensor) -> bool {
    let f32s = [x, w, b].iter().all(|t| t.dtype() == DType::F32);
    matches!(
        (x.dims(), w.dims(), b.dims()),
        (&[m, k], &[n, k2], &[n2]) if f32s && k == k2 && n == n2 && m * n * k > 0
    )
}

/// A dense layer `y = x Wᵀ + b`, optionally followed by its sine `sin(y · w0 + 0)`
/// ([`SineOp`]), as one node of the graph.
///
/// Forward: candle's own CPU matmul on the same layouts `x.matmul(&w.t())` passes it, then
/// `h[i][j] = y[i][j] + b[j]`; with the sine, `sin(h · w0 + 0)`, `h` kept in the op for the
/// backward pass.
///
/// Backward, from `G`: without the sine `G = 0 + dy` (candle's zero-filled accumulator of the
/// matmul output); with it `G = 0 + (((0 + dy · cos(h · w0 + 0)) · w0) + 0)` —
/// `SineBackward`'s operations followed by the zero-filled accumulator candle would add `h`'s
/// gradient to. Then `dx = G.matmul(&w.t().t())`, `dW = (x.t().matmul(&G)).t()`, `db` as
/// [`BiasAdd`]'s — the operations and operands candle's matmul, transpose, broadcast-add and
/// sine nodes use, so the bits are the same, without their zero-filled accumulators and
/// copies (with the sine also without the graph node of `h`: an allocation, a fill and an add
/// over `[rows, out]`, and a scan).
#[derive(Debug)]
pub struct Dense {
    /// The sine after the layer, if any.
    sine: Option<SineOp>,
    /// `h = x Wᵀ + b` of the forward pass (with a sine only).
    pre: std::sync::OnceLock<Vec<f32>>,
}

impl Dense {
    /// The op for a layer followed by `sine` (`None`: the layer alone).
    pub fn new(sine: Option<SineOp>) -> Self {
        Self {
            sine,
            pre: std::sync::OnceLock::new(),
        }
    }
}

impl candle_core::CustomOp3 for Dense {
    fn name(&self) -> &'static str {
        match self.sine {
            None => "gpecnet-linear",
            Some(_) => "gpecnet-linear-sine",
        }
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
        let Some(op) = self.sine else {
            return Ok((CpuStorage::F32(h), Shape::from((m, n))));
        };
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
        let Some(op) = self.sine else {
            // `0 + dy` is `dy` itself unless `dy` holds a -0.0 (or is strided).
            let g = if grad.is_contiguous() && !has_negative_zero(grad)? {
                grad.clone()
            } else {
                grad.affine(1.0, 0.0)?
            };
            return linear_backward(x, w, b, &g);
        };
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

/// [`Dense`]'s layer, forward: `(x Wᵀ + b, rows, out)`.
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

/// [`Dense`]'s layer, backward from `G`, the gradient of its output after candle's accumulator
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

// `cpu_fwd` as candle's `CustomOp2` declares it, the same signature as `BiasAdd`'s.
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

#[cfg(test)]
mod tests;
