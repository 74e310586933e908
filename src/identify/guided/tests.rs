use super::*;
use crate::identify::black_box::tests::{objective, truth};
use crate::identify::correspondence::Observability;

fn specs() -> Vec<SubproblemSpec> {
    let s = |o: &str, p: &[&str]| SubproblemSpec {
        output: o.into(),
        parameters: p.iter().map(|s| s.to_string()).collect(),
    };
    let all = ["k1.k_x", "k12.k_x", "k23.k_x", "k3.k_x"];
    vec![
        s("p0.mode1.frequency", &all),
        s("p0.mode1.mac", &all),
        s("p0.mode2.mac", &all),
        s("p0.mode3.frequency", &all[..3]),
        s("p0.mode1.damping", &["k1.c_x", "k12.c_x", "k1.k_x"]),
        s("p0.mode2.damping", &["k23.c_x"]),
    ]
}

fn run(settings: &GuidedParams, budget: usize, seed: u64) -> Result<GuidedResult, IdentifyError> {
    let o = objective();
    let c = Correspondence::new(&o, &o.nominal(), Observability::all()).unwrap();
    let specs = specs();
    let screening = Screening {
        specs: &specs,
        significant: None,
        modes: &[],
    };
    guided(
        &o,
        &c,
        screening,
        settings,
        &SlsqpParams::default(),
        &o.nominal(),
        budget,
        seed,
        &|_| {},
    )
}

fn worst_error(x: &[f64]) -> f64 {
    let t = truth();
    (0..4)
        .map(|i| (x[i] / t[i] - 1.0).abs())
        .fold(0.0, f64::max)
}

#[test]
fn guided_recovers_the_three_mass_truth() {
    let t = truth();
    let settings = GuidedParams::default();
    let r = run(&settings, 3000, 5).unwrap();
    assert_eq!(r.subproblems.len(), 3);
    assert_eq!(
        r.subproblems[0].outputs,
        ["p0.mode1.frequency", "p0.mode1.mac"]
    );
    assert_eq!(r.damping, [4, 5, 6]);
    assert!(r.evaluations <= 3000, "{}", r.evaluations);
    assert_eq!(r.evaluations, r.phase_evaluations.iter().sum::<usize>());
    assert!(worst_error(&r.x) < 1e-6, "{:?} vs {t:?}", r.x);
    assert_eq!(r.status, Status::Converged);
    let kept = &r.refinement[0];
    assert!(kept.end < 1e-12 && kept.end < kept.start, "{kept:?}");
    // The continuation's stages: two, then all three modes.
    let stages: Vec<usize> = kept.stages.iter().map(|s| s.modes).collect();
    assert_eq!(stages, [2, 3]);
    // The history starts after step 1 and ends at MAC 1.
    let last = r.history.last().unwrap();
    assert!(r.history[0].evaluation > r.phase_evaluations[0]);
    assert!(last.mean_mac > 1.0 - 1e-12, "{last:?}");
    // Same seed → same result.
    assert_eq!(run(&settings, 3000, 5).unwrap().x, r.x);
}

#[test]
fn the_refinement_alone_and_the_subproblems_alone() {
    // repeats = 0: no subproblem step; the refinement alone from the file
    // values converges here.
    let only_refine = GuidedParams {
        repeats: 0,
        ..GuidedParams::default()
    };
    let r = run(&only_refine, 800, 1).unwrap();
    assert_eq!(r.phase_evaluations[0], 0);
    assert!(r.subproblems.is_empty() && r.chosen.iter().all(|c| !c.taken));
    assert!(worst_error(&r.x) < 1e-6, "{:?}", r.x);
    assert!(r.evaluations < 400, "{}", r.evaluations);
    // refine = false: PUB3's step alone. One mode cannot pin four
    // stiffnesses, so the repeats scatter and little is taken: the
    // estimate stays far from the truth.
    let no_refine = GuidedParams {
        refine: false,
        ..GuidedParams::default()
    };
    let r = run(&no_refine, 3000, 1).unwrap();
    assert_eq!(r.phase_evaluations[1], 0);
    assert!(r.refinement.is_empty());
    assert!(worst_error(&r.x) > 1e-2, "{:?}", r.x);
    // Too small a budget is an error that names the minimum.
    let e = run(&GuidedParams::default(), 20, 1).unwrap_err();
    assert!(e.to_string().contains("give at least"), "{e}");
}

/// What the subproblems leave may not pay one refinement run: the better
/// start stands with the status "budget exhausted" (the verdict names the
/// budget), not an error after the work is done.
#[test]
fn a_refinement_the_budget_cannot_pay_ends_at_the_budget() {
    let o = objective();
    let settings = GuidedParams::default();
    let free: Vec<usize> = (0..4).collect();
    let start = o.nominal();
    let mut x1 = truth();
    x1[0] *= 1.01;
    let recorder = Recorder::starting_at(0);
    let refinement = Refinement {
        o: &o,
        free: &free,
        start: &start,
        settings: &settings,
        seed: 1,
        recorder: &recorder,
        progress: &|_| {},
    };
    let minimum = run_minimum(&o, free.len(), &settings);
    let short = refinement.refine(&x1, minimum - 1).unwrap();
    assert_eq!(short.status, Status::BudgetExhausted);
    assert!(short.runs.is_empty());
    assert_eq!(short.x, x1, "the better of start and subproblems stands");
    assert!(short.evaluations < 8, "{}", short.evaluations);
    // One run's worth, even where the first run's usual share (3/5 of what
    // is left) would be less: it runs.
    let one = refinement.refine(&x1, minimum + 8).unwrap();
    assert_eq!(one.runs.len(), 1, "{:?}", one.runs.len());
}

#[test]
fn the_refinement_does_not_depend_on_the_start() {
    // From three corners of the box the continuation reaches the truth.
    let o = objective();
    let bounds = o.bounds().unwrap();
    let specs = specs();
    for corner in [0.1, 0.5, 0.9] {
        let u = vec![corner; o.parameters().len()];
        let start = bounds.to_physical(&u);
        let c = Correspondence::new(&o, &start, Observability::all()).unwrap();
        let r = guided(
            &o,
            &c,
            Screening {
                specs: &specs,
                significant: None,
                modes: &[],
            },
            &GuidedParams {
                repeats: 0,
                ..GuidedParams::default()
            },
            &SlsqpParams::default(),
            &start,
            3000,
            1,
            &|_| {},
        )
        .unwrap();
        assert!(
            worst_error(&r.x) < 1e-6,
            "from {corner}: {:?} {:#?}",
            r.x,
            r.refinement
        );
    }
}

#[test]
fn a_foreign_output_name_is_rejected() {
    let o = objective();
    let c = Correspondence::new(&o, &o.nominal(), Observability::all()).unwrap();
    let subs = vec![SubproblemSpec {
        output: "y1".into(),
        parameters: vec!["k1.k_x".into()],
    }];
    let e = guided(
        &o,
        &c,
        Screening {
            specs: &subs,
            significant: None,
            modes: &[],
        },
        &GuidedParams::default(),
        &SlsqpParams::default(),
        &o.nominal(),
        100,
        0,
        &|_| {},
    )
    .unwrap_err();
    assert!(e.to_string().contains("p<position>.mode<r>"), "{e}");
}
