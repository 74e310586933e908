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

use serde::{Deserialize, Serialize};

/// Weighted-residual RMS (σ units) up to which a fit is within the noise.
pub const NOISE_RMS: f64 = 2.0;

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
    /// One line a person reads first.
    pub message: String,
    /// Everything else worth a look.
    pub warnings: Vec<String>,
}

impl Verdict {
    /// Judge a result: `start_rms`/`end_rms` are weighted-residual RMS values.
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
        let lost = modes.unpaired + modes.outliers;
        let ok = status == Status::Converged && fit == Fit::WithinNoise && !worse && lost == 0;
        let mut parts = vec![match status {
            Status::Converged => "converged".to_string(),
            Status::Stalled => "stalled before converging".to_string(),
            Status::BudgetExhausted => "stopped by the budget before converging".to_string(),
        }];
        parts.push(match fit {
            Fit::WithinNoise => format!(
                "residual {end_rms:.2}σ RMS: the model reproduces the reference within its uncertainty"
            ),
            Fit::AboveNoise => format!(
                "residual {end_rms:.1}σ RMS is above the reference's uncertainty (start {start_rms:.1}σ): model error, wrongly paired modes or a local minimum"
            ),
        });
        if worse {
            parts.push("the result fits WORSE than the start".into());
        }
        if lost > 0 {
            parts.push(format!(
                "but {lost} of {} used reference modes are not reproduced ({} without a model partner, {} outliers): spurious or wrongly paired modes, or a local minimum",
                modes.used, modes.unpaired, modes.outliers
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
            message: parts.join("; "),
            warnings,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn counts() -> ModeCounts {
        ModeCounts {
            reference: 10,
            used: 9,
            excluded: 1,
            unpaired: 0,
            ambiguous: 0,
            outliers: 0,
        }
    }

    #[test]
    fn a_converged_fit_within_noise_is_ok_and_anything_else_is_not() {
        let v = Verdict::judge(Status::Converged, 40.0, 0.3, counts(), 20, 18, vec![]);
        assert!(v.ok && v.fit == Fit::WithinNoise && !v.worse_than_start);
        assert_eq!(v.warnings.len(), 1, "{:?}", v.warnings);
        let above = Verdict::judge(Status::Converged, 40.0, 7.5, counts(), 20, 20, vec![]);
        assert!(!above.ok && above.fit == Fit::AboveNoise);
        assert!(above.message.contains("7.5σ"), "{}", above.message);
        let floor = Verdict::judge(Status::Stalled, 9.0, 0.5, counts(), 20, 20, vec![]);
        assert_eq!(floor.status, Status::Converged);
        let worse = Verdict::judge(Status::Stalled, 3.0, 4.0, counts(), 20, 20, vec![]);
        assert_eq!(worse.status, Status::Stalled);
        assert!(!worse.ok && worse.worse_than_start);
        assert!(worse.message.contains("WORSE"), "{}", worse.message);
        let budget = Verdict::judge(Status::BudgetExhausted, 9.0, 1.0, counts(), 5, 5, vec![]);
        assert!(!budget.ok);
        let lost = ModeCounts {
            unpaired: 2,
            ..counts()
        };
        assert!(!Verdict::judge(Status::Converged, 9.0, 1.0, lost, 5, 5, vec![]).ok);
        let outlier = ModeCounts {
            outliers: 1,
            ..counts()
        };
        let v = Verdict::judge(Status::Converged, 9.0, 1.0, outlier, 5, 5, vec![]);
        assert!(!v.ok && v.message.contains("1 outliers"), "{}", v.message);
        // NaN residuals (model unsolvable) are never within the noise.
        let nan = Verdict::judge(Status::Converged, 9.0, f64::NAN, counts(), 5, 5, vec![]);
        assert!(!nan.ok && nan.worse_than_start);
    }

    #[test]
    fn terminations_map_to_statuses() {
        use crate::optimize::Termination as T;
        assert_eq!(Status::of(&T::Converged), Status::Converged);
        assert_eq!(Status::of(&T::BudgetExhausted), Status::BudgetExhausted);
        assert_eq!(Status::of(&T::Stalled), Status::Stalled);
        assert_eq!(
            Status::of(&T::Failed {
                message: "x".into()
            }),
            Status::Stalled
        );
    }
}
