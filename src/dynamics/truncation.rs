//! The FRF an impact test measures when a mode outlasts its record.
//!
//! An impact test's H1 estimate is the DFT of the response over one record
//! of T = 1/Δf seconds, divided by the force's. The hit comes t₀ after the
//! record starts (the pre-trigger), so the response is cut T − t₀ after it.
//! Without an exponential window a lightly damped mode has not decayed by
//! then (e^{−ζω_r T}: 0.39 for ζ = 0.07 % at 54 Hz and T = 4 s), and the
//! estimate is the FRF of the *truncated* impulse response: each pole term
//! of the quantity's impulse response, c·e^{λt} on [0, T − t₀], transforms to
//!
//! c (1 − e^{(λ − jω)(T − t₀)}) / (jω − λ)   instead of   c / (jω − λ)
//!
//! (the force's factor e^{−jωt₀} cancels in H1; the sampled DFT gives the
//! same ratio). Near the mode e^{−jω(T − t₀)} ≈ e^{−jω_r(T − t₀)}, but over a
//! band the pre-trigger turns the correction's phase by (ω − ω_r)t₀: 3 rad
//! at 50 Hz from the mode for t₀ = 10 ms, so it must be known. For a viscous mode with
//! pole λ, conjugate λ̄ and receptance φ_j φ_k/((jω − λ)(jω − λ̄)) =
//! φ_j φ_k/(λ − λ̄) · [1/(jω − λ) − 1/(jω − λ̄)], the quantity's impulse
//! response (displacement, velocity, acceleration: n = 0, 1, 2 derivatives)
//! has the pole terms φ_j φ_k λⁿ/(λ − λ̄) and −φ_j φ_k λ̄ⁿ/(λ − λ̄), so the
//! truncation adds to the mode's term
//!
//! −φ_j φ_k/(λ − λ̄) · [λⁿ e^{(λ−jω)T'}/(jω − λ) − λ̄ⁿ e^{(λ̄−jω)T'}/(jω − λ̄)],
//! T' = T − t₀.
//!
//! That is what the simulated impact test of `synthesize` measures (viscous
//! impulse responses with the pole of [`super::solve::mode_pole`], no
//! exponential window unless given), and what a real test without one does.
//! On the vertical mill's simulated impact tests it is the whole misfit of
//! the truth at its 0.07 % modes (up to 60σ at a line; 1.2σ RMS once
//! modelled). A mode that decays within the record contributes nothing
//! (e^{−ζω_r T} < e^{−40} is skipped).

use num_complex::Complex64;

/// Decay exponent ζω_r·T beyond which a mode's truncation is negligible.
const DECAYED: f64 = 40.0;

/// The truncation of every mode of a modal solution over one record.
pub struct Truncation {
    /// T' = T − t₀: how long after the hit the record ends, s.
    after_hit_s: f64,
    /// The modes that outlast the record enough to matter.
    active: Vec<Cut>,
}

/// One mode's truncation in partial fractions over its pole pair.
///
/// With A = λⁿ e^{λT'}, the bracket of the module docs over the common
/// denominator D(ω) = (jω − λ)(jω − λ̄) = |λ|² − ω² − j 2 Re(λ) ω is
/// e^{−jωT'} (A (jω − λ̄) − Ā (jω − λ)) / D, and since λ − λ̄ = 2j Im λ the
/// term per unit φ_j φ_k is
///
/// −e^{−jωT'} (jω α − β) / D,  α = Im A / Im λ,  β = Im(A λ̄) / Im λ,
///
/// with α and β real: one complex division per mode and line, and one
/// exponential per line for all modes (the direct form costs two complex
/// exponentials and powers per mode and line).
struct Cut {
    /// The mode's index in the modal solution.
    mode: usize,
    /// |λ|², rad²/s².
    modulus_sq: f64,
    /// −2 Re λ = 2ζω_r, rad/s.
    decay2: f64,
    /// α = Im A / Im λ, (rad/s)ⁿ⁻¹: the numerator's factor of jω.
    alpha: f64,
    /// β = Im(A λ̄) / Im λ, (rad/s)ⁿ: the numerator's constant.
    beta: f64,
}

impl Truncation {
    /// For modes with poles `poles` (λ_r, rad/s; `None`: no term, e.g. a
    /// rigid-body mode), a record that ends `after_hit_s` seconds after the
    /// hit (T − t₀) and a quantity with `power` time derivatives of
    /// displacement.
    pub fn new(poles: &[Option<Complex64>], after_hit_s: f64, power: i32) -> Truncation {
        let active = poles
            .iter()
            .enumerate()
            .filter_map(|(r, p)| {
                p.filter(|l| l.im > 0.0 && -l.re * after_hit_s < DECAYED)
                    .map(|l| {
                        let a = l.powi(power) * (l * after_hit_s).exp();
                        Cut {
                            mode: r,
                            modulus_sq: l.norm_sqr(),
                            decay2: -2.0 * l.re,
                            alpha: a.im / l.im,
                            beta: (a * l.conj()).im / l.im,
                        }
                    })
            })
            .collect();
        Truncation {
            after_hit_s,
            active,
        }
    }

