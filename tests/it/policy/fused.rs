//! The fused LSTM gates against the composite reference built from candle ops: outputs and
//! gradients (inputs, memory and weights) agree to 1e-5 relative.

use crate::common::tensors::{close, random, real_inputs};
use candle_core::{Device, Tensor, Var};
use groundscope::policy::{ColourCodes, Memory, ModelConfig, Net, Params, Variant};
use rand::{Rng as _, SeedableRng as _};

#[test]
fn fused_lstm_gates_match_the_autograd_reference() {
    let cfg = ModelConfig::new(Variant::Attention);
    let params = Params::init(&cfg, 3).unwrap();
    let net = Net::new(cfg, params.tracked()).unwrap();
    let hid = cfg.lstm_hidden;
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(7);
    let b = 9;
    // Large pre-activations too, where the sigmoids and tanh saturate.
    let gx = Var::from_tensor(&random(&mut rng, (b, 4 * hid), 4.0)).unwrap();
    let h0 = Var::from_tensor(&random(&mut rng, (b, hid), 1.0)).unwrap();
    let c0 = Var::from_tensor(&random(&mut rng, (b, hid), 2.0)).unwrap();
    let wh = random(&mut rng, (b, hid), 1.0);
    let wc = random(&mut rng, (b, hid), 1.0);
    let mem = Memory {
        h: h0.as_tensor().clone(),
        c: c0.as_tensor().clone(),
    };
    let run = |fused: bool| {
        let m = if fused {
            net.lstm_cell(gx.as_tensor(), &mem).unwrap()
        } else {
            net.lstm_cell_reference(gx.as_tensor(), &mem).unwrap()
        };
        // Two steps, so that the gradient flows through a fused output back into the op.
        let m2 = if fused {
            net.lstm_cell(gx.as_tensor(), &m).unwrap()
        } else {
            net.lstm_cell_reference(gx.as_tensor(), &m).unwrap()
        };
        let loss = ((&m2.h * &wh).unwrap().sum_all().unwrap()
            + (&m2.c * &wc).unwrap().sum_all().unwrap())
        .unwrap();
        (m2, loss.backward().unwrap())
    };
    let (mf, gf) = run(true);
    let (mr, gr) = run(false);
    close(&mf.h, &mr.h, "h");
    close(&mf.c, &mr.c, "c");
    for (name, v) in [("gx", &gx), ("h0", &h0), ("c0", &c0)] {
        close(
            gf.get(v.as_tensor()).unwrap(),
            gr.get(v.as_tensor()).unwrap(),
            name,
        );
    }
    for name in ["lstm.weight_hh_l0", "lstm.bias_hh_l0"] {
        let w = params.vars.get(name).unwrap();
        close(
            gf.get(w.as_tensor()).unwrap(),
            gr.get(w.as_tensor()).unwrap(),
            name,
        );
    }
}

#[test]
fn fused_attention_matches_the_autograd_reference() {
    // Our filter factor 49 and the paper's 1; the paper's word weights and warmer ones.
    // With and without the null key (the big-room study's part 9).
    for null in [false, true] {
        for (scale, t) in [(49, 1.0), (1, 1.0), (1, 3.89), (49, 0.5)] {
            fused_attention_matches_reference(scale, t, null);
        }
    }
}

