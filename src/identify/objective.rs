//! The identification objective (seed section 2.3.4, PUB3/PUB4): model modes
//! are paired with reference modes per axis position and the mismatch is
//!
//! J(x) = Σ_positions Σ_r [ w_mac (1 − MAC_r) + w_nfd NFD_r + w_ndd NDD_r ]
//!
//! with MAC (eq. 2.62), NFD (eq. 2.64) and NDD (eq. 2.65) of the pair. Modes
//! are paired by [`crate::metrics::pair_modes`] (optimal MAC assignment within
//! a relative frequency window, as the GSA pairs them); a reference mode left
//! unpaired costs the fixed penalty [`Weights::penalty`] =
//! `w_mac + w_nfd · window + w_ndd`, i.e. as much as a pair at the edge of the
//! window with MAC 0 and 100 % damping difference, so losing a mode is never
//! cheaper than keeping a bad pair.
//!
//! Shapes are compared at the DOFs the reference and the model's sensors
//! share (same node and axis; an opposite direction flips the sign).
//!
//! Reference modes can be left out ([`ModalObjective::without_modes`]): a
//! mode the sensors barely see (a local mode of an unmeasured part) has a
//! MAC that flips with tiny parameter changes and traps local optimizers;
//! PUB4 likewise identified with "only a subset of the found modes". Modes
//! keep their reference numbers (`p0.mode9` stays mode 9), so GSA output
//! names still apply.
//!
//! The stiffness is identified from frequencies and shapes alone (PUB3):
//! they do not depend on the damping parameters (section 2.3.1), so NDD is
//! left out of [`ModalObjective::mode_cost`] (a subproblem's criterion for
//! SLSQP) and of [`ModalObjective::residuals`] (the joint refinement's
//! least-squares residuals). SLSQP needs a smooth criterion, and |NFD| has a
//! kink at a perfect match: `mode_cost` uses the pseudo-Huber form
//! h_δ(t) = √(t² + δ²) − δ of NFD (|t| − δ ≤ h_δ(t) ≤ |t|, quadratic for
//! |t| ≪ δ).

mod residuals;

use super::IdentifyError;
use crate::dynamics::{self, PreparedModel};
use crate::metrics::{mac, nfd, pair_modes};
use crate::modal::{ModalModel, Mode};
use crate::optimize::{Bounds, Scale};
use num_complex::Complex64;

/// Weights of the three terms of J.
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Weights {
    pub mac: f64,
    pub nfd: f64,
    pub ndd: f64,
}

impl Default for Weights {
    fn default() -> Self {
        Weights {
            mac: 1.0,
            nfd: 1.0,
            ndd: 1.0,
        }
    }
}

impl Weights {
    /// Cost of an unpaired reference mode (see the module docs).
    pub fn penalty(&self, window: f64) -> f64 {
        self.mac + self.nfd * window + self.ndd
    }
}

/// NDD (eq. 2.65), guarded for undamped modes: with min(ζ₁, ζ₂) ≤ 0 the
/// absolute difference is used instead of the relative one.
pub fn ndd_guarded(z1: f64, z2: f64) -> f64 {
    let m = z1.min(z2);
    if m > 0.0 {
        (z1 - z2).abs() / m
    } else {
        (z1 - z2).abs()
    }
}

/// Reference modes of one position reduced to the shared DOFs.
struct Reference {
    config: usize,
    position: crate::frf::Position,
    frequencies: Vec<f64>,
    damping: Vec<f64>,
    shapes: Vec<Vec<Complex64>>,
    /// 1-based number of each mode in the reference as given.
    numbers: Vec<usize>,
    /// (model sensor row, sign, reference DOF) per shared DOF.
    rows: Vec<(usize, f64, crate::frf::Dof)>,
}

/// The model mode paired with one reference mode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Match {
    pub frequency_hz: f64,
    pub damping_ratio: f64,
    pub mac: f64,
}

/// A prepared model with reference modes: J(x) and its parts.
pub struct ModalObjective {
    prepared: PreparedModel,
    parameters: Vec<dynamics::Parameter>,
    references: Vec<Reference>,
    modes: usize,
    pub weights: Weights,
    pub window: f64,
}

