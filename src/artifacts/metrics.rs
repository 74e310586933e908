//! `metrics`: `metrics.json`, the evaluate kind's summary: one schema for
//! the writer (the evaluate kind) and every reader (`report`, `modalflow
//! compare`, tests), so a field cannot be renamed on one side only.
//!
//! Criteria are fractions (MAC, NFD, NDD, FRAC, CSF; eq. 2.62–2.67). A mean
//! over nothing (no pair, no channel) is `null`. Mode numbers are 1-based,
//! as in `modes.csv`.

use super::{read_json, to_json, write_file, ArtifactError, SchemaVersion};
use crate::identify::Verdict;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The file name of a `metrics` output.
pub const FILE: &str = "metrics.json";

/// The schema this build writes (2: `schema_version` stated).
pub const SCHEMA_VERSION: u32 = 2;

/// The contents of metrics.json; a part is absent when its inputs were not
/// bound.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Set by [`Metrics::write`]; absent in files of version 1.
    #[serde(default)]
    pub schema_version: SchemaVersion,
    /// Modes: pairing and the criteria of the pairs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub modes: Option<ModeMetrics>,
    /// FRFs: FRAC and CSF per channel, averaged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frf: Option<FrfMetrics>,
    /// Parameters against the truth.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub parameters: Option<ParameterMetrics>,
    /// The verdict of the identification that produced the candidate,
    /// copied from its cost.json (the `cost` input).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verdict: Option<Verdict>,
}

impl Metrics {
    /// Read a metrics.json (any version up to [`SCHEMA_VERSION`]).
    pub fn read(path: &Path) -> Result<Metrics, ArtifactError> {
        let m: Metrics = read_json(path, "an evaluate metrics.json")?;
        m.schema_version
            .check("metrics.json", SCHEMA_VERSION)
            .map_err(|e| ArtifactError::malformed(path, e))?;
        Ok(m)
    }

    /// Write a metrics.json of the current schema version.
    pub fn write(&self, path: &Path) -> Result<(), ArtifactError> {
        let current = Metrics {
            schema_version: SchemaVersion(SCHEMA_VERSION),
            ..self.clone()
        };
        write_file(path, to_json(&current, "metrics.json")?)
    }

    /// Whether anything needs a reader's attention: unpaired or ambiguous
    /// modes, or a failed verdict.
    pub fn has_findings(&self) -> bool {
        self.verdict.as_ref().is_some_and(|v| !v.ok)
            || self
                .modes
                .as_ref()
                .is_some_and(|m| m.unpaired_reference + m.unpaired_candidate + m.ambiguous > 0)
    }
}

/// Modes over all positions.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ModeMetrics {
    pub paired: usize,
    pub reference_modes: usize,
    #[serde(default)]
    pub candidate_modes: usize,
    /// Reference modes without a candidate partner (missed by the candidate).
    #[serde(default)]
    pub unpaired_reference: usize,
    /// Candidate modes without a reference partner (spurious, or outside the
    /// reference's band).
    #[serde(default)]
    pub unpaired_candidate: usize,
    /// Pairs with a margin below the `ambiguity` setting.
    #[serde(default)]
    pub ambiguous: usize,
    pub mean_mac: Option<f64>,
    pub mean_nfd: Option<f64>,
    pub mean_ndd: Option<f64>,
    pub positions: Vec<PositionModes>,
    /// What was left out and why: pairs without a damping ratio (no NDD,
    /// no MACXP), positions paired by frequency alone (modes without
    /// shapes: no MAC).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

/// Modes of one position.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PositionModes {
    pub position: u32,
    pub label: String,
    pub reference_modes: usize,
    pub candidate_modes: usize,
    pub paired: usize,
    pub common_dofs: usize,
    pub mean_mac: Option<f64>,
    pub min_mac: Option<f64>,
    pub mean_nfd: Option<f64>,
    pub max_nfd: Option<f64>,
    pub mean_ndd: Option<f64>,
    #[serde(default)]
    pub unpaired_reference: Vec<ModeRef>,
    #[serde(default)]
    pub unpaired_candidate: Vec<ModeRef>,
    #[serde(default)]
    pub ambiguous: Vec<AmbiguousPair>,
    /// Why this position could not be compared (e.g. the candidate has no
    /// modes for it; then every reference mode is unpaired).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// A mode by its number and frequency.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ModeRef {
    pub mode: usize,
    pub frequency_hz: f64,
}

/// A pair that another assignment nearly matches (`crate::pairing::margins`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AmbiguousPair {
    pub reference_mode: usize,
    pub candidate_mode: usize,
    pub reference_hz: f64,
    pub candidate_hz: f64,
    pub mac: f64,
    /// Increase of the total pairing cost if this pair were forbidden.
    pub margin: f64,
    /// The allowed candidate mode that would suit this reference mode next
    /// best, and the allowed reference mode that would suit this candidate
    /// mode next best (either may be absent).
    pub rival_candidate: Option<usize>,
    pub rival_reference: Option<usize>,
}

/// FRFs over all positions.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FrfMetrics {
    pub channels: usize,
    pub mean_frac: Option<f64>,
    pub mean_csf: Option<f64>,
    pub positions: Vec<PositionFrf>,
    /// The initial model's FRAC/CSF against the reference (`initial_frf`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial_mean_frac: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial_mean_csf: Option<f64>,
    /// The quantity compared in (the reference's): receptance, mobility or
    /// accelerance.
    #[serde(default)]
    pub quantity: String,
    /// Conversions of candidate or initial FRFs to the reference's quantity
    /// by (jω)ⁿ, one line each (empty when all agreed).
    #[serde(default)]
    pub conversions: Vec<String>,
}

/// FRFs of one position.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PositionFrf {
    pub position: u32,
    pub label: String,
    pub channels: usize,
    pub mean_frac: Option<f64>,
    pub mean_csf: Option<f64>,
}

/// Parameter errors against the truth (relative, |estimate − truth|/truth).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ParameterMetrics {
    pub parameters: usize,
    pub mean_abs_relative_error: Option<f64>,
    pub max_abs_relative_error: Option<f64>,
}
