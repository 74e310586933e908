use super::*;
use crate::identify::batch_means::Correlation;
use crate::identify::consider::consider;
use crate::identify::identifiability::{analyze, Z95};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

const SIGMA: f64 = 0.05;

fn names(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

fn spring(name: &str, value: f64, kind: ParameterKind) -> Member {
    Member {
        name: name.into(),
        value,
        lower: value / 4.0,
        upper: value * 4.0,
        kind,
    }
}

/// A straight-line fit's least-squares (a, S), its time points, whitened
/// residuals, a fixed parameter's column and the residuals' correlation.
type Line = ((f64, f64), Vec<f64>, Vec<f64>, Vec<f64>, Correlation);

/// y_k = a + S t_k + e_k (σ = 0.05, seeded) on 40 points, the least-squares
/// (a, S), the whitened residuals at them, the time points, and a fixed
/// parameter's column (a quadratic term) with the correlation of blocks of
/// five neighbouring lines (so the sandwich takes part).
fn straight_line() -> Line {
    let m = 40;
    let t: Vec<f64> = (0..m).map(|k| k as f64 / (m - 1) as f64).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let y: Vec<f64> = t
        .iter()
        .map(|x| 1.0 + 2.0 * x + SIGMA * (rng.random::<f64>() - 0.5) * 3.46)
        .collect();
    let n = m as f64;
    let (st, stt) = (t.iter().sum::<f64>(), t.iter().map(|v| v * v).sum::<f64>());
    let sy: f64 = y.iter().sum();
    let sty: f64 = t.iter().zip(&y).map(|(a, b)| a * b).sum();
    let s = (n * sty - st * sy) / (n * stt - st * st);
    let a = (sy - s * st) / n;
    let r: Vec<f64> = t
        .iter()
        .zip(&y)
        .map(|(x, y)| (a + s * x - y) / SIGMA)
        .collect();
    let quadratic: Vec<f64> = t.iter().map(|x| x * x / SIGMA).collect();
    let correlation = Correlation {
        inflation: 1.0,
        blocks: (0..8)
            .map(|b| std::iter::once(5 * b..5 * b + 5).collect())
            .collect(),
        block_lines: 5,
        integrated_time: 1.0,
    };
    ((a, s), t, r, quadratic, correlation)
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a / b - 1.0).abs() < tol
}

/// The sum of two springs that act only together, S = k₁ + k₂, gets the
/// standard errors and interval of S itself identified in a model that has
/// S as one parameter (the same data, the same fixed parameter): the
/// change of coordinates is exact.
#[test]
fn the_sum_of_parallel_springs_has_the_interval_of_a_direct_fit() {
    let ((a, s), t, r, quadratic, correlation) = straight_line();
    let line = |scale: f64| -> Vec<f64> { t.iter().map(|x| scale * x / SIGMA).collect() };
    let offset = vec![a / SIGMA; t.len()];
    let fixed = [quadratic];
    let spreads = [0.1];
    let fixed_names = names(&["q"]);
    // Direct: ln a and ln S.
    let direct_cols = vec![offset.clone(), line(s)];
    let direct = analyze(&direct_cols, &r, &names(&["a", "S"]), 10.0, &correlation);
    // The consider analysis of some identified columns, the same fixed one.
    let considered =
        |cols: &[Vec<f64>]| consider(cols, &fixed, &r, &fixed_names, &spreads, 1.0, &correlation);
    let direct_c = considered(&direct_cols);
    // Split: ln a, ln k1, ln k2 with k1 + k2 = S.
    let (k1, k2) = (0.3 * s, 0.7 * s);
    let cols = vec![offset, line(k1), line(k2)];
    let split_names = names(&["a", "k1", "k2"]);
    let mut split = analyze(&cols, &r, &split_names, 10.0, &correlation);
    assert_eq!(split.undetermined.len(), 1, "{:?}", split.undetermined);
    let members = vec![
        spring("a", a, ParameterKind::Stiffness),
        spring("k1", k1, ParameterKind::Stiffness),
        spring("k2", k2, ParameterKind::Stiffness),
    ];
    let sums = SumCoordinates::of(&split, &cols, &members).expect("the sum is determined");
    let rotated = sums.rotate(&cols);
    let ra = analyze(&rotated, &r, &split_names, 10.0, &correlation);
    let rc = considered(&rotated);
    sums.attach(&mut split, &ra, Some(&rc));
    let joint = split.undetermined[0].joint.clone().expect("a joint effect");
    assert_eq!(joint.quantity, "k1 + k2");
    assert!(close(joint.value, s, 1e-12));
    let se = direct.parameters[1].std_error.unwrap();
    let se_fixed = direct_c.std_error[1];
    assert!(
        se_fixed > se * 1.01,
        "the fixed term widens: {se_fixed} vs {se}"
    );
    assert!(
        close(joint.std_error.unwrap(), se, 1e-8),
        "{joint:?} vs {se}"
    );
    assert!(close(joint.std_error_with_fixed.unwrap(), se_fixed, 1e-8));
    assert!(close(
        joint.ci_low.unwrap(),
        s * (-Z95 * se_fixed).exp(),
        1e-8
    ));
    assert!(close(
        joint.ci_high.unwrap(),
        s * (Z95 * se_fixed).exp(),
        1e-8
    ));
    // The other parameter is untouched by the change of coordinates.
    assert!(close(
        ra.parameters[0].std_error.unwrap(),
        split.parameters[0].std_error.unwrap(),
        1e-10
    ));
    assert!(close(
        split.parameters[0].std_error.unwrap(),
        direct.parameters[0].std_error.unwrap(),
        1e-8
    ));
    assert!(split.undetermined[0].describe().contains("k1 + k2 = "));
}

