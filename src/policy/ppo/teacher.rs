//! Trained policies as imitation's teachers (`train --imitate --teacher [ID=]CHECKPOINT`):
//! policy distillation. On a level a teacher is given for, its greedy action is the label of
//! every frame, in place of the BabyAI bot's advice, which labels almost none of MiniGrid's
//! ids; a level without one keeps the bot. Each teacher steps its own memory beside the
//! student's, masked at the same episode starts, so it acts as it did when it was evaluated.

use candle_core::{Device, Tensor};
use serde::{Deserialize, Serialize};

use super::missions::MissionCache;
use super::{LevelMix, Trainer};
use crate::env::level::LevelId;
use crate::env::view::Observation;
use crate::policy::error::PolicyError;
use crate::policy::model::{Memory, Net};
use crate::policy::obs::CellCodes;
use crate::policy::{ModelConfig, Params};

/// One `--teacher`: a checkpoint name and the level it teaches, or every level no other
/// teacher names.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TeacherSpec {
    /// The level taught; `None`: every level of the mix that no other teacher names.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level: Option<LevelId>,
    /// A checkpoint, a run directory or `bundled:NAME`.
    pub name: String,
}

impl TeacherSpec {
    /// Parses `ID=CHECKPOINT` (a registered id before the first `=`) or `CHECKPOINT`.
    pub fn parse(arg: &str) -> Result<Self, PolicyError> {
        if let Some((id, name)) = arg.split_once('=')
            && let Ok(level) = LevelId::parse(id.trim())
        {
            if name.trim().is_empty() {
                return Err(PolicyError::Input(format!(
                    "--teacher {arg}: no checkpoint after {id}= (write ID=CHECKPOINT)"
                )));
            }
            return Ok(Self {
                level: Some(level),
                name: name.trim().to_owned(),
            });
        }
        if arg.trim().is_empty() {
            return Err(PolicyError::Input(
                "--teacher: no checkpoint given (write [ID=]CHECKPOINT)".into(),
            ));
        }
        Ok(Self {
            level: None,
            name: arg.trim().to_owned(),
        })
    }
}

impl std::fmt::Display for TeacherSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.level {
            Some(l) => write!(f, "{}={}", l.id(), self.name),
            None => f.write_str(&self.name),
        }
    }
}

/// Which teacher (an index into `specs`) teaches each level of `levels`, in mix order: the
/// one naming the level, else the one naming none. Refuses a teacher naming a level outside
/// the mix, two for one level, and two that name none (reasons without the flag's name,
/// which the caller adds).
pub fn teacher_of(
    specs: &[TeacherSpec],
    levels: &LevelMix,
) -> Result<Vec<Option<usize>>, PolicyError> {
    let bad = |s: String| Err(PolicyError::Input(s));
    let mut default = None;
    for (i, s) in specs.iter().enumerate() {
        match s.level {
            None if default.is_some() => {
                return bad(format!(
                    "{} and {} both teach every level (give at most one without ID=)",
                    specs[default.unwrap_or(0)].name,
                    s.name
                ));
            }
            None => default = Some(i),
            Some(l) => {
                if !levels.entries().iter().any(|e| e.level.babyai == Some(l)) {
                    return bad(format!("{} is not one of the levels trained on", l.id()));
                }
                if specs[..i].iter().any(|o| o.level == Some(l)) {
                    return bad(format!("{} is given two teachers", l.id()));
                }
            }
        }
    }
    Ok(levels
        .entries()
        .iter()
        .map(|e| {
            specs
                .iter()
                .position(|s| s.level.is_some() && s.level == e.level.babyai)
                .or(default)
        })
        .collect())
}

/// A teacher's network and the missions it has met (its weights never change).
pub(super) struct Teacher {
    net: Net,
    hidden: usize,
    missions: MissionCache,
}

/// The loaded teachers and which one teaches each mix entry.
pub(super) struct Teachers {
    nets: Vec<Teacher>,
    of_entry: Vec<Option<usize>>,
}

impl Teachers {
    /// Whether mix entry `entry` has a teacher (else the bot labels it).
    pub(super) fn teaches(&self, entry: usize) -> bool {
        self.of_entry.get(entry).copied().flatten().is_some()
    }
}

