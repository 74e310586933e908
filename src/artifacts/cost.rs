//! `cost`: `cost.json`, the identify kind's summary: what the run cost, how
//! well the result matches, and the verdict. One schema for the writer and
//! every reader (report, evaluate, compare).

use super::{read_json, to_json, write_file, ArtifactError, SchemaVersion};
use crate::identify::objective::ModeSummary;
use crate::identify::Verdict;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The file name of a `cost` output.
pub const FILE: &str = "cost.json";

/// The schema this build writes (2: `schema_version` stated; 3: the
/// verdict's cause may be `minimum_or_model_error`, which a build of
/// schema 2 cannot read; 4: a follow-up's kind may be `window`).
pub const SCHEMA_VERSION: u32 = 4;

/// Model evaluations per phase of the guided strategy (and the assessment
/// every strategy ends with).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Phases {
    pub subproblems: usize,
    pub refine: usize,
    pub damping: usize,
    /// The FRF refinement (0 without the `frf` input).
    #[serde(default)]
    pub frf: usize,
    /// A black-box strategy's optimizer.
    #[serde(default)]
    pub optimizer: usize,
    /// The refits and escape searches after the strategy (`follow_ups`).
    #[serde(default)]
    pub follow_ups: usize,
    pub assessment: usize,
}

impl Phases {
    /// All phases: the update's evaluations.
    pub fn total(&self) -> usize {
        self.subproblems
            + self.refine
            + self.damping
            + self.frf
            + self.optimizer
            + self.follow_ups
            + self.assessment
    }
}

/// The contents of cost.json.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cost {
    /// Set by [`Cost::write`]; absent in files of version 1.
    #[serde(default)]
    pub schema_version: SchemaVersion,
    /// Model evaluations in all (never more than `budget`).
    pub evaluations: usize,
    pub seconds: f64,
    /// J at the result (the black-box criterion, eq. 2.62/2.64/2.65).
    #[serde(deserialize_with = "crate::identify::verdict::nan_if_null")]
    pub best_objective: f64,
    pub strategy: String,
    pub optimizer: String,
    /// The match at the result over the used modes.
    pub modes: ModeSummary,
    pub phase_evaluations: Phases,
    /// The FRF refinement, when the `frf` input was given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frf: Option<crate::identify::frf_refinement::FrfSummary>,
    /// What ran after the strategy before the verdict, in order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub follow_ups: Vec<crate::identify::FollowUpRecord>,
    pub verdict: Verdict,
}

impl Cost {
    /// Read a cost.json (any version up to [`SCHEMA_VERSION`]).
    pub fn read(path: &Path) -> Result<Cost, ArtifactError> {
        let c: Cost = read_json(path, "an identify cost.json")?;
        c.schema_version
            .check(FILE, SCHEMA_VERSION)
            .map_err(|e| ArtifactError::malformed(path, e))?;
        Ok(c)
    }

    /// Write a cost.json of the current schema version.
    pub fn write(&self, path: &Path) -> Result<(), ArtifactError> {
        let current = Cost {
            schema_version: SchemaVersion(SCHEMA_VERSION),
            ..self.clone()
        };
        write_file(path, to_json(&current, FILE)?)
    }
}
