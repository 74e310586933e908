//! `modalflow exec`: run one stage job from its description in the cache.

use modalflow::pipeline::executor::exec::{self, ExecOutcome, Finished};
use modalflow::pipeline::store::Store;
use std::path::PathBuf;

/// Run one stage job from its description in the cache (what a cluster job runs).
///
/// The Slurm executor's batch scripts call this: the stage's outputs and run
/// record, or one shard's partial result, are committed to the (shared) cache
/// with the same atomic protocol as a local run. The pipeline file is never read.
///
/// Exit codes: 0 the result is in the cache, 1 the stage failed, 3 cache error.
#[derive(clap::Args)]
pub struct Args {
    /// The job description (`CACHE/jobs/<key>/job.json` or `merge.json`).
    job: PathBuf,
    /// Run only this shard (the array task index) of a sharded job.
    #[arg(long)]
    shard: Option<usize>,
    /// Cache directory; must be the one the description lives in.
    #[arg(long, env = "MODALFLOW_CACHE", default_value = "cache")]
    cache: PathBuf,
}

pub fn exec(args: Args) -> anyhow::Result<u8> {
    let store = Store::open(&args.cache)?;
    let what = match args.shard {
        Some(i) => format!("shard {i} of {}", args.job.display()),
        None => args.job.display().to_string(),
    };
    match exec::exec(&store, &args.job, args.shard) {
        Ok(ExecOutcome::AlreadyDone) => {
            eprintln!("modalflow exec: {what}: already in the cache");
            Ok(crate::cli::exit::SUCCESS)
        }
        Ok(ExecOutcome::Ran(Finished::Record(r))) => {
            eprintln!(
                "modalflow exec: stage {} done in {:.3} s (key {})",
                r.stage, r.seconds, r.key
            );
            Ok(crate::cli::exit::SUCCESS)
        }
        Ok(ExecOutcome::Ran(Finished::Shard(r))) => {
            eprintln!(
                "modalflow exec: {what}: partial {} done in {:.3} s",
                r.artifact.hash, r.seconds
            );
            Ok(crate::cli::exit::SUCCESS)
        }
        Err(e) => {
            eprintln!("modalflow: {what}: stage failed: {e}");
            Ok(crate::cli::exit::STAGE_FAILED)
        }
    }
}
