//! `history`: a convergence `history.csv`, one row per improvement of the
//! best objective (`evaluation,best_objective,mean_mac`).

use super::{read_rows, to_csv, write_file, ArtifactError};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The file name of a `history` output.
pub const FILE: &str = "history.csv";

/// One row of history.csv.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HistoryRow {
    /// 1-based count of model evaluations so far.
    pub evaluation: usize,
    /// The best objective J so far.
    pub best_objective: f64,
    /// The mean MAC of the paired modes at that best point.
    pub mean_mac: f64,
}

/// Write a history.csv.
pub fn write(path: &Path, rows: &[HistoryRow]) -> Result<(), ArtifactError> {
    write_file(path, to_csv(rows, FILE)?)
}

/// The rows of a history.csv.
pub fn read(path: &Path) -> Result<Vec<HistoryRow>, ArtifactError> {
    read_rows(path, "a history.csv")
}
