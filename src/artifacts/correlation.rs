//! `correlation`: the identify kind's `correlation.csv`, one row per
//! reference mode: its partner among the model's modes at the start
//! ("nominal") and at the result, and why it is used or not.

use super::{read_rows, to_csv, write_file, ArtifactError};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The file name of a `correlation` output.
pub const FILE: &str = "correlation.csv";

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
    /// Why it is not used, or (used) why only its frequency is compared.
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

/// Write a correlation.csv.
pub fn write(path: &Path, rows: &[CorrelationRow]) -> Result<(), ArtifactError> {
    write_file(path, to_csv(rows, FILE)?)
}

/// The rows of a correlation.csv.
pub fn read(path: &Path) -> Result<Vec<CorrelationRow>, ArtifactError> {
    read_rows(path, "an identify correlation.csv")
}
