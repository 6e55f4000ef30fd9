//! The policy: gradients, checkpoints, traces.

use std::collections::BTreeMap;

use candle_core::{Device, Tensor};
use groundscope::env::LevelConfig;
use groundscope::episode::{ActionMode, EpisodeSpec, run_episode};
use groundscope::policy::model::TRANSPOSED;
use groundscope::policy::obs::{CellCodes, TokenBatch};
use groundscope::policy::{
    ActOptions, AttendWords, Checkpoint, ColourCodes, Memory, ModelConfig, Net, Params,
    TrainingState, Variant, WordTemperature, act,
};

fn tiny(variant: Variant) -> ModelConfig {
    ModelConfig {
        variant,
        conv_channels: 3,
        conv_kernel: 3,
        filter_scale: 49,
        colour_codes: ColourCodes::All,
        word_temperature: WordTemperature::PAPER,
        key_kernel: None,
        attend_words: AttendWords::All,
        search_query: false,
        null_key: false,
        key_context: false,
        layout_path: false,
        filter_norm: false,
        vocab_size: groundscope::env::vocab::VOCAB_SIZE,
        word_dim: 4,
        key_dim: 4,
        lstm_hidden: 5,
        gru_hidden: 4,
        head_hidden: 3,
    }
}

/// A scalar that depends on every output of a two-step sequence.
fn loss(net: &Net, level: &LevelConfig) -> Tensor {
    let w1 = level.generate(1).unwrap();
    let w2 = level.generate(2).unwrap();
    let t1 = groundscope::env::vocab::tokenize(&w1.mission).unwrap();
    let t2 = groundscope::env::vocab::tokenize(&w2.mission).unwrap();
    let obs = [w1.observe(), w2.observe(), w2.observe(), w1.observe()];
    let missions: Vec<&[u32]> = vec![&t1, &t2, &t1, &t2];
    let tb = TokenBatch::new(&missions).unwrap();
    let hid = net.cfg.lstm_hidden;
    let mem0 = Memory {
        h: Tensor::from_vec(
            (0..2 * hid)
                .map(|i| i as f32 * 0.05 - 0.2)
                .collect::<Vec<_>>(),
            (2, hid),
            &Device::Cpu,
        )
        .unwrap(),
        c: Tensor::from_vec(
            (0..2 * hid)
                .map(|i| 0.1 - i as f32 * 0.03)
                .collect::<Vec<_>>(),
            (2, hid),
            &Device::Cpu,
        )
        .unwrap(),
    };
    let keep = Tensor::from_vec(vec![1f32, 1., 1., 0.], (2, 2), &Device::Cpu).unwrap();
    let (logits, values, _) = net
        .sequence(&CellCodes::new(&obs), &tb, &mem0, &keep)
        .unwrap();
    let coef = Tensor::from_vec(
        (0..28)
            .map(|i| ((i * 7) % 5) as f32 - 2.0)
            .collect::<Vec<_>>(),
        (4, 7),
        &Device::Cpu,
    )
    .unwrap();
    let lp = candle_nn::ops::log_softmax(&logits, candle_core::D::Minus1).unwrap();
    ((lp * coef).unwrap().sum_all().unwrap() + values.sqr().unwrap().sum_all().unwrap()).unwrap()
}

