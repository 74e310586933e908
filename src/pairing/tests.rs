//! Known answers of the pairing: the assignment itself against brute force,
//! and the cases measured data produce — missing modes, shifted numbering,
//! a spurious mode, a close neighbour that looks alike (cross-pair bait).

use super::*;

fn c(re: f64) -> Complex64 {
    Complex64::new(re, 0.0)
}

fn shape(v: &[f64]) -> Vec<Complex64> {
    v.iter().map(|&x| c(x)).collect()
}

/// Five orthogonal-ish shapes on six DOFs and their frequencies.
fn truth() -> (Vec<f64>, Vec<Vec<Complex64>>) {
    let f = vec![20.0, 35.0, 51.0, 52.5, 80.0];
    let s = vec![
        shape(&[1.0, 1.0, 1.0, 1.0, 1.0, 1.0]),
        shape(&[1.0, 0.6, 0.2, -0.2, -0.6, -1.0]),
        shape(&[1.0, -0.2, -1.0, -1.0, -0.2, 1.0]),
        // Close to mode 3 in frequency and, at these sensors, alike in shape.
        shape(&[0.9, 0.1, -1.0, -0.8, -0.5, 1.0]),
        shape(&[1.0, -1.0, 1.0, -1.0, 1.0, -1.0]),
    ];
    (f, s)
}

fn pairs_of(p: &[Pair]) -> Vec<(usize, usize)> {
    p.iter().map(|p| (p.reference, p.candidate)).collect()
}

#[test]
fn identical_sets_pair_one_to_one_with_zero_cost() {
    let (f, s) = truth();
    let p = pair_modes(&f, &s, &f, &s, &Pairing::default());
    assert_eq!(pairs_of(&p), (0..5).map(|k| (k, k)).collect::<Vec<_>>());
    assert!(p
        .iter()
        .all(|p| p.cost.abs() < 1e-12 && (p.mac - 1.0).abs() < 1e-12));
}

#[test]
fn missing_modes_and_shifted_numbering_pair_by_physics() {
    // The estimate lost modes 2 and 4: its numbering shifts (its mode 2 is
    // the truth's mode 3), and the pairing must follow the physics.
    let (f, s) = truth();
    let keep = [0, 2, 4];
    let ef: Vec<f64> = keep.iter().map(|&k| f[k] * 1.004).collect();
    let es: Vec<_> = keep.iter().map(|&k| s[k].clone()).collect();
    let p = pair_modes(&f, &s, &ef, &es, &Pairing::default());
    assert_eq!(pairs_of(&p), [(0, 0), (2, 1), (4, 2)]);
    // Seen from the estimate, every one of its modes finds its truth.
    let q = pair_modes(&ef, &es, &f, &s, &Pairing::default());
    assert_eq!(pairs_of(&q), [(0, 0), (1, 2), (2, 4)]);
}

#[test]
fn a_spurious_mode_stays_unpaired() {
    let (f, s) = truth();
    let mut ef = f.clone();
    let mut es = s.clone();
    // A noise mode at 65 Hz with a shape unlike any true one, inserted in
    // frequency order (it renumbers the modes above it).
    ef.insert(4, 65.0);
    es.insert(4, shape(&[0.3, 0.9, -0.7, 0.2, 0.1, -0.4]));
    let p = pair_modes(&f, &s, &ef, &es, &Pairing::within(0.1));
    assert_eq!(pairs_of(&p), [(0, 0), (1, 1), (2, 2), (3, 3), (4, 5)]);
}

