use super::{largest_moves, window_due, Gain, Outcome, Status, WINDOW_SEARCHES};
use crate::identify::follow_up::{FollowUpKind, FollowUpRecord};
use crate::identify::verdict::SearchEvidence;

/// The gain warning names the identified parameters a refit moved most,
/// largest |ln ratio| first, a fall as much as a rise.
#[test]
fn the_largest_moves_of_a_refit_are_named() {
    let o = crate::identify::black_box::tests::objective();
    let names: Vec<&str> = o.parameters().iter().map(|p| p.name.as_str()).collect();
    let before = Outcome {
        x: o.nominal(),
        identified: vec![0, 1, 2, 3],
        status: Status::Converged,
        frf: None,
        evidence: SearchEvidence::default(),
        searched: false,
        refitted: Vec::new(),
    };
    let mut x = o.nominal();
    x[0] *= 1.1;
    x[1] *= 0.25;
    x[2] *= 3.0;
    // Not identified before the refit: not named, however far it moved.
    x[5] *= 9.0;
    assert_eq!(
        largest_moves(&o, &before, &x),
        format!("{} ×0.25, {} ×3, {} ×1.1", names[1], names[2], names[0])
    );
}

/// A refit refuted the implication of `a` and `b`; the escape that
/// followed is judged afresh, and its score test implicates `a` and `c`:
/// `a` stays refuted (with the warning that said so), `c` is new.
#[test]
fn a_refutation_holds_on_later_judgements() {
    use super::super::super::consider::{Consider, FixedParameter};
    use super::super::super::identifiability::Identifiability;
    use super::super::super::verdict::{Implication, ModeCounts, Verdict};
    use super::{Judged, Refutation};
    let fixed = |name: &str, statistic: f64| FixedParameter {
        parameter: name.into(),
        spread: 0.3,
        statistic,
        p_value: 1e-9,
        change: 0.2,
        at_bound: false,
        implicated: true,
        influence: 0.0,
    };
    let untested = Verdict::judge(
        Status::Converged,
        9.0,
        5.0,
        ModeCounts::default(),
        4,
        4,
        vec![],
    );
    let implicated = [
        Implication::new("a", 0.2, 90.0),
        Implication::new("c", 0.2, 40.0),
    ];
    let mut judged = Judged {
        verdict: untested.clone().with_implicated(&implicated),
        untested,
        identifiability: Identifiability {
            parameters: Vec::new(),
            singular_values: Vec::new(),
            undetermined: Vec::new(),
            residuals: 0,
            rank: 0,
            residual_variance: None,
            max_std_error: 0.1,
            batch_lines: 0,
            integrated_time_lines: 1.0,
        },
        consider: Some(Consider {
            std_error: Vec::new(),
            fixed: vec![fixed("a", 90.0), fixed("c", 40.0)],
            critical: 10.0,
        }),
        pairs: Vec::new(),
        evaluations: 0,
    };
    assert_eq!(judged.verdict.implicated, ["a", "c"]);
    let refuted = |names: &[&str], warning: &str| Refutation {
        names: names.iter().map(|n| n.to_string()).collect(),
        warning: warning.into(),
    };
    judged.keep_refutation(&refuted(&["a", "b"], "refuted a, b"));
    assert_eq!(judged.verdict.implicated, ["c"]);
    assert!(judged.verdict.warnings.iter().any(|w| w == "refuted a, b"));
    // Nothing new implicated: the untested verdict, with the warning.
    judged.keep_refutation(&refuted(&["a", "c"], "refuted c"));
    assert!(judged.verdict.implicated.is_empty());
    assert_eq!(judged.verdict.warnings, judged.untested.warnings);
    assert!(judged.verdict.warnings.iter().any(|w| w == "refuted c"));
}

/// At the bound, even a refit down to the lowest noise floor measured
/// (0.945σ) is not a material gain; just above, it would be, so the
/// refit runs there. Above the noise, or without FRFs, it always runs.
#[test]
fn a_refit_is_skipped_only_where_it_cannot_gain_materially() {
    use super::{refit_can_gain, Fit, NOISE_FLOOR_BOUND};
    assert_ne!(Gain::of(NOISE_FLOOR_BOUND, 0.945), Gain::Material);
    assert_eq!(Gain::of(1.055, 0.945), Gain::Material);
    assert!(!refit_can_gain(Fit::WithinNoise, Some(1.03)));
    assert!(!refit_can_gain(Fit::WithinNoise, Some(NOISE_FLOOR_BOUND)));
    assert!(refit_can_gain(Fit::WithinNoise, Some(1.05)));
    assert!(refit_can_gain(Fit::AboveNoise, Some(1.03)));
    assert!(refit_can_gain(Fit::WithinNoise, Some(f64::NAN)));
    // Modes alone: too few residuals for the bound.
    assert!(refit_can_gain(Fit::WithinNoise, None));
}

#[test]
fn only_a_material_gain_is_one() {
    // The vertical mill's seed 9: six parameters added for 1.81 → 1.80σ.
    assert_eq!(Gain::of(1.81, 1.80), Gain::Slight);
    // 10 % lower RMS is the edge: cost 0.81 of before is not below it.
    assert_eq!(Gain::of(2.0, 1.8), Gain::Slight);
    assert_eq!(Gain::of(2.0, 1.79), Gain::Material);
    assert_eq!(Gain::of(5.0, 1.0), Gain::Material);
    assert_eq!(Gain::of(1.0, 1.0), Gain::None);
    assert_eq!(Gain::of(1.0, 1.2), Gain::None);
    assert_eq!(Gain::of(1.0, f64::NAN), Gain::None);
}

/// A window search follows another only while each gained materially
/// (cost below ESCAPED of before: 10 % lower RMS) and was taken, back to
/// back, at most WINDOW_SEARCHES in all, and while the budget left pays
/// twice the last one.
#[test]
fn a_window_search_is_repeated_only_after_a_material_gain() {
    let record = |kind, before: f64, after: f64, taken| FollowUpRecord {
        kind,
        evaluations: 800,
        parameters: 38,
        rms_before: before,
        rms_after: after,
        taken,
    };
    let window = |before, after| record(FollowUpKind::Window, before, after, true);
    let left = 10_000;
    assert!(window_due(&[], 0), "the first one is due whatever is left");
    assert!(
        window_due(&[window(4.66, 3.75)], left),
        "(3.75/4.66)² = 0.65"
    );
    assert!(
        !window_due(&[window(2.0, 1.9)], left),
        "(1.9/2)² = 0.90: slight"
    );
    assert!(!window_due(&[window(2.0, 2.1)], left));
    let kept = record(FollowUpKind::Window, 4.66, 3.75, false);
    assert!(!window_due(&[kept], left), "not taken");
    let refit = record(FollowUpKind::Refit, 3.75, 1.2, true);
    assert!(
        !window_due(&[window(4.66, 3.75), refit], left),
        "not back to back"
    );
    assert!(window_due(&[window(4.66, 3.75)], 1600), "2 × 800 left");
    assert!(
        !window_due(&[window(4.66, 3.75)], 1599),
        "the refit's share"
    );
    let mut chain = vec![window(15.1, 5.5)];
    while chain.len() < WINDOW_SEARCHES {
        assert!(
            window_due(&chain, left),
            "{} of {WINDOW_SEARCHES}",
            chain.len()
        );
        chain.push(window(5.5, 2.7));
    }
    assert!(!window_due(&chain, left), "at most {WINDOW_SEARCHES}");
    assert!(
        !window_due(&[window(f64::NAN, 1.0)], left),
        "NaN never gains"
    );
}
