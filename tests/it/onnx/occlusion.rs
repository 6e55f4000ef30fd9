//! The occlusion map of a graph without maps, recomputed here from a trace to check the one
//! the trace holds: every visible cell that is not floor, not unseen and not the agent's own
//! replaced by empty floor, one forward each, from the memory of the steps before.

use std::path::Path;

use groundscope::env::view::Observation;
use groundscope::policy::onnx::OnnxAgent;
use serde_json::Value;

/// The memory after feeding `steps` to `agent` from zeros, one step at a time (batch 1).
fn memory_after(agent: &OnnxAgent, steps: &[(Observation, u8)], tokens: &[u32]) -> Vec<f32> {
    let mut memory = vec![0.0; agent.meta.memory_size];
    for (obs, dir) in steps {
        memory = agent
            .step(&[*obs], &[*dir], &[tokens], &memory, None)
            .unwrap()
            .memory;
    }
    memory
}

fn softmax(l: &[f32]) -> Vec<f64> {
    let max = l.iter().fold(f32::NEG_INFINITY, |a, &b| a.max(b));
    let e: Vec<f64> = l.iter().map(|&x| f64::from(x - max).exp()).collect();
    let z: f64 = e.iter().sum();
    e.into_iter().map(|x| x / z).collect()
}

/// Asserts that the first `take` steps of the `replay --faithfulness --trace` JSON `trace` of
/// `graph` carry no attention and an occlusion map within 1e-5 of the recomputation; returns
/// how many cells changed the policy by more than 1e-4.
pub fn check_trace(graph: &Path, trace: &Value, take: usize, label: &str) -> usize {
    let tokens: Vec<u32> = trace["token_ids"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| u32::try_from(v.as_u64().unwrap()).unwrap())
        .collect();
    let steps: Vec<(Observation, u8)> = trace["steps"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            let image: [[[u8; 3]; 7]; 7] = serde_json::from_value(s["obs"].clone()).unwrap();
            let dir = u8::try_from(s["agent_dir"].as_u64().unwrap()).unwrap();
            (Observation { image }, dir)
        })
        .collect();
    let agent = OnnxAgent::load(graph).unwrap();
    let mut nonzero = 0;
    for (k, s) in trace["steps"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
        .take(take)
    {
        assert!(s["attention"].is_null(), "{label}: a graph without maps");
        let recorded: [[f64; 7]; 7] =
            serde_json::from_value(s["faithfulness"]["occlusion"].clone()).unwrap();
        let memory = memory_after(&agent, &steps[..k], &tokens);
        let (obs, dir) = steps[k];
        let p = softmax(
            &agent
                .step(&[obs], &[dir], &[&tokens], &memory, None)
                .unwrap()
                .logits[0],
        );
        for (vy, row) in recorded.iter().enumerate() {
            for (vx, &got) in row.iter().enumerate() {
                let code = obs.image[vx][vy];
                let want = if (vx, vy) == (3, 6) || code[0] == 0 || code[0] == 1 {
                    0.0
                } else {
                    let mut o = obs;
                    o.image[vx][vy] = [1, 0, 0];
                    let q = softmax(
                        &agent
                            .step(&[o], &[dir], &[&tokens], &memory, None)
                            .unwrap()
                            .logits[0],
                    );
                    0.5 * p.iter().zip(&q).map(|(a, b)| (a - b).abs()).sum::<f64>()
                };
                assert!(
                    (got - want).abs() < 1e-5,
                    "{label} step {k} cell ({vx}, {vy}): trace {got}, recomputed {want}"
                );
                nonzero += usize::from(want > 1e-4);
            }
        }
    }
    nonzero
}
