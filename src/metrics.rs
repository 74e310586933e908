//! Model evaluation criteria of seed section 2.3.4 (eq. 2.62–2.67) and the
//! pairing of modes between a model and a reference.
//!
//! All criteria are returned as fractions: multiply by 100 for the percent
//! values of the seed. Shapes and FRFs are complex vectors over the same DOFs
//! or frequency lines.

use num_complex::Complex64;

fn dot_t(a: &[Complex64], b: &[Complex64]) -> Complex64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn dot_h(a: &[Complex64], b: &[Complex64]) -> Complex64 {
    a.iter().zip(b).map(|(x, y)| x.conj() * y).sum()
}

fn norm_sqr(a: &[Complex64]) -> f64 {
    a.iter().map(Complex64::norm_sqr).sum()
}

/// Modal assurance criterion, eq. 2.62: |ψ₁ᵀψ₂*|² / ((ψ₁ᵀψ₁*)(ψ₂ᵀψ₂*)).
/// Invariant to complex scaling of either shape; 0 when a shape is zero.
pub fn mac(psi1: &[Complex64], psi2: &[Complex64]) -> f64 {
    assert_eq!(
        psi1.len(),
        psi2.len(),
        "MAC needs shapes over the same DOFs"
    );
    let den = norm_sqr(psi1) * norm_sqr(psi2);
    if den == 0.0 {
        return 0.0;
    }
    dot_h(psi2, psi1).norm_sqr() / den
}

/// The MAC matrix: `mac[i][j]` between `a[i]` and `b[j]`.
pub fn mac_matrix(a: &[Vec<Complex64>], b: &[Vec<Complex64>]) -> Vec<Vec<f64>> {
    a.iter()
        .map(|x| b.iter().map(|y| mac(x, y)).collect())
        .collect()
}

/// The continuous-time pole λ = −ζω + jω√(1−ζ²) of a mode with natural
/// frequency `f_hz` and damping ratio `zeta` (< 1).
pub fn pole(f_hz: f64, zeta: f64) -> Complex64 {
    let w = 2.0 * std::f64::consts::PI * f_hz;
    Complex64::new(-zeta * w, w * (1.0 - zeta * zeta).max(0.0).sqrt())
}

/// Extended MAC including the poles, eq. 2.63 (Vacher et al. 2010); better at
/// separating close modes when few DOFs are measured. Poles need Re(λ) ≠ 0.
pub fn macxp(
    psi1: &[Complex64],
    psi2: &[Complex64],
    lambda1: Complex64,
    lambda2: Complex64,
) -> f64 {
    assert_eq!(
        psi1.len(),
        psi2.len(),
        "MACXP needs shapes over the same DOFs"
    );
    let num = dot_h(psi1, psi2).norm() / (lambda1.conj() + lambda2).norm()
        + dot_t(psi1, psi2).norm() / (lambda1 + lambda2).norm();
    let self_term = |psi: &[Complex64], l: Complex64| {
        norm_sqr(psi) / (2.0 * l.re.abs()) + dot_t(psi, psi).norm() / (2.0 * l.norm())
    };
    let den = self_term(psi1, lambda1) * self_term(psi2, lambda2);
    if den == 0.0 || !den.is_finite() {
        return 0.0;
    }
    num * num / den
}

/// Natural frequency difference, eq. 2.64: |ω₁ − ω₂| / min(ω₁, ω₂).
pub fn nfd(f1: f64, f2: f64) -> f64 {
    (f1 - f2).abs() / f1.min(f2)
}

/// Natural damping difference, eq. 2.65: |ξ₁ − ξ₂| / min(ξ₁, ξ₂).
pub fn ndd(zeta1: f64, zeta2: f64) -> f64 {
    (zeta1 - zeta2).abs() / zeta1.min(zeta2)
}

/// Frequency response assurance criterion, eq. 2.66: the MAC of two FRFs
/// over frequency lines. Blind to a common scale factor.
pub fn frac(h1: &[Complex64], h2: &[Complex64]) -> f64 {
    mac(h1, h2)
}

