use super::*;

fn counts() -> ModeCounts {
    ModeCounts {
        reference: 10,
        used: 9,
        excluded: 1,
        unpaired: 0,
        ambiguous: 0,
        outliers: 0,
        weak: 0,
    }
}

#[test]
fn a_converged_fit_within_noise_is_ok_and_anything_else_is_not() {
    let v = Verdict::judge(Status::Converged, 40.0, 0.3, counts(), 20, 18, vec![]);
    assert!(v.ok && v.fit == Fit::WithinNoise && !v.worse_than_start);
    assert_eq!(v.warnings.len(), 1, "{:?}", v.warnings);
    let above = Verdict::judge(Status::Converged, 40.0, 7.5, counts(), 20, 20, vec![]);
    assert!(!above.ok && above.fit == Fit::AboveNoise);
    assert!(above.message.contains("7.5σ"), "{}", above.message);
    let floor = Verdict::judge(Status::Stalled, 9.0, 0.5, counts(), 20, 20, vec![]);
    assert_eq!(floor.status, Status::Converged);
    let worse = Verdict::judge(Status::Stalled, 3.0, 4.0, counts(), 20, 20, vec![]);
    assert_eq!(worse.status, Status::Stalled);
    assert!(!worse.ok && worse.worse_than_start);
    assert!(worse.message.contains("WORSE"), "{}", worse.message);
    let budget = Verdict::judge(Status::BudgetExhausted, 9.0, 1.0, counts(), 5, 5, vec![]);
    assert!(!budget.ok);
    let lost = ModeCounts {
        unpaired: 2,
        ..counts()
    };
    assert!(!Verdict::judge(Status::Converged, 9.0, 1.0, lost, 5, 5, vec![]).ok);
    let outlier = ModeCounts {
        outliers: 1,
        ..counts()
    };
    let v = Verdict::judge(Status::Converged, 9.0, 1.0, outlier, 5, 5, vec![]);
    assert!(!v.ok && v.message.contains("1 outliers"), "{}", v.message);
    let weak = ModeCounts {
        weak: 1,
        ..counts()
    };
    let v = Verdict::judge(Status::Converged, 9.0, 0.8, weak, 5, 5, vec![]);
    assert!(
        !v.ok && v.message.contains("1 weakly paired"),
        "{}",
        v.message
    );
    // NaN residuals (model unsolvable) are never within the noise.
    let nan = Verdict::judge(Status::Converged, 9.0, f64::NAN, counts(), 5, 5, vec![]);
    assert!(!nan.ok && nan.worse_than_start);
}

fn fit(rms: f64, lag1: f64) -> FrfFit {
    FrfFit {
        rms,
        robust_cost: rms * rms,
        mean_frac: 0.9,
        lag1,
    }
}

#[test]
fn with_frfs_the_frf_fit_decides_and_modal_losses_are_warnings() {
    let lost = ModeCounts {
        unpaired: 1,
        outliers: 1,
        ..counts()
    };
    // FRFs at the noise: ok although the EMA had a mode the model lacks.
    let f = FrfJudgement::new(fit(9.0, 0.9), fit(1.03, 0.02));
    let v = Verdict::judge(Status::Stalled, 9.0, 1.0, lost.clone(), 5, 5, vec![])
        .with_frf(Status::Stalled, f);
    assert!(v.ok && v.status == Status::Converged, "{}", v.message);
    assert!(v.message.contains("1.03σ"), "{}", v.message);
    assert!(
        v.warnings.iter().any(|w| w.starts_with("modal reference")),
        "{:?}",
        v.warnings
    );
    // Above the noise and smooth: named a systematic misfit, not ok,
    // even with the modal fit within its noise.
    let f = FrfJudgement::new(fit(30.0, 0.9), fit(6.5, 0.94));
    let v = Verdict::judge(Status::Converged, 9.0, 1.0, counts(), 5, 5, vec![])
        .with_frf(Status::Converged, f);
    assert!(!v.ok && f.systematic && v.fit == Fit::AboveNoise);
    assert!(v.message.contains("systematic"), "{}", v.message);
    // Above the noise and rough: not called systematic.
    let f = FrfJudgement::new(fit(30.0, 0.9), fit(3.0, 0.1));
    assert!(!f.systematic);
    // Worse than the modal result.
    let f = FrfJudgement::new(fit(1.5, 0.1), fit(1.8, 0.1));
    let v = Verdict::judge(Status::Converged, 9.0, 1.0, counts(), 5, 5, vec![])
        .with_frf(Status::Converged, f);
    assert!(!v.ok && v.worse_than_start && v.message.contains("WORSE"));
}

