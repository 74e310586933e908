//! The objective's known answers: exclusions, frequency-only modes, the
//! uncertainty the reference states.

use crate::identify::black_box::tests::{objective, truth};

#[test]
fn excluded_modes_leave_the_objective_with_their_reason() {
    let mut o = objective();
    o.exclude(0, 1, "not observable");
    assert_eq!(o.reference_modes(), 2);
    assert_eq!(o.exclusion(0, 1), Some("not observable"));
    assert_eq!(o.usable(), vec![vec![true, false, true]]);
    let m = o.matches(&truth()).unwrap();
    assert!(m[0][1].is_none() && m[0][0].is_some() && m[0][2].is_some());
    assert!(o.cost(&truth()) < 1e-12);
    let e = o.evaluate(&truth(), &o.usable()).unwrap();
    assert_eq!(e.residuals.len(), 14);
}

/// A mode compared by frequency alone: its shape residuals, J's MAC
/// term and its MAC in the mean leave; everything else is what the full
/// comparison gives, off the truth too.
#[test]
fn a_mode_compared_by_frequency_alone_keeps_its_frequency_residual_only() {
    let full = objective();
    let mut o = objective();
    o.compare_frequency_only(0, 1, "weak");
    assert_eq!(
        o.mode_use(0, 1),
        &super::ModeUse::FrequencyOnly("weak".into())
    );
    assert_eq!(o.exclusion(0, 1), None);
    assert_eq!(o.usable(), vec![vec![true; 3]]);
    assert_eq!(o.shapes_compared(), vec![vec![true, false, true]]);
    // Uneven, so the shapes move too (a uniform scale keeps them).
    let x: Vec<f64> = truth()
        .iter()
        .enumerate()
        .map(|(i, v)| v * (1.0 + 0.04 * i as f64))
        .collect();
    let r_full = full.evaluate(&x, &full.usable()).unwrap().residuals;
    let r = o.evaluate(&x, &o.usable()).unwrap().residuals;
    // 3 shared DOFs: 7 residuals per mode; mode 2 keeps its first.
    assert_eq!((r_full.len(), r.len()), (21, 15));
    let kept: Vec<f64> = r_full[..8].iter().chain(&r_full[14..]).copied().collect();
    assert_eq!(r, kept);
    assert!(r_full[8..14].iter().any(|v| v.abs() > 1e-3), "{r_full:?}");
    assert_eq!(
        o.segments(&o.usable())
            .iter()
            .map(|s| s.2)
            .collect::<Vec<_>>(),
        vec![7, 1, 7]
    );
    let m = full.matches(&x).unwrap();
    let mac_term = full.weights.mac * full.term(0, 1, m[0][1], Some(super::Term::Mac));
    assert!(mac_term > 1e-6, "{mac_term}");
    assert!((o.cost(&x) - (full.cost(&x) - mac_term)).abs() < 1e-12);
    let mean = (m[0][0].unwrap().mac + m[0][2].unwrap().mac) / 2.0;
    assert_eq!(o.summary(&x).unwrap().mean_mac, mean);
    assert!((o.mode_cost(0, 1, &x, 0.0) - nfd_of(&o, &x)).abs() < 1e-12);
}

/// NFD of reference mode 2 against the model mode nearest in frequency.
fn nfd_of(o: &super::ModalObjective, x: &[f64]) -> f64 {
    let f = o.reference_frequency(0, 1);
    o.model_modes_at(0, x)
        .unwrap()
        .modes
        .iter()
        .map(|m| crate::metrics::nfd(f, m.frequency_hz))
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn a_stated_spread_raises_frequency_and_shape_sigma_together() {
    let mut o = objective();
    let u = super::Uncertainty {
        from_complexity: false,
        ..Default::default()
    };
    o.set_uncertainty(u);
    let position = o.position(0).index;
    // A spread implying 5× the default σ_f: the shape is taken 5× less
    // certain too.
    let to_sigma = super::uncertainty::SPREAD_TO_SIGMA;
    o.raise_uncertainty(&u, position, 1, 5.0 * u.frequency / to_sigma, 0.5);
    let (f, s) = o.uncertainty_of(0, 1);
    assert!((f - 5.0 * u.frequency).abs() < 1e-15, "{f}");
    assert!((s - 5.0 * u.shape).abs() < 1e-14, "{s}");
    assert!((o.references[0].sigma_z[1] - 0.5 * to_sigma).abs() < 1e-15);
    // Below the defaults, a spread changes nothing; unknown modes and
    // positions are ignored.
    o.raise_uncertainty(&u, position, 0, 1e-6, 1e-6);
    assert_eq!(o.uncertainty_of(0, 0), (u.frequency, u.shape));
    o.raise_uncertainty(&u, position, 99, 1.0, 1.0);
    o.raise_uncertainty(&u, position + 7, 0, 1.0, 1.0);
    assert_eq!(o.uncertainty_of(0, 0), (u.frequency, u.shape));
    assert_eq!(o.references[0].sigma_z[0], u.damping);
}
