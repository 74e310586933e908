//! Model evaluation criteria of seed section 2.3.4 (eq. 2.62–2.67); which
//! modes to compare is [`crate::pairing`]'s job.
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
}
