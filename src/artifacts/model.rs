//! `model`: a synthesize stage's `model.json`, the model file's text with
//! every file it references embedded, the parameter values it was solved
//! at and its positions, so a downstream stage rebuilds the same model
//! without the pipeline directory.
//!
//! Fields: `schema_version`, `file` (the model file's name), `yaml` (its
//! text), `external` (referenced path → content), `parameters` (`name`,
//! `value`, `lower`, `upper`, `scale`, `kind`), `positions` (`index`,
//! `label`), `dofs`.

use super::{read_json, to_json, write_file, ArtifactError, SchemaVersion};
use crate::dynamics::model_file::{self, ModelFile};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The file name of a `model` output.
pub const FILE: &str = "model.json";

/// The schema this build writes (2: `schema_version` stated).
pub const SCHEMA_VERSION: u32 = 2;

/// One model parameter at the values the model was solved at.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelParameter {
    pub name: String,
    pub value: f64,
    pub lower: f64,
    pub upper: f64,
    /// `linear` or `log`.
    pub scale: String,
    /// `stiffness` or `damping`.
    pub kind: String,
}

/// One axis position of the model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelPosition {
    pub index: u32,
    pub label: String,
}

/// The contents of model.json.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelJson {
    /// Set by [`ModelJson::write`]; absent in files of version 1.
    #[serde(default)]
    pub schema_version: SchemaVersion,
    /// The model file's name (e.g. `beam.yaml`).
    #[serde(default)]
    pub file: Option<String>,
    /// The model file's text.
    pub yaml: String,
    /// Files the model references (relative path → content).
    #[serde(default)]
    pub external: BTreeMap<String, String>,
    #[serde(default)]
    pub parameters: Vec<ModelParameter>,
    #[serde(default)]
    pub positions: Vec<ModelPosition>,
    #[serde(default)]
    pub dofs: usize,
}

impl ModelJson {
    /// Read the model.json bound to input `input`.
    pub fn read(path: &Path, input: &str) -> Result<ModelJson, ArtifactError> {
        let m: ModelJson = read_json(path, "a synthesize model.json").map_err(|e| match e {
            ArtifactError::Malformed { message, .. } => ArtifactError::invalid(
                input,
                format!("{message}; bind a synthesize stage's `model` output"),
            ),
            other => other,
        })?;
        m.schema_version
            .check(FILE, SCHEMA_VERSION)
            .map_err(|e| ArtifactError::invalid(input, e))?;
        Ok(m)
    }

    /// Write a model.json of the current schema version.
    pub fn write(&self, path: &Path) -> Result<(), ArtifactError> {
        let current = ModelJson {
            schema_version: SchemaVersion(SCHEMA_VERSION),
            ..self.clone()
        };
        write_file(path, to_json(&current, FILE)?)
    }

    /// The model file's name, `default` when the file does not say.
    pub fn file_name<'a>(&'a self, default: &'a str) -> &'a str {
        self.file.as_deref().unwrap_or(default)
    }

    /// Read an embedded referenced file (the model builder's resolver).
    pub fn resolve(&self, p: &str) -> std::io::Result<Vec<u8>> {
        self.external
            .get(p)
            .map(|s| s.as_bytes().to_vec())
            .ok_or_else(|| {
                std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    format!("`{p}` is not embedded in model.json"),
                )
            })
    }

    /// The parsed model file (its sensors, axes and parameters).
    pub fn spec(&self) -> Result<ModelFile, String> {
        model_file::parse(&self.yaml, self.file_name(FILE)).map_err(|e| e.to_string())
    }
}