impl Trainer {
    /// Gives the run its teachers (`specs`, with each one's network, in the same order), for
    /// imitation: the run state records them, so a resume loads them again. Environments on
    /// a taught level drop the bot beside them.
    pub fn attach_teachers(
        &mut self,
        specs: Vec<TeacherSpec>,
        nets: Vec<(ModelConfig, Params)>,
    ) -> Result<(), PolicyError> {
        if !self.ppo.imitate {
            return Err(PolicyError::Input(
                "a teacher labels imitation's frames; add --imitate".into(),
            ));
        }
        if specs.len() != nets.len() {
            return Err(PolicyError::Input("a teacher without its network".into()));
        }
        let of_entry = teacher_of(&specs, &self.levels)?;
        let nets = nets
            .into_iter()
            .map(|(cfg, params)| {
                Ok(Teacher {
                    net: Net::new(cfg, params.detached())?,
                    hidden: cfg.lstm_hidden,
                    missions: MissionCache::default(),
                })
            })
            .collect::<Result<Vec<_>, PolicyError>>()?;
        for (k, env) in self.state.envs.iter_mut().enumerate() {
            let Some(t) = of_entry.get(env.entry).copied().flatten() else {
                continue;
            };
            let hid = nets[t].hidden;
            if env.teacher_h.is_empty() {
                env.teacher_h = vec![0.0; hid];
                env.teacher_c = vec![0.0; hid];
            }
            if env.teacher_h.len() != hid || env.teacher_c.len() != hid {
                return Err(PolicyError::Input(format!(
                    "envs[{k}].teacher_h: memory of length {}, the teacher {} has {hid}",
                    env.teacher_h.len(),
                    specs[t]
                )));
            }
            env.expert = None;
        }
        self.state.teachers = specs;
        self.teachers = Some(Teachers { nets, of_entry });
        Ok(())
    }

    /// The teachers the run imitates (empty without `--teacher`).
    pub fn teacher_specs(&self) -> &[TeacherSpec] {
        &self.state.teachers
    }

    /// Whether mix entry `entry` is labelled by the bot: imitation, and no teacher for it.
    pub(super) fn bot_labels(&self, entry: usize) -> bool {
        self.ppo.imitate && !self.teachers.as_ref().is_some_and(|t| t.teaches(entry))
    }

    /// Each environment's teacher's greedy action on `obs` (`None` where its level has no
    /// teacher), the teachers' memories stepped.
    pub(super) fn teach(&mut self, obs: &[Observation]) -> Result<Vec<Option<usize>>, PolicyError> {
        let mut out = vec![None; obs.len()];
        let Some(teachers) = self.teachers.as_mut() else {
            return Ok(out);
        };
        let envs = &mut self.state.envs;
        for (t, teacher) in teachers.nets.iter_mut().enumerate() {
            let rows: Vec<usize> = (0..envs.len())
                .filter(|&p| teachers.of_entry.get(envs[p].entry).copied().flatten() == Some(t))
                .collect();
            if rows.is_empty() {
                continue;
            }
            let hid = teacher.hidden;
            let mut h = Vec::with_capacity(rows.len() * hid);
            let mut c = Vec::with_capacity(rows.len() * hid);
            for &p in &rows {
                let e = &envs[p];
                // A fresh episode's slot may not hold the teacher's memory yet.
                let m = if e.teacher_h.len() == hid {
                    e.mask
                } else {
                    0.0
                };
                h.extend((0..hid).map(|j| e.teacher_h.get(j).copied().unwrap_or(0.0) * m));
                c.extend((0..hid).map(|j| e.teacher_c.get(j).copied().unwrap_or(0.0) * m));
            }
            let mem = Memory {
                h: Tensor::from_vec(h, (rows.len(), hid), &Device::Cpu)?,
                c: Tensor::from_vec(c, (rows.len(), hid), &Device::Cpu)?,
            };
            let view: Vec<Observation> = rows.iter().map(|&p| obs[p]).collect();
            let missions: Vec<&[u32]> = rows.iter().map(|&p| envs[p].tokens.as_slice()).collect();
            let inputs = teacher.missions.inputs(&teacher.net, &missions)?;
            let (logits, _, memory) =
                teacher
                    .net
                    .step_untraced(&CellCodes::new(&view), &inputs, &mem)?;
            let probs = crate::policy::model::probs_host(&logits)?;
            let (hs, cs) = (memory.h.to_vec2::<f32>()?, memory.c.to_vec2::<f32>()?);
            for (((&p, probs), h), c) in rows.iter().zip(probs).zip(hs).zip(cs) {
                // Greedy, as the teacher was evaluated.
                out[p] = Some(crate::episode::greedy_index(&probs));
                envs[p].teacher_h = h;
                envs[p].teacher_c = c;
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
#[path = "teacher_tests.rs"]
mod tests;
