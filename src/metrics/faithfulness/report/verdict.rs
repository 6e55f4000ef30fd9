//! The faithfulness report's verdict in a sentence (issue #83), read off its own closed-loop
//! figures: do the maps steer the agent? For a model that takes interventions on `M`, whether
//! steering `M` to another object sends the agent there and a uniform `M` costs it its success;
//! for any other, whether occluding the object its saliency ranks first hurts more than
//! occluding a random one. The figures quoted are the table's (`closed loop, …` rows).

use super::{CheckpointFaithfulness, ClosedLoop};

/// The least change of a closed-loop rate (distractor or success, against its control) that
/// the verdict calls an effect: a tenth of the episodes.
pub const EFFECT: f64 = 0.1;

/// A closed loop's success and distractor rates (means over seeds), where it ran.
fn rates(c: &CheckpointFaithfulness, name: &str) -> Option<(Option<f64>, Option<f64>)> {
    c.closed_loop
        .get(name)
        .map(|l: &ClosedLoop| (l.success.mean, l.distractor.mean))
}

/// A rate as the sentence gives it: three decimals, as in the table; `–` where not measured.
fn rate(x: Option<f64>) -> String {
    x.map_or_else(|| "–".to_owned(), |v| format!("{v:.3}"))
}

/// Whether `after` differs from `before` by at least [`EFFECT`] in the direction `sign` says
/// (+1: `after` higher, −1: lower).
fn moved(before: Option<f64>, after: Option<f64>, sign: f64) -> bool {
    matches!((before, after), (Some(b), Some(a)) if sign * (a - b) >= EFFECT)
}

/// The verdict on `c` in one sentence, from its closed-loop figures; a sentence saying why
/// there is none where the closed loop did not run.
pub fn sentence(c: &CheckpointFaithfulness) -> String {
    let Some((base_success, base_distractor)) = rates(c, "none") else {
        return "No verdict: the closed-loop re-runs it rests on were not run \
                (`--parts closed-loop`)."
            .to_owned();
    };
    let steered = rates(c, "steered");
    let uniform = rates(c, "uniform");
    if steered.is_some() || uniform.is_some() {
        let mut parts = Vec::new();
        let mut causal = false;
        if let Some((_, d)) = steered {
            causal |= moved(base_distractor, d, 1.0);
            parts.push(format!(
                "steering it to another object sends the agent to a distractor in {} of episodes (unmodified {})",
                rate(d),
                rate(base_distractor)
            ));
        }
        if let Some((s, _)) = uniform {
            causal |= moved(base_success, s, -1.0);
            parts.push(format!(
                "a uniform `M` leaves success at {} (unmodified {})",
                rate(s),
                rate(base_success)
            ));
        }
        let parts = parts.join(", and ");
        return if causal {
            format!("`M` is causal here: {parts}.")
        } else {
            format!(
                "`M` is not shown to be causal here: {parts}; neither moves the agent by {EFFECT} of episodes or more."
            )
        };
    }
    let salient = rates(c, "occlude_salient");
    let random = rates(c, "occlude_random");
    if let (Some((s, _)), Some((r, _))) = (salient, random) {
        let figures = format!(
            "hiding the most salient object at every step leaves success at {} against {} for a random object (unmodified {})",
            rate(s),
            rate(r),
            rate(base_success)
        );
        return if moved(r, s, -1.0) {
            format!("The occlusion saliency finds what the agent acts on: {figures}.")
        } else {
            format!(
                "The occlusion saliency is not shown to find what the agent acts on: {figures}, less than {EFFECT} apart."
            )
        };
    }
    "No verdict: no intervention ran in the closed loop.".to_owned()
}

#[cfg(test)]
mod tests {
    use super::super::summarise;
    use super::*;
    use crate::metrics::sweep::MeanStd;

    fn with_loops(variant: &str, loops: &[(&'static str, f64, f64)]) -> CheckpointFaithfulness {
        let mut c = summarise("ck", variant, &[]);
        let m = |x: f64| MeanStd {
            mean: Some(x),
            std: Some(0.0),
        };
        for &(name, success, distractor) in loops {
            c.closed_loop.insert(
                name,
                ClosedLoop {
                    success: m(success),
                    distractor: m(distractor),
                    episodes: 20,
                },
            );
        }
        c
    }

    #[test]
    fn a_map_that_steers_the_agent_is_called_causal_with_its_figures() {
        let c = with_loops(
            "attention",
            &[
                ("none", 0.97, 0.05),
                ("uniform", 0.1, 0.0),
                ("steered", 0.2, 0.78),
            ],
        );
        assert_eq!(
            sentence(&c),
            "`M` is causal here: steering it to another object sends the agent to a distractor in 0.780 of episodes (unmodified 0.050), and a uniform `M` leaves success at 0.100 (unmodified 0.970)."
        );
    }

    #[test]
    fn a_map_whose_interventions_change_nothing_is_not_called_causal() {
        let c = with_loops(
            "attention",
            &[
                ("none", 0.97, 0.05),
                ("uniform", 0.95, 0.05),
                ("steered", 0.96, 0.1),
            ],
        );
        let s = sentence(&c);
        assert!(s.starts_with("`M` is not shown to be causal here:"), "{s}");
        assert!(s.contains("0.100 of episodes (unmodified 0.050)"), "{s}");
    }

    #[test]
    fn a_model_without_map_interventions_is_judged_by_its_saliency() {
        let hurts = with_loops(
            "baseline",
            &[
                ("none", 1.0, 0.0),
                ("occlude_salient", 0.4, 0.0),
                ("occlude_random", 0.9, 0.0),
            ],
        );
        assert!(
            sentence(&hurts).starts_with("The occlusion saliency finds what the agent acts on"),
            "{}",
            sentence(&hurts)
        );
        let same = with_loops(
            "baseline",
            &[
                ("none", 1.0, 0.0),
                ("occlude_salient", 0.85, 0.0),
                ("occlude_random", 0.9, 0.0),
            ],
        );
        assert!(sentence(&same).contains("is not shown to find"));
        let none = with_loops("attention", &[]);
        assert!(sentence(&none).starts_with("No verdict"));
    }
}
