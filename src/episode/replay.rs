//! An episode replayed from the actions a report recorded, where the policy that took them
//! cannot be run here (a Python callable evaluated by `groundscope.evaluate`): the world, the
//! observations and minigrid's bot beside it, step for step, as the evaluation saw them. What
//! the policy computed is not in the report, so each step holds the action taken with all its
//! probability, a value of 0 and no attention maps.

use super::{EpisodeSpec, EpisodeTrace, StepRecord, initial_world};
use crate::bot::Expert;
use crate::env::vocab;
use crate::env::world::Action;
use crate::policy::{PolicyError, Variant};

/// Replays `actions` from `spec`'s level and seed (its mode is recorded, never used: no action
/// is chosen here). `policy` names the trace's policy, as it is shown. Fails, naming the step,
/// where the actions go on after the episode ended — actions that are not this level's episode.
pub fn replay_actions(
    policy: &str,
    spec: &EpisodeSpec,
    actions: &[Action],
) -> Result<EpisodeTrace, PolicyError> {
    let mut world = initial_world(spec)?;
    let tokens = vocab::tokenize(&world.mission)?;
    let mut expert = Expert::new(&world);
    let mut steps = Vec::with_capacity(actions.len());
    for (t, &action) in actions.iter().enumerate() {
        if world.ended() {
            return Err(PolicyError::Input(format!(
                "the recorded actions go on after the episode ended at step {t} of {} seed {}: they are not this level's episode",
                spec.level, spec.seed
            )));
        }
        let obs = world.observe();
        let expert_action = expert.advise(&world, &obs);
        let expert_plan = expert.plan(&world);
        expert.told(action);
        let mut probs = [0.0; Action::COUNT];
        probs[action as usize] = 1.0;
        let before = world.clone();
        let outcome = world.step(action)?;
        steps.push(StepRecord {
            t,
            world: before,
            obs,
            attention: None,
            probs,
            value: 0.0,
            action,
            reward: outcome.reward,
            terminated: outcome.terminated,
            truncated: outcome.truncated,
            expert_action,
            expert_plan,
            faithfulness: None,
        });
    }
    Ok(EpisodeTrace {
        checkpoint: policy.to_owned(),
        variant: Variant::Baseline,
        level: spec.level,
        seed: spec.seed,
        mission: world.mission.clone(),
        tokens,
        input_token_ids: None,
        model_name: None,
        mode: spec.mode,
        n_actions: Action::COUNT,
        steps,
        final_world: world,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::LevelConfig;
    use crate::episode::{ActionMode, run_from};
    use crate::policy::acting::BotAgent;

    /// The bot's own episode, replayed from its actions, is the same episode step for step.
    #[test]
    fn an_episode_replayed_from_its_actions_is_the_same_episode() {
        let spec = EpisodeSpec {
            level: LevelConfig::babyai(
                crate::env::LevelId::parse("BabyAI-GoToLocal-v0").unwrap(),
                false,
            ),
            seed: 5,
            mission: None,
            mode: ActionMode::Greedy,
        };
        let ran = run_from(&BotAgent, "bot", &spec, initial_world(&spec).unwrap()).unwrap();
        let actions: Vec<Action> = ran.steps.iter().map(|s| s.action).collect();
        let replayed = replay_actions("python policy 'bot'", &spec, &actions).unwrap();
        assert_eq!(replayed.steps.len(), ran.steps.len());
        for (a, b) in replayed.steps.iter().zip(&ran.steps) {
            assert_eq!(a.world.agent_pos, b.world.agent_pos);
            assert_eq!(a.obs, b.obs);
            assert!((a.reward - b.reward).abs() < 1e-12);
            assert_eq!(a.expert_action, b.expert_action);
            assert!(a.attention.is_none());
        }
        assert_eq!(replayed.success(), ran.success());
        assert_eq!(replayed.checkpoint, "python policy 'bot'");
        // One action too many is refused, naming the step.
        let mut more = actions.clone();
        more.push(Action::Left);
        let e = replay_actions("p", &spec, &more).unwrap_err().to_string();
        assert!(e.contains(&format!("step {}", actions.len())), "{e}");
    }
}