impl ModalObjective {
    /// Pair `model` with `reference` (matched by position index); `positions`
    /// keeps only those reference positions (all when `None`).
    pub fn new(
        model: &dynamics::Model,
        reference: &[ModalModel],
        positions: Option<&[u32]>,
        weights: Weights,
        window: f64,
    ) -> Result<ModalObjective, IdentifyError> {
        if !(window > 0.0 && window.is_finite()) {
            return Err(IdentifyError::Invalid(format!(
                "pairing window {window} must be a positive fraction such as 0.2"
            )));
        }
        let prepared =
            PreparedModel::new(model).map_err(|e| IdentifyError::Model(e.to_string()))?;
        let mut references = Vec::new();
        let mut most = 0;
        for r in reference {
            if positions.is_some_and(|p| !p.contains(&r.position.index)) {
                continue;
            }
            let matched = prepared
                .match_reference(r)
                .map_err(IdentifyError::Invalid)?;
            let config = matched.config;
            let rows: Vec<_> = matched
                .rows
                .iter()
                .zip(&matched.keep)
                .map(|(&(i, sign), &k)| (i, sign, r.dofs[k]))
                .collect();
            let keep = matched.keep;
            most = most.max(r.modes.len());
            references.push(Reference {
                config,
                position: r.position.clone(),
                frequencies: r.modes.iter().map(|m| m.frequency_hz).collect(),
                damping: r.modes.iter().map(|m| m.damping_ratio).collect(),
                shapes: r
                    .modes
                    .iter()
                    .map(|m| keep.iter().map(|&k| m.shape[k]).collect())
                    .collect(),
                numbers: (1..=r.modes.len()).collect(),
                rows,
            });
        }
        if most == 0 {
            return Err(IdentifyError::Invalid(
                "the reference has no modes at the selected positions".into(),
            ));
        }
        // Two spare model modes let the pairing skip a mode that moved in.
        let modes = (most + 2).min(prepared.n_dofs()).max(1);
        Ok(ModalObjective {
            prepared,
            parameters: model.parameters.clone(),
            references,
            modes,
            weights,
            window,
        })
    }

    /// Leave out the reference modes `exclude` = (position index, 1-based
    /// mode number). Errors name a mode the reference does not have or a
    /// position left without modes.
    pub fn without_modes(mut self, exclude: &[(u32, usize)]) -> Result<Self, IdentifyError> {
        for &(position, number) in exclude {
            let r = self
                .references
                .iter_mut()
                .find(|r| r.position.index == position)
                .ok_or_else(|| {
                    IdentifyError::Invalid(format!(
                        "exclude_modes: position {position} is not in the reference (or not selected by `positions`)"
                    ))
                })?;
            let k = r.numbers.iter().position(|&n| n == number).ok_or_else(|| {
                IdentifyError::Invalid(format!(
                    "exclude_modes: the reference has no mode {number} at position {position}"
                ))
            })?;
            r.frequencies.remove(k);
            r.damping.remove(k);
            r.shapes.remove(k);
            r.numbers.remove(k);
            if r.numbers.is_empty() {
                return Err(IdentifyError::Invalid(format!(
                    "exclude_modes leaves no reference mode at position {position}"
                )));
            }
        }
        Ok(self)
    }

    pub fn parameters(&self) -> &[dynamics::Parameter] {
        &self.parameters
    }

    /// Index (into the kept modes of slot `p`) of reference mode `number`
    /// (1-based, as in the reference); `None` when excluded or absent.
    pub fn mode_index(&self, p: usize, number: usize) -> Option<usize> {
        self.references[p].numbers.iter().position(|&n| n == number)
    }

    /// Number of reference positions (slots).
    pub fn positions(&self) -> usize {
        self.references.len()
    }

    /// Number of reference modes over all positions (terms of J).
    pub fn reference_modes(&self) -> usize {
        self.references.iter().map(|r| r.frequencies.len()).sum()
    }

    /// Box bounds of all parameters (log10 for `scale: log`).
    pub fn bounds(&self) -> Result<Bounds, IdentifyError> {
        let p = &self.parameters;
        Bounds::new(
            p.iter().map(|p| p.lower).collect(),
            p.iter().map(|p| p.upper).collect(),
            p.iter()
                .map(|p| match p.scale {
                    dynamics::Scale::Log => Scale::Log10,
                    dynamics::Scale::Linear => Scale::Linear,
                })
                .collect(),
        )
        .map_err(|e| IdentifyError::Invalid(e.to_string()))
    }

