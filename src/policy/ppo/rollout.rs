//! The rollout half of a PPO update: P environments stepped together for T frames with the
//! training path's untraced forward, then GAE over each environment's frames.

use candle_core::{Device, Tensor};
use rand::Rng as _;

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
        };
        let mut stats = EpisodeStats::default();
        for t in 0..t_n {
            let out = self.act_all(&net, &mut missions)?;
            let env_t = std::time::Instant::now();
            let st = &mut self.state;
            for (p, env) in st.envs.iter_mut().enumerate() {
                let i = p * t_n + t;
                let probs = &out.probs[p];
                let u: f32 = st.act_rng.random();
                let mut acc = 0.0;
                let sampled = probs
                    .iter()
                    .position(|&q| {
                        acc += q;
                        u < acc
                    })
                    .unwrap_or(probs.len() - 1);
                // Imitation: the bot's action is the label, and the action taken unless
                // this step takes the policy's own (DAgger's mixture) or the bot gave up.
                ro.obs[i] = env.world.observe();
                let advice = env
                    .expert
                    .as_mut()
                    .and_then(|e| e.advise(&env.world, &ro.obs[i]));
                ro.expert[i] = f32::from(u8::from(advice.is_some()));
                let label = advice.map_or(sampled, |a| a as usize);
                let share = self.ppo.imitate_policy_share;
                let own = share > 0.0 && st.act_rng.random::<f64>() < share;
                let a = if own { sampled } else { label };
                ro.tokens[i].clone_from(&env.tokens);
                ro.actions[i] = label as u32;
                ro.values[i] = out.values[p];
                ro.logps[i] = probs[label].max(1e-12).ln();
                ro.masks[i] = env.mask;
                ro.h[i].clone_from(&env.h);
                ro.c[i].clone_from(&env.c);
                let action = Action::from_index(a).unwrap_or(Action::Done);
                let outcome = env.world.step(action)?;
                if let Some(e) = env.expert.as_mut() {
                    e.told(action);
                }
                ro.rewards[i] = (outcome.reward * self.ppo.reward_scale) as f32;
                env.h.clone_from(&out.h[p]);
                env.c.clone_from(&out.c[p]);
                env.ep_return += outcome.reward;
                env.ep_len += 1;
                if outcome.terminated || outcome.truncated {
                    stats.episodes += 1;
                    stats.successes += u64::from(outcome.reward > 0.0);
                    stats.return_sum += env.ep_return;
                    stats.length_sum += u64::from(env.ep_len);
                    let fresh = new_slot(&self.levels, st.next_seed, hid, self.ppo.imitate)?;
                    st.next_seed += 1;
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
        let codes = crate::policy::obs::CellCodes::new(&obs);
        let encoded = secs(encode_t);
        let forward_t = std::time::Instant::now();
        let mission = cache.inputs(net, &missions)?;
        let (logits, values, memory) = net.step_untraced(&codes, &mission, &mem)?;
        let out = ActAll {
            probs: crate::policy::model::probs_host(&logits)?,
            values: values.to_vec1::<f32>()?,
            h: memory.h.to_vec2::<f32>()?,
            c: memory.c.to_vec2::<f32>()?,
        };
        self.times.rollout_encode += encoded;
        self.times.rollout_forward += secs(forward_t);
        Ok(out)
    }
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
    probs: Vec<Vec<f32>>,
    values: Vec<f32>,
    h: Vec<Vec<f32>>,
    c: Vec<Vec<f32>>,
}
