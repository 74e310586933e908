//! The least-squares view of the objective (the guided strategy's
//! refinement) and the per-mode criterion of a PUB3 subproblem. Both leave
//! damping out (frequencies and shapes do not depend on it) and neither has
//! J's penalty plateau.

use super::{mean_mac, ModalObjective, ModeSet};
use crate::metrics::{mac, nfd};
use num_complex::Complex64;

/// The residuals at one point.
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluation {
    /// The residual vector of the modes of the requested set.
    pub residuals: Vec<f64>,
    /// Per mode of the set, (ζ_m − ζ_r)/(ζ_r σ_ζ) (an unpaired mode: 1/σ_ζ).
    pub damping: Vec<f64>,
    /// ½‖r‖² over all usable modes (the same criterion whatever the set,
    /// so stages of a continuation can be compared).
    pub cost_usable: f64,
    /// Mean MAC over all usable modes whose shapes are compared, an
    /// unpaired mode counting 0.
    pub mean_mac: f64,
    /// The robust cost over all usable modes ([`ModalObjective::robust`]).
    pub robust_usable: f64,
    /// Number of residuals over all usable modes.
    pub count_usable: usize,
}

/// A mode's residual RMS (σ units) above which the robust cost grows only
/// linearly: an outlier counts, but cannot dominate.
pub const HUBER_RMS: f64 = 3.0;

impl ModalObjective {
    /// The weighted modal residuals of the modes in `set` at `x`, or `None`
    /// when the model cannot be solved. Per position and reference mode r of
    /// the set, paired with model mode m (by the pairing of the set alone):
    ///
    /// - √w_nfd (f_m − f_r) / (f_r σ_f,r): the signed NFD (eq. 2.64) in units
    ///   of the frequency's uncertainty;
    /// - √w_mac (α φ̂_m − ψ̂_r) / σ_s,r, real and imaginary parts per shared
    ///   DOF, with unit-normalized shapes and the unit phase factor α that
    ///   brings them closest: ‖α φ̂ − ψ̂‖² = 2 (1 − √MAC) ≈ 1 − MAC near a
    ///   match (eq. 2.62).
    ///
    /// An unpaired mode gives the constant residuals √w_nfd·window/σ_f and
    /// −ψ̂_r/σ_s. A mode compared by frequency alone
    /// ([`ModalObjective::compare_frequency_only`]) has the first only.
    pub fn evaluate(&self, x: &[f64], set: &ModeSet) -> Option<Evaluation> {
        let models = self.model_modes(x).ok()?;
        let usable = self.usable();
        let (residuals, damping) = self.residual_vector(&models, set);
        let all = if *set == usable {
            residuals.clone()
        } else {
            self.residual_vector(&models, &usable).0
        };
        let pairs = self.pair(&models, &usable);
        let cost_usable = 0.5 * all.iter().map(|v| v * v).sum::<f64>();
        let robust_usable = self.robust(&all, &usable);
        let finite = residuals.iter().chain(&damping).all(|v| v.is_finite());
        (finite && cost_usable.is_finite()).then(|| Evaluation {
            count_usable: all.len(),
            residuals,
            damping,
            cost_usable,
            mean_mac: mean_mac(&pairs, &self.shapes_compared()),
            robust_usable,
        })
    }

    /// The robust cost of the residual vector `r` of `set`: per mode, with
    /// n residuals of norm ‖r_m‖ and the bar b = 3√n (an RMS of 3σ), the
    /// Huber function ½‖r_m‖² below b and b‖r_m‖ − ½b² above. For data that
    /// fit to their noise it is ½‖r‖²; a mode the model cannot reproduce (a
    /// bad estimate, a model error local to it) adds linearly, so choosing
    /// between fits, or against the start, is not decided by one mode.
    pub fn robust(&self, r: &[f64], set: &ModeSet) -> f64 {
        let mut at = 0;
        let mut total = 0.0;
        for (_, _, len) in self.segments(set) {
            let Some(v) = r.get(at..at + len) else {
                return f64::INFINITY;
            };
            at += len;
            let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            let bar = HUBER_RMS * (len as f64).sqrt();
            total += if norm <= bar {
                0.5 * norm * norm
            } else {
                bar * norm - 0.5 * bar * bar
            };
        }
        total
    }

    /// (slot, mode, number of residuals) of each mode of `set`, in the
    /// order of the residual vector of [`Self::evaluate`].
    pub fn segments(&self, set: &ModeSet) -> Vec<(usize, usize, usize)> {
        self.references
            .iter()
            .zip(set)
            .enumerate()
            .flat_map(|(p, (r, used))| {
                let shape = 2 * r.rows.len();
                (0..used.len()).filter(move |&k| used[k]).map(move |k| {
                    let len = if r.compares_shape(k) { 1 + shape } else { 1 };
                    (p, k, len)
                })
            })
            .collect()
    }

