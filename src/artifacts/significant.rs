//! `significant`: a gsa stage's `significant.csv`, the PUB2 split in
//! parameter order: `parameter,score,score_low,score_high,undecided,
//! samples_needed,significant` — the weighted combined total Sobol index
//! (a fraction of the output variance), its bootstrap interval, whether the
//! interval straddles the threshold, the base sample size that would decide
//! it (empty: none within reach, or decided) and the split itself.
//! Files of gsa before version 8 have only `parameter,score,significant`.

use super::{read_rows, write_file, ArtifactError};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

/// The file name of a `significant` output.
pub const FILE: &str = "significant.csv";

const HEADER: &str = "parameter,score,score_low,score_high,undecided,samples_needed,significant";

/// One row of significant.csv.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SignificantRow {
    pub parameter: String,
    pub score: f64,
    #[serde(default)]
    pub score_low: Option<f64>,
    #[serde(default)]
    pub score_high: Option<f64>,
    #[serde(default)]
    pub undecided: Option<bool>,
    #[serde(default)]
    pub samples_needed: Option<usize>,
    pub significant: bool,
}

/// Write a significant.csv. Numbers in their shortest round-tripping
/// decimal form (Rust's `Display`), as gsa has always written them.
pub fn write(path: &Path, rows: &[SignificantRow]) -> Result<(), ArtifactError> {
    let mut csv = format!("{HEADER}\n");
    let opt = |v: Option<f64>| v.map_or(String::new(), |x| x.to_string());
    for r in rows {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{}",
            r.parameter,
            r.score,
            opt(r.score_low),
            opt(r.score_high),
            r.undecided.map_or(String::new(), |b| b.to_string()),
            r.samples_needed.map_or(String::new(), |n| n.to_string()),
            r.significant
        );
    }
    write_file(path, csv)
}

/// The rows of the significant.csv bound to input `input`.
pub fn read(path: &Path, input: &str) -> Result<Vec<SignificantRow>, ArtifactError> {
    read_rows(path, "a gsa significant.csv").map_err(|e| {
        ArtifactError::invalid(
            input,
            format!("{e}; bind a gsa stage's `significant` output"),
        )
    })
}
