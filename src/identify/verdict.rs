//! The verdict of an identification: did it reach its goal, and how far is
//! the updated model from the reference, in units of the reference's own
//! uncertainty. Written to cost.json and shown by `evaluate`, `report` and
//! `compare`, so a failed run never passes as a plausible result.
//!
//! - `status`: how the optimizer ended — `converged` (its tolerance met, or
//!   no more progress with the fit within the noise), `stalled` (no
//!   progress above the noise, iteration limit or a failure), or
//!   `budget_exhausted` (stopped by `budget` before converging).
//! - `fit`: the weighted residual at the result (each residual divided by
//!   its standard deviation, [`super::Uncertainty`]) as an RMS in σ units.
//!   `within_noise` when RMS ≤ 2; `above_noise` otherwise: the model cannot
//!   reproduce the reference (model error, a mode paired wrongly, or a
//!   local minimum). With every stiffness of a machine moved the model
//!   structurally cannot match, and the verdict says so with the size.
//! - `worse_than_start`: the result fits the reference worse than the start.
//! - `ok`: converged, within the noise, not worse than the start, and every
//!   usable mode paired.
//!
//! **With measured FRFs** (the `frf` input) the FRFs are the reference the
//! verdict is about: `fit` is the FRF residual in units of each channel's
//! noise ([`super::frf_objective`]; 1 at the truth), `worse_than_start`
//! compares it with the modal fit's, and the modal bookkeeping (unpaired
//! or outlier EMA modes, a modal residual above its uncertainty) becomes
//! warnings: the FRFs hold every mode, so an EMA mode the updated model does
//! not reproduce is the EMA's to explain. A residual above the noise whose
//! lag-1 correlation along frequency exceeds [`SMOOTH_LAG1`] is named a
//! systematic misfit (damping model, leakage of an impact test, model
//! error), not noise.

use super::frf_objective::{FrfFit, LocalMisfit, LOCAL_LINES};
pub use refit::{at_edge, Implausible, RefitValue};
use serde::{Deserialize, Serialize};

mod cause;
mod refit;
pub use cause::Cause;

/// Lag-1 correlation above which an FRF residual is called smooth.
pub const SMOOTH_LAG1: f64 = 0.5;

/// Implicated fixed parameters the message names (largest statistic first).
const NAMED_IMPLICATED: usize = 5;

/// Weighted-residual RMS (σ units) up to which a fit is within the noise.
pub const NOISE_RMS: f64 = 2.0;

/// RMS (σ units) over the worst window of lines
/// ([`super::frf_objective::LocalMisfit`]) up to which an FRF fit is within
/// the noise: four times [`NOISE_RMS`]. Noise alone stays below 1.6 (the
/// vertical mill family at 1 % noise: 1.04–1.07 at its successes); the H1
/// bias and leakage of impact tests sit on the resonances and the low lines
/// (test bench, 10 impact tests: 3.8–5.6σ at 1.5–2.0σ overall); resonances
/// the model misses or misplaces on the mill: 8.5–15σ.
pub const LOCAL_NOISE_RMS: f64 = 4.0 * NOISE_RMS;

/// How the optimizer ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    Converged,
    Stalled,
    BudgetExhausted,
}

impl Status {
    /// The status of an optimizer termination.
    pub fn of(t: &crate::optimize::Termination) -> Status {
        use crate::optimize::Termination as T;
        match t {
            T::Converged | T::TargetReached => Status::Converged,
            T::RoundoffLimited { accepted: true, .. } => Status::Converged,
            T::BudgetExhausted => Status::BudgetExhausted,
            T::MaxIterations | T::Stalled | T::RoundoffLimited { .. } | T::Failed { .. } => {
                Status::Stalled
            }
        }
    }
}

/// Whether the result reproduces the reference to its uncertainty.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Fit {
    WithinNoise,
    AboveNoise,
}

