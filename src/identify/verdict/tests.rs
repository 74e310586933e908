use super::*;

/// A converged modal fit within the noise (9σ at the start, 1σ at the
/// end), every mode reproduced: ok until something else is added.
fn converged_within_noise() -> Verdict {
    Verdict::judge(Status::Converged, 9.0, 1.0, counts(), 5, 5, vec![])
}

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
        local: None,
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
    // Within the noise but smooth: ok, with a warning that the intervals
    // do not contain the systematic part.
    let f = FrfJudgement::new(fit(9.0, 0.9), fit(1.8, 0.8));
    let v = converged_within_noise().with_frf(Status::Converged, f);
    assert!(v.ok && !f.systematic);
    assert!(
        v.warnings
            .iter()
            .any(|w| w.contains("lag-1 correlation 0.80")),
        "{:?}",
        v.warnings
    );
    // Above the noise and smooth: named a systematic misfit, not ok,
    // even with the modal fit within its noise.
    let f = FrfJudgement::new(fit(30.0, 0.9), fit(6.5, 0.94));
    let v = converged_within_noise().with_frf(Status::Converged, f);
    assert!(!v.ok && f.systematic && v.fit == Fit::AboveNoise);
    assert!(v.message.contains("systematic"), "{}", v.message);
    // Above the noise and rough: not called systematic.
    let f = FrfJudgement::new(fit(30.0, 0.9), fit(3.0, 0.1));
    assert!(!f.systematic);
    // Within the noise overall but 40σ over one resonance's lines: not ok,
    // and the message names where.
    let mut end = fit(1.7, 0.1);
    end.local = Some(LocalMisfit {
        rms: 40.0,
        frequency_hz: 120.2,
        position: 0,
    });
    let f = FrfJudgement::new(fit(9.0, 0.9), end);
    let v = converged_within_noise().with_frf(Status::Converged, f);
    assert!(!v.ok && v.fit == Fit::AboveNoise && !f.systematic);
    assert!(
        v.message.contains("120.2 Hz at position 0"),
        "{}",
        v.message
    );
    assert_eq!(v.cause, Cause::NotSearched);
    // A local window at the H1 bias of an impact test stays within.
    end.local = Some(LocalMisfit {
        rms: LOCAL_NOISE_RMS,
        ..end.local.unwrap()
    });
    assert_eq!(FrfJudgement::new(fit(9.0, 0.9), end).fit, Fit::WithinNoise);
    // Worse than the modal result.
    let f = FrfJudgement::new(fit(1.5, 0.1), fit(1.8, 0.1));
    let v = converged_within_noise().with_frf(Status::Converged, f);
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
        .with_implicated(&[Implication::new("colj.k_x", 0.25f64.ln_1p(), 80.0)]);
    assert!(!v.ok && v.cause == Cause::ScreenedOut, "{v:?}");
    assert!(v.message.contains("colj.k_x (+25 %"), "{}", v.message);
    assert_eq!(v.implicated, ["colj.k_x"]);
    // The budget comes first.
    let b = Verdict::judge(Status::BudgetExhausted, 9.0, 5.0, counts(), 5, 5, vec![])
        .with_implicated(&[Implication::new("a", 0.1, 30.0)]);
    assert_eq!(b.cause, Cause::Budget);
    // ... unless it was a refit of screened-out parameters that ran out,
    // with the fit still above the noise: the screening is the cause.
    let r = Verdict::judge(Status::BudgetExhausted, 9.0, 5.0, counts(), 5, 5, vec![])
        .with_refitted(vec![plausible("lb.k_y")]);
    assert_eq!(r.cause, Cause::ScreenedOut);
    let r = r.explained();
    assert!(r.message.contains("lb.k_y refitted"), "{}", r.message);
    assert!(r.message.contains("give more"), "{}", r.message);
    // Within the noise the refit's own budget is what is left to fix.
    let w = Verdict::judge(Status::BudgetExhausted, 9.0, 0.9, counts(), 5, 5, vec![])
        .with_refitted(vec![plausible("lb.k_y")]);
    assert_eq!(w.cause, Cause::Budget);
    // Above the noise: a further start that won names a local minimum;
    // one that did not, model error.
    let above = Verdict::judge(Status::Converged, 9.0, 5.0, counts(), 5, 5, vec![]);
    let escaped = SearchEvidence {
        escaped: Some(true),
        short: None,
    };
    let held = SearchEvidence {
        escaped: Some(false),
        short: None,
    };
    assert_eq!(above.clone().classified(escaped).cause, Cause::LocalMinimum);
    let model = above.clone().classified(held).explained();
    assert_eq!(model.cause, Cause::ModelError);
    assert!(
        model.message.contains("cause: model error"),
        "{}",
        model.message
    );
    // ... but only at a minimum: stalled, further starts that ended no
    // better do not tell a basin they did not leave from model error.
    let stalled = Verdict::judge(Status::Stalled, 9.0, 5.0, counts(), 5, 5, vec![])
        .classified(held)
        .explained();
    assert_eq!(stalled.cause, Cause::MinimumOrModelError);
    assert!(
        stalled
            .message
            .contains("a local minimum or model error, not told apart")
            && stalled.message.contains("stalled before converging"),
        "{}",
        stalled.message
    );
    // No further search: not told apart, and the message says so.
    let unsearched = above
        .clone()
        .classified(SearchEvidence::default())
        .explained();
    assert_eq!(unsearched.cause, Cause::NotSearched);
    assert!(
        unsearched.message.contains("not told apart")
            && unsearched.message.contains("no further search"),
        "{}",
        unsearched.message
    );
    // A search that ran short of the first refinement's evaluations: still
    // not told apart, but the message says it ran and why it counts for
    // nothing (vertical mill, impact seed 18: 1,771 against 3,564).
    let short = above
        .classified(SearchEvidence {
            escaped: None,
            short: Some((1771, 3564)),
        })
        .explained();
    assert_eq!(short.cause, Cause::NotSearched);
    assert!(
        short
            .message
            .contains("1771 evaluations, fewer than the 3564")
            && !short.message.contains("no further search"),
        "{}",
        short.message
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

/// The score test holds at a minimum over the identified parameters: what
/// it implicates at a stalled fit, or at one that misplaces a resonance
/// (another basin), names the screening only once a refit confirms it.
#[test]
fn an_untested_implication_off_a_minimum_is_not_blamed_on_the_screening() {
    let implicated = [Implication::new("colj.k_x", 0.4, 505.0)];
    let stalled = Verdict::judge(Status::Stalled, 29.0, 18.0, counts(), 5, 5, vec![])
        .with_frf(
            Status::Stalled,
            FrfJudgement::new(fit(29.0, 0.9), fit(18.0, 0.9)),
        )
        .with_implicated(&implicated);
    assert_eq!(stalled.cause, Cause::ScreeningOrLocalMinimum, "{stalled:?}");
    let text = stalled.clone().explained().message;
    assert!(text.contains("colj.k_x (+49 %"), "{text}");
    assert!(
        text.contains("stalled before converging, where a wrong basin"),
        "{text}"
    );
    assert!(text.contains("no refit tested them"), "{text}");
    // Converged overall at 1.9σ but 12σ over one window: another basin.
    let local = FrfFit {
        local: Some(LocalMisfit {
            rms: 12.0,
            frequency_hz: 119.5,
            position: 0,
        }),
        ..fit(1.9, 0.3)
    };
    let misplaced = converged_within_noise()
        .with_frf(Status::Converged, FrfJudgement::new(fit(11.0, 0.9), local))
        .with_implicated(&implicated);
    assert_eq!(misplaced.cause, Cause::ScreeningOrLocalMinimum);
    let text = misplaced.clone().explained().message;
    assert!(text.contains("misplaces a resonance"), "{text}");
    // A converged fit without such a window: the score test stands.
    let converged = converged_within_noise()
        .with_frf(
            Status::Converged,
            FrfJudgement::new(fit(11.0, 0.9), fit(3.0, 0.9)),
        )
        .with_implicated(&implicated);
    assert_eq!(converged.cause, Cause::ScreenedOut);
    let text = converged.clone().explained().message;
    assert!(
        text.contains("the screening left out what these data see"),
        "{text}"
    );
    // ... unless an escape search has just found it from a worse basin:
    // other minima exist, and no refit tested the implication.
    let escaped = converged.clone().classified(SearchEvidence {
        escaped: Some(true),
        short: None,
    });
    assert_eq!(escaped.cause, Cause::ScreeningOrLocalMinimum);
    let text = escaped.explained().message;
    assert!(text.contains("an escape search reached"), "{text}");
    // A refit with plausible values that fitted materially better confirms
    // it when the refit ends at a minimum ...
    let confirmed = converged.with_refitted(vec![plausible("colj.k_x")]);
    assert_eq!(confirmed.cause, Cause::ScreenedOut);
    // ... but not when it stalled itself or still misplaces a resonance
    // (the vertical mill's 1 % seed 16 and impact seeds 4 and 9 at
    // identify 26: the truth had moved no fixed parameter).
    for off in [stalled, misplaced] {
        let refitted = off.with_refitted(vec![plausible("colj.k_x")]);
        assert_eq!(refitted.cause, Cause::ScreeningOrLocalMinimum);
        let text = refitted.explained().message;
        for part in [
            "the refit of colj.k_x (held fixed by the screening) fitted materially better, but at a fit that",
            "compensating a wrong basin",
        ] {
            assert!(text.contains(part), "{part}: {text}");
        }
        assert!(!text.contains("needs "), "{text}");
    }
}

/// A refitted value 30 % above its file value, mid-range and determined.
fn plausible(name: &str) -> RefitValue {
    RefitValue::judge(name.into(), 1.3, 0.59, true, None)
}

/// The vertical mill's seed 12 (identify 19): three coupling stiffnesses
/// refitted for 11 % lower RMS, the truth at their file values.
fn seed_12() -> Vec<RefitValue> {
    vec![
        RefitValue::judge("cpl.k_y".into(), 0.334, 0.105, true, None),
        RefitValue::judge("cpl.k_x".into(), 2.566, 0.840, false, None),
        RefitValue::judge("cpl.k_ry".into(), 4.0, 1.0, false, None),
    ]
}

/// A refit whose values are plausible names the screening; one that needs a
/// value at a bound names the screening and a local minimum as not told
/// apart, with the parameter, its ratio to the file value and why.
#[test]
fn a_refit_is_evidence_for_the_screening_only_with_plausible_values() {
    let above = Verdict::judge(Status::Converged, 9.0, 4.9, counts(), 40, 25, vec![]);
    let v = above
        .clone()
        .with_refitted(vec![plausible("lb.k_y"), plausible("fb.k_y")])
        .explained();
    assert_eq!(v.cause, Cause::ScreenedOut);
    assert_eq!(v.refitted, ["lb.k_y", "fb.k_y"]);
    assert!(
        !v.warnings
            .iter()
            .any(|w| w.contains("not identified truths")),
        "{:?}",
        v.warnings
    );
    let values = seed_12();
    assert_eq!(values[0].implausible, None);
    assert_eq!(values[1].implausible, None);
    assert_eq!(values[2].implausible, Some(Implausible::AtUpperBound));
    let v = above.clone().with_refitted(values).explained();
    assert!(!v.ok && v.cause == Cause::ScreeningOrLocalMinimum, "{v:?}");
    assert_eq!(v.refitted, ["cpl.k_y", "cpl.k_x", "cpl.k_ry"]);
    for text in [
        "the screening or a local minimum, not told apart",
        "cpl.k_ry 4× its file value, at its upper bound",
        "refit of cpl.k_y, cpl.k_x, cpl.k_ry",
        "not identified truths",
    ] {
        assert!(v.message.contains(text), "{text}: {}", v.message);
    }
    // Every refitted value is named in the warning, with its ratio.
    let w = v
        .warnings
        .iter()
        .find(|w| w.contains("not identified truths"));
    let w = w.expect("a warning on the refitted values");
    assert!(w.contains("cpl.k_y 0.334× its file value;"), "{w}");
    assert!(
        w.contains("cpl.k_x 2.57× its file value, not determined"),
        "{w}"
    );
    // The cause survives the evidence of a further search.
    let held = SearchEvidence {
        escaped: Some(false),
        short: None,
    };
    assert_eq!(v.classified(held).cause, Cause::ScreeningOrLocalMinimum);
    // A refit that stopped at the budget: the same cause, the budget said.
    let b = Verdict::judge(Status::BudgetExhausted, 9.0, 4.9, counts(), 5, 5, vec![])
        .with_refitted(seed_12())
        .explained();
    assert_eq!(b.cause, Cause::ScreeningOrLocalMinimum);
    assert!(b.message.contains("stopped at the budget"), "{}", b.message);
    // Within the noise with nothing implicated the values are doubted too,
    // and the fit is not ok (identify 38; the vertical mill's 1 % seed 33:
    // ok at 1.28σ after a refit that needed fb.c_y at its bound, MAC 0.961
    // against the true modes). With plausible values it stays ok.
    let w = converged_within_noise()
        .with_refitted(seed_12())
        .explained();
    // Doubted: the screening or a local minimum, the bound value named.
    let doubted = |v: &Verdict| {
        assert_eq!(v.cause, Cause::ScreeningOrLocalMinimum, "{v:?}");
        assert!(
            v.message.contains("cpl.k_ry 4× its file value"),
            "{}",
            v.message
        );
    };
    assert!(!w.ok, "{w:?}");
    doubted(&w);
    assert!(w.warnings.iter().any(|t| t.contains("cpl.k_ry 4×")));
    let fine = converged_within_noise()
        .with_refitted(vec![plausible("lb.k_y")])
        .explained();
    assert!(fine.ok && fine.cause == Cause::None, "{fine:?}");
    // ... unless fixed parameters are still implicated there: a refit that
    // needed values at their bounds is no evidence that the score test's
    // parameters are what the screening left out either (the vertical
    // mill's impact seed 9 at identify 33, the truth in the model class).
    let implicated = [Implication::new("colj.c_z", (0.25f64).ln(), 226.0)];
    let still = converged_within_noise()
        .with_refitted(seed_12())
        .with_implicated(&implicated)
        .explained();
    doubted(&still);
    // With plausible refitted values the screening is named, as before.
    let named = converged_within_noise()
        .with_refitted(vec![plausible("lb.k_y")])
        .with_implicated(&implicated);
    assert_eq!(named.cause, Cause::ScreenedOut);
}

/// The vertical mill's 1 % seed 1 (identify 34): after a refit with
/// plausible values, converged within the noise, the score test still
/// implicates couplings whose suggested changes reach their bounds (+300 %),
/// the truth having moved no fixed parameter. The data point at values the
/// model file calls barely possible, so the screening is not named alone;
/// the same implication inside the bounds still names it.
#[test]
fn an_implication_that_needs_a_value_at_a_bound_does_not_name_the_screening() {
    let converged = || {
        converged_within_noise().with_refitted(vec![plausible("motor.k_t"), plausible("nut.k_y")])
    };
    let mut at_bound = Implication::new("cpl.k_ry", 4f64.ln(), 374.0);
    at_bound.at_bound = true;
    let inside = Implication::new("colj.k_y", 0.02, 39.0);
    let v = converged()
        .with_implicated(&[at_bound.clone(), inside.clone()])
        .explained();
    assert_eq!(v.cause, Cause::ScreeningOrLocalMinimum, "{v:?}");
    assert_eq!(v.implicated_at_bound, ["cpl.k_ry"]);
    for text in [
        "cpl.k_ry (+300 % to its bound, χ² 374)",
        "colj.k_y (+2 %, χ² 39)",
        "implicates cpl.k_ry after the refit of motor.k_t, nut.k_y, with changes that reach their bounds",
    ] {
        assert!(v.message.contains(text), "{text}: {}", v.message);
    }
    // Led by a change inside the bounds: the screening, as before, even
    // with a weaker implication at a bound beside it.
    let v = converged().with_implicated(&[inside.clone(), at_bound.clone()]);
    assert_eq!(v.cause, Cause::ScreenedOut, "{v:?}");
    // Without a refit too: the rule is the implication's, not the refit's.
    let v = converged_within_noise()
        .with_implicated(&[at_bound.clone()])
        .explained();
    assert_eq!(v.cause, Cause::ScreeningOrLocalMinimum, "{v:?}");
    assert!(!v.message.contains("after the refit"), "{}", v.message);
    // At a stalled fit the stall is what the cause line names first.
    let v = Verdict::judge(Status::Stalled, 9.0, 4.0, counts(), 5, 5, vec![])
        .with_implicated(&[at_bound])
        .explained();
    assert_eq!(v.cause, Cause::ScreeningOrLocalMinimum, "{v:?}");
    assert!(
        v.message
            .contains("at a fit that stalled before converging")
            && !v.message.contains("with changes that reach their bounds"),
        "{}",
        v.message
    );
}

/// The edges of the plausible range: the central 95 % of the bounds, and
/// with `fixed_spread` σ, 1.96 σ of ln p about the file value.
#[test]
fn refitted_values_are_judged_against_the_screened_range() {
    let judge = |ratio: f64, position: f64, spread: Option<f64>| {
        RefitValue::judge("p".into(), ratio, position, true, spread).implausible
    };
    assert_eq!(judge(0.25, 0.0, None), Some(Implausible::AtLowerBound));
    assert_eq!(judge(0.27, 0.02, None), Some(Implausible::AtLowerBound));
    assert_eq!(judge(0.28, 0.03, None), None);
    assert_eq!(judge(3.8, 0.97, None), None);
    assert_eq!(judge(3.9, 0.98, None), Some(Implausible::AtUpperBound));
    // A factor 1.5 is within 1.96 × 0.3 of ln p (0.41 < 0.59), a factor 2
    // (0.69) and its inverse are not.
    assert_eq!(judge(1.5, 0.65, Some(0.3)), None);
    assert_eq!(judge(2.0, 0.75, Some(0.3)), Some(Implausible::BeyondSpread));
    assert_eq!(judge(0.5, 0.25, Some(0.3)), Some(Implausible::BeyondSpread));
    // A zero spread (fixed parameters exact) leaves the bounds alone to judge.
    assert_eq!(judge(2.0, 0.75, Some(0.0)), None);
    // The cause's name in cost.json, and the values read back.
    let v =
        Verdict::judge(Status::Stalled, 9.0, 4.9, counts(), 5, 5, vec![]).with_refitted(seed_12());
    let json = serde_json::to_string(&v).unwrap();
    assert!(
        json.contains(r#""cause":"screening_or_local_minimum""#),
        "{json}"
    );
    assert!(json.contains(r#""implausible":"at_upper_bound""#), "{json}");
    let back: Verdict = serde_json::from_str(&json).unwrap();
    assert_eq!(back, v);
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