/// Cross signature scale factor, eq. 2.67: 2|h₁ᴴh₂| / (h₁ᴴh₁ + h₂ᴴh₂); unlike
/// FRAC it drops when amplitudes differ.
pub fn csf(h1: &[Complex64], h2: &[Complex64]) -> f64 {
    assert_eq!(h1.len(), h2.len(), "CSF needs FRFs on the same lines");
    let den = norm_sqr(h1) + norm_sqr(h2);
    if den == 0.0 {
        return 0.0;
    }
    2.0 * dot_h(h1, h2).norm() / den
}

/// A reference mode paired with a candidate mode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    pub reference: usize,
    pub candidate: usize,
    pub mac: f64,
}

/// Pair reference and candidate modes one-to-one, maximizing the summed MAC
/// over pairs whose frequencies differ by at most `window` (relative, e.g.
/// 0.2 for ±20 %) and whose MAC is at least `min_mac`. Solved exactly as an
/// assignment problem (Hungarian algorithm), so a mode is never claimed by two
/// partners as greedy MAC pairing can. Pairs are sorted by reference index.
pub fn pair_modes(
    ref_freqs: &[f64],
    ref_shapes: &[Vec<Complex64>],
    cand_freqs: &[f64],
    cand_shapes: &[Vec<Complex64>],
    window: f64,
    min_mac: f64,
) -> Vec<Pair> {
    let macs = mac_matrix(ref_shapes, cand_shapes);
    let allowed =
        |i: usize, j: usize| nfd(ref_freqs[i], cand_freqs[j]) <= window && macs[i][j] >= min_mac;
    // Cost 1 − MAC; forbidden pairs cost more than any feasible assignment.
    let big = 1.0 + ref_freqs.len().max(cand_freqs.len()) as f64;
    let cost: Vec<Vec<f64>> = (0..ref_freqs.len())
        .map(|i| {
            (0..cand_freqs.len())
                .map(|j| if allowed(i, j) { 1.0 - macs[i][j] } else { big })
                .collect()
        })
        .collect();
    let assignment = hungarian(&cost);
    let mut pairs: Vec<Pair> = assignment
        .into_iter()
        .enumerate()
        .filter_map(|(i, j)| {
            j.filter(|&j| allowed(i, j)).map(|j| Pair {
                reference: i,
                candidate: j,
                mac: macs[i][j],
            })
        })
        .collect();
    pairs.sort_by_key(|p| p.reference);
    pairs
}

