//! The vendored candle-core's changes (vendor/README.md) give candle's values: here the
//! tiled copy of transposed views, checked against indexing element by element.
#![allow(clippy::unwrap_used, reason = "test helpers fail loudly")]

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
