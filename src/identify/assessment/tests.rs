use super::*;
use crate::identify::batch_means::Correlation;

fn paired(model_mode: usize) -> Option<Match> {
    Some(Match {
        model_mode,
        frequency_hz: 0.0,
        damping_ratio: 0.05,
        mac: 1.0,
    })
}

/// Unpaired used reference modes are named with their numbers and
/// frequencies; excluded modes (not in `idx`) and paired ones are not.
#[test]
fn unpaired_reference_modes_are_named() {
    let idx = [0, 2, 3];
    let rf = [17.1, 118.9, 155.5];
    let matched = [paired(0), None, None, paired(2)];
    let w = unpaired_text(0, &idx, &rf, &matched).unwrap();
    assert!(w.contains("reference mode without a model partner"), "{w}");
    assert!(
        w.contains("mode 3 (118.90 Hz)") && !w.contains("mode 2 "),
        "{w}"
    );
    assert!(!w.contains("17.10") && !w.contains("155.50"), "{w}");
    assert!(unpaired_text(0, &[0], &[17.1], &[paired(0)]).is_none());
}

/// The real beam's 118.5 Hz mode paired 6.6 % away at MAC 0.61 is weak;
/// a close pair with a poor shape, or a far pair with a good one, is not.
#[test]
fn weak_pairs_need_both_frequency_and_shape_far_off() {
    let m = |f: f64, mac: f64| {
        Some(Match {
            model_mode: 4,
            frequency_hz: f,
            damping_ratio: 0.01,
            mac,
        })
    };
    let idx = [0, 1, 2];
    let rf = [118.5, 155.4, 265.2];
    let matched = [m(126.3, 0.61), m(155.9, 0.55), m(280.0, 0.95)];
    let w = weak_pairs(1, &idx, &rf, &matched);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("reference mode 1 (118.50 Hz)")
            && w[0].contains("+6.6 %")
            && w[0].contains("MAC 0.61"),
        "{}",
        w[0]
    );
    assert!(weak_pairs(1, &idx, &rf, &[None, None, None]).is_empty());
}

#[test]
fn a_model_pair_seen_as_one_reference_mode_is_named() {
    // Model: 40, 72.1, 72.9 (1.1 % apart), 100, 150 Hz; the reference
    // sees 40, 72.5 and 100 Hz, paired with model modes 1, 2 and 4.
    let mf = [40.0, 72.1, 72.9, 100.0, 150.0];
    let rf = [40.0, 72.5, 100.0];
    let w = unresolved_pairs(0, &mf, &rf, &[paired(0), paired(1), paired(3)]);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].contains("model mode 3 (72.90 Hz)") && w[0].contains("reference mode 2"));
    // 150 Hz is outside the reference band, 100 Hz is paired: no more.
    let all = unresolved_pairs(0, &mf, &rf, &[paired(0), paired(1), paired(3)]);
    assert!(!all.iter().any(|m| m.contains("150")));
    // Well separated unpaired modes are not close pairs.
    let apart = unresolved_pairs(0, &[40.0, 60.0, 100.0], &rf, &[paired(0), None, paired(2)]);
    assert!(apart.is_empty(), "{apart:?}");
}

/// The three-mass chain with a second spring `k1b` beside `k1` (both from
/// m1 to ground, so only their sum counts) and its dampers at 2 % of the
/// quickstart's: peaks narrower than the 0.5 Hz lines, where finite
/// differences of the FRFs are least accurate.
fn parallel_springs() -> (crate::dynamics::Model, Vec<f64>) {
    use crate::identify::black_box::tests::THREE_MASS;
    let text = THREE_MASS
        .replace(
            "  # Dampers:",
            "  - {name: k1b.k_x, value: 5.0e5, lower: 5.0e4, upper: 2.0e6, scale: log, kind: stiffness}\n  # Dampers:",
        )
        .replace(
            "  - {name: k12, a:",
            "  - {name: k1b, a: {body: m1, point: c}, connections: [{dir: x, stiffness: k1b.k_x}]}\n  - {name: k12, a:",
        );
    let read = |p: &str| std::fs::read(p);
    let model = crate::dynamics::Model::from_yaml(&text, "parallel.yaml", &read).unwrap();
    // k1 + k1b = 2.4e6, split 2.1e6 / 0.3e6; dampers light.
    let x = vec![2.1e6, 1.3e6, 1.15e6, 4.2e5, 3.0e5, 0.96, 0.5, 0.46, 0.24];
    (model, x)
}