/// Mode bookkeeping at the result.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ModeCounts {
    /// Reference modes given.
    pub reference: usize,
    /// Used in the fit (not excluded).
    pub used: usize,
    /// Left out, with the reasons in the correspondence table.
    pub excluded: usize,
    /// Used but without a model partner at the result.
    pub unpaired: usize,
    /// Paired, but another assignment is nearly as good.
    pub ambiguous: usize,
    /// Down-weighted as outliers: the model does not reproduce them (a
    /// spurious or wrongly paired reference mode, or a local minimum).
    #[serde(default)]
    pub outliers: usize,
    /// Paired, but far apart in frequency and shape: most likely a mode the
    /// model does not contain (see `assessment::weak_pairs`).
    #[serde(default)]
    pub weak: usize,
}

/// A number that JSON may hold as null (serde_json writes NaN and ±∞ so).
pub fn nan_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// The verdict.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Verdict {
    pub ok: bool,
    pub status: Status,
    pub fit: Fit,
    /// RMS of the weighted residuals at the start and at the result (JSON
    /// null when the model cannot be solved there).
    #[serde(deserialize_with = "nan_if_null")]
    pub start_rms: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub end_rms: f64,
    pub worse_than_start: bool,
    pub modes: ModeCounts,
    /// Parameters identified and how many of them the data determine.
    pub identified: usize,
    pub identifiable: usize,
    /// The FRF fit at the modal result and at the end, when FRFs were given.
    #[serde(default)]
    pub frf: Option<FrfJudgement>,
    /// Fixed parameters the score test implicates at the result
    /// ([`super::consider`]), with the change the data point to.
    #[serde(default)]
    pub implicated: Vec<String>,
    /// Those of them whose suggested change its bounds hold
    /// ([`Implication::at_bound`]).
    #[serde(default)]
    pub implicated_at_bound: Vec<String>,
    /// Fixed parameters the score test implicated earlier that a refit
    /// identified too ([`super::follow_up`]).
    #[serde(default)]
    pub refitted: Vec<String>,
    /// The refitted parameters at the result, each judged for plausibility
    /// against the range the screening held it in ([`refit`]).
    #[serde(default)]
    pub refit_values: Vec<RefitValue>,
    /// The damping ratios against the reference, when damping parameters
    /// were identified from modes alone.
    #[serde(default)]
    pub damping: Option<DampingJudgement>,
    /// Why the verdict is not ok (`none` when it is).
    #[serde(default)]
    pub cause: Cause,
    /// The evidence of a further search it was last classified with (not
    /// written: the cause and the message say what it showed).
    #[serde(skip)]
    pub search: SearchEvidence,
    /// One line a person reads first.
    pub message: String,
    /// Everything else worth a look.
    pub warnings: Vec<String>,
}

/// How well the identified damping reproduces the reference's damping
/// ratios, judged when damping parameters are identified from modes alone
/// (with FRFs, the FRF fit holds the damping): the RMS over the paired modes
/// of (ζ_model − ζ_ref)/(ζ_ref σ_ζ), with σ_ζ each mode's stated relative
/// uncertainty of its damping ratio (10 % by default; AutoEMA's spread
/// raises it).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DampingJudgement {
    /// RMS of the damping residuals (σ_ζ units).
    pub rms: f64,
    /// Paired reference modes with a damping ratio.
    pub modes: usize,
    pub fit: Fit,
    /// The worst mode, in words (position, frequency, both damping ratios).
    pub worst: String,
    /// The damping parameters identified.
    pub parameters: Vec<String>,
}

impl DampingJudgement {
    /// Judge the damping residuals `r` (σ_ζ units) of the paired modes;
    /// `worst` describes the largest. `None` without any paired mode.
    pub fn new(r: &[f64], worst: String, parameters: Vec<String>) -> Option<DampingJudgement> {
        if r.is_empty() {
            return None;
        }
        let rms = (r.iter().map(|v| v * v).sum::<f64>() / r.len() as f64).sqrt();
        Some(DampingJudgement {
            rms,
            modes: r.len(),
            fit: if rms <= NOISE_RMS {
                Fit::WithinNoise
            } else {
                Fit::AboveNoise
            },
            worst,
            parameters,
        })
    }
}

