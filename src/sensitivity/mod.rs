//! Global sensitivity analysis (seed section 2.1; PUB1, PUB2):
//!
//! - [`sobol`]: variance-based Sobol indices — Saltelli sampling on a
//!   scrambled Sobol sequence, Saltelli-2010 first-order and Jansen total
//!   estimators, bootstrap confidence intervals (`sobol::{sample, analyze}`
//!   as in SALib, and `sobol::run` over a [`crate::simulator::Model`]);
//! - [`aggregate`](mod@aggregate): weighted combination of total indices over outputs and a
//!   threshold → significant parameters and per-output subproblems (PUB2);
//! - [`adequacy`]: bootstrap intervals of the combined indices and the
//!   parameters whose interval straddles the threshold (the sample size
//!   cannot decide them), with a suggested sample size;
//! - [`selection`]: the threshold rule checked by PUB2's Monte Carlo
//!   validation (grow the kept set in ranking order until the minimum
//!   conformity reaches a target);
//! - [`anova`](mod@anova): ANOVA tables for factorial designs (section 2.1.1, PUB1).

pub mod adequacy;
pub mod aggregate;
pub mod anova;
pub mod factorial;
pub mod selection;
pub mod sobol;
pub mod validation;

pub use adequacy::{score_intervals, Adequacy, ScoreInterval};
pub use aggregate::{aggregate, combine, Combine, Screening, Subproblem};
pub use anova::{anova, AnovaRow, Design, Factor};
pub use factorial::{factorial_anova, FactorialResult};
pub use selection::{select_by_validation, select_guided, Influence, Probe, Selection};
pub use validation::{validate, ConformityKind, OutputConformity, Validation};

use crate::simulator::EvalError;

/// Why a sensitivity analysis cannot be carried out.
#[derive(Debug, thiserror::Error)]
pub enum SensitivityError {
    /// Settings or data that cannot be analyzed (sizes, ranges, non-finite outputs).
    #[error("{0}")]
    Invalid(String),
    /// A parameter subset names a parameter the model does not have.
    #[error("unknown parameter `{name}`; the model's parameters are: {}", known.join(", "))]
    UnknownParameter { name: String, known: Vec<String> },
    /// An output selection names an output the model does not have.
    #[error("unknown output `{name}`; the model's outputs are: {}", known.join(", "))]
    UnknownOutput { name: String, known: Vec<String> },
    /// Evaluating the model failed (the error names the sample).
    #[error("model evaluation failed: {0}")]
    Evaluation(#[from] EvalError),
    /// A data table is malformed, with its file and 1-based line.
    #[error("{file}:{line}: {message}")]
    Table {
        file: String,
        line: u64,
        message: String,
    },
    /// A multi-factor ANOVA design whose level combinations are not equally filled.
    #[error("unbalanced design: {0}")]
    Unbalanced(String),
}

/// Indices of the `requested` outputs among `names` (all of them when
/// `requested` is empty), in the requested order.
pub fn select_outputs(
    names: &[String],
    requested: &[String],
) -> Result<Vec<usize>, SensitivityError> {
    if requested.is_empty() {
        return Ok((0..names.len()).collect());
    }
    requested
        .iter()
        .map(|o| {
            names
                .iter()
                .position(|n| n == o)
                .ok_or_else(|| SensitivityError::UnknownOutput {
                    name: o.clone(),
                    known: names.to_vec(),
                })
        })
        .collect()
}
