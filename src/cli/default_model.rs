//! Which model a command opens without `--checkpoint`: one rule for `view`, `replay` and
//! `eval`. The paper's attention model (`bundled:attention`, or the pair for `eval`) wherever
//! it reads the missions asked for; `bundled:babyai` where it does not (a BabyAI level whose
//! words it never met); MiniGrid's `bundled:minigrid` (its pair for `eval`) on MiniGrid's own
//! ids. A switch is said on stderr, so a change of model is never silent.

use groundscope::env::LevelConfig;
use groundscope::policy::{Agent, bundled};

use super::flags::EpisodeArgs;

/// How many level seeds a command's check reads for a word the paper's model lacks: a level's
/// grammar shows every word class within a few dozen seeds.
const CHECK_SEEDS: u64 = 50;

/// Whether `agent` reads the missions of `level` from `seed` on (the first [`CHECK_SEEDS`]).
fn reads(agent: &Agent, level: &LevelConfig, seed: u64) -> bool {
    (seed..seed.saturating_add(CHECK_SEEDS)).all(|s| match level.generate(s) {
        Ok(w) => {
            groundscope::policy::acting::mission_tokens(agent.acting(), &w.mission, String::new)
                .is_ok()
        }
        // A seed that does not generate is the command's own error to report.
        Err(_) => true,
    })
}

/// The line a command prints when it opens `bundled:babyai` instead of the paper's model.
fn switch_note(command: &str, level: &LevelConfig) -> String {
    format!(
        "{command}: {} cannot read the missions of {level}; opening {} (it reads BabyAI's whole grammar; --checkpoint chooses another)",
        bundled::names()[0],
        bundled::BABYAI
    )
}

/// The line a command prints when it opens MiniGrid's model (or pair, `what`) instead.
fn minigrid_note(command: &str, level: &LevelConfig, what: &str) -> String {
    format!(
        "{command}: {level} is one of MiniGrid's own environments; opening {what} (trained on fourteen of them; --checkpoint chooses another)"
    )
}

/// The model `view` or `replay` (`command`) opens for `episode` without `--checkpoint`, with
/// its name; a switch to `bundled:babyai` is said on stderr.
pub fn for_episode(episode: &EpisodeArgs, command: &str) -> anyhow::Result<(String, Agent)> {
    let first = bundled::names()[0].clone();
    let agent = Agent::load(&first)?;
    let level = episode.level(agent.level())?;
    if level.is_minigrid() {
        eprintln!("{}", minigrid_note(command, &level, bundled::MINIGRID));
        return Ok((
            bundled::MINIGRID.to_owned(),
            Agent::load(bundled::MINIGRID)?,
        ));
    }
    if episode.mission.is_none() && !reads(&agent, &level, episode.seed) {
        eprintln!("{}", switch_note(command, &level));
        return Ok((bundled::BABYAI.to_owned(), Agent::load(bundled::BABYAI)?));
    }
    Ok((first, agent))
}

/// The models `eval` runs without `--checkpoint` on `levels` from level seed `first_seed` on:
/// the paper's pair, or `bundled:babyai` alone where the pair's attention model (`paper`,
/// already loaded) cannot read one of the levels, or MiniGrid's pair where one of them is
/// MiniGrid's own (said on stderr, naming it).
pub fn for_levels(paper: &Agent, levels: &[LevelConfig], first_seed: u64) -> Vec<String> {
    if let Some(l) = levels.iter().find(|l| l.is_minigrid()) {
        let pair = bundled::minigrid_pair();
        eprintln!("{}", minigrid_note("eval", l, &pair.join(" and ")));
        return pair;
    }
    if let Some(l) = levels.iter().find(|l| !reads(paper, l, first_seed)) {
        eprintln!("{}", switch_note("eval", l));
        return vec![bundled::BABYAI.to_owned()];
    }
    bundled::pair()
}

/// The model `faithfulness` runs without `--checkpoint` on `levels`: the paper's attention
/// model, or `bundled:minigrid` where one of them is MiniGrid's own (said on stderr).
pub fn for_faithfulness(levels: &[LevelConfig]) -> String {
    if let Some(l) = levels.iter().find(|l| l.is_minigrid()) {
        eprintln!("{}", minigrid_note("faithfulness", l, bundled::MINIGRID));
        return bundled::MINIGRID.to_owned();
    }
    bundled::names()[0].clone()
}
