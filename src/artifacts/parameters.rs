//! `parameters`: `parameters.csv`, one row per model parameter, written two
//! ways from one set of leading columns (`parameter,value,lower,upper`, in
//! the parameter's unit):
//! - a truth (synthesize): [`TruthRow`], adding `scale,kind`;
//! - an identification (identify): [`ParameterRow`], adding the start value,
//!   whether the data determine it, relative standard errors
//!   (`std_error_rel`, of ln p), an absolute 95 % interval (`ci_low`,
//!   `ci_high`) and, for fixed parameters, the score test.
//!
//! Every reader that needs only values uses [`read_values`], which takes
//! either. Version 1 of the identify table named the relative columns
//! `std_error`, `std_error_with_fixed` and `suggested_change`; they are read
//! under their old names too.

use super::{read_rows, to_csv, write_file, ArtifactError};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The file name of a `parameters` output.
pub const FILE: &str = "parameters.csv";

/// One row of a synthesize parameters.csv (the truth).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TruthRow {
    pub parameter: String,
    pub value: f64,
    pub lower: f64,
    pub upper: f64,
    /// `linear` or `log` (how the optimizers see the parameter).
    pub scale: String,
    /// `stiffness` or `damping`.
    pub kind: String,
}

/// One row of an identify parameters.csv.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParameterRow {
    pub parameter: String,
    pub value: f64,
    pub lower: f64,
    pub upper: f64,
    /// The start value.
    pub initial: f64,
    /// Moved by the strategy.
    pub identified: bool,
    /// Determined by the data (identified parameters only).
    pub identifiable: Option<bool>,
    /// Relative standard error (of ln p) from the data alone, every fixed
    /// parameter taken as exact; identifiable parameters only.
    #[serde(alias = "std_error")]
    pub std_error_rel: Option<f64>,
    /// Relative standard error (of ln p) with the fixed parameters' assumed
    /// spread carried in (consider covariance; `fixed_spread`).
    #[serde(default, alias = "std_error_with_fixed")]
    pub std_error_with_fixed_rel: Option<f64>,
    /// 95 % interval p·exp(∓1.96 σ) with σ = `std_error_with_fixed_rel`
    /// (absolute: in the parameter's unit, like `value`).
    pub ci_low: Option<f64>,
    pub ci_high: Option<f64>,
    /// Fixed parameters: the score test's χ²₁ statistic (is its value right?).
    #[serde(default)]
    pub score: Option<f64>,
    /// Fixed parameters: the residual points at it (score test above the
    /// Bonferroni-corrected quantile).
    #[serde(default)]
    pub implicated: Option<bool>,
    /// Fixed parameters: the relative change the data point to (linearized).
    #[serde(default, alias = "suggested_change")]
    pub suggested_change_rel: Option<f64>,
}

/// Write a parameters.csv of either row type.
pub fn write<T: Serialize>(path: &Path, rows: &[T]) -> Result<(), ArtifactError> {
    write_file(path, to_csv(rows, "parameters.csv")?)
}

/// The rows of an identify parameters.csv.
pub fn read_identified(path: &Path) -> Result<Vec<ParameterRow>, ArtifactError> {
    read_rows(path, "an identify parameters.csv")
}

/// The rows of a synthesize parameters.csv.
pub fn read_truth(path: &Path) -> Result<Vec<TruthRow>, ArtifactError> {
    read_rows(path, "a synthesize parameters.csv")
}

/// The leading columns every parameters.csv has.
#[derive(Deserialize)]
struct ValueRow {
    parameter: String,
    value: f64,
}

/// `parameter → value` from any parameters.csv bound to input `input`;
/// every value must be finite.
pub fn read_values(path: &Path, input: &str) -> Result<BTreeMap<String, f64>, ArtifactError> {
    let rows: Vec<ValueRow> = read_rows(path, "a parameters.csv (`parameter,value,...`)")
        .map_err(|e| ArtifactError::invalid(input, e.to_string()))?;
    let mut out = BTreeMap::new();
    for (line, r) in rows.into_iter().enumerate() {
        if !r.value.is_finite() {
            return Err(ArtifactError::invalid(
                input,
                format!(
                    "line {}: value of `{}` is not finite",
                    line + 2,
                    r.parameter
                ),
            ));
        }
        out.insert(r.parameter, r.value);
    }
    Ok(out)
}
