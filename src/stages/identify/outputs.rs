//! The identify kind's tables: parameters.csv with identifiability and
//! uncertainty, correlation.csv (every reference mode: its nominal partner,
//! why it is used or not, its partner at the result), identifiability.json
//! and history.csv.

use crate::artifacts::correlation::CorrelationRow;
use crate::artifacts::history::HistoryRow;
use crate::artifacts::identifiability::IdentifiabilityFile;
use crate::artifacts::parameters::ParameterRow;
use crate::identify::identifiability::interval;
use crate::identify::updating::Update;
use crate::identify::ModalObjective;
use crate::stages::StageError;
use std::path::Path;

/// What the intervals assume (identifiability.json, the report).
pub const ASSUMPTIONS: &str = "Linearized (Gauss–Newton) at the result; residuals scaled by the reference's stated uncertainty and by the residual variance when it is larger, and FRF residuals correlated along frequency counted as fewer independent lines (variance × (1 + ρ)/(1 − ρ), ρ their lag-1 correlation), and, with FRFs, each identified parameter's data variance at least the leave-one-block-out (jackknife) sandwich over blocks of neighbouring lines across the channels of one reference at one position (3 integrated correlation times long), on Student's t for the blocks that carry it (a misfit concentrated where a parameter acts, or shared by the channels of one impact); the parameters held fixed vary as `fixed_spread` says (default: uniform over their bounds), conditioned on what the data say of them, and their effect is carried in linearly (consider covariance); intervals are cut at the parameter's bounds; the model's form is right. `std_error_rel` alone assumes the fixed parameters exact.";

pub fn write(path: &Path, text: &str) -> Result<(), StageError> {
    std::fs::write(path, text)
        .map_err(|e| StageError::io(format!("cannot write {}", path.display()), e))
}

/// A finite value, else none (CSV has no NaN).
fn finite(v: Option<f64>) -> Option<f64> {
    v.filter(|v| !v.is_nan())
}

/// parameters.csv ([`ParameterRow`]): `std_error_rel` is relative (of ln p),
/// the fixed parameters taken as exact; `std_error_with_fixed_rel` carries their
/// assumed spread in and gives the interval p·exp(∓1.96 σ) — both only for
/// parameters the data determine. Fixed parameters get the score test.
pub fn parameter_rows(o: &ModalObjective, u: &Update) -> Vec<ParameterRow> {
    o.parameters()
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let v = u.x[i];
            let analysis = u
                .identified
                .iter()
                .position(|&k| k == i)
                .map(|j| &u.identifiability.parameters[j]);
            let se = analysis.and_then(|a| a.std_error).filter(|s| s.is_finite());
            let j = u.identified.iter().position(|&k| k == i);
            let with_fixed =
                j.and_then(|j| u.identifiability.stated_std_error(j, u.consider.as_ref()));
            let test = u
                .consider
                .as_ref()
                .and_then(|c| c.fixed.iter().find(|f| f.parameter == p.name));
            let ci = with_fixed.map(|s| interval(v, s, (p.lower, p.upper)));
            ParameterRow {
                parameter: p.name.clone(),
                value: v,
                lower: p.lower,
                upper: p.upper,
                initial: u.start[i],
                identified: analysis.is_some(),
                identifiable: analysis.map(|a| a.identifiable),
                std_error_rel: se,
                std_error_with_fixed_rel: with_fixed,
                ci_low: ci.map(|c| c.0),
                ci_high: ci.map(|c| c.1),
                score: test.map(|t| t.statistic),
                implicated: test.map(|t| t.implicated),
                suggested_change_rel: test.map(|t| t.change.exp_m1()),
            }
        })
        .collect()
}

/// correlation.csv ([`CorrelationRow`]): one row per reference mode.
pub fn correlation_rows(o: &ModalObjective, u: &Update) -> Vec<CorrelationRow> {
    let mut rows = Vec::new();
    for (p, slot) in u.correspondence.slots.iter().enumerate() {
        for r in 0..o.modes_at(p) {
            let nominal = slot.partner[r].map(|k| &slot.nominal[k]);
            let end = &u.pairs[p][r];
            rows.push(CorrelationRow {
                position: slot.position,
                reference_mode: r + 1,
                reference_hz: o.reference_frequency(p, r),
                used: o.exclusion(p, r).is_none(),
                sigma_frequency: o.uncertainty_of(p, r).0,
                sigma_shape: o.uncertainty_of(p, r).1,
                reason: o.mode_use(p, r).reason().unwrap_or("").to_string(),
                nominal_mode: nominal.map_or(String::new(), |n| {
                    format!("p{}.mode{}", slot.position, n.number)
                }),
                nominal_hz: nominal.map(|n| n.frequency_hz),
                visibility: finite(nominal.map(|n| n.visibility)),
                mac_start: nominal.map(|n| n.mac),
                margin_start: finite(nominal.map(|n| n.margin)),
                model_mode: end.matched.map(|m| m.model_mode + 1),
                model_hz: end.matched.map(|m| m.frequency_hz),
                mac: end.matched.map(|m| m.mac),
                margin: finite(end.matched.map(|_| end.margin)),
                ambiguous: end.matched.map(|_| end.margin < o.pairing.ambiguity),
            });
        }
    }
    rows
}

/// identifiability.json ([`IdentifiabilityFile`]): the analysis with each
/// undetermined combination written out.
pub fn identifiability(u: &Update) -> IdentifiabilityFile {
    IdentifiabilityFile {
        schema_version: Default::default(),
        analysis: u.identifiability.clone(),
        undetermined_text: u
            .identifiability
            .undetermined
            .iter()
            .map(|c| c.describe())
            .collect(),
        fixed: u.consider.clone(),
        assumptions: ASSUMPTIONS.to_string(),
    }
}

/// history.csv ([`HistoryRow`]).
pub fn history_rows(u: &Update) -> Vec<HistoryRow> {
    u.history
        .iter()
        .map(|h| HistoryRow {
            evaluation: h.evaluation,
            best_objective: h.objective,
            mean_mac: h.mean_mac,
        })
        .collect()
}