#[test]
fn a_close_look_alike_neighbour_is_not_cross_paired() {
    // Candidate modes 3 and 4 carry each other's frequencies' neighbours:
    // the estimate of truth mode 3 (51 Hz) has a shape that at these six
    // DOFs matches truth mode 4 slightly better than its own. MAC alone
    // cross-pairs; the frequency term keeps each with its own.
    let (f, s) = truth();
    let blend = |a: &[Complex64], b: &[Complex64], w: f64| -> Vec<Complex64> {
        a.iter()
            .zip(b)
            .map(|(x, y)| x * (1.0 - w) + y * w)
            .collect()
    };
    let mut es = s.clone();
    es[2] = blend(&s[2], &s[3], 0.55);
    es[3] = blend(&s[3], &s[2], 0.55);
    let ef = vec![20.0, 35.0, 51.1, 52.4, 80.0];
    let macs = mac_matrix(&s, &es);
    assert!(
        macs[2][3] > macs[2][2] && macs[3][2] > macs[3][3],
        "{macs:?}"
    );
    let mac_only = Pairing {
        frequency_scale: 1e12,
        ..Pairing::default()
    };
    let crossed = pair_modes(&f, &s, &ef, &es, &mac_only);
    assert_eq!(pairs_of(&crossed)[2..4], [(2, 3), (3, 2)]);
    let p = pair_modes(&f, &s, &ef, &es, &Pairing::default());
    assert_eq!(pairs_of(&p)[2..4], [(2, 2), (3, 3)]);
    // Its margin is finite and small; modes with no rival have none.
    let costs = cost_matrix(&f, &ef, &macs, &Pairing::default());
    let m = margins(&costs, &p);
    assert!(m[2] < 1.0 && m[2] == m[3], "{m:?}");
    assert!(m[0].is_infinite() && m[4].is_infinite(), "{m:?}");
    // With the two estimates at one frequency, nothing but the shapes
    // decides: the pair is flagged ambiguous.
    let ef = vec![20.0, 35.0, 51.7, 51.75, 80.0];
    let p = pair_modes(&f, &s, &ef, &es, &Pairing::default());
    let costs = cost_matrix(&f, &ef, &macs, &Pairing::default());
    let m = margins(&costs, &p);
    assert!(m[2] < Pairing::default().ambiguity, "{m:?}");
}

#[test]
fn window_and_mac_floor_forbid_pairs_and_unpaired_rows_are_left_out() {
    let (f, s) = truth();
    let far = [f[0] * 1.5];
    let p = pair_modes(&f[..1], &s[..1], &far, &s[..1], &Pairing::within(0.2));
    assert!(p.is_empty());
    let floor = Pairing {
        min_mac: 0.99,
        ..Pairing::default()
    };
    let p = pair_modes(&f[2..3], &s[2..3], &f[3..4], &s[3..4], &floor);
    assert!(p.is_empty(), "{p:?}");
    // More reference than candidate modes: the best-matching one is kept.
    let p = pair_modes(&f, &s, &f[1..2], &s[1..2], &Pairing::default());
    assert_eq!(pairs_of(&p), [(1, 0)]);
    // An allowed pair is never given up for a lower total cost.
    assert!(Pairing::default().check().is_ok());
    assert!(Pairing::within(0.0).check().is_err());
}

#[test]
fn hungarian_finds_the_optimum_where_greedy_fails() {
    // Greedy on row 0 would take column 0 (cost 1), forcing row 1 to cost 10.
    let cost = vec![vec![1.0, 2.0], vec![1.5, 10.0]];
    assert_eq!(hungarian(&cost), vec![Some(1), Some(0)]);
    // Rectangular both ways.
    let wide = vec![vec![5.0, 1.0, 3.0]];
    assert_eq!(hungarian(&wide), vec![Some(1)]);
    let tall = vec![vec![5.0], vec![1.0], vec![3.0]];
    assert_eq!(hungarian(&tall), vec![None, Some(0), None]);
    // Brute force over all permutations of a 4×4 seeded matrix.
    let m: Vec<Vec<f64>> = (0..4)
        .map(|i| (0..4).map(|j| ((i * 7 + j * 13) % 11) as f64).collect())
        .collect();
    let got: f64 = hungarian(&m)
        .iter()
        .enumerate()
        .map(|(i, j)| m[i][j.unwrap()])
        .sum();
    let mut best = f64::MAX;
    let mut perm = [0, 1, 2, 3];
    permute(&mut perm, 0, &mut |p| {
        best = best.min((0..4).map(|i| m[i][p[i]]).sum())
    });
    assert_eq!(got, best);
}

fn permute(p: &mut [usize; 4], k: usize, f: &mut dyn FnMut(&[usize; 4])) {
    if k == p.len() {
        f(p);
        return;
    }
    for i in k..p.len() {
        p.swap(k, i);
        permute(p, k + 1, f);
        p.swap(k, i);
    }
}
