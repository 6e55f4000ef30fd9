//! The training path's sequences against acting step by step, and the fused LSTM sequence
//! against its stepped reference. (Split from `policy::fused`.)

use crate::common::tensors::{close, random, real_inputs};
use candle_core::{Device, Tensor, Var};
use groundscope::policy::{Memory, ModelConfig, Net, Params, Variant};
use rand::SeedableRng as _;

#[test]
fn training_sequence_matches_step_by_step_acting() {
    use groundscope::env::LevelConfig;
    use groundscope::policy::obs::{CellCodes, TokenBatch};
    // The training path (sparse conv, keyed queries, fused attention and gates) against the
    // acting path (the composite attention of attention.rs), on real views and missions with
    // an episode start inside the sequence.
    // Split keys (a 1×1 key encoder beside the 3×3 one, the big-room study's recipe) take
    // the training path through padded channels; the acting path forms `Kc` directly.
    let split = ModelConfig {
        key_kernel: Some(1),
        word_temperature: groundscope::policy::WordTemperature(3.89),
        ..ModelConfig::new(Variant::Attention)
    };
    // The search query (the big-room study's part 5) adds a second filtered copy of `Õ`,
    // through the fused op on the training path and the composite maps on the acting path.
    let search = ModelConfig {
        search_query: true,
        attend_words: groundscope::policy::AttendWords::Content,
        word_temperature: groundscope::policy::WordTemperature(3.89),
        ..ModelConfig::new(Variant::Attention)
    };
    // The null key (part 9), with shared and with split keys.
    let null = ModelConfig {
        null_key: true,
        search_query: false,
        ..search
    };
    let null_split = ModelConfig {
        null_key: true,
        ..split
    };
    // Split keys that also read `Õ` (part 11): `Q̂` spans both halves of the channels.
    let context = ModelConfig {
        key_context: true,
        attend_words: groundscope::policy::AttendWords::Content,
        ..split
    };
    // Keys from a 3×3 encoder of their own, `Õ` from the 1×1 one, the paper's filter (part 12).
    let cell_values = ModelConfig {
        conv_kernel: 1,
        key_kernel: Some(3),
        filter_scale: 1,
        attend_words: groundscope::policy::AttendWords::Content,
        ..split
    };
    for cfg in [
        ModelConfig::new(Variant::Attention),
        ModelConfig::new(Variant::Baseline),
        split,
        search,
        null,
        null_split,
        context,
        cell_values,
    ] {
        let net = Net::new(cfg, Params::init(&cfg, 2).unwrap().detached()).unwrap();
        let level = LevelConfig::default();
        let (t_len, n) = (3, 4);
        let (obs, tokens) = real_inputs(&level, 0, t_len * n);
        let missions: Vec<&[u32]> = tokens.iter().map(Vec::as_slice).collect();
        let mut keep = vec![1f32; t_len * n];
        keep[n + 2] = 0.0;
        let keep_t = Tensor::from_vec(keep.clone(), (t_len, n), &Device::Cpu).unwrap();
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
        let mem0 = Memory {
            h: random(&mut rng, (n, cfg.lstm_hidden), 0.5),
            c: random(&mut rng, (n, cfg.lstm_hidden), 0.5),
        };
        let (logits, values, _) = net
            .sequence(
                &CellCodes::new(&obs),
                &TokenBatch::new(&missions).unwrap(),
                &mem0,
                &keep_t,
            )
            .unwrap();
        let mut mem = mem0;
        for t in 0..t_len {
            let rows = t * n..(t + 1) * n;
            let keep_row = Tensor::from_vec(keep[rows.clone()].to_vec(), n, &Device::Cpu).unwrap();
            let mi = net
                .mission_inputs(&TokenBatch::new(&missions[rows.clone()]).unwrap())
                .unwrap();
            let (l, v, m, _) = net
                .step(
                    &CellCodes::new(&obs[rows]),
                    &mi,
                    &mem.masked(&keep_row).unwrap(),
                )
                .unwrap();
            close(&l, &logits.narrow(0, t * n, n).unwrap(), "logits");
            close(&v, &values.narrow(0, t * n, n).unwrap(), "values");
            // The rollout's untraced step takes the training path one step at a time.
            let (lu, vu, mu) = net
                .step_untraced(
                    &CellCodes::new(&obs[t * n..(t + 1) * n]),
                    &net.mission_inputs_keyed(
                        &TokenBatch::new(&missions[t * n..(t + 1) * n]).unwrap(),
                    )
                    .unwrap(),
                    &mem.masked(&keep_row).unwrap(),
                )
                .unwrap();
            close(&lu, &l, "untraced logits");
            close(&vu, &v, "untraced values");
            close(&mu.c, &m.c, "untraced memory");
            mem = m;
        }
    }
}

