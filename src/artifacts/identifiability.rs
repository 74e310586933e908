//! `identifiability`: the identify kind's `identifiability.json`, the
//! analysis of what the data determine plus each undetermined combination
//! in words, the fixed parameters' consider analysis and what the intervals
//! of parameters.csv assume.

use super::{read_json, to_json, write_file, ArtifactError, SchemaVersion};
use crate::identify::Identifiability;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The file name of an `identifiability` output.
pub const FILE: &str = "identifiability.json";

/// The schema this build writes (2: `schema_version` stated; 3: a
/// structural group's determined sum, `undetermined[].joint`).
pub const SCHEMA_VERSION: u32 = 3;

/// identifiability.json: the analysis plus each undetermined combination
/// in words.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IdentifiabilityFile {
    /// Set by [`IdentifiabilityFile::write`]; absent in files of version 1.
    #[serde(default)]
    pub schema_version: SchemaVersion,
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
    /// Read an identifiability.json (any version up to [`SCHEMA_VERSION`]).
    pub fn read(path: &Path) -> Result<IdentifiabilityFile, ArtifactError> {
        let f: IdentifiabilityFile = read_json(path, "an identify identifiability.json")?;
        f.schema_version
            .check(FILE, SCHEMA_VERSION)
            .map_err(|e| ArtifactError::malformed(path, e))?;
        Ok(f)
    }

    /// Write an identifiability.json of the current schema version.
    pub fn write(&self, path: &Path) -> Result<(), ArtifactError> {
        let mut current = self.clone();
        current.schema_version = SchemaVersion(SCHEMA_VERSION);
        write_file(path, to_json(&current, FILE)?)
    }
}
