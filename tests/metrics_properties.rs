//! Property tests of the model evaluation criteria (eq. 2.62–2.67) on random
//! shapes, FRFs and cost matrices, plus small cases computed by hand.

use modalflow::metrics::{csf, frac, mac, macxp, ndd, nfd, pole};
use modalflow::pairing::{hungarian, pair_modes, Pairing};
use num_complex::Complex64;
use proptest::prelude::*;

fn c(re: f64, im: f64) -> Complex64 {
    Complex64::new(re, im)
}

/// Complex vectors of 1–12 entries, not all (near) zero.
fn vector() -> impl Strategy<Value = Vec<Complex64>> {
    prop::collection::vec((-10.0..10.0f64, -10.0..10.0f64), 1..12)
        .prop_map(|v| v.into_iter().map(|(a, b)| c(a, b)).collect::<Vec<_>>())
        .prop_filter("non-zero", |v| {
            v.iter().map(|x| x.norm_sqr()).sum::<f64>() > 1e-6
        })
}

fn pair() -> impl Strategy<Value = (Vec<Complex64>, Vec<Complex64>)> {
    (1..12usize).prop_flat_map(|n| {
        let v = prop::collection::vec((-10.0..10.0f64, -10.0..10.0f64), n)
            .prop_map(|v| v.into_iter().map(|(a, b)| c(a, b)).collect::<Vec<_>>());
        (v.clone(), v)
    })
}

proptest! {
    #[test]
    fn mac_of_a_shape_and_any_multiple_is_one(v in vector(), re in 0.1..5.0f64, im in -5.0..5.0f64) {
        let w: Vec<Complex64> = v.iter().map(|x| x * c(re, im)).collect();
        prop_assert!((mac(&v, &w) - 1.0).abs() < 1e-12);
        prop_assert!((frac(&v, &v) - 1.0).abs() < 1e-12);
        prop_assert!((csf(&v, &v) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn mac_frac_csf_are_symmetric_and_bounded((a, b) in pair()) {
        for f in [mac, frac, csf] {
            let (x, y) = (f(&a, &b), f(&b, &a));
            prop_assert!((x - y).abs() < 1e-12);
            prop_assert!((-1e-12..=1.0 + 1e-12).contains(&x), "{x}");
        }
        // CSF ≤ FRAC: amplitude differences only lower it (Cauchy–Schwarz + AM–GM).
        prop_assert!(csf(&a, &b) <= frac(&a, &b).sqrt() + 1e-12);
    }

    #[test]
    fn csf_of_a_scaled_frf_is_2s_over_1_plus_s2(v in vector(), s in 0.1..10.0f64) {
        let w: Vec<Complex64> = v.iter().map(|x| x * s).collect();
        prop_assert!((csf(&v, &w) - 2.0 * s / (1.0 + s * s)).abs() < 1e-12);
        prop_assert!((frac(&v, &w) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn nfd_ndd_vanish_for_equal_values_and_are_symmetric(a in 0.1..1e4f64, b in 0.1..1e4f64) {
        prop_assert_eq!(nfd(a, a), 0.0);
        prop_assert_eq!(ndd(a, a), 0.0);
        prop_assert_eq!(nfd(a, b), nfd(b, a));
        prop_assert!(nfd(a, b) >= 0.0);
    }

    #[test]
    fn macxp_is_one_for_identical_modes(v in vector(), f in 1.0..500.0f64, z in 0.001..0.2f64) {
        let l = pole(f, z);
        prop_assert!((macxp(&v, &v, l, l) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn hungarian_matches_brute_force(cost in prop::collection::vec(prop::collection::vec(0.0..1.0f64, 4), 4)) {
        let a = hungarian(&cost);
        let total: f64 = a.iter().enumerate().map(|(i, j)| cost[i][j.expect("square")]).sum();
        let mut best = f64::INFINITY;
        let mut perm = [0usize, 1, 2, 3];
        permutations(&mut perm, 0, &mut |p| {
            best = best.min((0..4).map(|i| cost[i][p[i]]).sum());
        });
        prop_assert!((total - best).abs() < 1e-12, "{total} vs {best}");
    }
}

fn permutations(p: &mut [usize; 4], k: usize, visit: &mut dyn FnMut(&[usize; 4])) {
    if k == p.len() {
        visit(p);
        return;
    }
    for i in k..p.len() {
        p.swap(k, i);
        permutations(p, k + 1, visit);
        p.swap(k, i);
    }
}

#[test]
fn hand_computed_cases() {
    let re = |v: &[f64]| v.iter().map(|&x| c(x, 0.0)).collect::<Vec<_>>();
    // |[1,0]·[1,1]|² / (1 · 2) = 1/2.
    assert!((mac(&re(&[1.0, 0.0]), &re(&[1.0, 1.0])) - 0.5).abs() < 1e-15);
    // Orthogonal shapes.
    assert_eq!(mac(&re(&[1.0, 1.0]), &re(&[1.0, -1.0])), 0.0);
    // [1, i] against [1, 1]: |1 − i|² / (2 · 2) = 2/4.
    assert!((mac(&[c(1.0, 0.0), c(0.0, 1.0)], &re(&[1.0, 1.0])) - 0.5).abs() < 1e-15);
    // CSF of [1, 2] and [2, 4]: 2·10 / (5 + 20) = 0.8.
    assert!((csf(&re(&[1.0, 2.0]), &re(&[2.0, 4.0])) - 0.8).abs() < 1e-15);
    // NFD 100 vs 110 Hz: 10/100; NDD 1 % vs 2 %: 0.01/0.01.
    assert!((nfd(100.0, 110.0) - 0.1).abs() < 1e-15);
    assert!((ndd(0.01, 0.02) - 1.0).abs() < 1e-12);
    // Pairing: two close modes swapped in frequency are paired by shape.
    let pairs = pair_modes(
        &[10.0, 11.0],
        &[re(&[1.0, 0.0]), re(&[0.0, 1.0])],
        &[10.2, 10.9],
        &[re(&[0.0, 1.0]), re(&[1.0, 0.1])],
        &Pairing {
            window: 0.2,
            min_mac: 0.3,
            ..Pairing::default()
        },
    );
    assert_eq!(pairs.len(), 2);
    assert_eq!((pairs[0].candidate, pairs[1].candidate), (1, 0));
    // MAC([1, 0], [1, 0.1]) = 1 / 1.01.
    assert!((pairs[0].mac - 1.0 / 1.01).abs() < 1e-12);
}