    /// The model file's values clamped to the bounds (the start point).
    pub fn nominal(&self) -> Vec<f64> {
        self.parameters
            .iter()
            .map(|p| p.value.clamp(p.lower, p.upper))
            .collect()
    }

    /// Model modes of each reference position at `x`, at the shared DOFs in
    /// the reference's orientation.
    pub fn model_modes(&self, x: &[f64]) -> Result<Vec<ModalModel>, IdentifyError> {
        (0..self.references.len())
            .map(|p| self.model_modes_at(p, x))
            .collect()
    }

    /// Model modes of position slot `p` alone (one eigensolution).
    pub fn model_modes_at(&self, p: usize, x: &[f64]) -> Result<ModalModel, IdentifyError> {
        let r = &self.references[p];
        let sol = self
            .prepared
            .evaluate(r.config, x, self.modes)
            .map_err(|e| IdentifyError::Model(e.to_string()))?;
        let f = sol.frequencies_hz();
        let z = sol.damping_ratios();
        Ok(ModalModel {
            position: r.position.clone(),
            dofs: r.rows.iter().map(|row| row.2).collect(),
            modes: (0..f.len())
                .map(|m| Mode {
                    frequency_hz: f[m],
                    damping_ratio: z[m],
                    shape: r
                        .rows
                        .iter()
                        .map(|&(i, s, _)| Complex64::new(s * sol.sensor_shapes[(i, m)], 0.0))
                        .collect(),
                })
                .collect(),
        })
    }

    /// Per position and reference mode, the paired model mode (`None` when
    /// unpaired).
    pub fn matches(&self, x: &[f64]) -> Result<Vec<Vec<Option<Match>>>, IdentifyError> {
        let models = self.model_modes(x)?;
        Ok(self
            .pairing(&models)
            .iter()
            .zip(&self.references)
            .zip(&models)
            .map(|((pairs, r), m)| {
                pairs
                    .iter()
                    .enumerate()
                    .map(|(k, c)| {
                        c.map(|c| {
                            let c = &m.modes[c];
                            Match {
                                frequency_hz: c.frequency_hz,
                                damping_ratio: c.damping_ratio,
                                mac: mac(&r.shapes[k], &c.shape),
                            }
                        })
                    })
                    .collect()
            })
            .collect())
    }

    /// Per slot and kept reference mode, the index of the paired model mode.
    fn pairing(&self, models: &[ModalModel]) -> Vec<Vec<Option<usize>>> {
        self.references
            .iter()
            .zip(models)
            .map(|(r, m)| {
                let f: Vec<f64> = m.modes.iter().map(|m| m.frequency_hz).collect();
                let shapes: Vec<Vec<Complex64>> = m.modes.iter().map(|m| m.shape.clone()).collect();
                let mut out = vec![None; r.frequencies.len()];
                for p in pair_modes(&r.frequencies, &r.shapes, &f, &shapes, self.window, 0.0) {
                    out[p.reference] = Some(p.candidate);
                }
                out
            })
            .collect()
    }

    /// Reference damping ratio of mode `r` at position slot `p`.
    pub fn reference_damping(&self, p: usize, r: usize) -> f64 {
        self.references[p].damping[r]
    }

    /// Reference frequency of mode `r` at position slot `p`.
    pub fn reference_frequency(&self, p: usize, r: usize) -> f64 {
        self.references[p].frequencies[r]
    }

    /// Position slot of reference position index `index`.
    pub fn slot(&self, index: u32) -> Option<usize> {
        self.references
            .iter()
            .position(|r| r.position.index == index)
    }

    /// One term of J for reference mode `r` at slot `p`: `which` selects
    /// (1 − MAC), NFD or NDD; the weighted sum of all three when `None`.
    pub fn term(&self, p: usize, r: usize, m: Option<Match>, which: Option<Term>) -> f64 {
        let w = self.weights;
        let Some(m) = m else {
            return match which {
                None => w.penalty(self.window),
                Some(Term::Mac) => 1.0,
                Some(Term::Nfd) => self.window,
                Some(Term::Ndd) => 1.0,
            };
        };
        let (f, z) = (
            self.references[p].frequencies[r],
            self.references[p].damping[r],
        );
        let t_mac = 1.0 - m.mac;
        let t_nfd = nfd(f, m.frequency_hz);
        let t_ndd = ndd_guarded(z, m.damping_ratio);
        match which {
            None => w.mac * t_mac + w.nfd * t_nfd + w.ndd * t_ndd,
            Some(Term::Mac) => t_mac,
            Some(Term::Nfd) => t_nfd,
            Some(Term::Ndd) => t_ndd,
        }
    }

