//! The identification objective (seed section 2.3.4, PUB3/PUB4): a model
//! and reference modes per axis position, compared pair by pair.
//!
//! Model modes are paired with reference modes per position by
//! [`crate::pairing`] (one assignment on (1 − MAC) + NFD/s_f within a
//! window): by physics, never by number. Shapes are compared at the DOFs the
//! reference and the model's sensors share (same node and axis; an opposite
//! direction flips the sign).
//!
//! Which reference modes take part is a [`ModeSet`]: modes excluded for a
//! stated reason (not observable, named by `exclude_modes`, not in any
//! pairing) are never used; the guided strategy's continuation activates
//! the rest stage by stage.
//!
//! Two views of the mismatch:
//! - J(x) = Σ_positions Σ_r [ w_mac (1 − MAC_r) + w_nfd NFD_r + w_ndd NDD_r ]
//!   over the used modes (MAC eq. 2.62, NFD eq. 2.64, NDD eq. 2.65), the
//!   black-box objective of PUB4. An unpaired reference mode costs the fixed
//!   penalty [`Weights::penalty`] = `w_mac + w_nfd · window + w_ndd`, as much
//!   as a pair at the edge of the window with MAC 0 and 100 % damping
//!   difference, so losing a mode is never cheaper than keeping a bad pair.
//! - the residual vector of least squares ([`residuals`]): frequency and
//!   shape differences, each divided by the reference's uncertainty
//!   ([`Uncertainty`]), so a noisy shape cannot outweigh an exact frequency.
//!
//! The stiffness is identified from frequencies and shapes alone (PUB3): they
//! do not depend on the damping parameters (section 2.3.1), so NDD is left
//! out of the residuals and of a subproblem's criterion.

mod model_modes;
mod residuals;
mod uncertainty;
mod visibility;

pub use residuals::Evaluation;
pub use uncertainty::{complexity, Uncertainty};

use super::IdentifyError;
use crate::dynamics::{self, PreparedModel};
use crate::metrics::nfd;
use crate::modal::ModalModel;
use crate::optimize::Bounds;
use crate::pairing::{cost_matrix, margins, pair_modes, Pair, Pairing};
use num_complex::Complex64;

/// Weights of the three terms of J (and of the residuals' two kinds).
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
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
pub(crate) struct Reference {
    pub(crate) config: usize,
    pub(crate) position: crate::frf::Position,
    pub(crate) frequencies: Vec<f64>,
    pub(crate) damping: Vec<f64>,
    pub(crate) shapes: Vec<Vec<Complex64>>,
    /// Relative standard deviation of each frequency and of each shape
    /// component (unit-normalized shape).
    pub(crate) sigma_f: Vec<f64>,
    pub(crate) sigma_s: Vec<f64>,
    /// Relative standard deviation of each damping ratio.
    pub(crate) sigma_z: Vec<f64>,
    /// How each mode takes part.
    pub(crate) uses: Vec<ModeUse>,
    /// (model sensor row, sign, reference DOF) per shared DOF.
    pub(crate) rows: Vec<(usize, f64, crate::frf::Dof)>,
}

/// How one reference mode takes part, with the reason when not in full.
#[derive(Clone, Debug, PartialEq)]
pub enum ModeUse {
    /// Frequency and shape.
    Full,
    /// Its frequency alone: the shape residuals, J's MAC term, the
    /// subproblem's MAC and the mean MAC leave it; the pairing still uses
    /// its shape to tell it from a neighbour.
    FrequencyOnly(String),
    /// Not at all.
    Excluded(String),
}

impl ModeUse {
    /// Why the mode is not used in full (`None`: it is).
    pub fn reason(&self) -> Option<&str> {
        match self {
            ModeUse::Full => None,
            ModeUse::FrequencyOnly(why) | ModeUse::Excluded(why) => Some(why),
        }
    }
}

impl Reference {
    /// Whether mode `k`'s shape is compared (not by frequency alone).
    pub(crate) fn compares_shape(&self, k: usize) -> bool {
        !matches!(self.uses[k], ModeUse::FrequencyOnly(_))
    }
}

/// Which reference modes take part, per position slot and mode.
pub type ModeSet = Vec<Vec<bool>>;

/// The model mode paired with one reference mode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Match {
    /// Index of the model mode (ascending frequency) at that point.
    pub model_mode: usize,
    pub frequency_hz: f64,
    pub damping_ratio: f64,
    pub mac: f64,
}

