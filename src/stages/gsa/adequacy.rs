//! Adequacy of a Sobol screening in the `gsa` stage (issue 26): the
//! validated threshold rule ([`crate::sensitivity::selection`]), the
//! bootstrap intervals of the combined indices against the threshold
//! applied ([`crate::sensitivity::adequacy`]), the split tables that carry
//! both, and the stage warnings that say when the sample size cannot decide
//! the split or the rule missed its target.

use super::num;
use super::spec::{Grow, SobolSpec};
use crate::artifacts::significant::SignificantRow;
use crate::parameter::nominal;
use crate::sensitivity::{self, sobol::SobolReport, Adequacy, Screening, Selection};
use crate::simulator::Model;
use crate::stages::{StageContext, StageError};
use std::fmt::Write;

/// Seed offset of the selection's probes: a stream apart from the Sobol
/// points and from the reported validation, which so checks the cut on
/// fresh samples.
const SELECTION_STREAM: u64 = 0x5345_4c45_4354_494f;

/// The parameters in decreasing order of their combined index (ties by name).
pub fn ranked(screening: &Screening) -> Vec<(String, f64)> {
    let mut ranked = screening.combined_ST.clone();
    ranked.sort_by(|a, b| b.1.total_cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
    ranked
}

/// With `min_conformity`, grow the threshold's set in ranking order until the
/// validation reaches it; the split then holds the kept set. Returns the
/// selection and the threshold applied: midway between the last kept and the
/// first dropped combined index (the configured threshold without a
/// selection).
pub fn select(
    ctx: &StageContext,
    model: &dyn Model,
    report: &SobolReport,
    screening: &mut Screening,
    s: &SobolSpec,
) -> Result<(Option<Selection>, f64), StageError> {
    let Some(target) = s.min_conformity else {
        return Ok((None, s.threshold));
    };
    let ranked = ranked(screening);
    let names: Vec<String> = ranked.iter().map(|(p, _)| p.clone()).collect();
    let start = screening.significant.len();
    ctx.progress.set_message(format!(
        "selection: growing {start} parameters to min conformity {target}"
    ));
    let x0 = nominal(model.parameters());
    let seed = ctx.seed ^ SELECTION_STREAM;
    let selection = match s.grow {
        Grow::Ranking => sensitivity::select_by_validation(
            model,
            &names,
            start,
            &x0,
            target,
            s.validation,
            seed,
            &|_| {},
        ),
        Grow::WorstOutput => {
            let total: Vec<(String, Vec<f64>)> = report
                .outputs
                .iter()
                .map(|(o, i)| (o.clone(), i.ST.clone()))
                .collect();
            let influence = sensitivity::Influence {
                parameters: &report.parameters,
                total: &total,
            };
            let (v, t) = (s.validation, target);
            sensitivity::select_guided(model, &names, &influence, start, &x0, t, v, seed, &|_| {})
        }
    }
    .map_err(|e| StageError::Failed(format!("selection: {e}")))?;
    let k = selection.kept.len();
    let last = k.checked_sub(1).and_then(|i| ranked.get(i)).map(|r| r.1);
    let applied = match (last, ranked.get(k)) {
        (Some(last), Some((_, next))) => 0.5 * (last + next),
        (None, Some((_, first))) => *first,
        (Some(last), None) => last,
        (None, None) => s.threshold,
    };
    let (kept, dropped): (Vec<_>, Vec<_>) = screening
        .combined_ST
        .iter()
        .map(|(p, _)| p.clone())
        .partition(|p| selection.kept.contains(p));
    screening.significant = kept;
    screening.non_significant = dropped;
    Ok((Some(selection), applied))
}

/// Bootstrap intervals of the combined indices and the parameters whose
/// interval straddles `threshold`.
pub fn intervals(
    report: &SobolReport,
    screening: &Screening,
    weights: &[f64],
    threshold: f64,
    s: &SobolSpec,
) -> Result<Adequacy, StageError> {
    let resamples: Vec<&[Vec<f64>]> = report
        .outputs
        .iter()
        .map(|(_, i)| i.ST_resamples.as_slice())
        .collect();
    let scores: Vec<f64> = screening.combined_ST.iter().map(|(_, v)| *v).collect();
    sensitivity::score_intervals(
        &report.parameters,
        &scores,
        &resamples,
        weights,
        s.combine,
        threshold,
        s.confidence,
        s.samples,
    )
    .map_err(|e| StageError::Failed(e.to_string()))
}

/// The adequacy fields of `subproblems.json`: the kept set's size, the
/// threshold applied, the undecided parameters with the suggested N, and
/// the selection's probes.
pub fn json(
    adequacy: &Adequacy,
    selection: Option<&Selection>,
    applied: f64,
    screening: &Screening,
) -> serde_json::Map<String, serde_json::Value> {
    let mut map = serde_json::Map::new();
    map.insert("kept".into(), screening.significant.len().into());
    map.insert("threshold_applied".into(), applied.into());
    map.insert("undecided".into(), adequacy.undecided.clone().into());
    map.insert(
        "suggested_samples".into(),
        adequacy.suggested_samples.into(),
    );
    map.insert(
        "selection".into(),
        serde_json::to_value(selection).unwrap_or(serde_json::Value::Null),
    );
    map
}

/// `significant.csv`: the split in parameter order with each combined
/// index's interval, whether it straddles the threshold applied, and the
/// base sample size that would decide it.
pub fn split_rows(screening: &Screening, adequacy: &Adequacy) -> Vec<SignificantRow> {
    screening
        .combined_ST
        .iter()
        .zip(&adequacy.intervals)
        .map(|((p, v), iv)| SignificantRow {
            parameter: p.clone(),
            score: *v,
            score_low: Some(v - iv.half_width),
            score_high: Some(v + iv.half_width),
            undecided: Some(iv.undecided),
            samples_needed: iv.samples_needed,
            significant: screening.significant.contains(p),
        })
        .collect()
}

/// The stage warnings: parameters the sample size cannot decide, with the
/// size that would; a selection that never reached its target.
pub fn warnings(adequacy: &Adequacy, selection: Option<&Selection>) -> Vec<String> {
    let mut out = Vec::new();
    let undecided = &adequacy.undecided;
    if !undecided.is_empty() {
        let hopeless: Vec<&str> = adequacy
            .intervals
            .iter()
            .filter(|i| i.undecided && i.samples_needed.is_none())
            .map(|i| i.parameter.as_str())
            .collect();
        let mut w = format!(
            "N = {} samples cannot decide {} of {} parameters: the {} % bootstrap interval of their combined total index straddles the threshold {} ({})",
            adequacy.samples,
            undecided.len(),
            adequacy.intervals.len(),
            100.0 * adequacy.confidence,
            num(adequacy.threshold),
            undecided.join(", ")
        );
        if let Some(n) = adequacy.suggested_samples {
            let _ = write!(
                w,
                "; about `samples: {n}` would decide them (the interval narrows as 1/√N)"
            );
        }
        if !hopeless.is_empty() {
            let _ = write!(
                w,
                "; {} sit(s) on the threshold: no feasible N decides them, move the threshold or keep them",
                hopeless.join(", ")
            );
        }
        out.push(w);
    }
    if let Some(sel) = selection.filter(|s| !s.passed) {
        out.push(format!(
            "no subset of the ranking reached the minimum conformity {} in the validation's probes (all {} parameters kept; best {:.4})",
            num(sel.target),
            sel.kept.len(),
            sel.probes.iter().map(|p| p.min).fold(f64::NEG_INFINITY, f64::max)
        ));
    }
    out
}

/// A warning when the reported validation (fresh samples) misses the
/// target the selection reached on its probes.
pub fn check_validation(
    selection: Option<&Selection>,
    min: f64,
    worst: &str,
    samples: usize,
) -> Option<String> {
    let sel = selection.filter(|s| s.passed && min < s.target)?;
    Some(format!(
        "the kept set ({} parameters) reached min conformity {} on the selection's {} samples, but the validation's {samples} fresh samples give {:.4} (`{worst}`): the minimum over so few samples is itself uncertain; raise `validation` or `min_conformity`",
        sel.kept.len(),
        num(sel.target),
        sel.samples,
        min
    ))
}
