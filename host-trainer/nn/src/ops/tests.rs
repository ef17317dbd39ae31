//! The fused ops against candle's plain graph: forward values and every gradient, bit for bit.

use super::*;
use crate::rng::Rng;
use candle_core::Var;

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
    let mut vec = |n: usize, r: f32| -> Vec<f32> { (0..n).map(|_| rng.uniform(-r, r)).collect() };
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
        let mut vec = |n: usize| -> Vec<f32> { (0..n).map(|_| rng.uniform(-2.0, 2.0)).collect() };
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
