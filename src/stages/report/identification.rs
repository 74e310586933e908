//! The identifiability section of a report: per identify stage, the
//! parameter combinations the data do not determine (from its
//! identifiability.json) and a table of the identified parameters with
//! value, relative standard error, 95 % interval and whether the data
//! determine them (from its parameters.csv; without one, from the analysis
//! alone). The two inputs are matched by stage; either may be bound alone.
//!
//! A parameter the data do not determine is marked ✗: its value is one of
//! many that fit equally well, not a measurement.
//!
//! When an evaluate stage had the truth (its `parameter_errors.csv` in the
//! bound `tables`), the table shows the true value, the error and whether
//! the 95 % interval holds the truth (✗ when not).

use super::{pct, sig4};
use crate::artifacts::identifiability::IdentifiabilityFile;
use crate::artifacts::parameters::{read_identified, ParameterRow};
use crate::report::document::{Document, Tone};
use crate::stages::StageError;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// The true parameter values from evaluate tables (`parameter_errors.csv`:
/// `parameter,truth,…`); a parameter whose truths disagree between stages
/// is left out.
pub fn truth(tables: &[(String, PathBuf)]) -> BTreeMap<String, f64> {
    let mut out: BTreeMap<String, Option<f64>> = BTreeMap::new();
    for (_, dir) in tables {
        let Ok(text) = std::fs::read_to_string(dir.join("parameter_errors.csv")) else {
            continue;
        };
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
        let col = |n: &str| header.iter().position(|h| *h == n);
        let (Some(c_name), Some(c_truth)) = (col("parameter"), col("truth")) else {
            continue;
        };
        for line in lines {
            let f: Vec<&str> = line.split(',').collect();
            let (Some(name), Some(t)) = (
                f.get(c_name),
                f.get(c_truth).and_then(|v| v.parse::<f64>().ok()),
            ) else {
                continue;
            };
            let e = out.entry(name.to_string()).or_insert(Some(t));
            if *e != Some(t) {
                *e = None;
            }
        }
    }
    out.into_iter().filter_map(|(k, v)| Some((k, v?))).collect()
}

/// Stages in order of first appearance in either list.
fn stages<'a>(a: &'a [(String, PathBuf)], b: &'a [(String, PathBuf)]) -> Vec<&'a str> {
    let mut out: Vec<&str> = Vec::new();
    for (s, _) in a.iter().chain(b) {
        if !out.contains(&s.as_str()) {
            out.push(s);
        }
    }
    out
}

pub fn identifiability(
    doc: &mut Document,
    analyses: &[(String, PathBuf)],
    parameters: &[(String, PathBuf)],
    tables: &[(String, PathBuf)],
) -> Result<(), StageError> {
    let names = stages(analyses, parameters);
    let truth = truth(tables);
    if names.is_empty() {
        return Ok(());
    }
    doc.heading(2, "Identifiability and uncertainty");
    doc.paragraph(
        "At the result: SVD of the Jacobian of the weighted residuals. A parameter in a direction the \
         modes cannot see, or whose standard error exceeds the limit, is not identifiable (✗): its value \
         is one of many that fit as well. Standard errors are relative, from the Gauss–Newton \
         covariance scaled by the residual variance; intervals are 95 %.",
    );
    for stage in names {
        let find = |list: &[(String, PathBuf)]| {
            list.iter()
                .find(|(s, _)| s == stage)
                .map(|(_, p)| p.clone())
        };
        let analysis = find(analyses)
            .map(|p| IdentifiabilityFile::read(&p).map_err(|e| e.to_string()))
            .transpose()
            .map_err(|m| invalid("identifiability", stage, m))?;
        let rows = find(parameters)
            .map(|p| read_identified(&p).map_err(|e| e.to_string()))
            .transpose()
            .map_err(|m| invalid("parameters", stage, m))?;
        doc.heading(3, stage);
        if let Some(a) = &analysis {
            undetermined(doc, a);
        }
        match (&rows, &analysis) {
            (Some(rows), _) => parameter_table(doc, rows, analysis.as_ref(), &truth),
            (None, Some(a)) => analysis_table(doc, &a.analysis),
            (None, None) => {}
        }
    }
    Ok(())
}

fn invalid(input: &str, stage: &str, message: String) -> StageError {
    StageError::InvalidInput {
        input: input.into(),
        message: format!("{stage}: {message}"),
    }
}

