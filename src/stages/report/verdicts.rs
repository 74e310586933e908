//! The verdicts of identifications in a report: a box at the top that says
//! how many failed (red, with each failed run's message) or that all passed,
//! and the cost table — evaluations, seconds, the match, and the verdict
//! split into ok (✓/✗), status, fit (with the end residual in σ units) and
//! message.

use super::{sig4, Metrics};
use crate::artifacts::cost::Cost;
use crate::identify::verdict::{Fit, Status, Verdict};
use crate::report::document::{Document, Tone};

/// `✓ ok` or `✗ failed`.
pub fn ok_cell(v: &Verdict) -> String {
    if v.ok { "✓ ok" } else { "✗ failed" }.into()
}

/// The optimizer's ending, marked ✗ unless converged.
pub fn status_cell(v: &Verdict) -> String {
    match v.status {
        Status::Converged => "converged".into(),
        Status::Stalled => "✗ stalled".into(),
        Status::BudgetExhausted => "✗ budget exhausted".into(),
    }
}

/// The fit with its end residual (σ units), marked ✗ above the noise or
/// when worse than the start.
/// With FRFs the residual shown is the FRF one (noise units), marked as such.
pub fn fit_cell(v: &Verdict) -> String {
    let (end, start, what) = match &v.frf {
        Some(f) => (f.end.rms, f.start.rms, "FRF "),
        None => (v.end_rms, v.start_rms, ""),
    };
    let rms = if end.is_finite() {
        format!("{what}{end:.2}σ")
    } else {
        "model unsolvable".into()
    };
    let mut s = match v.fit {
        Fit::WithinNoise => format!("within noise ({rms})"),
        Fit::AboveNoise => format!("✗ above noise ({rms})"),
    };
    if v.worse_than_start {
        if !s.starts_with('✗') {
            s.insert_str(0, "✗ ");
        }
        s.push_str(&format!(", worse than start ({start:.2}σ)"));
    }
    s
}

/// A box at the top: the failed verdicts with their messages, or that all
/// passed. The costs' verdicts count; without costs, those copied into
/// evaluate metrics.
pub fn summary(doc: &mut Document, costs: &[(String, Cost)], metrics: &[(String, Metrics)]) {
    let verdicts: Vec<(&str, &Verdict)> = if costs.is_empty() {
        metrics
            .iter()
            .filter_map(|(s, m)| m.verdict.as_ref().map(|v| (s.as_str(), v)))
            .collect()
    } else {
        costs
            .iter()
            .map(|(s, c)| (s.as_str(), &c.verdict))
            .collect()
    };
    if verdicts.is_empty() {
        return;
    }
    let failed: Vec<String> = verdicts
        .iter()
        .filter(|(_, v)| !v.ok)
        .map(|(s, v)| format!("{s}: {}", v.message))
        .collect();
    let n = verdicts.len();
    let runs = |k: usize| {
        if k == 1 {
            "identification"
        } else {
            "identifications"
        }
    };
    if failed.is_empty() {
        doc.callout(
            Tone::Pass,
            format!(
                "{n} {} passed the verdict: converged, within the reference's noise, every used mode paired",
                runs(n)
            ),
            Vec::new(),
        );
    } else {
        doc.callout(
            Tone::Failure,
            format!(
                "{} of {n} {} FAILED the verdict — do not use their parameters without a look",
                failed.len(),
                runs(n)
            ),
            failed,
        );
    }
}

/// The cost table with the verdict (the warnings are in their own section,
/// [`super::warnings`]).
pub fn costs(doc: &mut Document, costs: &[(String, Cost)]) {
    if costs.is_empty() {
        return;
    }
    let rows = costs
        .iter()
        .map(|(stage, c)| {
            let v = &c.verdict;
            vec![
                stage.clone(),
                format!("{} / {}", c.strategy, c.optimizer),
                c.evaluations.to_string(),
                format!("{:.2}", c.seconds),
                sig4(Some(c.best_objective)),
                sig4(Some(c.modes.mean_mac)),
                ok_cell(v),
                status_cell(v),
                fit_cell(v),
                v.message.clone(),
            ]
        })
        .collect();
    doc.heading(2, "Cost and verdict");
    doc.paragraph(
        "The verdict is ok when the optimizer converged, the weighted residual at the result is within \
         the reference's noise (RMS ≤ 2σ), the result fits no worse than the start, and every used \
         reference mode has a model partner. When the measured FRFs were given, their residual (in units \
         of each channel's noise) decides instead, and the modal bookkeeping becomes warnings.",
    );
    doc.table(
        [
            "stage",
            "strategy / optimizer",
            "evaluations",
            "seconds",
            "best objective",
            "mean MAC",
            "verdict",
            "status",
            "fit (end RMS)",
            "message",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    );
}
