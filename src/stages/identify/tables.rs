//! The identify kind's tables and files as types: one schema for the writer
//! ([`super::outputs`]) and every reader (the report), so a renamed column
//! is a compile error, not a silent "–" (STYLE rule 14).

use crate::identify::Identifiability;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One row of parameters.csv.
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
    pub std_error: Option<f64>,
    /// Relative standard error (of ln p) with the fixed parameters' assumed
    /// spread carried in (consider covariance; `fixed_spread`).
    #[serde(default)]
    pub std_error_with_fixed: Option<f64>,
    /// 95 % interval p·exp(∓1.96 σ) with σ = `std_error_with_fixed` (absolute,
    /// in the parameter's unit).
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
    #[serde(default)]
    pub suggested_change: Option<f64>,
}

/// One row of correlation.csv: a reference mode, its partner among the
/// model's modes at the start ("nominal") and at the result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CorrelationRow {
    pub position: u32,
    /// 1-based, as in the reference.
    pub reference_mode: usize,
    pub reference_hz: f64,
    pub used: bool,
    /// The standard deviations its residuals are scaled by: relative
    /// frequency and per shape component (defaults raised by the shape's
    /// complexity and the spread the reference states; 0 in files written
    /// before these columns existed).
    #[serde(default)]
    pub sigma_frequency: f64,
    #[serde(default)]
    pub sigma_shape: f64,
    /// Why it is not used.
    pub reason: String,
    /// `p<position>.mode<r>` of its partner at the start.
    pub nominal_mode: String,
    pub nominal_hz: Option<f64>,
    /// Sensor amplitude of that partner relative to the median mode.
    pub visibility: Option<f64>,
    pub mac_start: Option<f64>,
    /// Increase of the pairing cost if the pair were forbidden (`inf`: no
    /// other pairing keeps as many pairs).
    pub margin_start: Option<f64>,
    /// 1-based number of its partner among the model's modes at the result.
    pub model_mode: Option<usize>,
    pub model_hz: Option<f64>,
    pub mac: Option<f64>,
    pub margin: Option<f64>,
    /// The margin at the result is below the pairing's `ambiguity`.
    pub ambiguous: Option<bool>,
}

/// identifiability.json: the analysis plus each undetermined combination
/// in words.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IdentifiabilityFile {
    #[serde(flatten)]
    pub analysis: Identifiability,
    #[serde(default)]
    pub undetermined_text: Vec<String>,
    /// The fixed parameters at the result: consider spreads and score tests.
    #[serde(default)]
    pub fixed: Option<crate::identify::consider::Consider>,
    /// What the intervals of parameters.csv assume, in words.
    #[serde(default)]
    pub assumptions: String,
}

impl IdentifiabilityFile {
    pub fn read(path: &Path) -> Result<IdentifiabilityFile, String> {
        let bytes =
            std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        serde_json::from_slice(&bytes).map_err(|e| {
            format!(
                "{} is not an identify identifiability.json: {e}",
                path.display()
            )
        })
    }
}

/// The rows of an identify CSV table (`what` names it in errors).
pub fn read_rows<T: serde::de::DeserializeOwned>(
    path: &Path,
    what: &str,
) -> Result<Vec<T>, String> {
    let mut reader =
        csv::Reader::from_path(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    reader
        .deserialize()
        .enumerate()
        .map(|(k, row)| row.map_err(|e| format!("line {}: not an identify {what}: {e}", k + 2)))
        .collect()
}

/// `rows` as CSV text with a header.
pub fn to_csv<T: Serialize>(rows: &[T]) -> Result<String, String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r).map_err(|e| e.to_string())?;
    }
    let bytes = w.into_inner().map_err(|e| e.to_string())?;
    String::from_utf8(bytes).map_err(|e| e.to_string())
}