/// The pairing at one slot ([`ModalObjective::pair_with_margins`]).
pub struct SlotPairing {
    /// Reference mode numbers (0-based) taking part; pairs index into it.
    pub idx: Vec<usize>,
    /// Their frequencies (Hz).
    pub rf: Vec<f64>,
    /// Model frequencies (Hz) and shapes.
    pub mf: Vec<f64>,
    pub model_shapes: Vec<Vec<Complex64>>,
    pub pairs: Vec<Pair>,
    /// Per pair, its margin.
    pub margins: Vec<f64>,
}

/// A prepared model with reference modes: J(x), residuals and their parts.
pub struct ModalObjective {
    prepared: PreparedModel,
    parameters: Vec<dynamics::Parameter>,
    pub(crate) references: Vec<Reference>,
    modes: usize,
    pub weights: Weights,
    pub pairing: Pairing,
}

impl ModalObjective {
    /// Pair `model` with `reference` (matched by position index); `positions`
    /// keeps only those reference positions (all when `None`). Every mode
    /// gets the uncertainty `uncertainty` (see [`Self::with_uncertainty`]).
    pub fn new(
        model: &dynamics::Model,
        reference: &[ModalModel],
        positions: Option<&[u32]>,
        weights: Weights,
        pairing: Pairing,
    ) -> Result<ModalObjective, IdentifyError> {
        pairing
            .check()
            .map_err(|m| IdentifyError::Invalid(format!("pairing: {m}")))?;
        let prepared =
            PreparedModel::new(model).map_err(|e| IdentifyError::Model(e.to_string()))?;
        let defaults = Uncertainty::default();
        let mut references = Vec::new();
        let mut most = 0;
        for r in reference {
            if positions.is_some_and(|p| !p.contains(&r.position.index)) {
                continue;
            }
            let matched = prepared
                .match_reference(r)
                .map_err(IdentifyError::Invalid)?;
            if matched.keep.is_empty() {
                return Err(IdentifyError::Invalid(format!(
                    "reference position {} shares no DOF (node and axis) with the model's sensors",
                    r.position.index
                )));
            }
            let rows: Vec<_> = matched
                .rows
                .iter()
                .zip(&matched.keep)
                .map(|(&(i, sign), &k)| (i, sign, r.dofs[k]))
                .collect();
            let keep = matched.keep;
            let n = r.modes.len();
            most = most.max(n);
            references.push(Reference {
                config: matched.config,
                position: r.position.clone(),
                frequencies: r.modes.iter().map(|m| m.frequency_hz).collect(),
                damping: r.modes.iter().map(|m| m.damping_ratio).collect(),
                shapes: r
                    .modes
                    .iter()
                    .map(|m| keep.iter().map(|&k| m.shape[k]).collect())
                    .collect(),
                sigma_f: vec![defaults.frequency; n],
                sigma_s: vec![defaults.shape; n],
                sigma_z: vec![defaults.damping; n],
                uses: vec![ModeUse::Full; n],
                rows,
            });
        }
        if most == 0 {
            return Err(IdentifyError::Invalid(
                "the reference has no modes at the selected positions".into(),
            ));
        }
        // Spare model modes let the pairing skip modes that moved in or that
        // the reference lacks.
        let modes = (most + 4).min(prepared.n_dofs()).max(1);
        Ok(ModalObjective {
            prepared,
            parameters: model.parameters.clone(),
            references,
            modes,
            weights,
            pairing,
        })
    }

    /// Leave reference mode `r` of slot `p` out, saying why (the first
    /// reason given stays).
    pub fn exclude(&mut self, p: usize, r: usize, reason: impl Into<String>) {
        let used = &mut self.references[p].uses[r];
        if !matches!(used, ModeUse::Excluded(_)) {
            *used = ModeUse::Excluded(reason.into());
        }
    }

    /// Compare only the frequency of reference mode `r` of slot `p`, not
    /// its shape, saying why ([`ModeUse::FrequencyOnly`]); a mode already
    /// left out or reduced stays as it is.
    pub fn compare_frequency_only(&mut self, p: usize, r: usize, reason: impl Into<String>) {
        let used = &mut self.references[p].uses[r];
        if *used == ModeUse::Full {
            *used = ModeUse::FrequencyOnly(reason.into());
        }
    }

    /// How reference mode `r` of slot `p` takes part.
    pub fn mode_use(&self, p: usize, r: usize) -> &ModeUse {
        &self.references[p].uses[r]
    }

