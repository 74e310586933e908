//! The two encodings every schema uses: CSV rows through serde (one struct
//! per row, so a renamed column is a compile error) and JSON documents
//! that state their [`SchemaVersion`].

use super::ArtifactError;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The `schema_version` field of a JSON artifact. Absent: version 1, files
/// written before versions existed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct SchemaVersion(pub u32);

impl Default for SchemaVersion {
    fn default() -> Self {
        SchemaVersion(1)
    }
}

impl SchemaVersion {
    /// `Ok` when this build reads version `self` of `what` (at most
    /// `current`); else an error naming both versions and the fix.
    pub fn check(self, what: &str, current: u32) -> Result<(), String> {
        if self.0 <= current {
            return Ok(());
        }
        Err(format!(
            "{what} has schema_version {}, newer than this modalflow reads ({current}); \
             update modalflow, or run the pipeline again to rewrite it",
            self.0
        ))
    }
}

/// The rows of a CSV artifact; `what` names it in errors ("an identify
/// parameters.csv").
pub fn read_rows<T: DeserializeOwned>(path: &Path, what: &str) -> Result<Vec<T>, ArtifactError> {
    let mut reader = csv::Reader::from_path(path)
        .map_err(|e| ArtifactError::malformed(path, format!("cannot read {what}: {e}")))?;
    reader
        .deserialize()
        .enumerate()
        .map(|(k, row)| {
            row.map_err(|e| {
                ArtifactError::malformed(path, format!("line {}: not {what}: {e}", k + 2))
            })
        })
        .collect()
}

/// `rows` as CSV text with a header (`what` names the artifact in errors).
pub fn to_csv<T: Serialize>(rows: &[T], what: &str) -> Result<String, ArtifactError> {
    let encode = |message: String| ArtifactError::Encode {
        what: what.to_string(),
        message,
    };
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r).map_err(|e| encode(e.to_string()))?;
    }
    let bytes = w.into_inner().map_err(|e| encode(e.to_string()))?;
    String::from_utf8(bytes).map_err(|e| encode(e.to_string()))
}

/// A JSON artifact from `path`, refused when it is not `what`.
pub fn read_json<T: DeserializeOwned>(path: &Path, what: &str) -> Result<T, ArtifactError> {
    let bytes = std::fs::read(path)
        .map_err(|e| ArtifactError::io(format!("cannot read {}", path.display()), e))?;
    serde_json::from_slice(&bytes)
        .map_err(|e| ArtifactError::malformed(path, format!("not {what}: {e}")))
}

/// `value` as pretty JSON text ending in a newline.
pub fn to_json<T: Serialize>(value: &T, what: &str) -> Result<String, ArtifactError> {
    serde_json::to_string_pretty(value)
        .map(|t| t + "\n")
        .map_err(|e| ArtifactError::Encode {
            what: what.to_string(),
            message: e.to_string(),
        })
}