fn fused_attention_matches_reference(scale: u32, t: f32, null: bool) {
    use groundscope::policy::attention::{attend_with, keyed_queries, null_logits};
    use groundscope::policy::kernels::attention::{attention_filter, attention_filter_null};
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
    let (b, m, dk, k) = (5, 6, 8, 16);
    let q = Var::from_tensor(
        &random(&mut rng, (b * m, dk), 3.0)
            .reshape((b, m, dk))
            .unwrap(),
    )
    .unwrap();
    // W_k (d_k, K): the keys Kc = Õ W_kᵀ of the reference are formed from it.
    let wk = Var::from_tensor(&random(&mut rng, (dk, k), 1.5)).unwrap();
    let o = Var::from_tensor(
        &random(&mut rng, (b * 49, k), 1.0)
            .reshape((b, 49, k))
            .unwrap(),
    )
    .unwrap();
    // Frames with 6, 4 and 1 real words (padding masked out).
    let mut mask = vec![0f32; b * m];
    for (r, n) in [6usize, 4, 1, 5, 3].iter().enumerate() {
        for i in 0..*n {
            mask[r * m + i] = 1.0;
        }
    }
    let mask = Tensor::from_vec(mask, (b, m), &Device::Cpu).unwrap();
    let weights = random(&mut rng, (b * 49, k), 1.0)
        .reshape((b, 49, k))
        .unwrap();
    // The null key k₀ (1, d_k), large enough that some words put most of their mass on it.
    let k0 = Var::from_tensor(&random(&mut rng, (1, dk), 3.0)).unwrap();
    let run = |fused: bool| {
        let f = if fused {
            let qk = keyed_queries(q.as_tensor(), wk.as_tensor()).unwrap();
            if null {
                let n = null_logits(q.as_tensor(), k0.as_tensor()).unwrap();
                let qk = Tensor::cat(&[&qk, &n], 2).unwrap();
                attention_filter_null(&qk, &mask, o.as_tensor(), scale, t).unwrap()
            } else {
                attention_filter(&qk, &mask, o.as_tensor(), scale, t).unwrap()
            }
        } else {
            let kc = o
                .as_tensor()
                .reshape((b * 49, k))
                .unwrap()
                .matmul(&wk.as_tensor().t().unwrap())
                .unwrap()
                .reshape((b, 49, dk))
                .unwrap();
            let k0 = null.then(|| k0.as_tensor());
            attend_with(q.as_tensor(), &kc, &mask, o.as_tensor(), scale, t, k0, None)
                .unwrap()
                .f
        };
        let loss = (&f * &weights).unwrap().sum_all().unwrap();
        let grads = loss.backward().unwrap();
        (f, grads, loss)
    };
    let (ff, gf, loss_f) = run(true);
    let (fr, gr, _) = run(false);
    close(&ff, &fr, "F");
    // The first backward reads the maps the forward kept; a second one through the same
    // graph finds none and computes them again, to the same bits.
    let again = loss_f.backward().unwrap();
    let bits = |t: &Tensor| -> Vec<u32> {
        let v: Vec<f32> = t.flatten_all().unwrap().to_vec1().unwrap();
        v.into_iter().map(f32::to_bits).collect()
    };
    for v in [&q, &wk, &o, &k0] {
        let (first, second) = (gf.get(v.as_tensor()), again.get(v.as_tensor()));
        assert_eq!(first.map(bits), second.map(bits));
    }
    for (name, v) in [("q", &q), ("w_k", &wk), ("o", &o)] {
        close(
            gf.get(v.as_tensor()).unwrap(),
            gr.get(v.as_tensor()).unwrap(),
            name,
        );
    }
    if null {
        let (gk_f, gk_r) = (gf.get(k0.as_tensor()), gr.get(k0.as_tensor()));
        close(gk_f.unwrap(), gk_r.unwrap(), "k0");
        // The null key takes part: some words' maps are mostly its even share.
        let sum = gk_r.unwrap().abs().unwrap().sum_all().unwrap();
        assert!(sum.to_scalar::<f32>().unwrap() > 1e-4);
    } else {
        assert!(gf.get(k0.as_tensor()).is_none());
    }
}

#[test]
fn sparse_conv_matches_the_dense_patch_gemm() {
    // 16 channels take the fixed-width loops, 8 the general ones; 3×3 and 1×1 kernels; colour
    // codes on every cell (MiniGrid's), on objects only, or on walls and objects (unset slots
    // skipped).
    for colours in [
        ColourCodes::All,
        ColourCodes::Objects,
        ColourCodes::WallsObjects,
    ] {
        for (channels, kernel) in [(16, 3), (8, 3), (16, 1), (8, 1)] {
            sparse_conv_matches_dense(channels, kernel, colours);
        }
    }
}

