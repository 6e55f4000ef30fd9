//! The rollout half of a PPO update: P environments stepped together for T frames with the
//! training path's untraced forward, then GAE over each environment's frames.

use candle_core::{Device, Tensor};
use rand::Rng as _;

use super::ground::FrameTargets;
use super::workers::run_all;
use super::{EnvSlot, EpisodeStats, Trainer, missions, new_slot, secs};
use crate::env::view::Observation;
use crate::env::world::Action;
use crate::policy::error::PolicyError;
use crate::policy::model::{Memory, Net};

/// Rollout buffers, proc-major.
pub(super) struct Rollout {
    pub(super) obs: Vec<Observation>,
    pub(super) tokens: Vec<Vec<u32>>,
    pub(super) actions: Vec<u32>,
    pub(super) values: Vec<f32>,
    pub(super) logps: Vec<f32>,
    pub(super) rewards: Vec<f32>,
    pub(super) masks: Vec<f32>,
    pub(super) h: Vec<Vec<f32>>,
    pub(super) c: Vec<Vec<f32>>,
    pub(super) advantages: Vec<f32>,
    pub(super) returns: Vec<f32>,
    /// `--imitate`: 1 where the action is the bot's (0 where it had given up).
    pub(super) expert: Vec<f32>,
    /// `--ground-loss`: what each frame's words name in view (empty without the flag).
    pub(super) targets: Vec<FrameTargets>,
}

impl Trainer {
    pub(super) fn collect(&mut self) -> Result<(Rollout, EpisodeStats), PolicyError> {
        let (p_n, t_n, hid) = (
            self.ppo.procs,
            self.ppo.frames_per_proc,
            self.model.lstm_hidden,
        );
        let n = p_n * t_n;
        let net = Net::new(self.model, self.params.detached())?;
        let mut missions = std::mem::take(&mut self.missions);
        missions.renew();
        let mut ro = Rollout {
            obs: vec![
                Observation {
                    image: [[[0; 3]; 7]; 7]
                };
                n
            ],
            tokens: vec![Vec::new(); n],
            actions: vec![0; n],
            values: vec![0.0; n],
            logps: vec![0.0; n],
            rewards: vec![0.0; n],
            masks: vec![0.0; n],
            h: vec![Vec::new(); n],
            c: vec![Vec::new(); n],
            advantages: vec![0.0; n],
            returns: vec![0.0; n],
            expert: vec![0.0; n],
            targets: Vec::new(),
        };
        let ground = self.ppo.ground_loss > 0.0;
        if ground {
            ro.targets = vec![FrameTargets::default(); n];
        }
        let mut stats = EpisodeStats::default();
        let (share, scale) = (self.ppo.imitate_policy_share, self.ppo.reward_scale);
        let bot: Vec<bool> = (0..self.levels.entries().len())
            .map(|e| self.bot_labels(e))
            .collect();
        for t in 0..t_n {
            let out = self.act_all(&net, &mut missions)?;
            let taught = self.teach(&out.obs)?;
            let env_t = std::time::Instant::now();
            let st = &mut self.state;
            // The action stream is drawn in environment order, whatever the thread count.
            let draws: Vec<Draw> = out
                .probs
                .iter()
                .map(|probs| {
                    let u: f32 = st.act_rng.random();
                    let sampled = crate::policy::sample_index(probs, u);
                    let own = share > 0.0 && st.act_rng.random::<f64>() < share;
                    Draw { sampled, own }
                })
                .collect();
            // A world's step takes microseconds, less than starting a thread; the bot's
            // advice (imitation) is worth spreading.
            let env_threads = if self.ppo.imitate {
                self.ppo.threads
            } else {
                1
            };
            let stepped = on_shards(&mut st.envs, env_threads, |p, env| {
                step_env(env, draws[p], taught[p], &out, p, ground)
            })?;
            for (p, (env, s)) in st.envs.iter_mut().zip(stepped).enumerate() {
                let i = p * t_n + t;
                ro.obs[i] = s.obs;
                ro.expert[i] = f32::from(u8::from(s.advised));
                if let Some(t) = s.targets {
                    ro.targets[i] = t;
                }
                ro.tokens[i].clone_from(&env.tokens);
                ro.actions[i] = s.label as u32;
                ro.values[i] = out.values[p];
                ro.logps[i] = out.probs[p][s.label].max(1e-12).ln();
                ro.masks[i] = s.mask;
                ro.h[i] = s.h;
                ro.c[i] = s.c;
                ro.rewards[i] = (s.outcome.reward * scale) as f32;
                if s.outcome.terminated || s.outcome.truncated {
                    stats.episodes += 1;
                    stats.successes += u64::from(s.outcome.reward > 0.0);
                    stats.return_sum += env.ep_return;
                    stats.length_sum += u64::from(env.ep_len);
                    let fresh = new_slot(&self.levels, &mut st.next_seed, hid, &|e| bot[e])?;
                    *env = EnvSlot {
                        mask: 0.0,
                        h: std::mem::take(&mut env.h),
                        c: std::mem::take(&mut env.c),
                        ..fresh
                    };
                } else {
                    env.mask = 1.0;
                }
            }
            self.times.rollout_env += secs(env_t);
        }
        // Bootstrap values with the memory the next step would use.
        let last = self.act_all(&net, &mut missions)?;
        self.missions = missions;
        let gae_t = std::time::Instant::now();
        let (gamma, lambda) = (self.ppo.discount as f32, self.ppo.gae_lambda as f32);
        for p in 0..p_n {
            let steps = p * t_n..(p + 1) * t_n;
            let after = super::gae::After {
                value: last.values[p],
                mask: self.state.envs[p].mask,
            };
            super::gae::gae(
                &ro.rewards[steps.clone()],
                &ro.values[steps.clone()],
                &ro.masks[steps.clone()],
                after,
                (gamma, lambda),
                &mut ro.advantages[steps.clone()],
                &mut ro.returns[steps],
            );
        }
        if self.ppo.normalize_advantages {
            normalize(&mut ro.advantages);
        }
        self.times.gae += secs(gae_t);
        Ok((ro, stats))
    }

