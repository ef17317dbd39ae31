//! The ONNX export against the shipped blobs and the reference inference.

use super::*;
use gpecnet_core::frame::Frame;
use gpecnet_core::prng::Gaussian;
use gpecnet_core::{LibmSine, Predictor};
use std::collections::HashMap;

fn blob(name: &str) -> Vec<u8> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../weights/{name}.gpec"));
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn decode(name: &str) -> (ModelProto, RefModel) {
    let b = blob(name);
    let (bytes, summary) = blob_to_onnx(&b, false).unwrap();
    assert_eq!(summary.bytes, bytes.len());
    (
        ModelProto::decode(bytes.as_slice()).unwrap(),
        crate::export::read_blob(&b).unwrap(),
    )
}

fn dims(v: &ValueInfoProto) -> Vec<String> {
    let t = v.r#type.as_ref().unwrap().tensor_type.as_ref().unwrap();
    assert_eq!(t.elem_type, FLOAT);
    t.shape
        .as_ref()
        .unwrap()
        .dim
        .iter()
        .map(|d| match d.value.as_ref().unwrap() {
            DimValue::DimValue(v) => v.to_string(),
            DimValue::DimParam(s) => s.clone(),
        })
        .collect()
}

fn f32s(t: &TensorProto) -> Vec<f32> {
    t.raw_data
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

#[test]
fn shipped_blobs_export_well_formed_models() {
    for name in ["sdd-small", "sdd-tiny-v2", "sdd-tiny"] {
        let (m, r) = decode(name);
        assert_eq!(
            (m.ir_version, m.opset_import[0].version),
            (IR_VERSION, OPSET)
        );
        let g = m.graph.as_ref().unwrap();
        let c = &r.config;
        let io = |v: &[ValueInfoProto]| -> Vec<(String, Vec<String>)> {
            v.iter().map(|p| (p.name.clone(), dims(p))).collect()
        };
        let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        let (px, zd) = ((2 * c.past_len).to_string(), c.zdim.to_string());
        let mut want_in = vec![
            ("x".to_string(), s(&["n", &px])),
            ("z".to_string(), s(&["n", "k", &zd])),
        ];
        let mut want_out = vec![("d".to_string(), s(&["n", "k", "2"]))];
        if !r.nets.point_head.is_empty() {
            let w = (2 * c.future_len).to_string();
            want_out.push(("point".into(), s(&["n", &w])));
        }
        if !r.nets.predictor.is_empty() {
            want_in.push(("pos".into(), s(&["n", "2"])));
            let w = (2 * (c.future_len - 1)).to_string();
            want_out.push(("traj".into(), s(&["n", "k", &w])));
        }
        assert_eq!(io(&g.input), want_in, "{name}");
        assert_eq!(io(&g.output), want_out, "{name}");
        // Every weight and bias of the blob, transposed, split where documented.
        let init: HashMap<&str, &TensorProto> =
            g.initializer.iter().map(|t| (t.name.as_str(), t)).collect();
        let fdim = c.fdim;
        let ddim = r.nets.encoder_dest.last().map_or(0, |l| l.out_dim);
        let mut params = 0;
        for (net, layers) in crate::network::NETWORK_NAMES
            .iter()
            .zip(r.nets.in_blob_order())
        {
            for (i, l) in layers.iter().enumerate() {
                let parts: Vec<(String, std::ops::Range<usize>)> = match (*net, i) {
                    ("decoder", 0) => vec![
                        ("decoder.0.weight.f".into(), 0..fdim),
                        ("decoder.0.weight.z".into(), fdim..l.in_dim),
                    ],
                    ("predictor", 0) => vec![
                        ("predictor.0.weight.f".into(), 0..fdim),
                        ("predictor.0.weight.g".into(), fdim..fdim + ddim),
                        ("predictor.0.weight.pos".into(), fdim + ddim..l.in_dim),
                    ],
                    _ => vec![(format!("{net}.{i}.weight"), 0..l.in_dim)],
                };
                for (pname, cols) in parts {
                    let t = init[pname.as_str()];
                    assert_eq!(t.dims, vec![cols.len() as i64, l.out_dim as i64], "{pname}");
                    let want: Vec<f32> = cols
                        .clone()
                        .flat_map(|ci| (0..l.out_dim).map(move |j| l.w[j * l.in_dim + ci]))
                        .collect();
                    assert_eq!(f32s(t), want, "{pname}");
                }
                let b = init[format!("{net}.{i}.bias").as_str()];
                assert_eq!(b.dims, vec![l.out_dim as i64]);
                assert_eq!(f32s(b), l.b);
                params += l.w.len() + l.b.len();
            }
        }
        let counted: usize = g
            .initializer
            .iter()
            .filter(|t| t.data_type == FLOAT)
            .map(|t| t.raw_data.len() / 4)
            .sum();
        assert_eq!(counted, params, "{name}");
        // Every node input is a graph input, an initializer or an earlier output.
        let mut known: std::collections::HashSet<String> =
            g.input.iter().map(|i| i.name.clone()).collect();
        known.extend(g.initializer.iter().map(|t| t.name.clone()));
        for n in &g.node {
            for i in &n.input {
                assert!(known.contains(i), "{name}: {} reads unknown {i}", n.name);
            }
            known.extend(n.output.iter().cloned());
        }
        for o in &g.output {
            assert!(known.contains(&o.name));
        }
    }
}

#[test]
fn endpoint_only_has_x_z_and_d() {
    let (bytes, s) = blob_to_onnx(&blob("sdd-tiny-v2"), true).unwrap();
    let g = ModelProto::decode(bytes.as_slice()).unwrap().graph.unwrap();
    let names = |v: &[ValueInfoProto]| v.iter().map(|p| p.name.clone()).collect::<Vec<_>>();
    assert_eq!(names(&g.input), ["x", "z"]);
    assert_eq!(names(&g.output), ["d"]);
    assert_eq!(s.inputs.len(), 2);
    assert!(g
        .initializer
        .iter()
        .all(|t| t.name.starts_with("encoder_past.") || t.name.starts_with("decoder.")));
}

#[test]
fn refuses_fixed_point_and_garbage_without_panicking() {
    let e = blob_to_onnx(&blob("sdd-small-q"), false)
        .unwrap_err()
        .to_string();
    assert!(e.contains("fixed-point"), "{e}");
    assert!(blob_to_onnx(b"not a blob", false).is_err());
    let mut b = blob("sdd-tiny");
    let n = b.len();
    b[n / 2] ^= 0x40;
    assert!(blob_to_onnx(&b, false).is_err());
    assert!(blob_to_onnx(&[], true).is_err());
    let dir = tempfile::tempdir().unwrap();
    assert!(export_onnx(
        &dir.path().join("missing.gpec"),
        &dir.path().join("m.onnx"),
        false
    )
    .is_err());
}

/// A tensor of the tiny interpreter below: shape and row-major f64 values.
type T = (Vec<usize>, Vec<f64>);

fn broadcast_add(a: &T, b: &T) -> T {
    broadcast(a, b, |x, y| x + y)
}

/// `f` element by element under numpy broadcasting.
fn broadcast(a: &T, b: &T, f: impl Fn(f64, f64) -> f64) -> T {
    let r = a.0.len().max(b.0.len());
    let pad = |s: &[usize]| {
        let mut v = vec![1; r - s.len()];
        v.extend_from_slice(s);
        v
    };
    let (sa, sb) = (pad(&a.0), pad(&b.0));
    let shape: Vec<usize> = sa.iter().zip(&sb).map(|(x, y)| *x.max(y)).collect();
    let n: usize = shape.iter().product();
    let index = |s: &[usize], mut flat: usize| {
        let (mut idx, mut stride) = (0, 1);
        for d in (0..r).rev() {
            let i = flat % shape[d];
            flat /= shape[d];
            if s[d] != 1 {
                idx += i * stride;
            }
            stride *= s[d];
        }
        idx
    };
    let v = (0..n)
        .map(|i| f(a.1[index(&sa, i)], b.1[index(&sb, i)]))
        .collect();
    (shape, v)
}

fn matmul(a: &T, b: &T) -> T {
    let (m, n) = (b.0[0], b.0[1]);
    let rows = a.1.len() / m;
    let mut v = vec![0.0; rows * n];
    for r in 0..rows {
        for j in 0..n {
            v[r * n + j] = (0..m).map(|i| a.1[r * m + i] * b.1[i * n + j]).sum();
        }
    }
    let mut shape = a.0.clone();
    *shape.last_mut().unwrap() = n;
    (shape, v)
}

/// Runs the exported graph (the ops it uses) in f64.
fn run(g: &GraphProto, feeds: Vec<(&str, T)>) -> HashMap<String, T> {
    let mut env: HashMap<String, T> = feeds.into_iter().map(|(k, v)| (k.into(), v)).collect();
    for t in &g.initializer {
        let shape = t.dims.iter().map(|&d| d as usize).collect();
        let v = if t.data_type == INT64 {
            t.raw_data
                .chunks_exact(8)
                .map(|c| i64::from_le_bytes(c.try_into().unwrap()) as f64)
                .collect()
        } else {
            f32s(t).into_iter().map(f64::from).collect()
        };
        env.insert(t.name.clone(), (shape, v));
    }
    for n in &g.node {
        let a = &env[&n.input[0]];
        let out = match n.op_type.as_str() {
            "MatMul" => matmul(a, &env[&n.input[1]]),
            "Add" => broadcast_add(a, &env[&n.input[1]]),
            "Sin" => (a.0.clone(), a.1.iter().map(|v| v.sin()).collect()),
            "Relu" => (a.0.clone(), a.1.iter().map(|v| v.max(0.0)).collect()),
            "Identity" => a.clone(),
            "Unsqueeze" => {
                let ax = env[&n.input[1]].1[0] as usize;
                let mut s = a.0.clone();
                s.insert(ax, 1);
                (s, a.1.clone())
            }
            "Sub" => broadcast(a, &env[&n.input[1]], |x, y| x - y),
            "Mul" => broadcast(a, &env[&n.input[1]], |x, y| x * y),
            "Div" => broadcast(a, &env[&n.input[1]], |x, y| x / y),
            "Sqrt" => (a.0.clone(), a.1.iter().map(|v| v.sqrt()).collect()),
            "Clip" => {
                let (lo, hi) = (env[&n.input[1]].1[0], env[&n.input[2]].1[0]);
                (a.0.clone(), a.1.iter().map(|v| v.clamp(lo, hi)).collect())
            }
            "Reshape" => {
                // 0 keeps the input's size of that axis (the graph uses no -1).
                let want = &env[&n.input[1]].1;
                let s = want
                    .iter()
                    .enumerate()
                    .map(|(i, &d)| if d == 0.0 { a.0[i] } else { d as usize })
                    .collect::<Vec<_>>();
                assert_eq!(s.iter().product::<usize>(), a.1.len(), "{}", n.name);
                (s, a.1.clone())
            }
            "Softmax" => {
                // The last axis (the default axis of opset 13 and later).
                let w = *a.0.last().unwrap();
                let v =
                    a.1.chunks(w)
                        .flat_map(|r| {
                            let m = r.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                            let e: Vec<f64> = r.iter().map(|x| (x - m).exp()).collect();
                            let sum: f64 = e.iter().sum();
                            e.into_iter().map(move |x| x / sum)
                        })
                        .collect();
                (a.0.clone(), v)
            }
            "Slice" => {
                // One axis, positive starts and ends.
                let (st, en) = (
                    env[&n.input[1]].1[0] as usize,
                    env[&n.input[2]].1[0] as usize,
                );
                let ax = env[&n.input[3]].1[0] as usize;
                let inner: usize = a.0[ax + 1..].iter().product();
                let outer: usize = a.0[..ax].iter().product();
                let mut v = Vec::new();
                for o in 0..outer {
                    for i in st..en {
                        let at = (o * a.0[ax] + i) * inner;
                        v.extend_from_slice(&a.1[at..at + inner]);
                    }
                }
                let mut s = a.0.clone();
                s[ax] = en - st;
                (s, v)
            }
            "ReduceSum" => {
                // One axis, kept (keepdims = 1, the default).
                let ax = env[&n.input[1]].1[0] as usize;
                let inner: usize = a.0[ax + 1..].iter().product();
                let outer: usize = a.0[..ax].iter().product();
                let mut v = vec![0.0; outer * inner];
                for o in 0..outer {
                    for i in 0..a.0[ax] {
                        for j in 0..inner {
                            v[o * inner + j] += a.1[(o * a.0[ax] + i) * inner + j];
                        }
                    }
                }
                let mut s = a.0.clone();
                s[ax] = 1;
                (s, v)
            }
            op => panic!("unexpected op {op}"),
        };
        env.insert(n.output[0].clone(), out);
    }
    env
}

/// The graph's inputs for `past` as the core computes them: its frame, `x` and `pos`.
fn graph_inputs(model: &gpecnet_core::Model<'_>, past: &[[f32; 2]]) -> (Frame, Vec<f64>, Vec<f64>) {
    let c = model.config();
    let (frame, pts) = Frame::inputs(past, model).unwrap();
    let x = pts[..past.len()]
        .iter()
        .flatten()
        .map(|&v| f64::from(v))
        .collect();
    let q = frame.predictor_position(past[past.len() - 1]);
    let pos = vec![
        f64::from(q[0] / c.initial_pos_divisor),
        f64::from(q[1] / c.initial_pos_divisor),
    ];
    (frame, x, pos)
}

#[test]
fn graph_computes_what_the_core_computes() {
    for name in ["sdd-small", "sdd-tiny-v2"] {
        let b = blob(name);
        let (m, r) = decode(name);
        let g = m.graph.unwrap();
        let model = gpecnet_core::Model::from_blob(&b).unwrap();
        let c = *model.config();
        let mut p = Box::new(Predictor::<LibmSine, 256>::new(model).unwrap());
        let (k, zdim) = (5, c.zdim as usize);
        for w in 0..3u64 {
            let past: Vec<[f32; 2]> = (0..c.past_len as usize)
                .map(|t| {
                    let t = t as f32;
                    [100.0 + 3.5 * t + w as f32 * t * t * 0.3, 200.0 - 2.0 * t]
                })
                .collect();
            let (frame, x, pos) = graph_inputs(&model, &past);
            let mut gs = Gaussian::new(w);
            let z: Vec<f64> = (0..k * zdim)
                .map(|_| f64::from(c.sigma * gs.next()))
                .collect();
            let env = run(
                &g,
                vec![
                    ("x", (vec![1, x.len()], x)),
                    ("z", (vec![1, k, zdim], z)),
                    ("pos", (vec![1, 2], pos)),
                ],
            );
            let mut ends = vec![[0.0f32; 2]; k];
            p.predict_samples(&past, w, &mut ends).unwrap();
            let d = &env["d"];
            assert_eq!(d.0, vec![1, k, 2]);
            for (s, e) in ends.iter().enumerate() {
                let got = frame.output([d.1[2 * s] as f32, d.1[2 * s + 1] as f32], c.data_scale);
                for ci in 0..2 {
                    assert!((got[ci] - e[ci]).abs() < 1e-2, "{name}: {got:?} vs {e:?}");
                }
            }
            if !r.nets.point_head.is_empty() {
                let want = p.predict_point(&past).unwrap();
                let q = &env["point"].1;
                for (t, e) in want.iter().enumerate() {
                    let got = frame.output([q[2 * t] as f32, q[2 * t + 1] as f32], c.data_scale);
                    assert!((got[0] - e[0]).abs() < 1e-2 && (got[1] - e[1]).abs() < 1e-2);
                }
            }
        }
    }
}

/// A proposal model's graph (no `z` input; `prob` and `radii` outputs) against the core's
/// whole forecast (`Predictor::predict_forecast`) on 40 walkers in metres:
/// every output within 1e-5 of the blob's unit (metres), in f64. `sdd-m-lp` has
/// probabilities and radii; `sdd-m-lp-host` has neither.
#[test]
fn proposal_graph_computes_the_cores_forecast() {
    for name in ["sdd-m-lp", "sdd-m-lp-host"] {
        let b = blob(name);
        let (m, r) = decode(name);
        let g = m.graph.unwrap();
        let names = |v: &[ValueInfoProto]| v.iter().map(|p| p.name.clone()).collect::<Vec<_>>();
        let traj = !r.nets.predictor.is_empty();
        let scored = r.is_scored();
        let mut want_out = vec!["d", "point"];
        if scored {
            want_out.extend(["prob", "radii"]);
        }
        let want_in = ["x", "pos"];
        if traj {
            want_out.push("traj");
        }
        assert_eq!(names(&g.input), want_in[..1 + traj as usize], "{name}");
        assert_eq!(names(&g.output), want_out, "{name}");
        let k = r.proposal_latents();
        assert_eq!(dims(&g.output[0]), ["n", &k.to_string(), "2"]);
        let model = gpecnet_core::Model::from_blob(&b).unwrap();
        let c = *model.config();
        let mut p = Box::new(Predictor::<LibmSine, 256>::new(model).unwrap());
        let mut worst = 0.0f64;
        for w in 0..40u64 {
            // Walkers at 0.3-1.8 m/s on gentle curves, as the model sees in metres.
            let v = 0.3 + 0.04 * w as f32;
            let past: Vec<[f32; 2]> = (0..c.past_len as usize)
                .map(|t| {
                    let t = t as f32 * 0.4;
                    let a = 0.05 * (w % 7) as f32 * t;
                    [
                        3.0 + v * t * a.cos(),
                        -7.0 + v * t * a.sin() * (w % 3) as f32,
                    ]
                })
                .collect();
            let (frame, x, pos) = graph_inputs(&model, &past);
            let env = run(
                &g,
                vec![("x", (vec![1, x.len()], x)), ("pos", (vec![1, 2], pos))],
            );
            let want = p.predict_forecast::<64>(&past, w).unwrap();
            assert_eq!(want.endpoints.len(), k);
            let out = |v: &[f64], i: usize| {
                frame.output([v[2 * i] as f32, v[2 * i + 1] as f32], c.data_scale)
            };
            let mut diff = |a: f32, b: f32| worst = worst.max(f64::from((a - b).abs()));
            for (i, e) in want.endpoints.iter().enumerate() {
                let got = out(&env["d"].1, i);
                diff(got[0], e[0]);
                diff(got[1], e[1]);
            }
            assert_eq!(want.learned, scored);
            if scored {
                for (i, q) in want.probabilities.iter().enumerate() {
                    diff(env["prob"].1[i] as f32, *q);
                }
                let radii = want.radii.unwrap();
                assert_eq!(env["radii"].0, vec![1, 2]);
                diff(env["radii"].1[0] as f32, radii.r50);
                diff(env["radii"].1[1] as f32, radii.r90);
            }
            let pt = want.point.unwrap();
            let got = out(&env["point"].1, c.future_len as usize - 1);
            diff(got[0], pt[0]);
            diff(got[1], pt[1]);
        }
        assert!(worst <= 1e-5, "{name}: worst difference {worst}");
    }
}
