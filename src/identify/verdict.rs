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
pub use refit::{Implausible, RefitValue};
use serde::{Deserialize, Serialize};

mod refit;

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

/// Why a verdict is not ok, the first that applies in this order.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Cause {
    /// It is ok.
    #[default]
    None,
    /// The budget ran out before the fit converged.
    Budget,
    /// A refit of implicated fixed parameters fitted materially better but
    /// needs values the screening's range does not make plausible (at a
    /// bound, or beyond the assumed `fixed_spread`; [`RefitValue`]), or the
    /// score test implicates fixed parameters at a fit that stalled,
    /// misplaces a resonance or an escape search just reached, and no refit
    /// tested them: the screening and a local minimum are not told apart.
    ScreeningOrLocalMinimum,
    /// The residual points at parameters the update held fixed (score
    /// test) at a converged fit, or a refit of them fitted materially
    /// better with plausible values: the screening left out something these
    /// data see.
    ScreenedOut,
    /// A further search from other starts found a better fit (taken), so
    /// the landscape has other minima and the result may still be one.
    LocalMinimum,
    /// Above the noise, no fixed parameter implicated, and further starts
    /// end no better: the model cannot reproduce the data (form, damping
    /// model, the test itself).
    ModelError,
    /// Above the noise with nothing implicated, and no further search ran
    /// (no budget left, or no strategy for one): a local minimum and model
    /// error are not told apart.
    NotSearched,
    /// Within the noise, but reference modes are not reproduced (modes the
    /// model lacks, spurious or wrongly paired estimates).
    UnreproducedModes,
    /// The result fits worse than its start, or the optimizer stalled.
    Optimizer,
    /// Frequencies and shapes within the noise, but the identified damping
    /// parameters do not reproduce the reference's damping ratios
    /// ([`DampingJudgement`]): their values and intervals do not hold.
    Damping,
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
}

