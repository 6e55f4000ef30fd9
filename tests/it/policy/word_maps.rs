//! What one word's map can see (issue #64's location finding, docs/results.md): its query is
//! the word's embedding alone and its keys a 3×3 convolution of the view, so the map scores
//! what is at a cell and around it, never where the cell lies — why "left" cannot prefer an
//! object on the left, nor a location word single out its phrase's referent.

use groundscope::env::view::Observation;
use groundscope::policy::trace::AttentionTrace;
use groundscope::policy::{ActOptions, Memory, Net, act, bundled};

/// A view of empty floor with one red ball at `(x, y)` (x-major, as minigrid's `image`).
fn floor_with_ball(x: usize, y: usize) -> Observation {
    let mut image = [[[1, 0, 0]; 7]; 7];
    image[x][y] = [6, 0, 0];
    Observation { image }
}

/// The traced attention of one step from zero memory.
fn attention(net: &Net, obs: Observation, tokens: &[u32]) -> AttentionTrace {
    let mem = Memory::zeros(1, net.cfg.lstm_hidden).unwrap();
    let opts = ActOptions {
        traces: true,
        ..ActOptions::default()
    };
    let out = act(net, &[obs], &[tokens], &mem, opts).unwrap();
    out.traces.unwrap().remove(0)
}

#[test]
fn a_words_map_scores_what_is_at_a_cell_not_where_it_is() {
    let ckpt = bundled::load(bundled::BABYAI).unwrap();
    let net = Net::new(ckpt.meta.model, ckpt.params.detached()).unwrap();
    let tokens = groundscope::env::vocab::tokenize("pick up the red ball on your left").unwrap();
    // Cells at least two from the view's edge: their 3×3 neighbourhoods never reach the
    // convolution's padding, so moving the ball among them only permutes the keys.
    let left = attention(&net, floor_with_ball(2, 3), &tokens);
    for (x, y) in [(4, 3), (3, 2), (4, 4), (2, 4)] {
        let moved = attention(&net, floor_with_ball(x, y), &tokens);
        for (a, b) in left.words.iter().zip(&moved.words) {
            let (at_left, at_moved) = (a.map[3][2], b.map[y][x]);
            assert!(
                (at_left - at_moved).abs() < 1e-5,
                "{}: {at_left} on the ball at (2, 3), {at_moved} at ({x}, {y})",
                a.word
            );
        }
    }
    // The maps do look at the ball: the object, colour and location words' maps peak there
    // (the location word marks objects, any object, as the traces of PickupLoc show).
    let named = ["red", "ball", "left"];
    let peaks: Vec<&str> = left
        .words
        .iter()
        .filter(|w| {
            let peak = w.map.iter().flatten().fold(0.0_f32, |m, &v| m.max(v));
            w.map[3][2] == peak
        })
        .map(|w| w.word.as_str())
        .collect();
    for word in named {
        assert!(
            peaks.contains(&word),
            "{word}'s map does not peak on the ball: {peaks:?}"
        );
    }
}
