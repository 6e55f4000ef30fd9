//! Tensor helpers of the tests that compare the training path with its references.

use candle_core::{Device, Tensor};
use rand::Rng as _;

/// A `shape` tensor of values uniform in `(−scale, scale)`.
pub fn random(rng: &mut rand_pcg::Pcg64Mcg, shape: (usize, usize), scale: f32) -> Tensor {
    let v: Vec<f32> = (0..shape.0 * shape.1)
        .map(|_| rng.random_range(-scale..scale))
        .collect();
    Tensor::from_vec(v, shape, &Device::Cpu).unwrap()
}

/// The first views and the missions' tokens of `count` levels from seed `first`.
pub fn real_inputs(
    level: &groundscope::env::LevelConfig,
    first: u64,
    count: usize,
) -> (Vec<groundscope::env::view::Observation>, Vec<Vec<u32>>) {
    let worlds: Vec<_> = (0..count as u64)
        .map(|s| level.generate(first + s).unwrap())
        .collect();
    let obs = worlds
        .iter()
        .map(groundscope::env::World::observe)
        .collect();
    let tokens = worlds
        .iter()
        .map(|w| groundscope::env::vocab::tokenize(&w.mission).unwrap())
        .collect();
    (obs, tokens)
}

pub fn close(a: &Tensor, b: &Tensor, what: &str) {
    let a: Vec<f32> = a.flatten_all().unwrap().to_vec1().unwrap();
    let b: Vec<f32> = b.flatten_all().unwrap().to_vec1().unwrap();
    assert_eq!(a.len(), b.len(), "{what}");
    let scale = b.iter().fold(0f32, |m, x| m.max(x.abs())).max(1e-12);
    for (x, y) in a.iter().zip(&b) {
        assert!(
            (x - y).abs() <= 1e-5 * scale,
            "{what}: {x} vs {y} (scale {scale})"
        );
    }
}