    /// The residual vector (see [`Self::evaluate`]) of `set`, and the
    /// damping residuals.
    fn residual_vector(
        &self,
        models: &[crate::modal::ModalModel],
        set: &ModeSet,
    ) -> (Vec<f64>, Vec<f64>) {
        let pairing = self.pair(models, set);
        let (wf, ws) = (self.weights.nfd.sqrt(), self.weights.mac.sqrt());
        let mut out = Vec::new();
        let mut damping = Vec::new();
        for (((r, m), pairs), used) in self.references.iter().zip(models).zip(&pairing).zip(set) {
            for (k, c) in pairs.iter().enumerate() {
                if !used[k] {
                    continue;
                }
                let (sf, ss) = (r.sigma_f[k], r.sigma_s[k]);
                let psi = &r.shapes[k];
                let psi_norm = norm(psi);
                let shape = r.compares_shape(k);
                let Some(c) = c else {
                    damping.push(1.0 / r.sigma_z[k]);
                    out.push(wf * self.pairing.window / sf);
                    for v in psi.iter().filter(|_| shape) {
                        out.extend([-ws * v.re / psi_norm / ss, -ws * v.im / psi_norm / ss]);
                    }
                    continue;
                };
                let mode = &m.modes[c.model_mode];
                let zr = r.damping[k];
                damping.push(if zr > 0.0 {
                    (mode.damping_ratio - zr) / (zr * r.sigma_z[k])
                } else {
                    mode.damping_ratio / r.sigma_z[k]
                });
                out.push(wf * (mode.frequency_hz - r.frequencies[k]) / r.frequencies[k] / sf);
                if !shape {
                    continue;
                }
                let phi_norm = norm(&mode.shape);
                let dot: Complex64 = mode.shape.iter().zip(psi).map(|(p, q)| p.conj() * q).sum();
                let alpha = if dot.norm() > 0.0 {
                    dot / dot.norm()
                } else {
                    Complex64::new(1.0, 0.0)
                };
                for (p, q) in mode.shape.iter().zip(psi) {
                    let d = (alpha * p / phi_norm - q / psi_norm) / ss;
                    out.extend([ws * d.re, ws * d.im]);
                }
            }
        }
        (out, damping)
    }

    /// The criterion of one mode-shape reference (a PUB3 subproblem): reference
    /// mode `r` of slot `p` against its best-matching model mode,
    /// min over model modes m of w_mac (1 − MAC) + w_nfd h_δ(NFD). Taking the
    /// best match instead of the one-to-one pairing of J keeps the criterion
    /// continuous (no plateau when the pairing loses the mode); where the
    /// pairing is unambiguous both agree. A mode compared by frequency
    /// alone drops the MAC term (its nearest model mode in frequency then
    /// matches). Evaluates position `p` only.
    pub fn mode_cost(&self, p: usize, r: usize, x: &[f64], delta: f64) -> f64 {
        let Ok(model) = self.model_modes_at(p, x) else {
            return f64::INFINITY;
        };
        let w = self.weights;
        let reference = &self.references[p];
        let (f, shape) = (reference.frequencies[r], &reference.shapes[r]);
        let w_mac = if reference.compares_shape(r) {
            w.mac
        } else {
            0.0
        };
        let best = model
            .modes
            .iter()
            .map(|m| {
                w_mac * (1.0 - mac(shape, &m.shape)) + w.nfd * huber(nfd(f, m.frequency_hz), delta)
            })
            .fold(f64::INFINITY, f64::min);
        if best.is_finite() {
            best
        } else {
            f64::INFINITY
        }
    }
}

fn norm(v: &[Complex64]) -> f64 {
    v.iter().map(|v| v.norm_sqr()).sum::<f64>().sqrt()
}

/// The pseudo-Huber function h_δ(t) = √(t² + δ²) − δ: smooth, ≈ t²/2δ for
/// |t| ≪ δ and ≈ |t| − δ for |t| ≫ δ (δ = 0 gives |t|).
fn huber(t: f64, delta: f64) -> f64 {
    (t * t + delta * delta).sqrt() - delta
}

#[cfg(test)]
mod tests {
    use crate::identify::black_box::tests::{objective, truth};
    use crate::identify::Uncertainty;

    #[test]
    fn residuals_vanish_at_the_truth_and_match_mac_and_nfd_near_it() {
        let o = objective();
        let t = truth();
        let all = o.usable();
        let e = o.evaluate(&t, &all).unwrap();
        // 3 modes × (1 frequency + 2 × 3 shape components).
        assert_eq!(e.residuals.len(), 21);
        assert!(e.residuals.iter().all(|v| v.abs() < 1e-9), "{e:?}");
        assert!((e.mean_mac - 1.0).abs() < 1e-12);
        // Near the truth ½‖r‖² ≈ ½ Σ (1 − MAC)/σ_s² + (NFD/σ_f)² (eq. 2.62,
        // 2.64), with the default uncertainty.
        let u = Uncertainty::default();
        let mut x = t.clone();
        x[1] *= 1.002;
        let e = o.evaluate(&x, &all).unwrap();
        let half: f64 = 0.5 * e.residuals.iter().map(|v| v * v).sum::<f64>();
        assert!((half - e.cost_usable).abs() < 1e-12 * half);
        let m = o.matches(&x).unwrap();
        let expect: f64 = m[0]
            .iter()
            .enumerate()
            .map(|(k, m)| {
                let m = m.unwrap();
                let f = o.reference_frequency(0, k);
                let nfd = (m.frequency_hz - f) / f;
                0.5 * ((1.0 - m.mac) / u.shape.powi(2) + (nfd / u.frequency).powi(2))
            })
            .sum();
        assert!(
            half > 0.0 && (half / expect - 1.0).abs() < 1e-2,
            "{half} vs {expect}"
        );
        // A subset: only its modes' residuals, the usable cost unchanged.
        let first = vec![vec![true, false, false]];
        let s = o.evaluate(&x, &first).unwrap();
        assert_eq!(s.residuals.len(), 7);
        assert_eq!(s.cost_usable, e.cost_usable);
        let summary = o.summary(&x).unwrap();
        assert_eq!((summary.reference_modes, summary.paired), (3, 3));
        assert!(summary.mean_mac < 1.0 && summary.mean_nfd > 0.0);
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
