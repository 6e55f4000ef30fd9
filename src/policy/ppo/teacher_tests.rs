use super::*;
use crate::policy::obs::TokenBatch;
use crate::policy::ppo::PpoConfig;
use crate::policy::{ModelConfig, Variant};

fn mix(ids: &str) -> LevelMix {
    LevelMix::parse(ids, false).unwrap()
}

#[test]
fn a_teacher_names_its_level_or_every_level_no_other_names() {
    let a = TeacherSpec::parse("MiniGrid-DoorKey-5x5-v0=runs/a/model").unwrap();
    assert_eq!(a.level.map(LevelId::id), Some("MiniGrid-DoorKey-5x5-v0"));
    assert_eq!(a.name, "runs/a/model");
    assert_eq!(a.to_string(), "MiniGrid-DoorKey-5x5-v0=runs/a/model");
    // Not an id before the `=`: the whole is a file name.
    let b = TeacherSpec::parse("runs/x=1/model").unwrap();
    assert_eq!((b.level, b.name.as_str()), (None, "runs/x=1/model"));
    assert!(TeacherSpec::parse("MiniGrid-DoorKey-5x5-v0=").is_err());
    assert!(TeacherSpec::parse(" ").is_err());

    let levels = mix("MiniGrid-DoorKey-5x5-v0,MiniGrid-Unlock-v0,MiniGrid-FourRooms-v0");
    let unlock = TeacherSpec::parse("MiniGrid-Unlock-v0=u").unwrap();
    let rest = TeacherSpec::parse("r").unwrap();
    assert_eq!(
        teacher_of(&[unlock.clone(), rest.clone()], &levels).unwrap(),
        [Some(1), Some(0), Some(1)]
    );
    assert_eq!(
        teacher_of(std::slice::from_ref(&unlock), &levels).unwrap(),
        [None, Some(0), None]
    );
    let outside = TeacherSpec::parse("MiniGrid-Fetch-5x5-N2-v0=f").unwrap();
    let err = teacher_of(&[outside], &levels).unwrap_err().to_string();
    assert!(
        err.contains("MiniGrid-Fetch-5x5-N2-v0 is not one of"),
        "{err}"
    );
    let err = teacher_of(&[unlock.clone(), unlock], &levels)
        .unwrap_err()
        .to_string();
    assert!(err.contains("two teachers"), "{err}");
    let err = teacher_of(&[rest.clone(), rest], &levels)
        .unwrap_err()
        .to_string();
    assert!(err.contains("both teach every level"), "{err}");
}

/// Every action of a taught rollout is the teacher's greedy action, as the teacher computes
/// it on its own when the rollout's frames are replayed to it with their episode masks; every
/// frame is labelled, on a level the bot cannot label; and the student's own weights play no
/// part in the actions taken.
#[test]
fn a_taught_rollout_takes_the_teachers_greedy_actions() -> Result<(), Box<dyn std::error::Error>> {
    let levels = mix("MiniGrid-DoorKey-5x5-v0,MiniGrid-Empty-Random-5x5-v0");
    let student = ModelConfig {
        lstm_hidden: 16,
        gru_hidden: 16,
        ..ModelConfig::new(Variant::Baseline)
    };
    let teacher = ModelConfig {
        lstm_hidden: 8,
        gru_hidden: 8,
        vocab_size: ModelConfig::vocab_size_for(&levels.first()),
        ..ModelConfig::new(Variant::Attention)
    };
    let student = ModelConfig {
        vocab_size: teacher.vocab_size,
        ..student
    };
    let ppo = PpoConfig {
        procs: 4,
        frames_per_proc: 128,
        batch_size: 256,
        imitate: true,
        ..PpoConfig::default()
    };
    let t_params = Params::init(&teacher, 11)?;
    let rollout = |student_seed: u64| -> Result<_, Box<dyn std::error::Error>> {
        let mut tr = Trainer::new(
            student,
            levels.clone(),
            ppo,
            Params::init(&student, student_seed)?,
            5,
        )?;
        tr.attach_teachers(
            vec![TeacherSpec::parse("t")?],
            vec![(teacher, Params::init(&teacher, 11)?)],
        )?;
        assert!(tr.state.envs.iter().all(|e| e.expert.is_none()));
        Ok(tr.collect()?.0)
    };
    let ro = rollout(1)?;
    assert!(
        ro.expert.iter().all(|&x| x == 1.0),
        "every frame is labelled"
    );
    // The teacher's replay, all environments in one batch as the rollout stepped them.
    let net = Net::new(teacher, t_params.detached())?;
    let (p_n, t_n) = (ppo.procs, ppo.frames_per_proc);
    let mut h = vec![vec![0.0f32; 8]; p_n];
    let mut c = vec![vec![0.0f32; 8]; p_n];
    let mut ended = 0;
    for t in 0..t_n {
        let rows: Vec<usize> = (0..p_n).map(|p| p * t_n + t).collect();
        let obs: Vec<Observation> = rows.iter().map(|&i| ro.obs[i]).collect();
        let missions: Vec<&[u32]> = rows.iter().map(|&i| ro.tokens[i].as_slice()).collect();
        let masked = |m: &[Vec<f32>]| -> Vec<f32> {
            rows.iter()
                .zip(m)
                .flat_map(|(&i, v)| {
                    let mask = ro.masks[i];
                    v.iter().map(move |x| x * mask)
                })
                .collect()
        };
        ended += rows.iter().filter(|&&i| ro.masks[i] == 0.0).count();
        let mem = Memory {
            h: Tensor::from_vec(masked(&h), (p_n, 8), &Device::Cpu)?,
            c: Tensor::from_vec(masked(&c), (p_n, 8), &Device::Cpu)?,
        };
        let inputs = net.mission_inputs_keyed(&TokenBatch::new(&missions)?)?;
        let (logits, _, memory) = net.step_untraced(&CellCodes::new(&obs), &inputs, &mem)?;
        let probs = crate::policy::model::probs_host(&logits)?;
        for (p, &i) in rows.iter().enumerate() {
            assert_eq!(
                ro.actions[i] as usize,
                crate::episode::greedy_index(&probs[p]),
                "env {p} step {t}"
            );
        }
        h = memory.h.to_vec2()?;
        c = memory.c.to_vec2()?;
    }
    // Empty-Random-5x5 truncates at 100 steps: episodes end and begin within the rollout.
    assert!(ended > p_n, "{ended} episode starts");
    // Another student takes the same actions.
    assert_eq!(rollout(2)?.actions, ro.actions);
    Ok(())
}