fn sparse_conv_matches_dense(channels: usize, kernel: usize, colours: ColourCodes) {
    use groundscope::env::view::Observation;
    use groundscope::policy::obs::{CellCodes, patches};
    let mut cfg = ModelConfig::new(Variant::Attention);
    cfg.conv_channels = channels;
    cfg.conv_kernel = kernel;
    cfg.colour_codes = colours;
    let params = Params::init(&cfg, 5).unwrap();
    let net = Net::new(cfg, params.tracked()).unwrap();
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
    // Random views, codes out of range included (they clamp like the encoder's).
    let obs: Vec<Observation> = (0..13)
        .map(|_| {
            let mut o = Observation {
                image: [[[0; 3]; 7]; 7],
            };
            for col in &mut o.image {
                for cell in col.iter_mut() {
                    *cell = [
                        rng.random_range(0..12),
                        rng.random_range(0..7),
                        rng.random_range(0..4),
                    ];
                }
            }
            o
        })
        .collect();
    let k = cfg.conv_channels;
    let weights = random(&mut rng, (13 * 49, k), 1.0)
        .reshape((13, 49, k))
        .unwrap();
    let run = |sparse: bool| {
        let o = if sparse {
            net.cells(&CellCodes::new(&obs)).unwrap()
        } else {
            let codes = CellCodes::new(&obs).encoded(colours);
            net.cells_reference(&patches(&codes, kernel).unwrap())
                .unwrap()
        };
        let loss = (&o * &weights).unwrap().sum_all().unwrap();
        (o, loss.backward().unwrap())
    };
    let (os, gs) = run(true);
    let (od, gd) = run(false);
    assert_eq!(os.dims(), &[13, 49, k]);
    close(&os, &od, "cells");
    // Some cells are clamped by the ReLU, so its gradient mask is exercised.
    let zeros = os.flatten_all().unwrap().to_vec1::<f32>().unwrap();
    assert!(zeros.contains(&0.0) && zeros.iter().any(|x| *x > 0.0));
    for name in ["encoder.conv.weight", "encoder.conv.bias"] {
        let w = params.vars.get(name).unwrap();
        close(
            gs.get(w.as_tensor()).unwrap(),
            gd.get(w.as_tensor()).unwrap(),
            name,
        );
    }
}

#[test]
fn fused_two_biases_match_broadcast_adds() {
    use groundscope::policy::kernels::bias::add_two_biases;
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
    let x = Var::from_tensor(&random(&mut rng, (37, 12), 3.0)).unwrap();
    let b1 = Var::from_tensor(&random(&mut rng, (1, 12), 1.0).flatten_all().unwrap()).unwrap();
    let b2 = Var::from_tensor(&random(&mut rng, (1, 12), 1.0).flatten_all().unwrap()).unwrap();
    let w = random(&mut rng, (37, 12), 1.0);
    let run = |fused: bool| {
        let y = if fused {
            add_two_biases(x.as_tensor(), b1.as_tensor(), b2.as_tensor()).unwrap()
        } else {
            x.broadcast_add(b1.as_tensor())
                .unwrap()
                .broadcast_add(b2.as_tensor())
                .unwrap()
        };
        // A non-linear loss, so that each bias gradient is a sum of distinct rows.
        let loss = (y.tanh().unwrap() * &w).unwrap().sum_all().unwrap();
        (y, loss.backward().unwrap())
    };
    let (yf, gf) = run(true);
    let (yr, gr) = run(false);
    // The forward rounds exactly as the two broadcast adds.
    assert_eq!(
        yf.flatten_all().unwrap().to_vec1::<f32>().unwrap(),
        yr.flatten_all().unwrap().to_vec1::<f32>().unwrap()
    );
    for (name, v) in [("x", &x), ("b1", &b1), ("b2", &b2)] {
        close(
            gf.get(v.as_tensor()).unwrap(),
            gr.get(v.as_tensor()).unwrap(),
            name,
        );
    }
    // A bias of the wrong length is an error, not a panic.
    assert!(add_two_biases(x.as_tensor(), &b1.narrow(0, 0, 5).unwrap(), b2.as_tensor()).is_err());
}