/// Two springs acting only through their sum are one structural group
/// when the FRFs are given too, and the FRF residuals' columns are
/// parallel for them at light damping (peaks a few lines wide).
#[test]
fn parallel_springs_stay_structural_with_frfs() {
    use super::super::frf_objective::FrfNoise;
    use crate::identify::black_box::tests::objective_of;
    use crate::identify::frf_refinement::tests::measured;
    let (model, x) = parallel_springs();
    let o = objective_of(&model, &x);
    let prepared = o.prepared();
    let set = measured(prepared, &x, 0.01, 3);
    let frf =
        FrfReference::new(prepared, &[set], None, (10.0, 400.0), FrfNoise::default()).unwrap();
    // The stiffnesses: four dampers behind three modal damping ratios
    // would be a structural group of their own.
    let all: Vec<usize> = (0..5).collect();
    let names: Vec<String> = all
        .iter()
        .map(|&i| o.parameters()[i].name.clone())
        .collect();
    let ((id, _, _), _) = identifiability_at(&o, &x, &all, &[], 0.1, Some(&frf), &|_| {}).unwrap();
    let structural: Vec<&str> = id
        .parameters
        .iter()
        .filter(|p| p.structural)
        .map(|p| p.parameter.as_str())
        .collect();
    assert_eq!(
        structural,
        ["k1.k_x", "k1b.k_x"],
        "{:?}",
        id.singular_values
    );
    assert!(id.parameters[1..4].iter().all(|p| p.identifiable), "{id:?}");
    let joint = id.undetermined[0].joint.clone().expect("the pair's sum");
    assert_eq!(joint.quantity, "k1.k_x + k1b.k_x");
    assert!((joint.value / 2.4e6 - 1.0).abs() < 1e-12, "{joint:?}");
    // The data's own columns, FRF part by the chain rule, are parallel
    // for the pair: ∂r/∂k1 = ∂r/∂k1b, so ∂r/∂ln k1 / k1 = ∂r/∂ln k1b / k1b
    // (central differences of the FRF residuals were not, by up to 100 %).
    let (columns, r0, observed) =
        log_jacobian(&o, &x, &all, all.len(), Some(&frf), &|_| {}).unwrap();
    assert_eq!(observed.len(), all.len());
    let leading = r0.len() - frf.count();
    let (a, b) = (&columns[0][leading..], &columns[4][leading..]);
    let scale = a.iter().map(|v| (v / x[0]).abs()).fold(0.0, f64::max);
    let defect = a
        .iter()
        .zip(b)
        .map(|(p, q)| (p / x[0] - q / x[4]).abs())
        .fold(0.0, f64::max);
    assert!(scale > 0.0 && defect < 1e-6 * scale, "{defect} vs {scale}");
    let naive = analyze(&columns, &r0, &names, 0.1, &Correlation::independent());
    assert!(
        naive.parameters[0].structural,
        "{:?}",
        naive.singular_values
    );
}