/// Minimum-cost assignment of rows to columns for a rectangular cost matrix
/// (Kuhn–Munkres with potentials, O(n²m)). Returns the column of each row,
/// `None` for rows left over when there are more rows than columns.
pub fn hungarian(cost: &[Vec<f64>]) -> Vec<Option<usize>> {
    let rows = cost.len();
    let cols = cost.first().map_or(0, Vec::len);
    if rows == 0 || cols == 0 {
        return vec![None; rows];
    }
    // Work on the orientation with n ≤ m.
    let transposed = rows > cols;
    let (n, m) = if transposed {
        (cols, rows)
    } else {
        (rows, cols)
    };
    let c = |i: usize, j: usize| if transposed { cost[j][i] } else { cost[i][j] };
    let inf = f64::INFINITY;
    let (mut u, mut v) = (vec![0.0; n + 1], vec![0.0; m + 1]);
    let mut p = vec![0usize; m + 1];
    let mut way = vec![0usize; m + 1];
    for i in 1..=n {
        p[0] = i;
        let mut j0 = 0;
        let mut minv = vec![inf; m + 1];
        let mut used = vec![false; m + 1];
        loop {
            used[j0] = true;
            let i0 = p[j0];
            let mut delta = inf;
            let mut j1 = 0;
            for j in 1..=m {
                if !used[j] {
                    let cur = c(i0 - 1, j - 1) - u[i0] - v[j];
                    if cur < minv[j] {
                        minv[j] = cur;
                        way[j] = j0;
                    }
                    if minv[j] < delta {
                        delta = minv[j];
                        j1 = j;
                    }
                }
            }
            for j in 0..=m {
                if used[j] {
                    u[p[j]] += delta;
                    v[j] -= delta;
                } else {
                    minv[j] -= delta;
                }
            }
            j0 = j1;
            if p[j0] == 0 {
                break;
            }
        }
        loop {
            let j1 = way[j0];
            p[j0] = p[j1];
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    let mut out = vec![None; rows];
    for (j, &row) in p.iter().enumerate().skip(1) {
        if row != 0 {
            let (r, col) = if transposed {
                (j - 1, row - 1)
            } else {
                (row - 1, j - 1)
            };
            out[r] = Some(col);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(re: f64, im: f64) -> Complex64 {
        Complex64::new(re, im)
    }

    #[test]
    fn mac_is_one_for_scaled_shapes_symmetric_and_zero_for_orthogonal() {
        let a = vec![c(1.0, 0.0), c(0.5, 0.2), c(-0.3, 0.0)];
        let scaled: Vec<_> = a.iter().map(|x| x * c(-2.0, 3.0)).collect();
        assert!((mac(&a, &scaled) - 1.0).abs() < 1e-14);
        let b = vec![c(0.2, 0.1), c(1.0, 0.0), c(0.4, -0.3)];
        assert_eq!(mac(&a, &b), mac(&b, &a));
        assert!(mac(&a, &b) < 1.0);
        assert_eq!(
            mac(&[c(1.0, 0.0), c(0.0, 0.0)], &[c(0.0, 0.0), c(1.0, 0.0)]),
            0.0
        );
        // Known value: real shapes [1, 1] and [1, 0] give cos² 45° = 0.5.
        assert!(
            (mac(&[c(1.0, 0.0), c(1.0, 0.0)], &[c(1.0, 0.0), c(0.0, 0.0)]) - 0.5).abs() < 1e-15
        );
    }

    #[test]
    fn frac_ignores_scale_csf_does_not() {
        let h: Vec<_> = (0..50)
            .map(|k| c(1.0 / (1.0 + k as f64), -0.1 * k as f64))
            .collect();
        assert!((frac(&h, &h) - 1.0).abs() < 1e-14);
        assert!((csf(&h, &h) - 1.0).abs() < 1e-14);
        let double: Vec<_> = h.iter().map(|x| x * 2.0).collect();
        assert!((frac(&h, &double) - 1.0).abs() < 1e-14);
        // CSF of h and 2h: 2·2‖h‖² / (‖h‖² + 4‖h‖²) = 0.8.
        assert!((csf(&h, &double) - 0.8).abs() < 1e-14);
    }

    #[test]
    fn macxp_is_one_for_identical_modes_and_separates_poles() {
        let psi = vec![c(1.0, 0.0), c(0.6, 0.0), c(-0.2, 0.0)];
        let l = pole(50.0, 0.02);
        assert!((macxp(&psi, &psi, l, l) - 1.0).abs() < 1e-12);
        // Same shape, different pole: MACXP drops while MAC stays 1.
        let far = pole(80.0, 0.02);
        assert!(macxp(&psi, &psi, l, far) < 0.5);
    }

    #[test]
    fn nfd_and_ndd_known_values() {
        assert!((nfd(100.0, 110.0) - 0.1).abs() < 1e-15);
        assert_eq!(nfd(110.0, 100.0), nfd(100.0, 110.0));
        assert!((ndd(0.01, 0.015) - 0.5).abs() < 1e-15);
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

    #[test]
    fn pairing_respects_the_frequency_window_and_mac() {
        let s = |v: [f64; 2]| vec![c(v[0], 0.0), c(v[1], 0.0)];
        let refs = [s([1.0, 0.0]), s([0.0, 1.0])];
        let cands = [s([0.0, 1.0]), s([1.0, 0.05])];
        let pairs = pair_modes(&[10.0, 20.0], &refs, &[21.0, 10.5], &cands, 0.1, 0.5);
        assert_eq!(pairs.len(), 2);
        assert_eq!((pairs[0].reference, pairs[0].candidate), (0, 1));
        assert_eq!((pairs[1].reference, pairs[1].candidate), (1, 0));
        // Outside the window: unpaired.
        let none = pair_modes(&[10.0], &refs[..1], &[15.0], &cands[1..], 0.1, 0.5);
        assert!(none.is_empty());
    }
}