#[test]
fn fused_lstm_sequence_matches_the_stepped_reference() {
    use groundscope::policy::kernels::sequence::lstm_sequence;
    let cfg = ModelConfig::new(Variant::Attention);
    let params = Params::init(&cfg, 4).unwrap();
    let net = Net::new(cfg, params.tracked()).unwrap();
    let hid = cfg.lstm_hidden;
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(9);
    let (t_len, n) = (5, 3);
    let gx = Var::from_tensor(&random(&mut rng, (t_len * n, 4 * hid), 3.0)).unwrap();
    let h0 = Var::from_tensor(&random(&mut rng, (n, hid), 1.0)).unwrap();
    let c0 = Var::from_tensor(&random(&mut rng, (n, hid), 2.0)).unwrap();
    // Episode starts at (t 0, seq 1), (t 2, seq 0) and (t 4, seq 2).
    let mut keep = vec![1f32; t_len * n];
    for at in [1, 2 * n, 4 * n + 2] {
        keep[at] = 0.0;
    }
    let keep = Tensor::from_vec(keep, (t_len, n), &Device::Cpu).unwrap();
    let wh = random(&mut rng, (t_len * n, hid), 1.0);
    let wc = random(&mut rng, (n, hid), 1.0);
    let w_hh = params.vars.get("lstm.weight_hh_l0").unwrap();
    let b_hh = params.vars.get("lstm.bias_hh_l0").unwrap();
    let run = |fused: bool| {
        let (hs, c_last) = if fused {
            let gxb = gx.as_tensor().broadcast_add(b_hh.as_tensor()).unwrap();
            let out = lstm_sequence(
                &gxb,
                w_hh.as_tensor(),
                None,
                h0.as_tensor(),
                c0.as_tensor(),
                &keep,
            )
            .unwrap();
            let last = out.narrow(0, (t_len - 1) * n, n).unwrap();
            (
                out.narrow(1, 0, hid).unwrap(),
                last.narrow(1, hid, hid).unwrap(),
            )
        } else {
            let mut mem = Memory {
                h: h0.as_tensor().clone(),
                c: c0.as_tensor().clone(),
            };
            let mut hs = Vec::new();
            for t in 0..t_len {
                let masked = mem.masked(&keep.get(t).unwrap()).unwrap();
                mem = net
                    .lstm_cell_reference(&gx.as_tensor().narrow(0, t * n, n).unwrap(), &masked)
                    .unwrap();
                hs.push(mem.h.clone());
            }
            (Tensor::cat(&hs, 0).unwrap(), mem.c)
        };
        let loss = ((&hs * &wh).unwrap().sum_all().unwrap()
            + (&c_last * &wc).unwrap().sum_all().unwrap())
        .unwrap();
        (hs, loss.backward().unwrap())
    };
    let (hf, gf) = run(true);
    let (hr, gr) = run(false);
    close(&hf, &hr, "h");
    for (name, v) in [
        ("gx", &gx),
        ("h0", &h0),
        ("c0", &c0),
        ("W_hh", w_hh),
        ("b_hh", b_hh),
    ] {
        close(
            gf.get(v.as_tensor()).unwrap(),
            gr.get(v.as_tensor()).unwrap(),
            name,
        );
    }
}
