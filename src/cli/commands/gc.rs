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
    /// Cache directory.
    #[arg(long, env = "MODALFLOW_CACHE", default_value = "cache")]
    cache: PathBuf,
}

pub fn exec(args: Args) -> anyhow::Result<u8> {
    let store = Store::open(&args.cache)?;
    let r = gc::collect(&store, args.dry_run)?;
    if args.json {
        print_json(&r)?;
    } else {
        let verb = if r.dry_run { "would remove" } else { "removed" };
        print_text(&format!(
            "{verb} {} objects ({}), {} run records, {} temp files; kept {} objects ({})\n",
            r.removed_objects,
            human_bytes(r.removed_bytes),
            r.removed_records,
            r.removed_temp,
            r.kept_objects,
            human_bytes(r.kept_bytes)
        ))?;
    }
    Ok(crate::cli::exit::SUCCESS)
}

fn human_bytes(b: u64) -> String {
    const UNITS: [&str; 4] = ["B", "KiB", "MiB", "GiB"];
    let mut v = b as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{b} B")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}
