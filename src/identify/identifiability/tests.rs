use super::*;

fn names(n: usize) -> Vec<String> {
    (0..n).map(|i| format!("p{i}")).collect()
}

#[test]
fn covariance_of_a_straight_line_fit_matches_the_textbook_formula() {
    // y_k = a + b t_k + e_k, t = 0..4: J = [1, t], residuals at the LS
    // solution of y = (1.1, 2.9, 5.2, 6.8, 9.1). Closed form:
    // C = σ̂² (JᵀJ)⁻¹, (JᵀJ)⁻¹ = [[Σt², −Σt], [−Σt, n]] / (nΣt² − (Σt)²).
    let t = [0.0, 1.0, 2.0, 3.0, 4.0];
    let y = [1.1, 2.9, 5.2, 6.8, 9.1];
    let n = t.len() as f64;
    let (st, stt) = (t.iter().sum::<f64>(), t.iter().map(|v| v * v).sum::<f64>());
    let sy: f64 = y.iter().sum();
    let sty: f64 = t.iter().zip(&y).map(|(a, b)| a * b).sum();
    let det = n * stt - st * st;
    let b = (n * sty - st * sy) / det;
    let a = (sy - b * st) / n;
    let r: Vec<f64> = t.iter().zip(&y).map(|(t, y)| a + b * t - y).collect();
    let cols = vec![vec![1.0; 5], t.to_vec()];
    let id = analyze(&cols, &r, &names(2), 10.0, &Correlation::independent());
    let s2 = r.iter().map(|v| v * v).sum::<f64>() / 3.0;
    assert!((id.residual_variance.unwrap() / s2 - 1.0).abs() < 1e-12);
    let se_a = (s2 * stt / det).sqrt();
    let se_b = (s2 * n / det).sqrt();
    let got_a = id.parameters[0].std_error.unwrap();
    let got_b = id.parameters[1].std_error.unwrap();
    assert!((got_a / se_a - 1.0).abs() < 1e-10, "{got_a} vs {se_a}");
    assert!((got_b / se_b - 1.0).abs() < 1e-10, "{got_b} vs {se_b}");
    assert_eq!(id.rank, 2);
    assert!(id.undetermined.is_empty());
    // Prior errors are those of unit-variance residuals.
    assert!((id.parameters[1].prior_std_error - (n / det).sqrt()).abs() < 1e-12);
}

#[test]
fn parallel_columns_are_a_named_undetermined_combination() {
    // p1 and p2 act only through their sum (identical columns), p0 alone.
    let c0 = vec![1.0, 0.0, 2.0, 0.5];
    let c1 = vec![0.3, 1.0, -0.4, 0.8];
    let id = analyze(
        &[c0, c1.clone(), c1],
        &[0.0; 4],
        &["k0".into(), "k1".into(), "k2".into()],
        0.1,
        &Correlation::independent(),
    );
    assert_eq!(id.rank, 2);
    let flags: Vec<bool> = id.parameters.iter().map(|p| p.identifiable).collect();
    assert_eq!(flags, [true, false, false]);
    assert_eq!(id.undetermined.len(), 1);
    let c = &id.undetermined[0];
    let named: Vec<&str> = c.parameters.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(named, ["k1", "k2"]);
    assert_eq!(c.free, 1);
    // Each has half of the one free direction (1, −1)/√2.
    assert!((c.parameters[0].1 - 0.5).abs() < 1e-9, "{c:?}");
    assert!(
        c.describe().contains("{k1, k2}: 1 free combination"),
        "{}",
        c.describe()
    );
    assert!(id.parameters[1].structural && id.parameters[2].structural);
    // Exact data: σ̂ = 0, so the error is 0 where identifiable.
    assert_eq!(id.parameters[0].std_error, Some(0.0));
    assert_eq!(id.parameters[1].std_error, None);
}