/// The standard error of ln S for the chain at `x` (its first four
/// parameters identified) measured with 1 % FRF noise: the sum's when
/// `pair`, else the first spring's.
fn sum_std_error(model: &crate::dynamics::Model, x: &[f64], pair: bool) -> f64 {
    use super::super::frf_objective::FrfNoise;
    use crate::identify::black_box::tests::objective_of;
    use crate::identify::frf_refinement::tests::measured;
    let o = objective_of(model, x);
    let set = measured(o.prepared(), x, 0.01, 3);
    let frf = FrfReference::new(
        o.prepared(),
        &[set],
        None,
        (10.0, 400.0),
        FrfNoise::default(),
    )
    .unwrap();
    let identified: Vec<usize> = (0..if pair { 5 } else { 4 }).collect();
    let ((id, _, _), _) =
        identifiability_at(&o, x, &identified, &[], 0.1, Some(&frf), &|_| {}).unwrap();
    if pair {
        id.undetermined[0]
            .joint
            .as_ref()
            .unwrap()
            .std_error
            .unwrap()
    } else {
        id.parameters[0].std_error.unwrap()
    }
}

/// Two parallel springs' sum has the uncertainty of one spring of that
/// stiffness in their place, from the same data: at the fixture's light
/// dampers (2 % of the quickstart's; with central differences of the FRF
/// residuals the two differed by up to 100 % there) and at 10× the
/// quickstart's.
#[test]
fn the_sum_of_parallel_springs_is_as_certain_as_one_spring() {
    for factor in [1.0, 500.0] {
        sum_matches_one_spring(factor);
    }
}

fn sum_matches_one_spring(damping_factor: f64) {
    let (pair, mut x) = parallel_springs();
    x[5..].iter_mut().for_each(|d| *d *= damping_factor);
    let single = crate::dynamics::Model::from_yaml(
        crate::identify::black_box::tests::THREE_MASS,
        "single.yaml",
        &|p: &str| std::fs::read(p),
    )
    .unwrap();
    let mut xs = vec![2.4e6, 1.3e6, 1.15e6, 4.2e5];
    xs.extend(&x[5..]);
    let (got, want) = (
        sum_std_error(&pair, &x, true),
        sum_std_error(&single, &xs, false),
    );
    assert!(
        (got / want - 1.0).abs() < 0.01,
        "dampers ×{damping_factor}: {got} vs {want}"
    );
}

/// A suggested change is cut at the bounds and marked `at_bound` only where
/// it takes the parameter into the outer 2.5 % of its range in the
/// direction it moves: far beyond the upper bound, to just inside the lower
/// one; not a small change, nor a small one away from a bound the file
/// value already sits at.
#[test]
fn a_suggested_change_is_marked_where_it_reaches_a_bound() {
    use crate::identify::consider::FixedParameter;
    let o = crate::identify::black_box::tests::objective();
    let p = &o.parameters()[..4];
    let mut x = o.nominal();
    // Parameter 3 sits at 1.001 × its lower bound.
    x[3] = p[3].lower * 1.001;
    let span = |i: usize| (p[i].upper / x[i]).ln();
    let changes = [
        10.0 * span(0),                   // far beyond the upper bound
        0.1,                              // inside
        (p[2].lower / x[2]).ln() * 0.999, // to just inside the lower one
        0.05,                             // away from the bound it sits at
    ];
    let fixed_parameter = |i: usize| FixedParameter {
        parameter: p[i].name.clone(),
        spread: 0.3,
        statistic: 50.0,
        p_value: 1e-9,
        change: changes[i],
        at_bound: false,
        implicated: true,
        influence: 0.0,
    };
    let c = Consider {
        std_error: Vec::new(),
        fixed: (0..4).map(fixed_parameter).collect(),
        critical: 10.0,
    };
    let fixed: Vec<(usize, f64)> = (0..4).map(|i| (i, 0.3)).collect();
    let c = cut_at_bounds(&o, &x, &fixed, c);
    let marks: Vec<bool> = c.fixed.iter().map(|f| f.at_bound).collect();
    assert_eq!(marks, [true, false, true, false], "{:?}", c.fixed);
    assert!(
        (c.fixed[0].change - span(0)).abs() < 1e-12,
        "cut at the upper bound"
    );
    assert_eq!(c.fixed[1].change, 0.1);
}
