//! Known-answer tests of the AutoEMA chain on synthetic FRFs built by modal
//! superposition (eq. 2.45): PolyMAX poles, multi- vs single-reference on
//! close modes, LSFD shapes and FRAC, and the optimized selection end to end.

use super::synthetic::{four_mode_system, lines, modal_superposition, SyntheticMode};
use super::*;
use crate::metrics::{mac, pole};
use num_complex::Complex64;

fn data(modes: &[SyntheticMode], refs: &[usize], noise: f64) -> FrfData {
    let set = modal_superposition(modes, refs, &lines(20.0, 260.0, 0.25), noise, 11);
    FrfData::from_set(&set, None, Weighting::Uniform).unwrap()
}

/// Largest relative frequency and damping errors of the poles nearest each true mode.
fn errors(order: &PoleOrder, modes: &[SyntheticMode]) -> (f64, f64) {
    let mut worst = (0.0f64, 0.0f64);
    for m in modes {
        let Some(p) = order.poles.iter().min_by(|a, b| {
            let da = (a.s - pole(m.frequency_hz, m.damping_ratio)).norm();
            let db = (b.s - pole(m.frequency_hz, m.damping_ratio)).norm();
            da.total_cmp(&db)
        }) else {
            return (f64::INFINITY, f64::INFINITY);
        };
        worst.0 = worst
            .0
            .max((p.frequency_hz - m.frequency_hz).abs() / m.frequency_hz);
        worst.1 = worst
            .1
            .max((p.damping_ratio - m.damping_ratio).abs() / m.damping_ratio);
    }
    worst
}

#[test]
fn polymax_recovers_poles_of_clean_two_reference_frfs() {
    let modes = four_mode_system();
    let orders = polymax(
        &data(&modes, &[0, 3], 0.0),
        &PolymaxParams { max_order: 16 },
    )
    .unwrap();
    assert_eq!(orders.len(), 16);
    assert_eq!(orders[9].order, 10);
    let (df, dz) = errors(&orders[9], &modes);
    assert!(
        df < 1e-3 && dz < 0.02,
        "order 10: frequency error {df}, damping error {dz}"
    );
    // With enough order for the out-of-band residual effects, clean poles
    // come out exact: frequency to 4e-7, damping to 3e-5 (measured).
    let (df, dz) = orders
        .iter()
        .map(|o| errors(o, &modes))
        .fold((1.0f64, 1.0f64), |a, e| (a.0.min(e.0), a.1.min(e.1)));
    assert!(df < 1e-6, "best frequency error over orders {df}");
    assert!(dz < 1e-4, "best damping error over orders {dz}");
}

#[test]
fn polymax_tolerates_one_percent_noise() {
    let modes = four_mode_system();
    let orders = polymax(
        &data(&modes, &[0, 3], 0.01),
        &PolymaxParams { max_order: 20 },
    )
    .unwrap();
    let (df, dz) = errors(&orders[19], &modes);
    assert!(
        df < 5e-3 && dz < 0.1,
        "order 20: frequency error {df}, damping error {dz}"
    );
}

#[test]
fn reusing_the_normal_equations_gives_the_per_order_rebuild_poles() {
    let d = data(&four_mode_system(), &[0, 3], 0.01);
    let params = PolymaxParams { max_order: 12 };
    let fast = polymax(&d, &params).unwrap();
    let slow = polymax_rebuild_per_order(&d, &params).unwrap();
    for (a, b) in fast.iter().zip(&slow) {
        assert_eq!(a.poles.len(), b.poles.len(), "order {}", a.order);
        for (p, q) in a.poles.iter().zip(&b.poles) {
            assert!(
                (p.s - q.s).norm() < 1e-6 * p.s.norm(),
                "order {}: {} vs {}",
                a.order,
                p.s,
                q.s
            );
        }
    }
}

/// Two modes 1 Hz apart with different shapes.
fn close_modes() -> Vec<SyntheticMode> {
    let m = |f, s: [f64; 4]| SyntheticMode {
        frequency_hz: f,
        damping_ratio: 0.01,
        shape: s.to_vec(),
    };
    vec![
        m(60.0, [0.5, 0.5, 0.5, 0.5]),
        m(100.0, [1.0, 0.3, -0.6, 0.8]),
        m(101.0, [0.2, 1.0, 0.7, -0.5]),
        m(180.0, [0.4, -0.5, 0.6, -0.7]),
    ]
}

/// Lowest order whose poles recover both close modes (0.05 % frequency, 5 % damping).
fn first_resolving_order(orders: &[PoleOrder], modes: &[SyntheticMode]) -> Option<usize> {
    orders
        .iter()
        .find(|o| {
            let (df, dz) = errors(o, &modes[1..3]);
            df < 5e-4 && dz < 0.05
        })
        .map(|o| o.order)
}

