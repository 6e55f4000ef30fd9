//! The vendored candle-core's changes (vendor/README.md) give candle's values: here the
//! tiled copy of transposed views, checked against indexing element by element, and linear
//! layers' weight gradients, checked against upstream's bit for bit.

use candle_core::{Device, IndexOp as _, Tensor};

fn values(t: &Tensor) -> Vec<f32> {
    t.flatten_all().unwrap().to_vec1().unwrap()
}

#[test]
fn transposed_views_copy_to_their_elements() {
    for (r, c) in [(1, 7), (7, 1), (3, 5), (16, 16), (17, 33), (64, 130)] {
        let v: Vec<f32> = (0..r * c).map(|i| i as f32 * 0.5 - 3.0).collect();
        let a = Tensor::from_vec(v.clone(), (r, c), &Device::Cpu).unwrap();
        // (c, r) transposed, copied contiguous.
        let t = a.t().unwrap().contiguous().unwrap();
        assert_eq!(t.dims(), &[c, r]);
        let got = values(&t);
        for j in 0..c {
            for i in 0..r {
                assert_eq!(got[j * r + i], v[i * c + j], "({r}, {c}) at ({j}, {i})");
            }
        }
        // A transposed view that starts inside its storage (a narrowed column range).
        if c > 2 {
            let n = a
                .narrow(1, 1, c - 2)
                .unwrap()
                .t()
                .unwrap()
                .contiguous()
                .unwrap();
            let got = values(&n);
            for j in 0..c - 2 {
                for i in 0..r {
                    assert_eq!(got[j * r + i], v[i * c + j + 1]);
                }
            }
        }
    }
    // A batch of transposed matrices, and one of a batch.
    let v: Vec<f32> = (0..3 * 5 * 19).map(|i| i as f32).collect();
    let b = Tensor::from_vec(v.clone(), (3, 5, 19), &Device::Cpu).unwrap();
    let t = b.transpose(1, 2).unwrap().contiguous().unwrap();
    let got = values(&t);
    for k in 0..3 {
        for j in 0..19 {
            for i in 0..5 {
                assert_eq!(got[(k * 19 + j) * 5 + i], v[(k * 5 + i) * 19 + j]);
            }
        }
    }
    let one = b.i(2).unwrap().t().unwrap().contiguous().unwrap();
    assert_eq!(values(&one), values(&t.i(2).unwrap()));
    // Broadcast views (stride 0) are not transposes and keep candle's path.
    let row = Tensor::from_vec(vec![1f32, 2., 3.], (3, 1), &Device::Cpu).unwrap();
    let wide = row.broadcast_as((3, 4)).unwrap().contiguous().unwrap();
    assert_eq!(
        values(&wide),
        [1., 1., 1., 1., 2., 2., 2., 2., 3., 3., 3., 3.]
    );
}

/// A linear layer's weight gradient, which backward now forms as `gradᵀ·x` row-major, holds
/// the bits of upstream's `(xᵀ·grad)ᵀ` made contiguous, for row counts on both sides of
/// gemm's 512-deep blocking and the shapes of this model's layers (the LSTM's 512 × 784
/// input weight included); the input's gradient and a weight used twice add up as before.
#[test]
fn linear_weight_gradients_keep_upstreams_bits() {
    let fill = |n: usize, seed: f32| -> Vec<f32> {
        (0..n)
            .map(|i| ((i as f32 * 0.377 + seed).sin() * 1.9).powi(3))
            .collect()
    };
    for (rows, out, inp) in [
        (1, 7, 5),
        (2, 64, 128),
        (16, 512, 784),
        (128, 512, 784),
        (256, 384, 160),
        (600, 64, 128),
        (1024, 7, 64),
    ] {
        let x = Tensor::from_vec(fill(rows * inp, 0.1), (rows, inp), &Device::Cpu).unwrap();
        let c = Tensor::from_vec(fill(rows * out, 0.7), (rows, out), &Device::Cpu).unwrap();
        let w = candle_core::Var::from_tensor(
            &Tensor::from_vec(fill(out * inp, 0.3), (out, inp), &Device::Cpu).unwrap(),
        )
        .unwrap();
        let xv = candle_core::Var::from_tensor(&x).unwrap();
        let y = xv.as_tensor().matmul(&w.as_tensor().t().unwrap()).unwrap();
        let grads = (y * &c).unwrap().sum_all().unwrap().backward().unwrap();
        let got = values(grads.get(w.as_tensor()).unwrap());
        // Upstream: (xᵀ·c)ᵀ, copied contiguous.
        let want = values(
            &x.t()
                .unwrap()
                .matmul(&c)
                .unwrap()
                .t()
                .unwrap()
                .contiguous()
                .unwrap(),
        );
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&got), bits(&want), "{rows} × {inp} → {out}");
        let gx = values(grads.get(xv.as_tensor()).unwrap());
        let want_x = values(&c.matmul(&w.as_tensor().t().unwrap().t().unwrap()).unwrap());
        assert_eq!(bits(&gx), bits(&want_x));
    }
    // One weight in two products: both contributions arrive.
    let w = candle_core::Var::from_tensor(
        &Tensor::from_vec(vec![1f32, 2., 3., 4., 5., 6.], (2, 3), &Device::Cpu).unwrap(),
    )
    .unwrap();
    let x = Tensor::from_vec(vec![1f32, 0., 2.], (1, 3), &Device::Cpu).unwrap();
    let wt = w.as_tensor().t().unwrap();
    let y = (x.matmul(&wt).unwrap() + (x.matmul(&wt).unwrap() * 2.0).unwrap()).unwrap();
    let grads = y.sum_all().unwrap().backward().unwrap();
    assert_eq!(
        values(grads.get(w.as_tensor()).unwrap()),
        vec![3., 0., 6., 3., 0., 6.]
    );
}