#[test]
fn gradients_reach_every_parameter_and_match_finite_differences() {
    let level = LevelConfig::default();
    let one_by_one = ModelConfig {
        conv_kernel: 1,
        ..tiny(Variant::Attention)
    };
    let papers_filter = ModelConfig {
        filter_scale: 1,
        ..tiny(Variant::Attention)
    };
    let object_colours = ModelConfig {
        colour_codes: ColourCodes::Objects,
        ..tiny(Variant::Attention)
    };
    let warm_words = ModelConfig {
        word_temperature: WordTemperature(3.89),
        ..tiny(Variant::Attention)
    };
    let split_keys = ModelConfig {
        key_kernel: Some(1),
        ..tiny(Variant::Attention)
    };
    let search_query = ModelConfig {
        search_query: true,
        ..tiny(Variant::Attention)
    };
    // The null key (the big-room study's part 9), with shared and with split keys.
    let null_key = ModelConfig {
        null_key: true,
        ..tiny(Variant::Attention)
    };
    let null_split = ModelConfig {
        null_key: true,
        ..split_keys
    };
    // Split keys that also read `Õ` (part 11).
    let key_context = ModelConfig {
        key_context: true,
        ..split_keys
    };
    // Keys from a 3×3 encoder, `Õ` from the 1×1 one, the paper's filter (part 12).
    let cell_values = ModelConfig {
        conv_kernel: 1,
        key_kernel: Some(3),
        filter_scale: 1,
        ..tiny(Variant::Attention)
    };
    // The unattended layout path (issue #64), beside the search query's second copy.
    let layout_path = ModelConfig {
        layout_path: true,
        search_query: true,
        ..tiny(Variant::Attention)
    };
    // The filter rescaled to `Õ`'s norm (issue #64), the search's copy too, the layout after.
    let filter_norm = ModelConfig {
        filter_norm: true,
        search_query: true,
        layout_path: true,
        ..tiny(Variant::Attention)
    };
    for cfg in [
        cell_values,
        filter_norm,
        layout_path,
        key_context,
        null_key,
        null_split,
        search_query,
        split_keys,
        tiny(Variant::Attention),
        tiny(Variant::Baseline),
        one_by_one,
        papers_filter,
        object_colours,
        warm_words,
    ] {
        let variant = (
            cfg.variant,
            cfg.conv_kernel,
            cfg.filter_scale,
            cfg.colour_codes,
            cfg.word_temperature,
            cfg.key_kernel,
            cfg.search_query,
            cfg.null_key,
            cfg.key_context,
            cfg.layout_path,
            cfg.filter_norm,
        );
        let params = Params::init(&cfg, 3).unwrap();
        let net = Net::new(cfg, params.tracked()).unwrap();
        let grads = loss(&net, &level).backward().unwrap();
        let mut failures = Vec::new();
        for (name, var) in &params.vars {
            let g = grads
                .get(var.as_tensor())
                .unwrap_or_else(|| panic!("{name} gets no gradient"));
            let g = g.flatten_all().unwrap().to_vec1::<f32>().unwrap();
            assert!(
                g.iter().any(|x| *x != 0.0),
                "{variant:?}: gradient of {name} is all zero"
            );
            // Central differences on the entry with the largest gradient.
            let (i, ad) =
                g.iter().enumerate().fold(
                    (0, 0f32),
                    |b, (i, &x)| if x.abs() > b.1.abs() { (i, x) } else { b },
                );
            let base = var
                .as_tensor()
                .flatten_all()
                .unwrap()
                .to_vec1::<f32>()
                .unwrap();
            let eval = |delta: f32| {
                let mut v = base.clone();
                v[i] += delta;
                let mut w: BTreeMap<String, Tensor> = params.detached();
                w.insert(
                    name.clone(),
                    Tensor::from_vec(v, var.as_tensor().dims(), &Device::Cpu).unwrap(),
                );
                loss(&Net::new(cfg, w).unwrap(), &level)
                    .to_scalar::<f32>()
                    .unwrap()
            };
            let off = |fd: f32| (fd - ad).abs() > 0.05 * ad.abs().max(fd.abs()) + 2e-3;
            // A step of 1e-2 can straddle ReLU kinks (every empty cell of a view shares one
            // pre-activation per channel); a smaller step then has to agree instead. With the
            // search query's init a shared pre-activation sits within 1e-3 of 0 (conv bias:
            // 2.07 at 1e-3, 1.69 at 1e-4 against autograd's 1.70), hence the third step.
            let fd_at = |eps: f32| (eval(eps) - eval(-eps)) / (2.0 * eps);
            let mut fd = fd_at(1e-2);
            for eps in [1e-3, 1e-4] {
                if off(fd) {
                    fd = fd_at(eps);
                }
            }
            if off(fd) {
                failures.push(format!(
                    "{name}[{i}]: autograd {ad}, finite difference {fd}"
                ));
            }
        }
        assert!(failures.is_empty(), "{variant:?}:\n{}", failures.join("\n"));
    }
}

fn outputs(ckpt: &Checkpoint) -> Vec<Vec<f32>> {
    let level = LevelConfig::default();
    let w = level.generate(5).unwrap();
    let t = groundscope::env::vocab::tokenize(&w.mission).unwrap();
    let net = Net::new(ckpt.meta.model, ckpt.params.detached()).unwrap();
    let mem = Memory::zeros(1, ckpt.meta.model.lstm_hidden).unwrap();
    act(&net, &[w.observe()], &[&t], &mem, ActOptions::default())
        .unwrap()
        .logits
}

fn saved(variant: Variant, dir: &std::path::Path) -> (Checkpoint, std::path::PathBuf) {
    let cfg = ModelConfig::new(variant);
    let mut ckpt = Checkpoint::new(
        cfg,
        LevelConfig::default(),
        TrainingState::default(),
        Params::init(&cfg, 9).unwrap(),
    );
    let name = dir.join(variant.name());
    ckpt.save(&name).unwrap();
    (ckpt, name)
}

#[test]
fn save_then_load_gives_identical_outputs() {
    let dir = tempfile::tempdir().unwrap();
    for variant in [Variant::Attention, Variant::Baseline] {
        let (ckpt, name) = saved(variant, dir.path());
        let loaded = Checkpoint::load(&name).unwrap();
        assert_eq!(loaded.meta, ckpt.meta);
        assert_eq!(outputs(&loaded), outputs(&ckpt));
    }
}