    /// One gradient-free step for every environment with its masked memory.
    fn act_all(
        &mut self,
        net: &Net,
        cache: &mut missions::MissionCache,
    ) -> Result<ActAll, PolicyError> {
        let encode_t = std::time::Instant::now();
        let hid = self.model.lstm_hidden;
        let envs = &self.state.envs;
        let obs: Vec<Observation> = envs.iter().map(|e| e.world.observe()).collect();
        let missions: Vec<&[u32]> = envs.iter().map(|e| e.tokens.as_slice()).collect();
        let mut h = Vec::with_capacity(envs.len() * hid);
        let mut c = Vec::with_capacity(envs.len() * hid);
        for e in envs {
            h.extend(e.h.iter().map(|x| x * e.mask));
            c.extend(e.c.iter().map(|x| x * e.mask));
        }
        let mem = Memory {
            h: Tensor::from_vec(h, (envs.len(), hid), &Device::Cpu)?,
            c: Tensor::from_vec(c, (envs.len(), hid), &Device::Cpu)?,
        };
        let encoded = secs(encode_t);
        let forward_t = std::time::Instant::now();
        let mission = cache.inputs(net, &missions)?;
        let n = envs.len();
        let per = n.div_ceil(self.ppo.threads.max(1));
        // Each thread runs the forward pass of its own rows (a row's numbers depend on the
        // rows computed beside it only through the kernels' blocking, so on the count alone).
        let mut parts: Vec<std::ops::Range<usize>> = (0..n)
            .step_by(per.max(1))
            .map(|lo| lo..(lo + per).min(n))
            .collect();
        if parts.is_empty() {
            parts.push(0..0);
        }
        let forward = |r: &std::ops::Range<usize>| -> Result<ActAll, PolicyError> {
            let (codes, shard_mission, shard_mem);
            let (m, mm) = if parts.len() == 1 {
                codes = crate::policy::obs::CellCodes::new(&obs);
                (&mission, &mem)
            } else {
                codes = crate::policy::obs::CellCodes::new(&obs[r.clone()]);
                let rows = Tensor::arange(r.start as u32, r.end as u32, &Device::Cpu)?;
                shard_mission = mission.select(&rows)?;
                shard_mem = Memory {
                    h: mem.h.narrow(0, r.start, r.len())?,
                    c: mem.c.narrow(0, r.start, r.len())?,
                };
                (&shard_mission, &shard_mem)
            };
            let (logits, values, memory) = net.step_untraced(&codes, m, mm)?;
            Ok(ActAll {
                obs: Vec::new(),
                probs: crate::policy::model::probs_host(&logits)?,
                values: values.to_vec1::<f32>()?,
                h: memory.h.to_vec2::<f32>()?,
                c: memory.c.to_vec2::<f32>()?,
            })
        };
        let outs = run_all(parts.iter().map(|r| || forward(r)).collect())?;
        let mut out = ActAll {
            obs: Vec::new(),
            probs: Vec::with_capacity(n),
            values: Vec::with_capacity(n),
            h: Vec::with_capacity(n),
            c: Vec::with_capacity(n),
        };
        for o in outs {
            out.probs.extend(o.probs);
            out.values.extend(o.values);
            out.h.extend(o.h);
            out.c.extend(o.c);
        }
        out.obs = obs;
        self.times.rollout_encode += encoded;
        self.times.rollout_forward += secs(forward_t);
        Ok(out)
    }
}

