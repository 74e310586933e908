//! Exit codes, documented in the README; scripts rely on them.

use modalflow::pipeline::plan::PlanError;
use modalflow::pipeline::run::RunError;

/// Everything succeeded (or, for `status`, the question was answered).
pub const SUCCESS: u8 = 0;
/// At least one stage failed; the others' results are cached.
pub const STAGE_FAILED: u8 = 1;
/// The pipeline file (or a flag) is invalid; nothing ran.
pub const INVALID: u8 = 2;
/// The cache or the file system failed.
pub const ERROR: u8 = 3;

pub fn for_error(e: &anyhow::Error) -> u8 {
    let bad_force = e
        .downcast_ref::<RunError>()
        .is_some_and(|r| matches!(r, RunError::UnknownForce { .. }));
    if e.downcast_ref::<PlanError>().is_some() || bad_force {
        INVALID
    } else {
        ERROR
    }
}
