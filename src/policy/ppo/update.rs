//! The update half of a PPO update: epochs of shuffled minibatches of BPTT chunks (torch-ac's
//! batching), each split over threads, gradients combined, clipped and applied by Adam.

use std::collections::BTreeMap;

use candle_core::Var;
use candle_core::backprop::GradStore;
use rand::seq::SliceRandom as _;

use super::grads::{clip_factor, with_minibatch_grads};
use super::loss::{ShardOut, shard_step};
use super::rollout::Rollout;
use super::workers::run_all;
use super::{Trainer, UpdateLog, secs};
use crate::policy::error::PolicyError;
use crate::policy::model::Net;
use crate::policy::params::computes_maps;

impl Trainer {
    /// torch-ac's `_get_batches_starting_indexes`, but for one case: where a process's
    /// frames are one chunk (`frames_per_proc == recurrence`) no chunk can start half a chunk
    /// later, and torch-ac's shifted call returns no start at all (its odd updates then train
    /// on nothing and log NaN). Here the odd calls keep the unshifted starts instead.
    fn batch_starts(&mut self) -> Vec<Vec<usize>> {
        let (rec, fpp) = (self.ppo.recurrence, self.ppo.frames_per_proc);
        let n = self.ppo.frames_per_update();
        let mut idx: Vec<usize> = (0..n).step_by(rec).collect();
        idx.shuffle(&mut self.state.batch_rng);
        if self.state.batch_num % 2 == 1 && fpp > rec {
            idx.retain(|&i| (i + rec) % fpp != 0);
            for i in &mut idx {
                *i += rec / 2;
            }
        }
        self.state.batch_num += 1;
        idx.chunks(self.ppo.batch_size / rec)
            .map(<[usize]>::to_vec)
            .collect()
    }

    pub(super) fn optimise(&mut self, ro: &mut Rollout) -> Result<UpdateLog, PolicyError> {
        let net = Net::new(self.model, self.params.tracked())?;
        // Frozen map parameters leave the merge of the shards' gradients, the clip and Adam.
        let frozen = self.ppo.maps_frozen(self.state.frames);
        let trainable: BTreeMap<String, Var> = self
            .params
            .vars
            .iter()
            .filter(|(name, _)| !(frozen && computes_maps(name)))
            .map(|(name, var)| (name.clone(), var.clone()))
            .collect();
        let mut log = UpdateLog::default();
        let mut n_batches = 0.0;
        for _ in 0..self.ppo.epochs {
            for starts in self.batch_starts() {
                let per = starts.len().div_ceil(self.ppo.threads);
                let parts: Vec<&[usize]> = starts.chunks(per).collect();
                let (ro_ref, net, ppo): (&Rollout, _, _) = (ro, &net, &self.ppo);
                let outs: Vec<(GradStore, ShardOut)> = run_all(
                    parts
                        .iter()
                        .map(|part| move || shard_step(net, ro_ref, part, ppo))
                        .collect(),
                )?;
                // Each shard's loss is a mean over its frames: its share of the minibatch.
                let shares: Vec<f64> = parts
                    .iter()
                    .map(|p| p.len() as f64 / starts.len() as f64)
                    .collect();
                let (stores, outs): (Vec<GradStore>, Vec<ShardOut>) = outs.into_iter().unzip();
                let opt_t = std::time::Instant::now();
                for ((part, out), w) in parts.iter().zip(&outs).zip(&shares) {
                    // Refresh the stored memories inside each chunk, as torch-ac does.
                    for (k, (hs, cs)) in out.mems.iter().enumerate() {
                        for (j, &s) in part.iter().enumerate() {
                            ro.h[s + k + 1].clone_from(&hs[j]);
                            ro.c[s + k + 1].clone_from(&cs[j]);
                        }
                    }
                    log.policy_loss += w * out.policy;
                    log.value_loss += w * out.value;
                    log.entropy += w * out.entropy;
                    log.ground_loss += w * out.ground;
                    self.times.add(&out.times);
                }
                let (adam, threads) = (&mut self.adam, self.ppo.threads);
                let norm = with_minibatch_grads(&trainable, &stores, &shares, |grads| {
                    let (norm, clip) = clip_factor(grads, self.ppo.max_grad_norm, threads)?;
                    adam.step_host(grads, clip, threads)?;
                    Ok(norm)
                })?;
                self.times.optimizer += secs(opt_t);
                log.grad_norm += norm;
                n_batches += 1.0;
            }
        }
        log.policy_loss /= n_batches;
        log.value_loss /= n_batches;
        log.entropy /= n_batches;
        log.ground_loss /= n_batches;
        log.grad_norm /= n_batches;
        Ok(log)
    }
}