#[test]
fn a_run_directory_names_its_model() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    std::fs::create_dir(&run).unwrap();
    // A directory without a model names the file it looked for.
    let err = Checkpoint::load(&run).unwrap_err().to_string();
    assert!(err.contains("model.json"), "{err}");
    let (mut ckpt, _) = saved(Variant::Baseline, &run);
    ckpt.save(&run.join("model")).unwrap();
    let loaded = Checkpoint::load(&run).unwrap();
    assert_eq!(loaded.meta, ckpt.meta);
    assert_eq!(outputs(&loaded), outputs(&ckpt));
}

#[test]
fn broken_checkpoints_name_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let (_, name) = saved(Variant::Attention, dir.path());
    let st = dir.path().join("attention.safetensors");
    let js = dir.path().join("attention.json");
    let good_st = std::fs::read(&st).unwrap();
    let good_js = std::fs::read_to_string(&js).unwrap();
    let expect_err = |what: &str| {
        let err = Checkpoint::load(&name).unwrap_err().to_string();
        assert!(err.contains(what), "expected {what:?} in {err:?}");
    };
    // Truncated weights: the hash catches it first.
    std::fs::write(&st, &good_st[..good_st.len() / 2]).unwrap();
    expect_err("weights_sha256");
    // Corrupt weights with a matching hash: safetensors rejects the header.
    let mut junk = good_st.clone();
    junk[..8].copy_from_slice(&u64::MAX.to_le_bytes());
    std::fs::write(&st, &junk).unwrap();
    let hash: String = {
        use sha2::Digest as _;
        sha2::Sha256::digest(&junk)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect()
    };
    let re_hashed = good_js.replace(
        &serde_json::from_str::<serde_json::Value>(&good_js).unwrap()["weights_sha256"]
            .as_str()
            .unwrap()
            .to_owned(),
        &hash,
    );
    std::fs::write(&js, &re_hashed).unwrap();
    expect_err("safetensors");
    std::fs::write(&st, &good_st).unwrap();
    // A different hidden size: the first mismatching tensor is named.
    std::fs::write(
        &js,
        good_js.replace("\"lstm_hidden\": 128", "\"lstm_hidden\": 64"),
    )
    .unwrap();
    expect_err("shape");
    // A vocabulary from another build.
    std::fs::write(&js, good_js.replace("\"purple\"", "\"violet\"")).unwrap();
    expect_err("vocabulary");
    // Baseline metadata over attention weights: an unexpected tensor.
    std::fs::write(
        &js,
        good_js.replace("\"variant\": \"attention\"", "\"variant\": \"baseline\""),
    )
    .unwrap();
    expect_err("attention.");
    // Malformed JSON and a missing file.
    std::fs::write(&js, &good_js[..good_js.len() / 2]).unwrap();
    expect_err("line");
    std::fs::remove_file(&js).unwrap();
    expect_err("attention.json");
}

#[test]
fn traces_are_deterministic_and_maps_are_distributions() {
    let dir = tempfile::tempdir().unwrap();
    let (ckpt, _) = saved(Variant::Attention, dir.path());
    for mode in [ActionMode::Greedy, ActionMode::Sampled] {
        let spec = EpisodeSpec {
            level: LevelConfig::default(),
            seed: 11,
            mission: None,
            mode,
        };
        let a = run_episode(&ckpt, "x", &spec).unwrap();
        let b = run_episode(&ckpt, "x", &spec).unwrap();
        assert_eq!(a.to_json(), b.to_json());
        for s in &a.steps {
            let att = s.attention.as_ref().unwrap();
            assert_eq!(att.words.len(), a.tokens.len());
            for w in &att.words {
                let sum: f32 = w.map.iter().flatten().sum();
                assert!((sum - 1.0).abs() < 1e-4, "{} map sums to {sum}", w.word);
            }
            let m: f32 = att.combined.iter().flatten().sum();
            assert!((m - 1.0).abs() < 1e-4);
            let ws: f32 = att.words.iter().map(|w| w.weight).sum();
            assert!((ws - 1.0).abs() < 1e-4);
        }
    }
    let (base, _) = saved(Variant::Baseline, dir.path());
    let spec = EpisodeSpec {
        level: LevelConfig::default(),
        seed: 11,
        mission: None,
        mode: ActionMode::Greedy,
    };
    assert!(
        run_episode(&base, "b", &spec)
            .unwrap()
            .steps
            .iter()
            .all(|s| s.attention.is_none())
    );
}