/// The worst window of `fit` when it is above [`LOCAL_NOISE_RMS`].
fn local_excess(fit: &FrfFit) -> Option<LocalMisfit> {
    fit.local.filter(|l| l.rms > LOCAL_NOISE_RMS)
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
    /// (`(name, change of ln p, statistic)`, largest first): not ok, and
    /// they are named in the message.
    pub fn with_implicated(mut self, implicated: &[(String, f64, f64)]) -> Verdict {
        if implicated.is_empty() {
            return self;
        }
        self.ok = false;
        let mut named: Vec<String> = implicated
            .iter()
            .take(NAMED_IMPLICATED)
            .map(|(name, change, t)| {
                format!("{name} ({:+.0} %, χ² {t:.0})", 100.0 * change.exp_m1())
            })
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
        self.implicated = implicated.iter().map(|i| i.0.clone()).collect();
        self.classified(SearchEvidence::default())
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
        self.refitted = values.iter().map(|v| v.parameter.clone()).collect();
        self.warnings.extend(refit::warning(&values));
        self.refit_values = values;
        self.classified(SearchEvidence::default())
    }

    /// The message with the cause named (once, at the end of an update).
    pub fn explained(mut self) -> Verdict {
        let line: String;
        let why: &str = match self.cause {
            Cause::None => return self,
            Cause::Budget => "cause: the budget ran out before the fit converged — give more",
            Cause::ScreeningOrLocalMinimum if self.refit_values.is_empty() => {
                line = format!(
                    "cause: the screening or a local minimum, not told apart — the score test implicates the fixed parameters named above, but at a fit that {}, where a wrong basin of the identified parameters makes the residual point at fixed ones too, and no refit tested them (`refit_implicated` off, or no budget left for it): give more budget so that the refit can tell, or check these parameters' file values",
                    self.off_minimum().unwrap_or("has not converged")
                );
                &line
            }
            Cause::ScreeningOrLocalMinimum => {
                line = refit::cause_line(
                    &self.refit_values,
                    self.status == Status::BudgetExhausted,
                );
                &line
            }
            Cause::ScreenedOut if self.implicated.is_empty() => {
                line = format!(
                    "cause: parameters the screening left fixed — {} refitted, and the fit is still above the noise{}",
                    self.refitted.join(", "),
                    if self.status == Status::BudgetExhausted {
                        " (the refit stopped at the budget: give more to let it finish)"
                    } else {
                        ": more of them, or model error, remain"
                    }
                );
                &line
            }
            Cause::ScreenedOut => "cause: parameters the screening left fixed (named above): the screening left out what these data see; identify them too (`refit_implicated`) or check the model file's values",
            Cause::LocalMinimum => "cause: a local minimum — a further search from other starts found a better fit (taken), so this one may not be the best either; more `restarts` or a larger budget",
            Cause::ModelError => "cause: model error — further starts end no better and no fixed parameter is implicated: the model's form, its damping model or the test itself (leakage, attachments) differs from the structure",
            Cause::NotSearched => "cause: not told apart — the fit ends above the noise with no fixed parameter implicated, and no further search from other starts ran (budget or strategy), so a local minimum and model error are both possible",
            Cause::UnreproducedModes => "cause: reference modes the model does not reproduce (named in the warnings)",
            Cause::Optimizer => "cause: the optimizer did not converge (stalled or ended worse than its start)",
            Cause::Damping => "cause: the damping — frequencies and shapes fit, but the identified dampers cannot reproduce the damping ratios: dampers held fixed off their values, a damping model the structure does not follow, a mode shape wrong where the damper sits, or reference damping ratios poorer than stated",
        };
        self.message = format!("{}; {why}", self.message);
        self
    }

    /// Name the cause (see [`Cause`]) from the verdict and the `evidence`
    /// of a further search.
    pub fn classified(mut self, evidence: SearchEvidence) -> Verdict {
        self.search = evidence;
        // Parameters the screening held fixed and a refit had to add, with
        // the fit still above the noise: the screening is the cause, even
        // when that refit (not the strategy) ran out of budget — more budget
        // for it is the remedy the message gives, not the diagnosis.
        // (A strategy cut by the budget runs no refit: its implicated
        // parameters come from an unconverged point, so the budget is named.)
        // A refit whose gain needs implausible values is no evidence for the
        // screening: it is named apart, before what is still implicated.
        let refit_short = !self.refitted.is_empty() && self.fit == Fit::AboveNoise;
        self.cause = if self.ok {
            Cause::None
        } else if self.status == Status::BudgetExhausted && !refit_short {
            Cause::Budget
        } else if refit_short && refit::any_implausible(&self.refit_values) {
            Cause::ScreeningOrLocalMinimum
        } else if !self.implicated.is_empty() && !refit_short && self.off_minimum().is_some() {
            // The score test holds at a minimum over the identified
            // parameters; away from one (stalled, or a resonance misplaced:
            // another basin) a refit must confirm what it implicates.
            Cause::ScreeningOrLocalMinimum
        } else if !self.implicated.is_empty() || refit_short {
            Cause::ScreenedOut
        } else if self.fit == Fit::AboveNoise {
            match evidence.escaped {
                Some(true) => Cause::LocalMinimum,
                Some(false) => Cause::ModelError,
                None => Cause::NotSearched,
            }
        } else if self.worse_than_start || self.status == Status::Stalled {
            Cause::Optimizer
        } else if self.modes.unpaired + self.modes.outliers + self.modes.weak == 0
            && self
                .damping
                .as_ref()
                .is_some_and(|d| d.fit == Fit::AboveNoise)
        {
            Cause::Damping
        } else {
            Cause::UnreproducedModes
        };
        self
    }
}

impl Verdict {
    /// Why the result may not be a minimum in the right basin, in words:
    /// the optimizer stalled above the noise, a further search just left
    /// another minimum for it, or a window of the FRFs misses a resonance
    /// the overall fit does not (another basin, or a mode the model lacks).
    /// `None` at a converged fit without any of these.
    fn off_minimum(&self) -> Option<&'static str> {
        if self.status == Status::Stalled {
            return Some("stalled before converging");
        }
        if self.search.escaped == Some(true) {
            return Some("an escape search reached from a worse basin (the landscape has other minima, and this may be one)");
        }
        let local = self.frf.as_ref().and_then(|f| local_excess(&f.end));
        local.map(|_| {
            "misses or misplaces a resonance (its worst window of lines is far above the noise)"
        })
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
