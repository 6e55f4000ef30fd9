//! PPO: learning on a tiny level, determinism, exact resume.

use groundscope::env::{LevelConfig, TaskSet};
use groundscope::episode::{ActionMode, EpisodeSpec, run_from};
use groundscope::policy::ppo::{PpoConfig, Trainer};
use groundscope::policy::{ModelConfig, Net, Params, Variant};

fn tiny_level() -> LevelConfig {
    LevelConfig {
        room_size: 5,
        n_objects: 1,
        tasks: TaskSet::GoTo,
        done_required: false,
        color_optional: false,
        babyai: None,
    }
}

fn small_model(variant: Variant) -> ModelConfig {
    ModelConfig {
        lstm_hidden: 32,
        gru_hidden: 32,
        head_hidden: 32,
        ..ModelConfig::new(variant)
    }
}

fn trainer(seed: u64, ppo: PpoConfig) -> Trainer {
    let model = small_model(Variant::Attention);
    Trainer::new(
        model,
        tiny_level(),
        ppo,
        Params::init(&model, seed).unwrap(),
        seed,
    )
    .unwrap()
}

fn small_ppo() -> PpoConfig {
    PpoConfig {
        procs: 8,
        frames_per_proc: 32,
        batch_size: 64,
        ..PpoConfig::default()
    }
}

#[test]
fn ppo_learns_the_tiny_level() {
    let mut t = trainer(1, small_ppo());
    for _ in 0..120 {
        t.update().unwrap();
    }
    let net = Net::new(t.model, t.params.detached()).unwrap();
    let mut successes = 0;
    for seed in 0..100 {
        let spec = EpisodeSpec {
            level: tiny_level(),
            seed,
            mission: None,
            mode: ActionMode::Greedy,
        };
        let world = tiny_level().generate(seed).unwrap();
        successes += usize::from(run_from(&net, "t", &spec, world).unwrap().success());
    }
    assert!(
        successes >= 80,
        "greedy success {successes}/100 after {} frames",
        t.state.frames
    );
}

#[test]
fn losses_are_deterministic_for_a_seed() {
    let ppo = PpoConfig {
        procs: 4,
        frames_per_proc: 16,
        batch_size: 32,
        ..PpoConfig::default()
    };
    let (mut a, mut b) = (trainer(5, ppo), trainer(5, ppo));
    for _ in 0..3 {
        let (la, lb) = (a.update().unwrap(), b.update().unwrap());
        assert_eq!(format!("{la:?}"), format!("{lb:?}"));
    }
    let mut c = trainer(6, ppo);
    assert_ne!(
        format!("{:?}", c.update().unwrap()),
        format!("{:?}", trainer(5, ppo).update().unwrap())
    );
}

#[test]
fn threads_share_a_minibatch_without_changing_the_maths() {
    let ppo = |threads| PpoConfig {
        procs: 4,
        frames_per_proc: 16,
        batch_size: 32,
        threads,
        ..PpoConfig::default()
    };
    let (mut one, mut two, mut again) =
        (trainer(5, ppo(1)), trainer(5, ppo(2)), trainer(5, ppo(2)));
    for _ in 0..3 {
        let (l1, l2, l3) = (
            one.update().unwrap(),
            two.update().unwrap(),
            again.update().unwrap(),
        );
        // Two shards sum the same gradient in another order: equal up to rounding...
        for (x, y) in [
            (l1.policy_loss, l2.policy_loss),
            (l1.value_loss, l2.value_loss),
            (l1.entropy, l2.entropy),
            (l1.grad_norm, l2.grad_norm),
        ] {
            assert!((x - y).abs() < 1e-4 * (1.0 + x.abs()), "{x} vs {y}");
        }
        // ...and a fixed thread count is deterministic.
        assert_eq!(format!("{l2:?}"), format!("{l3:?}"));
    }
    for (name, v) in &one.params.vars {
        let a: Vec<f32> = v.as_tensor().flatten_all().unwrap().to_vec1().unwrap();
        let b: Vec<f32> = two.params.vars[name]
            .as_tensor()
            .flatten_all()
            .unwrap()
            .to_vec1()
            .unwrap();
        let diff = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max);
        assert!(diff < 1e-3, "{name} moved apart by {diff}");
    }
}

/// Every parameter's values, by name.
fn weights(t: &Trainer) -> Vec<(String, Vec<f32>)> {
    t.params
        .vars
        .iter()
        .map(|(k, v)| {
            let x = v
                .as_tensor()
                .flatten_all()
                .unwrap()
                .to_vec1::<f32>()
                .unwrap();
            (k.clone(), x)
        })
        .collect()
}

#[test]
fn freezing_the_maps_stops_exactly_their_parameters_from_the_given_frame() {
    let ppo = PpoConfig {
        procs: 4,
        frames_per_proc: 16,
        batch_size: 32,
        ..PpoConfig::default()
    };
    let per = ppo.frames_per_update() as u64;
    // Frozen from the second update on, and a freeze that never comes.
    let mut frozen = trainer(
        5,
        PpoConfig {
            freeze_attention_at: Some(per),
            ..ppo
        },
    );
    let mut later = trainer(
        5,
        PpoConfig {
            freeze_attention_at: Some(1_000 * per),
            ..ppo
        },
    );
    let mut plain = trainer(5, ppo);
    let first = frozen.update().unwrap();
    assert_eq!(
        format!("{first:?}"),
        format!("{:?}", plain.update().unwrap())
    );
    later.update().unwrap();
    let after_one = weights(&frozen);
    for _ in 0..2 {
        frozen.update().unwrap();
        // Before its frame a freeze changes nothing, bit for bit.
        assert_eq!(
            format!("{:?}", later.update().unwrap()),
            format!("{:?}", plain.update().unwrap())
        );
    }
    assert_eq!(weights(&later), weights(&plain));
    let (mut kept, mut moved) = (Vec::new(), Vec::new());
    for ((name, was), (_, now)) in after_one.iter().zip(weights(&frozen)) {
        if *was == now {
            kept.push(name.clone());
        } else {
            moved.push(name.clone());
        }
    }
    let maps: Vec<String> = after_one
        .iter()
        .map(|(n, _)| n.clone())
        .filter(|n| groundscope::policy::params::computes_maps(n))
        .collect();
    assert_eq!(
        maps,
        [
            "attention.k.weight",
            "attention.q.weight",
            "encoder.conv.bias",
            "encoder.conv.weight",
            "word_emb.weight"
        ]
    );
    assert_eq!(kept, maps, "moved: {moved:?}");
    for part in ["lstm.", "gru.", "actor.", "critic."] {
        assert!(
            moved.iter().any(|n| n.starts_with(part)),
            "{part}: {moved:?}"
        );
    }
}

#[test]
fn a_baseline_has_no_maps_to_freeze() {
    let model = small_model(Variant::Baseline);
    let ppo = PpoConfig {
        freeze_attention_at: Some(0),
        ..small_ppo()
    };
    let Err(e) = Trainer::new(
        model,
        tiny_level(),
        ppo,
        Params::init(&model, 1).unwrap(),
        1,
    ) else {
        panic!("a baseline run with a freeze started");
    };
    assert!(e.to_string().contains("--freeze-attention-at"), "{e}");
}