    /// Why reference mode `r` of slot `p` is left out, if it is.
    pub fn exclusion(&self, p: usize, r: usize) -> Option<&str> {
        match self.mode_use(p, r) {
            ModeUse::Excluded(why) => Some(why),
            _ => None,
        }
    }

    /// The modes used with their shapes: those of the mean MAC.
    pub fn shapes_compared(&self) -> ModeSet {
        self.mode_set(|u| *u == ModeUse::Full)
    }

    /// The modes not excluded.
    pub fn usable(&self) -> ModeSet {
        self.mode_set(|u| !matches!(u, ModeUse::Excluded(_)))
    }

    fn mode_set(&self, take: impl Fn(&ModeUse) -> bool) -> ModeSet {
        self.references
            .iter()
            .map(|r| r.uses.iter().map(&take).collect())
            .collect()
    }

    pub fn parameters(&self) -> &[dynamics::Parameter] {
        &self.parameters
    }

    pub fn prepared(&self) -> &PreparedModel {
        &self.prepared
    }

    /// Number of reference positions (slots).
    pub fn positions(&self) -> usize {
        self.references.len()
    }

    /// Number of reference modes at slot `p` (used or not).
    pub fn modes_at(&self, p: usize) -> usize {
        self.references[p].frequencies.len()
    }

    /// Number of usable reference modes over all positions.
    pub fn reference_modes(&self) -> usize {
        self.usable().iter().flatten().filter(|&&u| u).count()
    }

    /// The reference position of slot `p`.
    pub fn position(&self, p: usize) -> &crate::frf::Position {
        &self.references[p].position
    }