#[test]
fn independent_degeneracies_are_separate_groups_whatever_the_basis() {
    // Two parallel pairs (a, b) and (c, d), plus e alone: the null space
    // has dimension 2 and any basis of it mixes the pairs; the groups
    // must not.
    let ca = vec![1.0, 0.0, 0.5, 0.2, 0.0];
    let cc = vec![0.0, 1.0, -0.3, 0.0, 0.7];
    let ce = vec![0.2, 0.1, 0.0, 1.0, 0.4];
    let names: Vec<String> = ["a", "b", "c", "d", "e"].map(String::from).to_vec();
    let id = analyze(
        &[ca.clone(), ca, cc.clone(), cc, ce],
        &[0.0; 5],
        &names,
        0.1,
        &Correlation::independent(),
    );
    let groups: Vec<Vec<&str>> = id
        .undetermined
        .iter()
        .map(|c| c.parameters.iter().map(|p| p.0.as_str()).collect())
        .collect();
    assert_eq!(groups, [vec!["a", "b"], vec!["c", "d"]]);
    assert!(id.undetermined.iter().all(|c| c.free == 1));
    assert!(id.parameters[4].identifiable);
}

#[test]
fn a_weak_but_nonzero_direction_is_judged_by_the_threshold() {
    // Column norm 5, σ̂ = 1 (‖r‖² = 1, one degree of freedom): error
    // 0.2 — identifiable at 0.25, not at 0.1.
    let cols = vec![vec![3.0, 4.0]];
    let r = [0.8, -0.6];
    assert!(
        analyze(&cols, &r, &names(1), 0.25, &Correlation::independent()).parameters[0].identifiable
    );
    let id = analyze(&cols, &r, &names(1), 0.1, &Correlation::independent());
    assert!(!id.parameters[0].identifiable && !id.parameters[0].structural);
    assert_eq!(id.undetermined.len(), 1);
    assert!((id.undetermined[0].singular_value - 5.0).abs() < 1e-12);
    // The same data without noise determine it exactly.
    assert!(
        analyze(
            &cols,
            &[0.0, 0.0],
            &names(1),
            0.1,
            &Correlation::independent()
        )
        .parameters[0]
            .identifiable
    );
}

#[test]
fn exact_null_directions_are_parallel_terms_of_any_size() {
    // Rank-one terms g gᵀ: a = 3e8·(1, 1, 0) and b = 5e7·(2, 2, 0) lie on
    // one line of action (scaled copies); c = 4e3·(1, −1, 0) does not.
    // G_ab = x_a x_b (g_aᵀ g_b)² with x the values.
    let g = [
        [1.0, 1.0, 0.0],
        [2.0, 2.0, 0.0],
        [1.0, -1.0, 0.0],
        [0.0, 0.0, 0.0],
    ];
    let x = [3e8, 5e7, 4e3, 1.0];
    let gram = Mat::<f64>::from_fn(4, 4, |a, b| {
        let d: f64 = g[a].iter().zip(&g[b]).map(|(p, q)| p * q).sum();
        x[a] * x[b] * d * d
    });
    let null = exact_null_directions(&gram);
    assert_eq!(null.len(), 1, "{null:?}");
    let v = &null[0];
    // x_a·4·v_a + x_b·16·v_b = 0 along (1, 1, 0): v ∝ (1/(4 x_a), −1/(16 x_b)).
    let expect = [1.0 / (4.0 * x[0]), -1.0 / (16.0 * x[1])];
    let ratio = v[0] / v[1];
    assert!(
        (ratio / (expect[0] / expect[1]) - 1.0).abs() < 1e-9,
        "{v:?}"
    );
    assert!(v[2].abs() < 1e-12 && v[3] == 0.0, "{v:?}");
    assert!((v.iter().map(|a| a * a).sum::<f64>() - 1.0).abs() < 1e-12);
}

