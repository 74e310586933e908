//! Known answers for the continuation's budget and mode order.

use super::{continuation, minimum_budget, ContinuationParams, ContinuationResult};
use super::{mode_order as order, ModeOrder};
use crate::identify::black_box::tests::objective;
use crate::identify::history::Recorder;
use crate::identify::{IdentifyError, ModalObjective};

/// The continuation of the four stiffnesses from the file's nominal values
/// (the start and the prior's centre) with `budget` and `settings`.
fn from_nominal(
    o: &ModalObjective,
    budget: usize,
    settings: &ContinuationParams,
) -> Result<ContinuationResult, IdentifyError> {
    continuation(
        o,
        &FREE,
        &o.nominal(),
        &o.nominal(),
        budget,
        settings,
        &Recorder::default(),
        &|_| {},
    )
}

/// The three-mass chain's stiffnesses.
const FREE: [usize; 4] = [0, 1, 2, 3];

#[test]
fn the_minimum_budget_is_exactly_what_the_continuation_runs_with() {
    let o = objective();
    let settings = ContinuationParams::default();
    let minimum = minimum_budget(&o, FREE.len(), &settings);
    let run = |budget| from_nominal(&o, budget, &settings);
    let r = run(minimum).expect("runs at its minimum");
    assert!(r.evaluations <= minimum, "{} > {minimum}", r.evaluations);
    assert!(matches!(run(minimum - 1), Err(IdentifyError::Invalid(_))));
}

#[test]
fn isolation_brings_the_isolated_top_mode_in_before_the_crowded_band() {
    // Gaps: 177 Hz 61 %, 25 Hz 42 %, 43 Hz 33 %, 64 Hz 4.5 %, 67 and
    // 69 Hz both 2.9 % (a tie, broken by frequency).
    let f = [25.0, 43.0, 64.0, 67.0, 69.0, 177.0];
    assert_eq!(order(&f, ModeOrder::Isolation), vec![5, 0, 1, 2, 3, 4]);
    assert_eq!(order(&f, ModeOrder::Frequency), vec![0, 1, 2, 3, 4, 5]);
    // One mode: nothing to compare with, it simply comes first.
    assert_eq!(order(&[80.0], ModeOrder::Isolation), vec![0]);
}

#[test]
fn secant_jacobians_reach_the_same_stiffness_as_full_ones() {
    // From the file's nominal values to the truth of the three-mass chain's
    // three modes (a zero-residual problem): with Broyden updates between
    // forward-difference Jacobians the continuation must end at the same
    // stiffness values as with a full Jacobian at every step.
    let o = objective();
    let truth = crate::identify::black_box::tests::truth();
    let run = |secant| {
        let settings = ContinuationParams {
            secant,
            ..ContinuationParams::default()
        };
        from_nominal(&o, 4000, &settings).expect("runs")
    };
    let (full, secant) = (run(false), run(true));
    for r in [&full, &secant] {
        for &i in &FREE {
            let e = r.x[i] / truth[i] - 1.0;
            assert!(e.abs() < 1e-4, "parameter {i}: {e:e} ({:?})", r.x);
        }
    }
}
