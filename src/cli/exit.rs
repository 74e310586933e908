//! Exit codes, documented in the README and docs/cli.md; scripts rely on them.

use modalflow::pipeline::plan::PlanError;
use modalflow::pipeline::scheduler::RunError;

/// Everything succeeded (or, for `status`, the question was answered).
pub const SUCCESS: u8 = 0;
/// At least one stage failed; the others' results are cached.
pub const STAGE_FAILED: u8 = 1;
/// The pipeline file, a flag or a named stage is invalid; nothing ran.
pub const INVALID: u8 = 2;
/// The cache or the file system failed.
pub const ERROR: u8 = 3;

/// A usage error found by a command (unknown stage, bad `--set`): exit 2.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct Invalid(pub String);

pub fn for_error(e: &anyhow::Error) -> u8 {
    let run_invalid = e.downcast_ref::<RunError>().is_some_and(RunError::is_usage);
    if e.downcast_ref::<PlanError>().is_some()
        || e.downcast_ref::<Invalid>().is_some()
        || run_invalid
    {
        INVALID
    } else {
        ERROR
    }
}
