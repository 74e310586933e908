//! Parameter comparison of the evaluate kind: relative errors of estimated
//! parameters against the truth (`parameter_errors.csv`).

use super::write;
use super::{extreme, mean};
use crate::artifacts::metrics::ParameterMetrics;
use crate::stages::StageError;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// Relative errors of `estimate` against `truth` over their common parameters.
pub fn compare_parameters(
    truth: &BTreeMap<String, f64>,
    estimate: &BTreeMap<String, f64>,
    tables: &Path,
) -> Result<ParameterMetrics, StageError> {
    let mut csv = String::from("parameter,truth,estimate,relative_error,log10_ratio\n");
    let mut rel = Vec::new();
    for (name, &t) in truth {
        let Some(&e) = estimate.get(name) else {
            continue;
        };
        let r = (e - t) / t;
        let _ = writeln!(csv, "{name},{t},{e},{r},{}", (e / t).abs().log10());
        rel.push(r.abs());
    }
    if rel.is_empty() {
        return Err(StageError::InvalidInput {
            input: "estimate".into(),
            message: "no parameter in common with the truth".into(),
        });
    }
    write(&tables.join("parameter_errors.csv"), &csv)?;
    Ok(ParameterMetrics {
        parameters: rel.len(),
        mean_abs_relative_error: mean(&rel),
        max_abs_relative_error: extreme(&rel, f64::max),
    })
}