/// The cause named for each kind of failure, in its order of precedence.
#[test]
fn the_cause_is_classified_on_small_cases() {
    let ok = Verdict::judge(Status::Converged, 9.0, 0.5, counts(), 5, 5, vec![]);
    assert_eq!(ok.cause, Cause::None);
    // Implicated fixed parameters: not ok, named, whatever the fit.
    let v = ok
        .clone()
        .with_implicated(&[("colj.k_x".into(), 0.25f64.ln_1p(), 80.0)]);
    assert!(!v.ok && v.cause == Cause::ScreenedOut, "{v:?}");
    assert!(v.message.contains("colj.k_x (+25 %"), "{}", v.message);
    assert_eq!(v.implicated, ["colj.k_x"]);
    // The budget comes first.
    let b = Verdict::judge(Status::BudgetExhausted, 9.0, 5.0, counts(), 5, 5, vec![])
        .with_implicated(&[("a".into(), 0.1, 30.0)]);
    assert_eq!(b.cause, Cause::Budget);
    // ... unless it was a refit of screened-out parameters that ran out,
    // with the fit still above the noise: the screening is the cause.
    let r = Verdict::judge(Status::BudgetExhausted, 9.0, 5.0, counts(), 5, 5, vec![])
        .with_refitted(&["lb.k_y".into()]);
    assert_eq!(r.cause, Cause::ScreenedOut);
    let r = r.explained();
    assert!(r.message.contains("lb.k_y refitted"), "{}", r.message);
    assert!(r.message.contains("give more"), "{}", r.message);
    // Within the noise the refit's own budget is what is left to fix.
    let w = Verdict::judge(Status::BudgetExhausted, 9.0, 0.9, counts(), 5, 5, vec![])
        .with_refitted(&["lb.k_y".into()]);
    assert_eq!(w.cause, Cause::Budget);
    // Above the noise: a further start that won names a local minimum;
    // one that did not, model error.
    let above = Verdict::judge(Status::Converged, 9.0, 5.0, counts(), 5, 5, vec![]);
    let escaped = SearchEvidence {
        escaped: Some(true),
    };
    let held = SearchEvidence {
        escaped: Some(false),
    };
    assert_eq!(above.clone().classified(escaped).cause, Cause::LocalMinimum);
    let model = above.clone().classified(held).explained();
    assert_eq!(model.cause, Cause::ModelError);
    assert!(
        model.message.contains("cause: model error"),
        "{}",
        model.message
    );
    // No further search: not told apart, and the message says so.
    let unsearched = above.classified(SearchEvidence::default()).explained();
    assert_eq!(unsearched.cause, Cause::NotSearched);
    assert!(
        unsearched.message.contains("not told apart"),
        "{}",
        unsearched.message
    );
    // Within the noise but a mode lost.
    let lost = ModeCounts {
        unpaired: 1,
        ..counts()
    };
    let v = Verdict::judge(Status::Converged, 9.0, 1.0, lost, 5, 5, vec![]);
    assert_eq!(v.cause, Cause::UnreproducedModes);
    // Worse than the start within the noise: the optimizer.
    let w = Verdict::judge(Status::Converged, 0.5, 0.9, counts(), 5, 5, vec![]);
    assert_eq!(w.cause, Cause::Optimizer);
    // An ok verdict's message gets no cause.
    assert_eq!(ok.clone().explained().message, ok.message);
}

/// Identified damping that misses the reference's damping ratios: not ok,
/// the cause is the damping — unless modes are lost, which explain more.
#[test]
fn damping_ratios_not_reproduced_are_the_cause_when_nothing_else_is() {
    let ok = Verdict::judge(Status::Converged, 9.0, 0.5, counts(), 5, 5, vec![]);
    let dampers = vec!["motor.c_drive".to_string()];
    // Residuals of 0.5, 1 and 37 σ_ζ (a drive mode at 4.7× its ζ): RMS 21.
    let bad = DampingJudgement::new(&[0.5, 1.0, 37.0], "mode 5".into(), dampers.clone()).unwrap();
    assert!((bad.rms - (1370.25f64 / 3.0).sqrt()).abs() < 1e-12);
    assert_eq!(bad.fit, Fit::AboveNoise);
    let v = ok.clone().with_damping(bad.clone()).explained();
    assert!(!v.ok && v.cause == Cause::Damping, "{v:?}");
    assert!(v.message.contains("motor.c_drive"), "{}", v.message);
    assert!(v.message.contains("cause: the damping"), "{}", v.message);
    // Within their uncertainty: ok stays ok.
    let good = DampingJudgement::new(&[0.5, -1.0, 1.5], "mode 2".into(), dampers).unwrap();
    let v = ok.clone().with_damping(good);
    assert!(v.ok && v.cause == Cause::None, "{v:?}");
    // A lost mode is named first: it may be what the dampers miss.
    let lost = ModeCounts {
        outliers: 1,
        ..counts()
    };
    let v = Verdict::judge(Status::Converged, 9.0, 1.0, lost, 5, 5, vec![]).with_damping(bad);
    assert_eq!(v.cause, Cause::UnreproducedModes);
    assert!(DampingJudgement::new(&[], String::new(), vec![]).is_none());
}

#[test]
fn terminations_map_to_statuses() {
    use crate::optimize::Termination as T;
    assert_eq!(Status::of(&T::Converged), Status::Converged);
    assert_eq!(Status::of(&T::BudgetExhausted), Status::BudgetExhausted);
    assert_eq!(Status::of(&T::Stalled), Status::Stalled);
    assert_eq!(
        Status::of(&T::Failed {
            message: "x".into()
        }),
        Status::Stalled
    );
}