/// Bit patterns of a tensor's values, for exact comparisons.
fn bits(t: &Tensor) -> Vec<u32> {
    t.flatten_all()
        .unwrap()
        .to_vec1::<f32>()
        .unwrap()
        .iter()
        .map(|x| x.to_bits())
        .collect()
}

/// An acting net multiplies by contiguous copies of its matrices' transposes (gemm repacks a
/// strided `W.t()` at every call); that must not move a bit. gemm is checked on those matrices
/// of both models at the row counts acting, rollouts and minibatches use, and the nets
/// end to end: a detached net (with the copies) against the same weights tracked (without).
#[test]
fn contiguous_transposes_change_no_bit() {
    let mut rng_state = 7u64;
    let mut next = || {
        rng_state = rng_state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((rng_state >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    };
    for variant in [Variant::Attention, Variant::Baseline] {
        let cfg = ModelConfig::new(variant);
        let params = Params::init(&cfg, 5).unwrap();
        let weights = params.detached();
        for name in TRANSPOSED {
            let w = &weights[name];
            let (_, k) = w.dims2().unwrap();
            let wt = w.t().unwrap().contiguous().unwrap();
            for rows in (2..=64).chain([100, 128, 255, 256, 500, 784, 1024, 2048]) {
                let x: Vec<f32> = (0..rows * k).map(|_| next()).collect();
                let x = Tensor::from_vec(x, (rows, k), &Device::Cpu).unwrap();
                assert_eq!(
                    bits(&x.matmul(&w.t().unwrap()).unwrap()),
                    bits(&x.matmul(&wt).unwrap()),
                    "{name}, {rows} rows"
                );
            }
        }
        let acting = Net::new(cfg, params.detached()).unwrap();
        let tracked = Net::new(cfg, params.tracked()).unwrap();
        let level = LevelConfig::default();
        for batch in [1, 2, 16, 40] {
            let worlds: Vec<_> = (0..batch)
                .map(|s| level.generate(s as u64).unwrap())
                .collect();
            let tokens: Vec<Vec<u32>> = worlds
                .iter()
                .map(|w| groundscope::env::vocab::tokenize(&w.mission).unwrap())
                .collect();
            let missions: Vec<&[u32]> = tokens.iter().map(Vec::as_slice).collect();
            let tb = TokenBatch::new(&missions).unwrap();
            let codes = CellCodes::new(
                &worlds
                    .iter()
                    .map(groundscope::env::World::observe)
                    .collect::<Vec<_>>(),
            );
            let mut state = || {
                let v: Vec<f32> = (0..batch * cfg.lstm_hidden).map(|_| next()).collect();
                Tensor::from_vec(v, (batch, cfg.lstm_hidden), &Device::Cpu).unwrap()
            };
            let mem = Memory {
                h: state(),
                c: state(),
            };
            let traced = |net: &Net| {
                let m = net.mission_inputs(&tb).unwrap();
                let (l, v, mem, _) = net.step(&codes, &m, &mem).unwrap();
                [l, v, mem.h, mem.c].iter().map(bits).collect::<Vec<_>>()
            };
            assert_eq!(
                traced(&acting),
                traced(&tracked),
                "{variant:?} acting, batch {batch}"
            );
            let untraced = |net: &Net| {
                let m = net.mission_inputs_keyed(&tb).unwrap();
                let (l, v, mem) = net.step_untraced(&codes, &m, &mem).unwrap();
                [l, v, mem.h, mem.c, m.text]
                    .iter()
                    .map(bits)
                    .collect::<Vec<_>>()
            };
            assert_eq!(
                untraced(&acting),
                untraced(&tracked),
                "{variant:?} rollout step, batch {batch}"
            );
        }
    }
}

/// The rollout's probabilities on the host are candle-nn's `softmax_last_dim` to the bit, for
/// logits small and large, equal and far apart.
#[test]
fn host_probabilities_are_candles_softmax() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
    for scale in [1e-3f32, 1.0, 10.0, 80.0] {
        let mut v: Vec<f32> = (0..64 * 7)
            .map(|_| rng.random_range(-1.0f32..1.0) * scale)
            .collect();
        // Rows with ties and with one dominant entry.
        v[..7].fill(0.25);
        v[7..14].copy_from_slice(&[0.0, 0.0, 0.0, 90.0, 0.0, 0.0, 0.0]);
        let logits = Tensor::from_vec(v, (64, 7), &Device::Cpu).unwrap();
        let host = groundscope::policy::model::probs_host(&logits).unwrap();
        let reference = candle_nn::ops::softmax_last_dim(&logits)
            .unwrap()
            .to_vec2::<f32>()
            .unwrap();
        let to_bits = |rows: &[Vec<f32>]| -> Vec<u32> {
            rows.iter().flatten().map(|x| x.to_bits()).collect()
        };
        assert_eq!(to_bits(&host), to_bits(&reference), "scale {scale}");
    }
}
