//! Parameter comparison of the evaluate kind: relative errors of estimated
//! parameters against the truth (`parameter_errors.csv`), and the reader of
//! parameter tables (`parameter,value,...`) other kinds share.

use super::schema::{extreme, mean, ParameterMetrics};
use super::write;
use crate::stages::StageError;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// `parameter → value` from a parameters.csv (`parameter,value,...`).
pub fn read_parameters(path: &Path, input: &str) -> Result<BTreeMap<String, f64>, StageError> {
    let bad = |message: String| StageError::InvalidInput {
        input: input.into(),
        message,
    };
    let mut reader =
        csv::Reader::from_path(path).map_err(|e| bad(format!("not a parameters.csv: {e}")))?;
    let headers = reader.headers().map_err(|e| bad(e.to_string()))?.clone();
    let col = |name: &str| {
        headers.iter().position(|h| h == name).ok_or_else(|| {
            bad(format!(
                "no `{name}` column (columns: {})",
                headers.iter().collect::<Vec<_>>().join(", ")
            ))
        })
    };
    let (pc, vc) = (col("parameter")?, col("value")?);
    let mut out = BTreeMap::new();
    for (line, rec) in reader.records().enumerate() {
        let rec = rec.map_err(|e| bad(e.to_string()))?;
        let v: f64 = rec
            .get(vc)
            .unwrap_or_default()
            .trim()
            .parse()
            .map_err(|_| bad(format!("line {}: value is not a number", line + 2)))?;
        if !v.is_finite() {
            return Err(bad(format!("line {}: value is not finite", line + 2)));
        }
        out.insert(rec.get(pc).unwrap_or_default().to_string(), v);
    }
    Ok(out)
}

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
