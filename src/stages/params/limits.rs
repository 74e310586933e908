//! Resource estimates ([`crate::resources`]) as param problems located at
//! the param to reduce, reported at validation.

use super::ParamProblem;
use crate::resources;

fn problem(path: &[&str], e: resources::Excess) -> ParamProblem {
    ParamProblem::new(path, e.message, e.help)
}

/// The problem of an estimate of `bytes` for `what` above the memory
/// limit, located at `path`.
pub fn memory_problem(path: &[&str], what: &str, bytes: f64) -> Option<ParamProblem> {
    resources::memory_excess(path, what, bytes).map(|e| problem(path, e))
}

/// The problem of `samples` simulated samples (for `what`) above the work
/// limit, located at `path`.
pub fn work_problem(path: &[&str], what: &str, samples: f64) -> Option<ParamProblem> {
    resources::work_excess(path, what, samples).map(|e| problem(path, e))
}