/// What the update learned about its own search, for naming the cause.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SearchEvidence {
    /// A further search ran because the fit ended above the noise; `Some(true)`
    /// when it found a better fit.
    pub escaped: Option<bool>,
    /// A search that found nothing better with fewer evaluations than the
    /// refinement it second-guessed (its own, the first's): it ran, but its
    /// failure is no evidence (`escaped` stays `None`).
    pub short: Option<(usize, usize)>,
}

/// The worst window of `fit` when it is above [`LOCAL_NOISE_RMS`].
fn local_excess(fit: &FrfFit) -> Option<LocalMisfit> {
    fit.local.filter(|l| l.rms > LOCAL_NOISE_RMS)
}

impl Verdict {
    /// The worst window of lines of the result's FRF fit when it is far
    /// above the noise ([`LOCAL_NOISE_RMS`]): a resonance the fit misses or
    /// misplaces.
    pub fn misplaced_window(&self) -> Option<LocalMisfit> {
        self.frf.as_ref().and_then(|f| local_excess(&f.end))
    }
}

/// The FRF part of a verdict.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrfJudgement {
    /// At the modal fit (where the FRF refinement started).
    pub start: FrfFit,
    /// At the result.
    pub end: FrfFit,
    pub fit: Fit,
    /// The residual above the noise is smooth along frequency.
    pub systematic: bool,
}

impl FrfJudgement {
    /// Judge the FRF fit from its start and end.
    pub fn new(start: FrfFit, end: FrfFit) -> FrfJudgement {
        let fit = if end.rms <= NOISE_RMS && local_excess(&end).is_none() {
            Fit::WithinNoise
        } else {
            Fit::AboveNoise
        };
        FrfJudgement {
            start,
            end,
            fit,
            systematic: end.rms > NOISE_RMS && end.lag1 > SMOOTH_LAG1,
        }
    }

    fn worse(&self) -> bool {
        self.end
            .rms
            .partial_cmp(&self.start.rms)
            .is_none_or(|o| o.is_gt())
    }

    fn sentence(&self) -> String {
        let (s, e) = (self.start.rms, self.end.rms);
        // Within the noise overall: above it only through one window.
        if let Some(l) = local_excess(&self.end).filter(|_| e <= NOISE_RMS) {
            return format!(
                "FRF residual {e:.2}σ RMS (from {s:.1}σ) overall, but {:.0}σ over the {LOCAL_LINES} lines around {:.1} Hz at position {}: a resonance the model misses or misplaces (another basin, or a mode the model lacks), which the overall RMS dilutes",
                l.rms, l.frequency_hz, l.position
            );
        }
        match (self.fit, self.systematic) {
            (Fit::WithinNoise, _) => format!(
                "FRF residual {e:.2}σ RMS (from {s:.1}σ), FRAC {:.3}: the model reproduces the measured FRFs within their noise",
                self.end.mean_frac
            ),
            (Fit::AboveNoise, true) => format!(
                "FRF residual {e:.1}σ RMS (from {s:.1}σ) is above the noise and smooth along frequency (lag-1 correlation {:.2}): a systematic misfit, not noise",
                self.end.lag1
            ),
            (Fit::AboveNoise, false) => format!(
                "FRF residual {e:.1}σ RMS (from {s:.1}σ) is above the measured noise"
            ),
        }
    }
}

