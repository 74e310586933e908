//! `cost.json`, the identify kind's summary: what the run cost, how well
//! the result matches, and the verdict. One schema for the writer and every
//! reader (report, evaluate, compare).

use crate::identify::objective::ModeSummary;
use crate::identify::Verdict;
use serde::{Deserialize, Serialize};

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
    pub assessment: usize,
}

/// The contents of cost.json.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cost {
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
    pub verdict: Verdict,
}

impl Cost {
    /// Read a cost.json.
    pub fn read(path: &std::path::Path) -> Result<Cost, String> {
        let bytes =
            std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        serde_json::from_slice(&bytes)
            .map_err(|e| format!("{} is not an identify cost.json: {e}", path.display()))
    }
}