/// The rank line and the combinations the data do not determine.
fn undetermined(doc: &mut Document, a: &IdentifiabilityFile) {
    let x = &a.analysis;
    let variance = x.residual_variance.map_or("–".into(), |v| sig4(Some(v)));
    doc.paragraph(format!(
        "Rank {} of {} parameters from {} residuals; residual variance σ̂² = {variance} \
         (≈ 1: fits to the stated noise; ≫ 1: model error); standard-error limit {}.",
        x.rank,
        x.parameters.len(),
        x.residuals,
        pct(Some(x.max_std_error)) + " %",
    ));
    if a.undetermined_text.is_empty() {
        doc.callout(
            Tone::Pass,
            "The data determine every identified parameter",
            Vec::new(),
        );
    } else {
        doc.callout(
            Tone::Warning,
            "The data do not determine these parameter combinations",
            a.undetermined_text.clone(),
        );
    }
}

/// `✓ yes`, or `✗ no` with the reason when the analysis gives it.
fn identifiable_cell(identifiable: Option<bool>, structural: Option<bool>) -> String {
    match (identifiable, structural) {
        (Some(true), _) => "✓ yes".into(),
        (Some(false), Some(true)) => "✗ no: the modes cannot see it".into(),
        (Some(false), Some(false)) => "✗ no: standard error above the limit".into(),
        (Some(false), None) => "✗ no".into(),
        (None, _) => "–".into(),
    }
}

fn parameter_table(
    doc: &mut Document,
    rows: &[ParameterRow],
    a: Option<&IdentifiabilityFile>,
    truth: &BTreeMap<String, f64>,
) {
    let with_truth = rows
        .iter()
        .any(|r| r.identified && truth.contains_key(&r.parameter));
    let structural = |name: &str| {
        a.and_then(|a| {
            a.analysis
                .parameters
                .iter()
                .find(|p| p.parameter == name)
                .map(|p| p.structural)
        })
    };
    let table = rows
        .iter()
        .filter(|r| r.identified)
        .map(|r| {
            let interval = match (r.ci_low, r.ci_high) {
                (Some(lo), Some(hi)) => format!("[{}, {}]", sig4(Some(lo)), sig4(Some(hi))),
                _ => "–".into(),
            };
            let mut row = vec![
                r.parameter.clone(),
                sig4(Some(r.value)),
                sig4(Some(r.initial)),
                pct(r.std_error_rel),
                interval,
                identifiable_cell(r.identifiable, structural(&r.parameter)),
            ];
            if with_truth {
                row.extend(truth_cells(r, truth.get(&r.parameter).copied()));
            }
            row
        })
        .collect();
    let mut header = vec![
        "parameter",
        "value",
        "start",
        "std error %",
        "95 % interval",
        "identifiable",
    ];
    if with_truth {
        header.extend(["truth", "error %", "truth in interval"]);
    }
    doc.table(header.into_iter().map(String::from).collect(), table);
    let held: Vec<&str> = rows
        .iter()
        .filter(|r| !r.identified)
        .map(|r| r.parameter.as_str())
        .collect();
    if !held.is_empty() {
        const SHOWN: usize = 20;
        let more = held.len().saturating_sub(SHOWN);
        doc.paragraph(format!(
            "Not identified (kept at their start values): {}{}.",
            held[..held.len().min(SHOWN)].join(", "),
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            }
        ));
    }
}

/// The truth, the error (value − truth)/truth and whether the interval
/// holds the truth.
fn truth_cells(r: &ParameterRow, truth: Option<f64>) -> [String; 3] {
    let Some(t) = truth else {
        return ["–".into(), "–".into(), "–".into()];
    };
    let covered = match (r.ci_low, r.ci_high) {
        (Some(lo), Some(hi)) if (lo..=hi).contains(&t) => "✓ yes".to_string(),
        (Some(_), Some(_)) => "✗ no".into(),
        _ => "–".into(),
    };
    [
        sig4(Some(t)),
        crate::report::format::sig(100.0 * (r.value - t) / t, 3),
        covered,
    ]
}

/// Without a parameters.csv: the analysis' own per-parameter results.
fn analysis_table(doc: &mut Document, a: &crate::identify::Identifiability) {
    let rows = a
        .parameters
        .iter()
        .map(|p| {
            vec![
                p.parameter.clone(),
                pct(p.std_error),
                pct(Some(p.prior_std_error)),
                identifiable_cell(Some(p.identifiable), Some(p.structural)),
            ]
        })
        .collect();
    doc.table(
        [
            "parameter",
            "std error %",
            "a-priori std error %",
            "identifiable",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    );
}
