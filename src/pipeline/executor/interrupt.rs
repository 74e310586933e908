//! Cancelling submitted jobs when `modalflow run` is interrupted: every job
//! id is registered while it is in the queue; on SIGINT, SIGTERM or SIGHUP
//! the handler runs `scancel` on them and exits with 130. The cache stays
//! consistent (an unfinished stage has no run record), so the next run
//! resumes: finished stages and finished shards are reused.

use std::collections::BTreeSet;
use std::sync::{Mutex, Once};

static LIVE: Mutex<BTreeSet<String>> = Mutex::new(BTreeSet::new());
static INSTALL: Once = Once::new();

/// Exit code of an interrupted run (128 + SIGINT), as shells report it.
pub const INTERRUPTED: i32 = 130;

/// Install the handler (once per process).
pub fn install() {
    INSTALL.call_once(|| {
        // A process that already has a handler keeps it; jobs then run on.
        let _ = ctrlc::set_handler(|| {
            cancel_all();
            std::process::exit(INTERRUPTED);
        });
    });
}

/// A job id in the queue; dropping it forgets the id.
pub struct Live(String);

impl Live {
    pub fn register(id: &str) -> Live {
        if let Ok(mut live) = LIVE.lock() {
            live.insert(id.to_string());
        }
        Live(id.to_string())
    }
}

impl Drop for Live {
    fn drop(&mut self) {
        if let Ok(mut live) = LIVE.lock() {
            live.remove(&self.0);
        }
    }
}

fn cancel_all() {
    let ids: Vec<String> = LIVE
        .lock()
        .map(|l| l.iter().cloned().collect())
        .unwrap_or_default();
    if ids.is_empty() {
        return;
    }
    eprintln!(
        "modalflow: interrupted; cancelling slurm jobs {}",
        ids.join(" ")
    );
    if let Err(e) = std::process::Command::new("scancel").args(&ids).status() {
        eprintln!("modalflow: scancel failed ({e}); cancel the jobs by hand");
    }
}