    /// Box bounds of all parameters (log10 for `scale: log`).
    pub fn bounds(&self) -> Result<Bounds, IdentifyError> {
        let p = &self.parameters;
        Bounds::new(
            p.iter().map(|p| p.lower).collect(),
            p.iter().map(|p| p.upper).collect(),
            p.iter().map(|p| p.scale).collect(),
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

    /// Per slot and reference mode of `set`, the paired model mode of
    /// `models` (`None` when not in the set or unpaired).
    pub fn pair(&self, models: &[ModalModel], set: &ModeSet) -> Vec<Vec<Option<Match>>> {
        self.references
            .iter()
            .zip(models)
            .zip(set)
            .map(|((r, m), used)| {
                let idx: Vec<usize> = (0..r.frequencies.len()).filter(|&k| used[k]).collect();
                let rf: Vec<f64> = idx.iter().map(|&k| r.frequencies[k]).collect();
                let rs: Vec<Vec<Complex64>> = idx.iter().map(|&k| r.shapes[k].clone()).collect();
                let f: Vec<f64> = m.modes.iter().map(|m| m.frequency_hz).collect();
                let shapes: Vec<Vec<Complex64>> = m.modes.iter().map(|m| m.shape.clone()).collect();
                let mut out = vec![None; r.frequencies.len()];
                for p in pair_modes(&rf, &rs, &f, &shapes, &self.pairing) {
                    let c = &m.modes[p.candidate];
                    out[idx[p.reference]] = Some(Match {
                        model_mode: p.candidate,
                        frequency_hz: c.frequency_hz,
                        damping_ratio: c.damping_ratio,
                        mac: p.mac,
                    });
                }
                out
            })
            .collect()
    }

    /// The pairing of the usable reference modes at slot `p` with the modes
    /// of `model`, with each pair's margin (how much the assignment's cost
    /// rises if that pair is forbidden): the one computation behind the
    /// correspondence at the start and the final pairs at the result.
    pub fn pair_with_margins(&self, p: usize, model: &ModalModel, set: &ModeSet) -> SlotPairing {
        let idx: Vec<usize> = (0..self.modes_at(p)).filter(|&k| set[p][k]).collect();
        let rf: Vec<f64> = idx
            .iter()
            .map(|&k| self.reference_frequency(p, k))
            .collect();
        let rs: Vec<Vec<Complex64>> = idx
            .iter()
            .map(|&k| self.reference_shape(p, k).to_vec())
            .collect();
        let mf: Vec<f64> = model.modes.iter().map(|m| m.frequency_hz).collect();
        let ms: Vec<Vec<Complex64>> = model.modes.iter().map(|m| m.shape.clone()).collect();
        let pairs = pair_modes(&rf, &rs, &mf, &ms, &self.pairing);
        let macs = crate::metrics::mac_matrix(&rs, &ms);
        let margins = margins(&cost_matrix(&rf, &mf, &macs, &self.pairing), &pairs);
        SlotPairing {
            idx,
            rf,
            mf,
            model_shapes: ms,
            pairs,
            margins,
        }
    }

    /// Per position and usable reference mode, the paired model mode at `x`.
    pub fn matches(&self, x: &[f64]) -> Result<Vec<Vec<Option<Match>>>, IdentifyError> {
        let models = self.model_modes(x)?;
        Ok(self.pair(&models, &self.usable()))
    }

    /// Reference damping ratio of mode `r` at position slot `p`.
    pub fn reference_damping(&self, p: usize, r: usize) -> f64 {
        self.references[p].damping[r]
    }

    /// Relative standard deviation σ_ζ of the damping ratio of reference
    /// mode `r` at position slot `p` ([`Uncertainty::damping`], raised by the
    /// estimate's own spread).
    pub fn reference_damping_sigma(&self, p: usize, r: usize) -> f64 {
        self.references[p].sigma_z[r]
    }

    /// Reference frequency of mode `r` at position slot `p`.
    pub fn reference_frequency(&self, p: usize, r: usize) -> f64 {
        self.references[p].frequencies[r]
    }

    /// Reference shape of mode `r` at position slot `p` (shared DOFs).
    pub fn reference_shape(&self, p: usize, r: usize) -> &[Complex64] {
        &self.references[p].shapes[r]
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
        let window = self.pairing.window;
        let Some(m) = m else {
            return match which {
                None => w.penalty(window),
                Some(Term::Mac) => 1.0,
                Some(Term::Nfd) => window,
                Some(Term::Ndd) => 1.0,
            };
        };
        let (f, z) = (
            self.references[p].frequencies[r],
            self.references[p].damping[r],
        );
        let t_mac = if self.references[p].compares_shape(r) {
            1.0 - m.mac
        } else {
            0.0
        };
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

    /// J(x) and the mean MAC over all usable reference modes (an unpaired
    /// mode counts 0), from one model evaluation; (+∞, 0) when it cannot be
    /// solved.
    pub fn cost_and_mac(&self, x: &[f64]) -> (f64, f64) {
        let Ok(all) = self.matches(x) else {
            return (f64::INFINITY, 0.0);
        };
        (
            self.sum_terms(&all),
            mean_mac(&all, &self.shapes_compared()),
        )
    }

    fn sum_terms(&self, all: &[Vec<Option<Match>>]) -> f64 {
        let usable = self.usable();
        let mut j = 0.0;
        for (p, ms) in all.iter().enumerate() {
            for (r, m) in ms.iter().enumerate() {
                if usable[p][r] {
                    j += self.term(p, r, *m, None);
                }
            }
        }
        if j.is_finite() {
            j
        } else {
            f64::INFINITY
        }
    }
}

/// How well the model modes at a point match the usable reference modes.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ModeSummary {
    pub reference_modes: usize,
    pub paired: usize,
    /// Mean MAC over the usable reference modes whose shapes are compared,
    /// an unpaired mode counting 0.
    pub mean_mac: f64,
    /// Mean NFD and NDD over the paired modes (eq. 2.64, 2.65).
    pub mean_nfd: f64,
    pub mean_ndd: f64,
}

impl ModalObjective {
    /// The [`ModeSummary`] at `x`.
    pub fn summary(&self, x: &[f64]) -> Result<ModeSummary, IdentifyError> {
        let all = self.matches(x)?;
        let usable = self.usable();
        let (mut paired, mut nfd_sum, mut ndd_sum) = (0, 0.0, 0.0);
        for (p, ms) in all.iter().enumerate() {
            for (r, m) in ms.iter().enumerate() {
                if let (Some(m), true) = (m, usable[p][r]) {
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
            mean_mac: mean_mac(&all, &self.shapes_compared()),
            mean_nfd: nfd_sum / n,
            mean_ndd: ndd_sum / n,
        })
    }
}

/// Mean MAC over the modes of `set`, an unpaired mode counting 0 (callers
/// pass [`ModalObjective::shapes_compared`] or a part of it).
pub fn mean_mac(matches: &[Vec<Option<Match>>], set: &ModeSet) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for (ms, used) in matches.iter().zip(set) {
        for (m, &u) in ms.iter().zip(used) {
            if u {
                n += 1;
                sum += m.map_or(0.0, |m| m.mac);
            }
        }
    }
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
mod tests;
