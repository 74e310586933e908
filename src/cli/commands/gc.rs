//! `modalflow gc`: reclaim cache space.

use crate::cli::output::{print_json, print_text};
use modalflow::pipeline::{gc, store::Store};
use std::path::PathBuf;

/// Remove cached objects and records that no pipeline's last run references.
#[derive(clap::Args)]
pub struct Args {
    /// Only report what would be removed.
    #[arg(long)]
    dry_run: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    /// Cache directory. Default: `cache` in the project root found from
    /// the current directory (the nearest folder at or above it holding a
    /// `.modalflow` marker file or a cache), else `./cache`.
    #[arg(long, env = "MODALFLOW_CACHE")]
    cache: Option<PathBuf>,
}

pub fn exec(args: Args) -> anyhow::Result<u8> {
    let cache = match args.cache {
        Some(c) => c,
        None => crate::cli::output::Locations::default().resolve(None).cache,
    };
    let store = Store::open(&cache)?;
    let r = gc::collect(&store, args.dry_run)?;
    if args.json {
        print_json(&r)?;
    } else {
        let verb = if r.dry_run { "would remove" } else { "removed" };
        print_text(&format!(
            "{verb} {} objects ({}), {} run records, {} temp files; kept {} objects ({})\n",
            r.removed_objects,
            modalflow::resources::human(r.removed_bytes as f64),
            r.removed_records,
            r.removed_temp,
            r.kept_objects,
            modalflow::resources::human(r.kept_bytes as f64)
        ))?;
    }
    Ok(crate::cli::exit::SUCCESS)
}