    /// J(x); +∞ when the model cannot be solved at x.
    pub fn cost(&self, x: &[f64]) -> f64 {
        match self.matches(x) {
            Ok(all) => self.sum_terms(&all),
            Err(_) => f64::INFINITY,
        }
    }

    /// J(x) and the mean MAC over all kept reference modes (an unpaired mode
    /// counts 0), from one model evaluation; (+∞, 0) when it cannot be solved.
    pub fn cost_and_mac(&self, x: &[f64]) -> (f64, f64) {
        let Ok(all) = self.matches(x) else {
            return (f64::INFINITY, 0.0);
        };
        (self.sum_terms(&all), mean_mac(&all))
    }

    fn sum_terms(&self, all: &[Vec<Option<Match>>]) -> f64 {
        let mut j = 0.0;
        for (p, ms) in all.iter().enumerate() {
            for (r, m) in ms.iter().enumerate() {
                j += self.term(p, r, *m, None);
            }
        }
        if j.is_finite() {
            j
        } else {
            f64::INFINITY
        }
    }
}

/// How well the model modes at a point match the kept reference modes.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ModeSummary {
    pub reference_modes: usize,
    pub paired: usize,
    /// Mean MAC over the kept reference modes, an unpaired mode counting 0.
    pub mean_mac: f64,
    /// Mean NFD and NDD over the paired modes (eq. 2.64, 2.65).
    pub mean_nfd: f64,
    pub mean_ndd: f64,
}

impl ModalObjective {
    /// The [`ModeSummary`] at `x`.
    pub fn summary(&self, x: &[f64]) -> Result<ModeSummary, IdentifyError> {
        let all = self.matches(x)?;
        let (mut paired, mut nfd_sum, mut ndd_sum) = (0, 0.0, 0.0);
        for (p, ms) in all.iter().enumerate() {
            for (r, m) in ms.iter().enumerate() {
                if let Some(m) = m {
                    paired += 1;
                    nfd_sum += nfd(self.references[p].frequencies[r], m.frequency_hz);
                    ndd_sum += ndd_guarded(self.references[p].damping[r], m.damping_ratio);
                }
            }
        }
        let n = paired.max(1) as f64;
        Ok(ModeSummary {
            reference_modes: self.reference_modes(),
            paired,
            mean_mac: mean_mac(&all),
            mean_nfd: nfd_sum / n,
            mean_ndd: ndd_sum / n,
        })
    }
}

/// Mean MAC over all reference modes of `matches`, an unpaired mode counting 0.
pub fn mean_mac(matches: &[Vec<Option<Match>>]) -> f64 {
    let n: usize = matches.iter().map(Vec::len).sum();
    let sum: f64 = matches
        .iter()
        .flatten()
        .map(|m| m.map_or(0.0, |m| m.mac))
        .sum();
    sum / n.max(1) as f64
}

/// One criterion of J.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Term {
    Mac,
    Nfd,
    Ndd,
}

#[cfg(test)]
mod tests {
    use crate::identify::black_box::tests::{objective, truth};

    #[test]
    fn excluded_modes_leave_the_objective_and_bad_names_are_errors() {
        let o = objective().without_modes(&[(0, 2)]).unwrap();
        assert_eq!(o.reference_modes(), 2);
        assert_eq!(
            (o.mode_index(0, 1), o.mode_index(0, 2), o.mode_index(0, 3)),
            (Some(0), None, Some(1))
        );
        let (r, _) = o.residuals(&truth()).unwrap();
        assert_eq!(r.len(), 14);
        let error = |exclude: &[(u32, usize)]| match objective().without_modes(exclude) {
            Ok(_) => panic!("{exclude:?} accepted"),
            Err(e) => e.to_string(),
        };
        let e = error(&[(0, 4)]);
        assert!(e.contains("no mode 4"), "{e}");
        let e = error(&[(2, 1)]);
        assert!(e.contains("position 2"), "{e}");
        let e = error(&[(0, 1), (0, 2), (0, 3)]);
        assert!(e.contains("leaves no reference mode"), "{e}");
    }
}