/// Two springs on different lever arms (the modes see k₁ + 2k₂) are one
/// structural group, but their sum is not what the data determine; nor is
/// the sum of a spring and a damper.
#[test]
fn a_lever_or_mixed_kinds_have_no_sum() {
    let ((a, s), t, r, _, correlation) = straight_line();
    let (k1, k2) = (0.5 * s, 0.25 * s);
    let line = |scale: f64| -> Vec<f64> { t.iter().map(|x| scale * x / SIGMA).collect() };
    let offset = vec![a / SIGMA; t.len()];
    let n = names(&["a", "k1", "k2"]);
    let lever = vec![offset.clone(), line(k1), line(2.0 * k2)];
    let analysis = analyze(&lever, &r, &n, 10.0, &correlation);
    assert_eq!(analysis.undetermined.len(), 1);
    let springs = vec![
        spring("a", a, ParameterKind::Stiffness),
        spring("k1", k1, ParameterKind::Stiffness),
        spring("k2", k2, ParameterKind::Stiffness),
    ];
    assert!(SumCoordinates::of(&analysis, &lever, &springs).is_none());
    // On one line, but a spring and a damper.
    let parallel = vec![offset, line(k1), line(k2)];
    let analysis = analyze(&parallel, &r, &n, 10.0, &correlation);
    let mut mixed = springs.clone();
    mixed[2].kind = ParameterKind::Damping;
    assert!(SumCoordinates::of(&analysis, &parallel, &mixed).is_none());
    assert!(SumCoordinates::of(&analysis, &parallel, &springs).is_some());
}

#[test]
fn the_basis_is_orthonormal_and_starts_with_the_given_vector() {
    let w = [0.2, 0.5, 0.3];
    let norm = w.iter().map(|v| v * v).sum::<f64>().sqrt();
    let unit: Vec<f64> = w.iter().map(|v| v / norm).collect();
    let b = orthonormal_from(unit.clone(), 3);
    assert_eq!(b.len(), 3);
    assert_eq!(b[0], unit);
    for i in 0..3 {
        for j in 0..3 {
            let d: f64 = b[i].iter().zip(&b[j]).map(|(x, y)| x * y).sum();
            let want = if i == j { 1.0 } else { 0.0 };
            assert!((d - want).abs() < 1e-14, "{i}, {j}: {d}");
        }
    }
}

#[test]
fn a_sum_is_written_with_the_digits_its_interval_needs() {
    let j = JointEffect {
        quantity: "me1.k_x + me2.k_x".into(),
        value: 100_386_676.6,
        std_error: Some(2.2e-4),
        std_error_with_fixed: Some(2.3e-4),
        ci_low: Some(100_341_242.6),
        ci_high: Some(100_432_131.3),
    };
    assert_eq!(
        j.describe(),
        "me1.k_x + me2.k_x = 1.00387e8 (95 %: 1.00341e8 to 1.00432e8)"
    );
}

#[test]
fn an_undetermined_sum_says_so() {
    let j = JointEffect {
        quantity: "k1 + k2".into(),
        value: 3.0e8,
        std_error: None,
        std_error_with_fixed: None,
        ci_low: None,
        ci_high: None,
    };
    assert_eq!(j.describe(), "k1 + k2 = 3e8, not determined by the data");
}