#[test]
fn every_simd_level_gives_the_same_bits() {
    use groundscope::env::LevelConfig;
    use groundscope::policy::kernels::simd::{Level, detected, with_cap};
    use groundscope::policy::obs::{CellCodes, TokenBatch};
    // The fused loops are compiled for AVX-512, AVX2 and baseline x86-64 and chosen at run
    // time; every clone must compute the training step and the acting step to the bit, so a
    // run's numbers do not depend on the CPU it runs on.
    let cfg = ModelConfig::new(Variant::Attention);
    let params = Params::init(&cfg, 4).unwrap();
    let tracked = params.tracked();
    let net = Net::new(cfg, tracked.clone()).unwrap();
    let level = LevelConfig::default();
    let (t_len, n) = (4, 6);
    let (obs, tokens) = real_inputs(&level, 100, t_len * n);
    let missions: Vec<&[u32]> = tokens.iter().map(Vec::as_slice).collect();
    let mut keep = vec![1f32; t_len * n];
    keep[n + 1] = 0.0;
    let keep = Tensor::from_vec(keep, (t_len, n), &Device::Cpu).unwrap();
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(9);
    let mem0 = Memory {
        h: random(&mut rng, (n, cfg.lstm_hidden), 0.5),
        c: random(&mut rng, (n, cfg.lstm_hidden), 0.5),
    };
    let weights = random(&mut rng, (t_len * n, 7), 1.0);
    let bits = |t: &Tensor| -> Vec<u32> {
        let v: Vec<f32> = t.flatten_all().unwrap().to_vec1().unwrap();
        v.into_iter().map(f32::to_bits).collect()
    };
    let run = |cap: Level| {
        with_cap(cap, || {
            let (logits, values, _) = net
                .sequence(
                    &CellCodes::new(&obs),
                    &TokenBatch::new(&missions).unwrap(),
                    &mem0,
                    &keep,
                )
                .unwrap();
            let loss = ((&logits * &weights).unwrap().sum_all().unwrap()
                + values.sqr().unwrap().sum_all().unwrap())
            .unwrap();
            let grads = loss.backward().unwrap();
            let mut out = vec![bits(&logits), bits(&values)];
            for t in tracked.values() {
                out.push(bits(grads.get(t).expect("every parameter has a gradient")));
            }
            let acted = groundscope::policy::act(
                &net,
                &obs[..n],
                &missions[..n],
                &mem0,
                groundscope::policy::ActOptions {
                    traces: true,
                    ..Default::default()
                },
            )
            .unwrap();
            out.push(bits(&acted.memory.h));
            out.push(bits(&acted.memory.c));
            out
        })
    };
    let base = run(Level::Base);
    for cap in [Level::Avx2, Level::Avx512] {
        if cap <= detected() {
            assert!(run(cap) == base, "{cap:?} differs from the baseline clone");
        }
    }
}

/// The fused mission GRU gives the word-by-word composite's state to the bit (on a training
/// net, whose `W_hh` is a variable, and on an acting net, which keeps `W_hhᵀ`), and its
/// gradients (the embeddings behind the inputs, `W_ih`, `W_hh`, both biases) to 1e-5, on
/// missions of 1 to 9 words padded to the longest.
#[test]
fn fused_gru_matches_the_word_by_word_reference() {
    use groundscope::policy::obs::TokenBatch;
    let cfg = ModelConfig::new(Variant::Attention);
    let params = Params::init(&cfg, 11).unwrap();
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
    let missions: Vec<Vec<u32>> = (0..13)
        .map(|i| {
            (0..=(i % 9))
                .map(|_| rng.random_range(1..cfg.vocab_size as u32))
                .collect()
        })
        .collect();
    let refs: Vec<&[u32]> = missions.iter().map(Vec::as_slice).collect();
    let tb = TokenBatch::new(&refs).unwrap();
    let bits = |t: &Tensor| -> Vec<u32> {
        let v: Vec<f32> = t.flatten_all().unwrap().to_vec1().unwrap();
        v.into_iter().map(f32::to_bits).collect()
    };
    for net in [
        Net::new(cfg, params.tracked()).unwrap(),
        Net::new(cfg, params.detached()).unwrap(),
    ] {
        let emb = net.embed(&tb).unwrap();
        let fused = net.encode_text(&tb, &emb).unwrap();
        let reference = net.encode_text_reference(&tb, &emb).unwrap();
        assert_eq!(fused.dims(), &[tb.distinct.len(), cfg.gru_hidden]);
        assert_eq!(bits(&fused), bits(&reference));
    }
    let net = Net::new(cfg, params.tracked()).unwrap();
    let wh = random(&mut rng, (tb.distinct.len(), cfg.gru_hidden), 1.0);
    let grads = |fused: bool| {
        let emb = net.embed(&tb).unwrap();
        let h = if fused {
            net.encode_text(&tb, &emb).unwrap()
        } else {
            net.encode_text_reference(&tb, &emb).unwrap()
        };
        (h * &wh).unwrap().sum_all().unwrap().backward().unwrap()
    };
    let (gf, gr) = (grads(true), grads(false));
    for name in [
        "word_emb.weight",
        "gru.weight_ih_l0",
        "gru.weight_hh_l0",
        "gru.bias_ih_l0",
        "gru.bias_hh_l0",
    ] {
        let v = params.vars.get(name).unwrap();
        close(
            gf.get(v.as_tensor()).unwrap(),
            gr.get(v.as_tensor()).unwrap(),
            name,
        );
    }
}