#[test]
fn multi_reference_resolves_close_modes_at_lower_order_than_single_reference() {
    let modes = close_modes();
    let params = PolymaxParams { max_order: 30 };
    let multi = polymax(&data(&modes, &[0, 1], 0.005), &params).unwrap();
    let single = polymax(&data(&modes, &[0], 0.005), &params).unwrap();
    let m = first_resolving_order(&multi, &modes).expect("two references resolve the close modes");
    let s = first_resolving_order(&single, &modes).unwrap_or(usize::MAX);
    // Same number of poles (order · references) or fewer suffices with two references.
    assert!(
        2 * m < s,
        "multi-reference order {m} (×2 poles) vs single-reference order {s}"
    );
}

#[test]
fn lsfd_recovers_shapes_and_frfs_for_the_true_poles() {
    let modes = four_mode_system();
    let d = data(&modes, &[0, 3], 0.0);
    let lambdas: Vec<Complex64> = modes
        .iter()
        .map(|m| pole(m.frequency_hz, m.damping_ratio))
        .collect();
    let fit = lsfd(&d, &lambdas).unwrap();
    for (m, shape) in modes.iter().zip(&fit.shapes) {
        let truth: Vec<Complex64> = m.shape.iter().map(|&v| Complex64::new(v, 0.0)).collect();
        assert!(mac(&truth, shape) > 0.999, "MAC {}", mac(&truth, shape));
    }
    assert!(
        fit.mean_frac(&d) > 0.999999,
        "mean FRAC {}",
        fit.mean_frac(&d)
    );
    // Residues of mode r at channel (o, i) are φ_o φ_i / (2jω_d) for this model.
    let wd = lambdas[0].im;
    let want = modes[0].shape[1] * modes[0].shape[3] / (2.0 * wd);
    let got = fit.residues[0][d.n_ref() + 1];
    assert!(
        (got - Complex64::new(0.0, -want)).norm() < 1e-6 * want.abs(),
        "{got} vs -j{want}"
    );
}

#[test]
fn auto_ema_finds_the_four_modes() {
    let modes = four_mode_system();
    let d = data(&modes, &[0, 3], 0.01);
    let params = AutoEmaParams {
        max_order: Some((8, 24)),
        evaluations: 30,
        initial: 10,
        ..AutoEmaParams::default()
    };
    let r = auto_ema(&d, &params, &|| {}).unwrap();
    assert!((30..=90).contains(&r.trace.len()), "{}", r.trace.len());
    assert_eq!(
        r.best.roots.len(),
        4,
        "selected {:?}",
        r.best.hyperparameters
    );
    for (c, m) in r.best.roots.iter().zip(&modes) {
        let p = c.pole(&r.orders);
        assert!(
            (p.frequency_hz - m.frequency_hz).abs() / m.frequency_hz < 5e-3,
            "{} vs {}",
            p.frequency_hz,
            m.frequency_hz
        );
        assert!((p.damping_ratio - m.damping_ratio).abs() / m.damping_ratio < 0.1);
    }
    for (shape, m) in r.fit.shapes.iter().zip(&modes) {
        let truth: Vec<Complex64> = m.shape.iter().map(|&v| Complex64::new(v, 0.0)).collect();
        assert!(mac(&truth, shape) > 0.99);
    }
    assert!(r.best.mean_frac > 0.99, "mean FRAC {}", r.best.mean_frac);
    // Fixing every hyperparameter leaves one evaluation.
    let fixed = r.best.hyperparameters.to_array();
    let pinned = AutoEmaParams {
        fixed: HYPERPARAMETER_NAMES
            .iter()
            .zip(fixed)
            .map(|(n, v)| (n.to_string(), v))
            .collect(),
        ..params.clone()
    };
    let again = auto_ema(&d, &pinned, &|| {}).unwrap();
    assert_eq!(again.trace.len(), 1);
    assert_eq!(again.best.roots.len(), 4);
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let d = data(&four_mode_system(), &[0, 3], 0.01);
    let params = AutoEmaParams {
        max_order: Some((6, 14)),
        evaluations: 8,
        initial: 5,
        ..AutoEmaParams::default()
    };
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| auto_ema(&d, &params, &|| {}).unwrap())
    };
    assert_eq!(run(1), run(3));
}