#[test]
fn a_direction_one_block_sees_is_not_structural() {
    // Block 1 cannot tell p0 from p1; block 2 can (with small numbers),
    // and neither tells p2 from p3.
    let b1 = vec![
        vec![1.0, 2.0],
        vec![1.0, 2.0],
        vec![0.0, 1.0],
        vec![0.0, 1.0],
    ];
    let b2 = vec![
        vec![1e-6, 0.0],
        vec![0.0, 1e-6],
        vec![3e-6, 0.0],
        vec![3e-6, 0.0],
    ];
    let null = structural_directions(&[b1.clone(), b2]);
    assert_eq!(null.len(), 1, "{null:?}");
    let v = &null[0];
    assert!(v[0].abs() < 1e-6 && v[1].abs() < 1e-6, "{v:?}");
    assert!((v[2] + v[3]).abs() < 1e-9 && v[2].abs() > 0.7, "{v:?}");
    // Without the second block p0 and p1 form a second direction.
    assert_eq!(structural_directions(std::slice::from_ref(&b1)).len(), 2);
    // Taking the directions out leaves the rest of the columns alone.
    // Columns that do see it (J v ≠ 0) lose it; the others stay.
    let cols = vec![
        vec![1.0, 0.0],
        vec![0.0, 1.0],
        vec![1.0, 0.0],
        vec![0.0, 0.0],
    ];
    let cut = without_directions(&cols, &null);
    for k in 0..2 {
        assert!(cut[k]
            .iter()
            .zip(&cols[k])
            .all(|(a, b)| (a - b).abs() < 1e-12));
    }
    for line in 0..2 {
        let jv: f64 = cut.iter().zip(v).map(|(c, w)| c[line] * w).sum();
        assert!(jv.abs() < 1e-12, "{cut:?}");
    }
    assert!((cut[2][0] - 0.5).abs() < 1e-6, "{cut:?}");
}

#[test]
fn an_interval_spanning_its_box_is_named_as_not_determined_within_it() {
    // The straight line of the first test, both parameters identifiable at
    // a bar of 0.5; values 1 and 2 in boxes [0.5, 2] and [1, 4].
    let t = [0.0, 1.0, 2.0, 3.0, 4.0];
    let r = [0.06, -0.12, 0.1, -0.08, 0.04];
    let cols = vec![vec![1.0; 5], t.to_vec()];
    let id = analyze(&cols, &r, &names(2), 0.5, &Correlation::independent());
    assert!(id.parameters.iter().all(|p| p.identifiable), "{id:?}");
    let at = [(1.0, (0.5, 2.0)), (2.0, (1.0, 4.0))];
    assert!(id.spanning_their_box(at, None).is_empty());
    // ln 2 / 1.96 = 0.354 is the σ at which 95 % reaches a factor 2 each
    // way: just below it the interval stays inside, just above it spans.
    let edge = 2f64.ln() / Z95;
    let with = |s: f64| {
        let mut id = id.clone();
        id.parameters[1].std_error = Some(s);
        id
    };
    assert!(with(0.99 * edge).spanning_their_box(at, None).is_empty());
    assert_eq!(with(1.01 * edge).spanning_their_box(at, None), vec!["p1"]);
    // The consider error (the fixed parameters' spread) is the stated one.
    let consider = |s: f64| super::super::consider::Consider {
        std_error: vec![0.01, s],
        fixed: Vec::new(),
        critical: f64::NAN,
    };
    let c = consider(1.01 * edge);
    assert_eq!(id.spanning_their_box(at, Some(&c)), vec!["p1"]);
    let c = consider(0.99 * edge);
    assert!(with(1.01 * edge)
        .spanning_their_box(at, Some(&c))
        .is_empty());
    // Reaching one bound only is a one-sided interval, not "undetermined".
    let off = [(1.0, (0.5, 2.0)), (2.0, (1.0, 40.0))];
    assert!(with(1.01 * edge).spanning_their_box(off, None).is_empty());
    // No stated error (a falling cost) is named elsewhere, as is a
    // parameter the design cannot determine.
    let mut hidden = with(10.0);
    hidden.parameters[1].identifiable = false;
    assert!(hidden.spanning_their_box(at, None).is_empty());
    let mut none = with(10.0);
    none.parameters[1].std_error = None;
    assert!(none.spanning_their_box(at, None).is_empty());
    let w = with(10.0).spanning_warning(at, None).unwrap();
    assert!(
        w.starts_with("p1 not determined within their bounds"),
        "{w}"
    );
    assert_eq!(id.spanning_warning(at, None), None);
}
