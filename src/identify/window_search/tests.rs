//! The window search on the three-mass chain: a planted misplaced
//! resonance, one between grid points, and the rules for another basin
//! and for opening a second window.

use super::*;
use crate::identify::black_box::tests::{objective, truth};
use crate::identify::follow_up::tests::{chain_reference, frf_plan, stalled_at, stuck_at};

/// A planted misplaced resonance: the three-mass chain's FRFs at 1 %
/// noise, fitted with `k3.k_x` held at 2.2× its true value (the others
/// compensate, as a basin the refinement does not leave): the worst
/// window is far above the noise. The scan puts `k3.k_x` among the
/// parameters that mend the window, and the refinement from its best
/// point brings the fit to the noise with `k3.k_x` at its true value,
/// within its budget, as evidence of a local minimum.
#[test]
fn a_planted_misplaced_resonance_is_found_by_its_window() {
    let o = objective();
    // k3.k_x's true value on a point of its scan (the middle of its log
    // range): a 9-point scan finds a sharp resonance only near one.
    let mut t = truth();
    t[3] = (1.2e5f64 * 2.0e6).sqrt();
    let r = chain_reference(&t);
    let settings = FrfRefinementParams::default();
    let mut x0 = t.clone();
    x0[3] *= 2.2;
    let held: Vec<usize> = (0..8).filter(|&i| i != 3).collect();
    let stuck = stuck_at(&r, &held, &x0, &settings);
    let local = stuck.summary.end.local.unwrap();
    assert!(local.rms > 10.0, "{:?}", stuck.summary.end);
    let all: Vec<usize> = (0..8).collect();
    let lines = r.window_hz(local.position, local.frequency_hz).unwrap();
    let (moves, cost) = window_moves(&o, &r, &stuck.x, &all, &[(local.position, lines)], 0)
        .unwrap()
        .unwrap();
    assert_eq!(cost, 1 + SCAN * 8);
    assert!(moves.len() <= PARAMETERS && !moves.is_empty());
    assert!(
        moves.windows(2).all(|w| w[0].gain >= w[1].gain),
        "{moves:?}"
    );
    assert!(
        moves.iter().all(|m| m.gain > 0.0 && m.gain <= 1.0),
        "{moves:?}"
    );
    assert!(moves.iter().any(|m| m.parameter == 3), "{moves:?}");
    let optimizer = crate::optimize::Optimizer::from_settings("slsqp", None).unwrap();
    let plan = frf_plan(&r, &settings, &optimizer);
    let now = stalled_at(stuck);
    let step = window_search(&o, &plan, &o.nominal(), &now, local, 3000, &|_| {})
        .unwrap()
        .unwrap();
    assert!(step.cost <= 3000, "{}", step.cost);
    let end = step.escape.unwrap();
    assert!(end.better);
    let next = step.outcome;
    assert_eq!(next.evidence.escaped, Some(true));
    assert!(!next.searched, "the escape over every box is still to run");
    let fit = next.frf.as_ref().unwrap().summary.end;
    assert!(fit.rms < 1.1, "{fit:?}");
    assert_eq!(fit.rms, end.rms);
    assert!(
        (next.x[3] / t[3] - 1.0).abs() < 0.01,
        "{}",
        next.x[3] / t[3]
    );
    // No budget for the search: nothing runs.
    assert!(
        window_search(&o, &plan, &o.nominal(), &now, local, 100, &|_| {})
            .unwrap()
            .is_none()
    );
}

/// The three-mass chain's FRFs at 1 % noise, the model exact but for
/// `k3.k_x` 6 % above its truth (its first mode 1.5 Hz, three lines,
/// high), the truth between two grid points (44 % up its log range,
/// ×1.2 from the nearest): the resonance is so sharp that the grid's
/// best point is that far off; the crossings place the first mode on
/// the window line nearest its true frequency (lines 0.5 Hz apart) and
/// `k3.k_x` within 1 % of its truth.
#[test]
fn a_resonance_between_grid_points_is_placed_by_its_crossing() {
    let o = objective();
    let mut t = truth();
    t[3] = 1.2e5 * (2.0e6f64 / 1.2e5).powf(0.44);
    let r = chain_reference(&t);
    let mut x = t.clone();
    x[3] *= 1.06;
    let fit = r.fit(o.prepared(), &x).unwrap();
    let local = fit.local.unwrap();
    assert!(local.rms > 10.0, "{fit:?}");
    let window = [(
        local.position,
        r.window_hz(local.position, local.frequency_hz).unwrap(),
    )];
    let all: Vec<usize> = (0..8).collect();
    let k3 = |crossings| {
        let (moves, cost) = window_moves(&o, &r, &x, &all, &window, crossings)
            .unwrap()
            .unwrap();
        let m = moves.into_iter().find(|m| m.parameter == 3);
        (m.map(|m| m.value / t[3]), cost)
    };
    let (grid, cost) = k3(0);
    assert_eq!(cost, 1 + SCAN * 8);
    assert!(grid.is_none_or(|v| (v - 1.0).abs() > 0.1), "{grid:?}");
    let (placed, cost) = k3(CROSSINGS);
    assert!(
        cost > 1 + SCAN * 8 && cost <= 1 + (SCAN + CROSSINGS) * 8,
        "{cost}"
    );
    let placed = placed.expect("k3.k_x mends the window");
    assert!((placed - 1.0).abs() < 0.01, "{placed}");
}

/// A search that ends below [`ESCAPED`] of the robust cost, or better
/// with its worst window near the noise, found another basin; better
/// with the window still far above the noise, or mended but worse, did
/// not.
#[test]
fn another_basin_is_a_better_cost_or_a_mended_window() {
    let fit = |cost: f64, window: f64| FrfFit {
        rms: 1.0,
        robust_cost: cost,
        mean_frac: 0.99,
        lag1: 0.3,
        local: Some(LocalMisfit {
            rms: window,
            frequency_hz: 54.5,
            position: 3,
        }),
    };
    let before = fit(100.0, 12.0);
    assert!(another_basin(&before, &fit(80.0, 12.0)));
    assert!(another_basin(&before, &fit(88.0, 1.6)));
    assert!(!another_basin(&before, &fit(88.0, 12.0)));
    assert!(!another_basin(&before, &fit(101.0, 1.6)));
}

/// A refinement that ended with a window far above the noise elsewhere
/// opens it; one inside a searched window, near the noise, better than
/// the standing, or at the chain's depth does not.
#[test]
fn a_new_window_far_above_the_noise_is_opened_once() {
    let r = chain_reference(&truth());
    let first = (0, r.window_hz(0, 100.0).unwrap());
    let end = |hz: f64, rms: f64, cost: f64| FrfFit {
        rms: 2.0,
        robust_cost: cost,
        mean_frac: 0.99,
        lag1: 0.5,
        local: Some(LocalMisfit {
            rms,
            frequency_hz: hz,
            position: 0,
        }),
    };
    let far = end(250.0, 30.0, 2.0);
    assert_eq!(
        opened(&r, &[first], &far, 1.0),
        Some((0, r.window_hz(0, 250.0).unwrap()))
    );
    assert_eq!(opened(&r, &[first], &end(101.0, 30.0, 2.0), 1.0), None);
    assert_eq!(
        opened(&r, &[first], &end(250.0, 0.5 * LOCAL_NOISE_RMS, 2.0), 1.0),
        None
    );
    assert_eq!(opened(&r, &[first], &far, 3.0), None);
    assert_eq!(opened(&r, &[first; DEPTH], &far, 1.0), None);
}
