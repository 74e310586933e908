//! `modalflow exec`: run stage jobs from their descriptions in the cache.

use modalflow::pipeline::executor::exec::{self, ExecOutcome, Finished};
use modalflow::pipeline::store::Store;
use std::path::PathBuf;

/// Run stage jobs from their descriptions in the cache (what a cluster job runs).
///
/// The Slurm executor's batch scripts call this: the stage's outputs and run
/// record, or one shard's partial result, are committed to the (shared) cache
/// with the same atomic protocol as a local run. The pipeline file is never
/// read. Several descriptions (a group job) run in turn; a failure does not
/// stop the ones after it.
///
/// Exit codes: 0 every result is in the cache, 1 a stage failed, 3 cache error.
#[derive(clap::Args)]
pub struct Args {
    /// The job descriptions (`CACHE/jobs/<key>/job.json` or `merge.json`).
    #[arg(required = true)]
    jobs: Vec<PathBuf>,
    /// Run only this shard (the array task index) of a sharded job.
    #[arg(long)]
    shard: Option<usize>,
    /// Node-local directory for scratch files and input checkouts.
    #[arg(long, value_name = "DIR")]
    scratch: Option<PathBuf>,
    /// Cache directory; must be the one the descriptions live in.
    #[arg(long, env = "MODALFLOW_CACHE", default_value = "cache")]
    cache: PathBuf,
}

pub fn exec(args: Args) -> anyhow::Result<u8> {
    if args.shard.is_some() && args.jobs.len() > 1 {
        return Err(crate::cli::exit::Invalid(
            "--shard takes one job description, not several".into(),
        )
        .into());
    }
    let store = Store::open(&args.cache)?;
    let mut code = crate::cli::exit::SUCCESS;
    for job in &args.jobs {
        let what = match args.shard {
            Some(i) => format!("shard {i} of {}", job.display()),
            None => job.display().to_string(),
        };
        match exec::exec(&store, job, args.shard, args.scratch.as_deref()) {
            Ok(ExecOutcome::AlreadyDone) => {
                eprintln!("modalflow exec: {what}: already in the cache");
            }
            Ok(ExecOutcome::Ran(Finished::Record(r))) => {
                eprintln!(
                    "modalflow exec: stage {} done in {:.3} s (key {})",
                    r.stage, r.seconds, r.key
                );
            }
            Ok(ExecOutcome::Ran(Finished::Shard(r))) => {
                eprintln!(
                    "modalflow exec: {what}: partial {} done in {:.3} s",
                    r.artifact.hash, r.seconds
                );
            }
            Err(e) => {
                eprintln!("modalflow: {what}: stage failed: {e}");
                code = crate::cli::exit::STAGE_FAILED;
            }
        }
    }
    Ok(code)
}
