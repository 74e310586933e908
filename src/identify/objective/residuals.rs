//! The guided strategy's smooth views of the objective (PUB3, module docs of
//! [`super`]): the least-squares residual vector of the joint refinement and
//! the per-mode criterion of a subproblem. Both leave damping out (frequencies
//! and shapes do not depend on it) and neither has J's penalty plateau.

use super::ModalObjective;
use crate::metrics::{mac, nfd};
use num_complex::Complex64;

impl ModalObjective {
    /// The modal residual vector of the joint refinement and the mean MAC,
    /// or `None` when the model cannot be solved. Per position and kept
    /// reference mode r, paired with model mode m as in J:
    ///
    /// - √w_nfd (f_m − f_r)/f_r (the signed NFD, eq. 2.64);
    /// - √w_mac (α φ̂_m − ψ̂_r), real and imaginary parts per shared DOF, with
    ///   unit-normalized shapes and the unit phase factor α that brings them
    ///   closest; ‖α φ̂ − ψ̂‖² = 2 (1 − √MAC) ≈ 1 − MAC near a match (eq. 2.62).
    ///
    /// An unpaired mode gives the constant residuals √w_nfd·window and −ψ̂_r.
    /// ½‖r‖² ≈ ½ Σ [w_mac (1 − MAC) + w_nfd NFD²]: the least-squares form of
    /// J's MAC and NFD terms (damping plays no part, see the module docs).
    pub fn residuals(&self, x: &[f64]) -> Option<(Vec<f64>, f64)> {
        let models = self.model_modes(x).ok()?;
        let pairing = self.pairing(&models);
        let (wf, ws) = (self.weights.nfd.sqrt(), self.weights.mac.sqrt());
        let mut out = Vec::new();
        let (mut mac_sum, mut count) = (0.0, 0usize);
        for ((r, m), pairs) in self.references.iter().zip(&models).zip(&pairing) {
            for (k, c) in pairs.iter().enumerate() {
                let psi = &r.shapes[k];
                let psi_norm = psi.iter().map(|v| v.norm_sqr()).sum::<f64>().sqrt();
                count += 1;
                let Some(c) = c else {
                    out.push(wf * self.window);
                    for v in psi {
                        out.extend([-ws * v.re / psi_norm, -ws * v.im / psi_norm]);
                    }
                    continue;
                };
                let mode = &m.modes[*c];
                mac_sum += mac(psi, &mode.shape);
                out.push(wf * (mode.frequency_hz - r.frequencies[k]) / r.frequencies[k]);
                let phi_norm = mode.shape.iter().map(|v| v.norm_sqr()).sum::<f64>().sqrt();
                let dot: Complex64 = mode.shape.iter().zip(psi).map(|(p, q)| p.conj() * q).sum();
                let alpha = if dot.norm() > 0.0 {
                    dot / dot.norm()
                } else {
                    Complex64::new(1.0, 0.0)
                };
                for (p, q) in mode.shape.iter().zip(psi) {
                    let d = alpha * p / phi_norm - q / psi_norm;
                    out.extend([ws * d.re, ws * d.im]);
                }
            }
        }
        out.iter()
            .all(|v| v.is_finite())
            .then(|| (out, mac_sum / count.max(1) as f64))
    }

    /// The criterion of one mode-shape reference (a PUB3 subproblem): reference
    /// mode `r` of slot `p` against its best-matching model mode,
    /// min over model modes m of w_mac (1 − MAC) + w_nfd h_δ(NFD). Taking the
    /// best match instead of the one-to-one pairing of J keeps the criterion
    /// continuous (no plateau when the pairing loses the mode); where the
    /// pairing is unambiguous both agree. Evaluates position `p` only.
    pub fn mode_cost(&self, p: usize, r: usize, x: &[f64], delta: f64) -> f64 {
        let Ok(model) = self.model_modes_at(p, x) else {
            return f64::INFINITY;
        };
        let w = self.weights;
        let reference = &self.references[p];
        let (f, shape) = (reference.frequencies[r], &reference.shapes[r]);
        let best = model
            .modes
            .iter()
            .map(|m| {
                w.mac * (1.0 - mac(shape, &m.shape)) + w.nfd * huber(nfd(f, m.frequency_hz), delta)
            })
            .fold(f64::INFINITY, f64::min);
        if best.is_finite() {
            best
        } else {
            f64::INFINITY
        }
    }
}

/// The pseudo-Huber function h_δ(t) = √(t² + δ²) − δ: smooth, ≈ t²/2δ for
/// |t| ≪ δ and ≈ |t| − δ for |t| ≫ δ (δ = 0 gives |t|).
fn huber(t: f64, delta: f64) -> f64 {
    (t * t + delta * delta).sqrt() - delta
}

#[cfg(test)]
mod tests {
    use crate::identify::black_box::tests::{objective, truth};

    #[test]
    fn residuals_vanish_at_the_truth_and_match_mac_and_nfd_near_it() {
        let o = objective();
        let t = truth();
        let (r, mac) = o.residuals(&t).unwrap();
        // 3 modes × (1 frequency + 2 × 3 shape components).
        assert_eq!(r.len(), 21);
        assert!(r.iter().all(|v| v.abs() < 1e-12), "{r:?}");
        assert!((mac - 1.0).abs() < 1e-12);
        // Near the truth ½‖r‖² ≈ ½ Σ (1 − MAC) + NFD² (eq. 2.62, 2.64).
        let mut x = t.clone();
        x[1] *= 1.002;
        let (r, _) = o.residuals(&x).unwrap();
        let half: f64 = 0.5 * r.iter().map(|v| v * v).sum::<f64>();
        let all = o.matches(&x).unwrap();
        let expect: f64 = all[0]
            .iter()
            .enumerate()
            .map(|(k, m)| {
                let m = m.unwrap();
                let nfd =
                    (m.frequency_hz - o.reference_frequency(0, k)) / o.reference_frequency(0, k);
                0.5 * ((1.0 - m.mac) + nfd * nfd)
            })
            .sum();
        assert!(
            half > 0.0 && (half / expect - 1.0).abs() < 1e-2,
            "{half} vs {expect}"
        );
        let s = o.summary(&x).unwrap();
        assert_eq!((s.reference_modes, s.paired), (3, 3));
        assert!(s.mean_mac < 1.0 && s.mean_nfd > 0.0);
    }

    #[test]
    fn the_mode_criterion_uses_the_best_matching_mode() {
        let o = objective();
        let t = truth();
        assert!(o.mode_cost(0, 1, &t, 1e-3).abs() < 1e-12);
        // Far off, the mode is still compared with some model mode: finite,
        // positive, and no larger than the worst case 1 + h(NFD).
        let mut x = t.clone();
        x[0] *= 3.5;
        let c = o.mode_cost(0, 0, &x, 1e-3);
        assert!(c.is_finite() && c > 1e-3, "{c}");
    }
}