    /// Whether no mode outlasts the record: every correction is zero.
    pub fn is_negligible(&self) -> bool {
        self.active.is_empty()
    }

    /// The modes that outlast the record, by index: only their terms are
    /// not zero.
    pub fn modes(&self) -> impl Iterator<Item = usize> + '_ {
        self.active.iter().map(|c| c.mode)
    }

    /// The truncation's term at ω (rad/s) per unit φ_j φ_k, in the
    /// quantity's units (module docs), of each of [`Self::modes`] in turn,
    /// into `out`.
    pub fn terms(&self, w: f64, out: &mut [Complex64]) {
        let (sin, cos) = (w * self.after_hit_s).sin_cos();
        let minus_e = Complex64::new(-cos, sin); // −e^{−jωT'}
        for (o, c) in out.iter_mut().zip(&self.active) {
            let den = Complex64::new(c.modulus_sq - w * w, c.decay2 * w);
            *o = minus_e * Complex64::new(-c.beta, w * c.alpha) / den;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The DFT over one record of the sampled impulse response of a mode
    /// (receptance h(t) = e^{−σt} sin(ω_d t)/ω_d, or its second derivative
    /// for accelerance), at the record's DFT lines, against the modal term
    /// plus [`Truncation::terms`].
    #[test]
    fn matches_the_dft_of_the_truncated_impulse_response() {
        let (f_r, zeta, record) = (54.0, 0.0007, 4.0);
        let w_r = 2.0 * std::f64::consts::PI * f_r;
        let l = Complex64::new(-zeta * w_r, w_r * (1.0 - zeta * zeta).sqrt());
        let n = 1 << 17; // 32.8 kHz: the DFT's sum is the integral to 1e-4
        let dt = record / n as f64;
        for power in [0, 2] {
            let trunc = Truncation::new(&[Some(l)], record, power);
            assert!(!trunc.is_negligible());
            // Impulse response of the quantity: Σ c·e^{λt} over both poles.
            let c = |x: Complex64| x.powi(power) / (l - l.conj()) * if x == l { 1.0 } else { -1.0 };
            for k in [212, 216, 217, 220] {
                let w = 2.0 * std::f64::consts::PI * k as f64 / record;
                // Trapezoid sum of h(t) e^{−jωt} over [0, T) (h(0) = 0 for
                // receptance; the acceleration's δ at t = 0 is no pole term).
                let dft: Complex64 = (0..n)
                    .map(|m| {
                        let t = m as f64 * dt;
                        let h = c(l) * (l * t).exp() + c(l.conj()) * (l.conj() * t).exp();
                        let weight = if m == 0 { 0.5 } else { 1.0 };
                        h * Complex64::new(0.0, -w * t).exp() * (weight * dt)
                    })
                    .sum();
                let s = Complex64::new(0.0, w);
                let full = c(l) / (s - l) + c(l.conj()) / (s - l.conj());
                let mut t = [Complex64::new(0.0, 0.0)];
                trunc.terms(w, &mut t);
                let want = full + t[0];
                assert!(
                    (dft - want).norm() <= 2e-3 * full.norm(),
                    "power {power}, line {k}: {dft} vs {want} (untruncated {full})"
                );
                // The truncation is no small correction here.
                assert!(t[0].norm() > 0.1 * full.norm(), "line {k}: {}", t[0]);
            }
        }
    }

    /// The partial-fraction form of [`Truncation::terms`] against the
    /// module docs' direct form, per pole, over a band around two modes.
    #[test]
    fn equals_the_direct_form_of_each_pole_term() {
        let poles = [
            Complex64::new(-0.0007 * 339.0, 339.0),
            Complex64::new(-0.003 * 1200.0, 1200.0 * (1.0f64 - 9e-6).sqrt()),
        ];
        let after = 3.9895;
        for power in [0, 1, 2] {
            let trunc = Truncation::new(&[Some(poles[0]), None, Some(poles[1])], after, power);
            assert_eq!(trunc.modes().collect::<Vec<_>>(), vec![0, 2]);
            for w in [10.0, 300.0, 338.7, 339.0, 1150.0, 1200.0, 5000.0] {
                let mut got = [Complex64::new(0.0, 0.0); 2];
                trunc.terms(w, &mut got);
                let s = Complex64::new(0.0, w);
                for (g, l) in got.iter().zip(poles) {
                    let lc = l.conj();
                    let term = |x: Complex64| x.powi(power) * ((x - s) * after).exp() / (s - x);
                    let want = -(term(l) - term(lc)) / (l - lc);
                    assert!(
                        (g - want).norm() <= 1e-10 * want.norm(),
                        "power {power}, ω {w}: {g} vs {want}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_mode_that_decays_within_the_record_is_skipped() {
        let l = Complex64::new(-0.02 * 300.0, 300.0); // ζ 2 %, ζω·T = 24 at T = 4 s
        assert!(!Truncation::new(&[Some(l)], 4.0, 0).is_negligible());
        assert!(Truncation::new(&[Some(l)], 8.0, 0).is_negligible()); // 48
        assert!(Truncation::new(&[None], 4.0, 2).is_negligible());
    }
}
