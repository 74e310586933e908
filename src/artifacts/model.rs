//! `model`: a synthesize stage's `model.json`, the model file's text, the
//! files it references **by reference** (path, size, blake3 content hash;
//! never their text), the parameter values it was solved at and its
//! positions, so a downstream stage rebuilds the same model from the
//! pipeline directory and knows when a matrix file changed under it.
//!
//! Fields: `schema_version`, `file` (the model file's name), `path` (its
//! path relative to the pipeline directory, version 3), `yaml` (its text),
//! `files` (referenced files: `path` as the model file writes it, relative
//! to the model file's directory, `bytes`, `blake3`; version 3),
//! `parameters` (`name`, `value`, `lower`, `upper`, `scale`, `kind`),
//! `positions` (`index`, `label`), `dofs`. Versions 1 and 2 embedded the
//! referenced files' text in `external` (path → content); they still read.
//!
//! Why by reference: the matrices of a 190k-DOF FE export are ~0.5–0.7 GB
//! of text, which the embedded form stored once per synthesize stage in the
//! cache and again in `results/`. The matrices are already part of the
//! synthesize stage's key (hashed by content), so the pipeline directory is
//! their one copy; the hash here lets a reader refuse a file edited since.

use super::{read_json, to_json, write_file, ArtifactError, SchemaVersion};
use crate::dynamics::model_file::{self, ModelFile};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io;
use std::path::{Path, PathBuf};

/// The file name of a `model` output.
pub const FILE: &str = "model.json";

/// The schema this build writes (2: `schema_version` stated; 3: referenced
/// files by path, size and blake3 hash instead of their text).
pub const SCHEMA_VERSION: u32 = 3;

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

/// A file the model file references, by reference.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ReferencedFile {
    /// As the model file writes it: relative to the model file's directory.
    pub path: String,
    /// Size in bytes.
    pub bytes: u64,
    /// blake3 of the content, hex (64 characters).
    pub blake3: String,
}

impl ReferencedFile {
    /// The reference of `content` read from `path`.
    pub fn of(path: &str, content: &[u8]) -> ReferencedFile {
        ReferencedFile {
            path: path.to_string(),
            bytes: content.len() as u64,
            blake3: blake3::hash(content).to_hex().to_string(),
        }
    }

    /// `content` if it is the file this reference recorded, else an error
    /// saying it changed since the synthesize stage ran and what to do.
    pub fn verify(&self, content: Vec<u8>) -> io::Result<Vec<u8>> {
        let now = ReferencedFile::of(&self.path, &content);
        if now.bytes == self.bytes && now.blake3 == self.blake3 {
            return Ok(content);
        }
        Err(io::Error::new(
            io::ErrorKind::InvalidData,
            format!(
                "`{}` changed since the synthesize stage ran ({} bytes, blake3 {}… recorded in \
                 model.json; {} bytes, blake3 {}… now): rerun the synthesize stage (`modalflow \
                 run` reruns it, the file is part of its key) or restore the file",
                self.path,
                self.bytes,
                &self.blake3[..self.blake3.len().min(12)],
                now.bytes,
                &now.blake3[..12],
            ),
        ))
    }
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
    /// The model file's path relative to the pipeline directory (version
    /// 3); referenced files are read relative to its directory.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<String>,
    /// The model file's text.
    pub yaml: String,
    /// Files the model references, by path, size and content hash
    /// (version 3).
    #[serde(default)]
    pub files: Vec<ReferencedFile>,
    /// Versions 1–2 only: files the model references (relative path →
    /// content). Never written.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
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

    /// Write a model.json of the current schema version (no embedded text:
    /// `external` is dropped, `files` carries the references).
    pub fn write(&self, path: &Path) -> Result<(), ArtifactError> {
        let current = ModelJson {
            schema_version: SchemaVersion(SCHEMA_VERSION),
            external: BTreeMap::new(),
            ..self.clone()
        };
        write_file(path, to_json(&current, FILE)?)
    }

    /// The model file's name, `default` when the file does not say.
    pub fn file_name<'a>(&'a self, default: &'a str) -> &'a str {
        self.file.as_deref().unwrap_or(default)
    }

    /// The directory the referenced paths are relative to: the model
    /// file's, below `pipeline_dir`.
    fn model_dir(&self, pipeline_dir: &Path) -> PathBuf {
        let file = pipeline_dir.join(self.path.as_deref().unwrap_or(""));
        match self.path {
            Some(_) => file.parent().unwrap_or(pipeline_dir).to_path_buf(),
            None => pipeline_dir.to_path_buf(),
        }
    }

    /// The model builder's resolver: a referenced file's bytes, embedded
    /// (versions 1–2) or read where the model file lives below
    /// `pipeline_dir` (confined to it and the model's directory, as the
    /// synthesize stage read it) and checked against the recorded size and
    /// hash.
    pub fn resolver<'a>(
        &'a self,
        pipeline_dir: &'a Path,
    ) -> impl Fn(&str) -> io::Result<Vec<u8>> + 'a {
        let base = self.model_dir(pipeline_dir);
        let read = crate::paths::confined_reader(
            base.clone(),
            vec![pipeline_dir.to_path_buf(), base.clone()],
        );
        move |p: &str| {
            if let Some(text) = self.external.get(p) {
                return Ok(text.as_bytes().to_vec());
            }
            let Some(r) = self.files.iter().find(|f| f.path == p) else {
                return Err(io::Error::new(
                    io::ErrorKind::NotFound,
                    format!("`{p}` is not among the files model.json references"),
                ));
            };
            let bytes = read(p).map_err(|e| {
                io::Error::new(
                    e.kind(),
                    format!(
                        "cannot read `{p}` (below {}), which the synthesize stage's model \
                         references: {e}; model.json refers to the file where the model file \
                         names it, so it must stay there",
                        base.display()
                    ),
                )
            })?;
            r.verify(bytes)
        }
    }

    /// Every referenced file's path (as the model file writes it) and
    /// bytes, read and verified by [`ModelJson::resolver`].
    pub fn referenced(
        &self,
        pipeline_dir: &Path,
        input: &str,
    ) -> Result<BTreeMap<String, Vec<u8>>, ArtifactError> {
        let resolve = self.resolver(pipeline_dir);
        let paths = self
            .external
            .keys()
            .chain(self.files.iter().map(|f| &f.path));
        paths
            .map(|p| {
                let bytes = resolve(p).map_err(|e| ArtifactError::invalid(input, e.to_string()))?;
                Ok((p.clone(), bytes))
            })
            .collect()
    }

    /// The parsed model file (its sensors, axes and parameters).
    pub fn spec(&self) -> Result<ModelFile, String> {
        model_file::parse(&self.yaml, self.file_name(FILE)).map_err(|e| e.to_string())
    }
}