impl Verdict {
    /// Judge a result against the reference modes: `start_rms`/`end_rms` are
    /// weighted-residual RMS values.
    pub fn judge(
        status: Status,
        start_rms: f64,
        end_rms: f64,
        modes: ModeCounts,
        identified: usize,
        identifiable: usize,
        mut warnings: Vec<String>,
    ) -> Verdict {
        let fit = if end_rms <= NOISE_RMS {
            Fit::WithinNoise
        } else {
            Fit::AboveNoise
        };
        // An optimizer that stops making progress with the fit within the
        // noise has reached the noise floor: that is convergence.
        let status = if status == Status::Stalled && fit == Fit::WithinNoise {
            Status::Converged
        } else {
            status
        };
        // NaN (a model that cannot be solved) counts as worse.
        let worse = end_rms.partial_cmp(&start_rms).is_none_or(|o| o.is_gt());
        // Within the noise means the robust (Huber) residual; modes it
        // down-weighted or could not pair are not reproduced, so they keep
        // the verdict from being ok and are named in the message.
        let lost = modes.unpaired + modes.outliers + modes.weak;
        let ok = status == Status::Converged && fit == Fit::WithinNoise && !worse && lost == 0;
        let mut parts = vec![status_text(status).to_string()];
        parts.push(match fit {
            Fit::WithinNoise => format!(
                "residual {end_rms:.2}σ RMS: the model reproduces the reference within its uncertainty"
            ),
            Fit::AboveNoise => format!(
                "residual {end_rms:.1}σ RMS is above the reference's uncertainty (start {start_rms:.1}σ)"
            ),
        });
        if worse {
            parts.push("the result fits WORSE than the start".into());
        }
        if lost > 0 {
            parts.push(format!(
                "but {lost} of {} used reference modes are not reproduced ({} without a model partner, {} outliers, {} weakly paired): modes the model does not contain, spurious or wrongly paired modes, or a local minimum (named in the warnings)",
                modes.used, modes.unpaired, modes.outliers, modes.weak
            ));
        }
        if modes.unpaired > 0 {
            warnings.push(format!(
                "{} used reference mode(s) have no model partner at the result",
                modes.unpaired
            ));
        }
        if modes.ambiguous > 0 {
            warnings.push(format!(
                "{} mode pair(s) are ambiguous: another pairing is nearly as good",
                modes.ambiguous
            ));
        }
        if identifiable < identified {
            warnings.push(format!(
                "{} of {identified} identified parameters are not determined by the data (see identifiability)",
                identified - identifiable
            ));
        }
        Verdict {
            ok,
            status,
            fit,
            start_rms,
            end_rms,
            worse_than_start: worse,
            modes,
            identified,
            identifiable,
            frf: None,
            implicated: Vec::new(),
            implicated_at_bound: Vec::new(),
            refitted: Vec::new(),
            refit_values: Vec::new(),
            damping: None,
            cause: Cause::None,
            search: SearchEvidence::default(),
            message: parts.join("; "),
            warnings,
        }
        .classified(SearchEvidence::default())
    }
}

impl Verdict {
    /// Judge again with the measured FRFs as the reference (module docs):
    /// `status` is how the FRF refinement ended; the modal verdict's message
    /// and warnings become warnings.
    pub fn with_frf(self, status: Status, f: FrfJudgement) -> Verdict {
        let status = if status == Status::Stalled && f.fit == Fit::WithinNoise {
            Status::Converged
        } else {
            status
        };
        let worse = f.worse();
        let ok = status == Status::Converged && f.fit == Fit::WithinNoise && !worse;
        let mut parts = vec![status_text(status).to_string(), f.sentence()];
        if worse {
            parts.push("the FRFs fit WORSE than at the modal result".into());
        }
        let mut warnings = self.warnings;
        if !self.ok {
            warnings.insert(0, format!("modal reference: {}", self.message));
        }
        if f.fit == Fit::WithinNoise && f.end.lag1 > SMOOTH_LAG1 {
            warnings.push(format!(
                "the FRF residual is within the noise but smooth along frequency (lag-1 correlation {:.2}): a systematic part (the H1 bias and leakage of an impact test, the damping model) that the intervals do not contain — they count it as fewer independent lines, not as a bias; on simulated impact tests the stiffnesses carried biases of several standard errors",
                f.end.lag1
            ));
        }
        Verdict {
            ok,
            status,
            fit: f.fit,
            worse_than_start: worse,
            frf: Some(f),
            message: parts.join("; "),
            warnings,
            ..self
        }
        .classified(SearchEvidence::default())
    }