#[test]
fn incomplete_channel_matrices_and_tiny_bands_are_errors() {
    let mut set = modal_superposition(
        &four_mode_system(),
        &[0, 3],
        &lines(20.0, 260.0, 1.0),
        0.0,
        1,
    );
    set.channels.remove(1);
    let e = FrfData::from_set(&set, None, Weighting::Uniform).unwrap_err();
    assert!(e.to_string().contains("missing"), "{e}");
    let set = modal_superposition(&four_mode_system(), &[0], &lines(20.0, 30.0, 1.0), 0.0, 1);
    let d = FrfData::from_set(&set, None, Weighting::Uniform).unwrap();
    assert!(polymax(&d, &PolymaxParams { max_order: 20 }).is_err());
}

/// Issue 5 acceptance: two modes 3 % apart with 2–3 % damping, a third well
/// separated, 2 % complex noise, two references: every mode is found (NFD <
/// 0.5 %, NDD < 20 %, MAC > 0.98 with the true shapes), nothing spurious,
/// mean FRAC > 0.998.
#[test]
fn auto_ema_separates_close_modes_with_two_references() {
    let m = |f, z, s: [f64; 5]| SyntheticMode {
        frequency_hz: f,
        damping_ratio: z,
        shape: s.to_vec(),
    };
    let modes = vec![
        m(100.0, 0.020, [0.9, 0.6, 0.2, -0.3, -0.7]),
        m(103.0, 0.030, [0.2, -0.5, 0.8, 0.7, 0.3]),
        m(180.0, 0.020, [0.5, -0.8, 0.6, -0.4, 0.2]),
    ];
    let set = modal_superposition(&modes, &[0, 3], &lines(40.0, 260.0, 0.25), 0.02, 7);
    let d = FrfData::from_set(&set, None, Weighting::Uniform).unwrap();
    let params = AutoEmaParams {
        max_order: Some((8, 30)),
        evaluations: 40,
        initial: 12,
        ..AutoEmaParams::default()
    };
    let r = auto_ema(&d, &params, &|| {}).unwrap();
    assert_eq!(
        r.best.roots.len(),
        modes.len(),
        "modes {:?}",
        r.best
            .roots
            .iter()
            .map(|c| c.pole(&r.orders).frequency_hz)
            .collect::<Vec<_>>()
    );
    for (k, (c, m)) in r.best.roots.iter().zip(&modes).enumerate() {
        let p = c.pole(&r.orders);
        let nfd = (p.frequency_hz - m.frequency_hz).abs() / m.frequency_hz;
        let ndd = (p.damping_ratio - m.damping_ratio).abs() / m.damping_ratio;
        assert!(
            nfd < 5e-3 && ndd < 0.2,
            "mode {k}: {} Hz ζ {} vs {} Hz ζ {}",
            p.frequency_hz,
            p.damping_ratio,
            m.frequency_hz,
            m.damping_ratio
        );
        let truth: Vec<Complex64> = m.shape.iter().map(|&v| Complex64::new(v, 0.0)).collect();
        let mac_k = mac(&truth, &r.fit.shapes[k]);
        assert!(mac_k > 0.98, "mode {k}: MAC {mac_k}");
    }
    assert!(r.best.mean_frac > 0.998, "mean FRAC {}", r.best.mean_frac);
}

/// A mode of one hyperparameter point is dropped: on the wide-band family's
/// seed 8 at 2 % noise the chosen selection holds a spurious mode that none
/// of the search's next-best selections holds; checked against them the
/// result has every true mode and no other, and says why the mode went.
#[test]
fn a_mode_no_near_optimal_selection_holds_is_dropped() {
    use super::families::{case, estimates, frf_data, score};
    use super::significance::Reason;
    let c = case("wide_band", 8).unwrap();
    let d = frf_data(&c, 0.02, 8);
    let run = |consensus| {
        let p = AutoEmaParams {
            consensus,
            ..AutoEmaParams::default()
        };
        let r = auto_ema(&d, &p, &|| {}).unwrap();
        let s = score(&c, 0.02, &estimates(&r), r.best.mean_frac);
        (r, s)
    };
    let (_, unchecked) = run(0);
    assert_eq!((unchecked.spurious, unchecked.success), (1, false));
    let (r, checked) = run(12);
    assert!(checked.success && checked.spurious == 0, "{checked:?}");
    assert_eq!(r.consensus_of, 12);
    assert!(r
        .best
        .rejected
        .iter()
        .any(|j| j.reason == Reason::NoConsensus { of: 12 }));
    // Every mode kept is held by another selection, or too narrow to judge.
    assert_eq!(r.support.len(), r.best.roots.len());
    let step = d.frequencies_hz[1] - d.frequencies_hz[0];
    for (root, &n) in r.best.roots.iter().zip(&r.support) {
        let p = root.pole(&r.orders);
        let lines = adequacy::bandwidth_lines(p.frequency_hz, p.damping_ratio, step);
        assert!(n > 0 || lines <= CONSENSUS_MIN_LINES, "{p:?}");
    }
}