/// The actions drawn for one environment's step.
#[derive(Clone, Copy)]
struct Draw {
    /// The policy's sampled action.
    sampled: usize,
    /// Imitation: this step takes the policy's action rather than the bot's.
    own: bool,
}

/// What one environment's step leaves for the rollout buffers.
struct Stepped {
    obs: Observation,
    /// The bot advised an action (imitation).
    advised: bool,
    /// The action learnt from: the bot's where it advised, else the one taken.
    label: usize,
    /// The memory and mask the step was taken with.
    mask: f32,
    h: Vec<f32>,
    c: Vec<f32>,
    outcome: crate::env::world::StepOutcome,
    /// `--ground-loss`: what the mission's words name in the view the step was taken from.
    targets: Option<FrameTargets>,
}

/// Steps environment `p`: the teacher's action (`taught`) or the bot's advice (imitation), the
/// grounding targets (`ground`), the action, the world, the memory.
fn step_env(
    env: &mut EnvSlot,
    draw: Draw,
    taught: Option<usize>,
    out: &ActAll,
    p: usize,
    ground: bool,
) -> Result<Stepped, PolicyError> {
    // Imitation: the teacher's or the bot's action is the label, and the action taken unless
    // this step takes the policy's own (DAgger's mixture) or the bot gave up.
    let obs = out.obs[p];
    let advice = match taught {
        Some(a) => Some(a),
        None => env
            .expert
            .as_mut()
            .and_then(|e| e.advise(&env.world, &obs))
            .map(|a| a as usize),
    };
    let label = advice.unwrap_or(draw.sampled);
    let targets = ground.then(|| FrameTargets::of(&env.world, &obs, env.tokens.len()));
    let a = if draw.own { draw.sampled } else { label };
    let action = Action::from_index(a).unwrap_or(Action::Done);
    let outcome = env.world.step(action)?;
    if let Some(e) = env.expert.as_mut() {
        e.told(action);
    }
    env.ep_return += outcome.reward;
    env.ep_len += 1;
    Ok(Stepped {
        obs,
        advised: advice.is_some(),
        label,
        mask: env.mask,
        h: std::mem::replace(&mut env.h, out.h[p].clone()),
        c: std::mem::replace(&mut env.c, out.c[p].clone()),
        outcome,
        targets,
    })
}

/// `f(p, env)` for every environment, the environments split into `threads` contiguous
/// shards stepped on their own threads; results in environment order.
fn on_shards<T: Send>(
    envs: &mut [EnvSlot],
    threads: usize,
    f: impl Fn(usize, &mut EnvSlot) -> Result<T, PolicyError> + Sync,
) -> Result<Vec<T>, PolicyError> {
    // One shard (one thread) runs inline.
    let per = envs.len().div_ceil(threads.max(1)).max(1);
    let f = &f;
    let jobs: Vec<_> = envs
        .chunks_mut(per)
        .enumerate()
        .map(|(k, chunk)| {
            move || {
                chunk
                    .iter_mut()
                    .enumerate()
                    .map(|(j, e)| f(k * per + j, e))
                    .collect::<Result<Vec<T>, PolicyError>>()
            }
        })
        .collect();
    Ok(run_all(jobs)?.into_iter().flatten().collect())
}

/// `x ← (x − mean) / (std + 1e-8)`, the population statistics taken in f64.
fn normalize(xs: &mut [f32]) {
    let n = xs.len().max(1) as f64;
    let mean = xs.iter().map(|&x| f64::from(x)).sum::<f64>() / n;
    let var = xs
        .iter()
        .map(|&x| (f64::from(x) - mean).powi(2))
        .sum::<f64>()
        / n;
    let scale = 1.0 / (var.sqrt() + 1e-8);
    for x in xs {
        *x = ((f64::from(*x) - mean) * scale) as f32;
    }
}

struct ActAll {
    /// The observations the step was computed from (each environment's next input).
    obs: Vec<Observation>,
    probs: Vec<Vec<f32>>,
    values: Vec<f32>,
    h: Vec<Vec<f32>>,
    c: Vec<Vec<f32>>,
}