    /// The verdict with the score test's implicated fixed parameters
    /// (largest statistic first): not ok, and they are named in the message.
    pub fn with_implicated(mut self, implicated: &[Implication]) -> Verdict {
        if implicated.is_empty() {
            return self;
        }
        self.ok = false;
        let mut named: Vec<String> = implicated
            .iter()
            .take(NAMED_IMPLICATED)
            .map(Implication::describe)
            .collect();
        if implicated.len() > NAMED_IMPLICATED {
            named.push(format!(
                "and {} more (identifiability.json, parameters.csv)",
                implicated.len() - NAMED_IMPLICATED
            ));
        }
        self.message.push_str(&format!(
            "; the residual points at parameter{} the update held fixed: {}",
            if named.len() == 1 { "" } else { "s" },
            named.join(", "),
        ));
        self.implicated = implicated.iter().map(|i| i.parameter.clone()).collect();
        self.implicated_at_bound = implicated
            .iter()
            .filter(|i| i.at_bound)
            .map(|i| i.parameter.clone())
            .collect();
        self.classified(SearchEvidence::default())
    }

    /// The most implicated fixed parameter asks for a change its bounds
    /// hold: the data point at a value the model file calls barely
    /// possible, which a wrong basin of the identified parameters explains
    /// as well as the screening does.
    fn leading_at_bound(&self) -> bool {
        self.implicated
            .first()
            .is_some_and(|n| self.implicated_at_bound.contains(n))
    }

    /// The verdict with the identified damping judged against the
    /// reference's damping ratios: above their uncertainty it is not ok.
    pub fn with_damping(mut self, d: DampingJudgement) -> Verdict {
        if d.fit == Fit::AboveNoise {
            self.ok = false;
            self.message.push_str(&format!(
                "; but the damping ratios are not reproduced: {:.1}σ_ζ RMS over {} paired modes (worst: {}), so the identified damping ({}) and its intervals do not hold",
                d.rms,
                d.modes,
                d.worst,
                d.parameters.join(", ")
            ));
        }
        self.damping = Some(d);
        self.classified(SearchEvidence::default())
    }

    /// The verdict with the fixed parameters a refit identified too, their
    /// values judged (see [`Cause::ScreenedOut`],
    /// [`Cause::ScreeningOrLocalMinimum`]); implausible ones are named in a
    /// warning whatever the cause.
    pub fn with_refitted(mut self, values: Vec<RefitValue>) -> Verdict {
        // A fit that needed a refitted value its bounds or spread hold is
        // not ok, even within the noise: the value says what the fit
        // needed, not what the structure has, and a wrong basin of the
        // identified parameters needs such compensation as readily as a
        // screening that left something out (the cause names it).
        if refit::any_implausible(&values) {
            self.ok = false;
        }
        self.refitted = values.iter().map(|v| v.parameter.clone()).collect();
        self.warnings.extend(refit::warning(&values));
        self.refit_values = values;
        self.classified(SearchEvidence::default())
    }
}

/// A fixed parameter the score test implicates ([`super::consider`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Implication {
    pub parameter: String,
    /// The change of ln p the data point to (linearized, cut at its bounds).
    pub change: f64,
    /// The score statistic, χ²₁ under "its value is right".
    pub statistic: f64,
    /// The change takes it to the outer [`refit::EDGE`] of its range, as a
    /// refitted value held by its bound ([`Implausible`]).
    pub at_bound: bool,
}

impl Implication {
    /// An implication whose change stays inside the bounds.
    pub fn new(parameter: impl Into<String>, change: f64, statistic: f64) -> Implication {
        Implication {
            parameter: parameter.into(),
            change,
            statistic,
            at_bound: false,
        }
    }

    /// "cpl.k_ry (+300 % to its bound, χ² 374)".
    fn describe(&self) -> String {
        format!(
            "{} ({:+.0} %{}, χ² {:.0})",
            self.parameter,
            100.0 * self.change.exp_m1(),
            if self.at_bound { " to its bound" } else { "" },
            self.statistic
        )
    }
}

impl From<&super::consider::FixedParameter> for Implication {
    fn from(f: &super::consider::FixedParameter) -> Implication {
        Implication {
            parameter: f.parameter.clone(),
            change: f.change,
            statistic: f.statistic,
            at_bound: f.at_bound,
        }
    }
}

fn status_text(status: Status) -> &'static str {
    match status {
        Status::Converged => "converged",
        Status::Stalled => "stalled before converging",
        Status::BudgetExhausted => "stopped by the budget before converging",
    }
}

#[cfg(test)]
mod tests;
