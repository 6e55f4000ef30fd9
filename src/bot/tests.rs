use super::*;
use crate::env::babyai;

/// Runs the bot alone on `id` / `seed`; its actions and the last step's reward.
fn solo(id: &str, seed: u64, done: bool) -> (Vec<Action>, f64) {
    let mut world = babyai::generate(babyai::spec(id).unwrap(), seed, done).unwrap();
    let mut bot = Bot::new(&world);
    let (mut taken, mut actions, mut reward) = (None, Vec::new(), 0.0);
    while !world.ended() {
        let Some(a) = bot.replan(&world, taken) else {
            break;
        };
        reward = world.step(a).unwrap().reward;
        actions.push(a);
        taken = Some(a);
    }
    (actions, reward)
}

#[test]
fn the_bot_solves_one_room_and_several_rooms() {
    for id in [
        "BabyAI-GoToLocal-v0",
        "BabyAI-GoTo-v0",
        "BabyAI-UnlockLocal-v0",
    ] {
        for seed in 0..5 {
            let (actions, reward) = solo(id, seed, false);
            assert!(
                reward > 0.0,
                "{id} seed {seed}: failed after {} actions",
                actions.len()
            );
        }
    }
}

#[test]
fn in_done_mode_the_bot_ends_with_done() {
    let (actions, reward) = solo("BabyAI-GoToLocal-v0", 3, true);
    assert!(reward > 0.0);
    assert_eq!(actions.last(), Some(&Action::Done));
}

#[test]
fn the_bot_is_deterministic() {
    assert_eq!(
        solo("BabyAI-SynthS5R2-v0", 7, false),
        solo("BabyAI-SynthS5R2-v0", 7, false)
    );
}

#[test]
fn a_put_next_plan_reads_top_first() {
    let world =
        babyai::generate(babyai::spec("BabyAI-PutNextLocal-v0").unwrap(), 0, false).unwrap();
    let bot = Bot::new(&world);
    let text = bot.plan_text(&world);
    let parts: Vec<&str> = text.split(" → ").collect();
    assert_eq!(parts.len(), 4, "{text}");
    assert!(parts[0].starts_with("GoNextTo "), "{text}");
    assert_eq!(parts[1], "Pickup");
    assert!(
        parts[2].starts_with("GoNextTo ") && parts[2].ends_with("(PutNext)"),
        "{text}"
    );
    assert_eq!(parts[3], "Drop");
}
