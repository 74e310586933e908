//! The artifacts stages exchange: one typed schema per kind of
//! [`Artifact`], each with its `read` and `write`, so a writer and every
//! reader (stages, `modalflow compare`, the tests, the Python package in
//! `python/`) agree on file names, columns and units. The layout and the
//! columns are documented once, in `docs/artifacts.md`.
//!
//! Conventions every schema follows:
//! - columns and fields carry their unit in the name where they have one
//!   (`frequency_hz`, `reference_hz`) and say `_rel` where a value is
//!   relative (`std_error_rel`: a standard deviation of ln p);
//! - booleans are `true`/`false`; an empty CSV cell means "not applicable"
//!   (never 0);
//! - every JSON artifact states `schema_version`; a file without it is
//!   version 1 (written before versions existed) and is read as such; a
//!   version newer than this build reads is refused, naming both. CSV
//!   artifacts are versioned by their header: an older header is read, an
//!   unknown one refused with the expected columns.
//!
//! This module sits below [`crate::stages`]: it knows the numerical core's
//! types (FRF sets, modal models, the identification's summaries) and
//! nothing of pipelines or stage kinds.

pub mod correlation;
pub mod cost;
pub mod frf;
pub mod history;
pub mod identifiability;
mod kind;
pub mod metrics;
pub mod model;
pub mod modes;
pub mod parameters;
pub mod significant;
mod table;
pub mod warnings;

pub use kind::Artifact;
pub use table::{read_json, read_rows, to_csv, to_json, SchemaVersion};

use std::path::{Path, PathBuf};

/// Why an artifact cannot be read or written.
#[derive(Debug, thiserror::Error)]
pub enum ArtifactError {
    /// The artifact bound to a stage input is not what the input takes.
    #[error("input `{input}`: {message}")]
    Invalid { input: String, message: String },
    /// A file read by its path (a report, `modalflow compare`) is not the
    /// artifact it should be.
    #[error("{}: {message}", path.display())]
    Malformed { path: PathBuf, message: String },
    /// File system trouble.
    #[error("{context}: {source}")]
    Io {
        context: String,
        #[source]
        source: std::io::Error,
    },
    /// A value cannot be written (e.g. serialization failed).
    #[error("cannot write {what}: {message}")]
    Encode { what: String, message: String },
}

impl ArtifactError {
    pub fn invalid(input: &str, message: impl Into<String>) -> Self {
        ArtifactError::Invalid {
            input: input.to_string(),
            message: message.into(),
        }
    }

    pub fn malformed(path: &Path, message: impl Into<String>) -> Self {
        ArtifactError::Malformed {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    pub fn io(context: impl Into<String>, source: std::io::Error) -> Self {
        ArtifactError::Io {
            context: context.into(),
            source,
        }
    }
}

/// Write `bytes` to `path`.
pub fn write_file(path: &Path, bytes: impl AsRef<[u8]>) -> Result<(), ArtifactError> {
    std::fs::write(path, bytes)
        .map_err(|e| ArtifactError::io(format!("cannot write {}", path.display()), e))
}

#[cfg(test)]
mod tests;
