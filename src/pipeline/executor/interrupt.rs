//! Cancelling submitted jobs when `modalflow run` is interrupted on purpose:
//! every job id is registered while a stage waits on it; on SIGINT (Ctrl-C)
//! or SIGTERM a signal thread runs `scancel` on them and exits with 130.
//! SIGHUP (a closed terminal, an ssh disconnect) is left alone: the jobs
//! run on, their ids are recorded in the cache, and the next `run` adopts
//! them ([`super::inflight`]). The cache stays consistent (an unfinished
//! stage has no run record), so the next run resumes either way.

use signal_hook::consts::{SIGINT, SIGTERM};
use signal_hook::iterator::Signals;
use std::collections::BTreeMap;
use std::sync::{Mutex, Once};

/// Job id → stages waiting on it (a shared array or group job has several).
static LIVE: Mutex<BTreeMap<String, usize>> = Mutex::new(BTreeMap::new());
static INSTALL: Once = Once::new();

/// Exit code of an interrupted run (128 + SIGINT), as shells report it.
pub const INTERRUPTED: i32 = 130;

/// Install the handler (once per process).
pub fn install() {
    INSTALL.call_once(|| {
        // Without a handler (registration refused) the default action
        // ends the run and the jobs run on, to be adopted later.
        if let Ok(mut signals) = Signals::new([SIGINT, SIGTERM]) {
            std::thread::spawn(move || {
                if signals.forever().next().is_some() {
                    cancel_all();
                    std::process::exit(INTERRUPTED);
                }
            });
        }
    });
}

/// A job id in the queue; dropping it forgets the id.
pub struct Live(String);

impl Live {
    pub fn register(id: &str) -> Live {
        if let Ok(mut live) = LIVE.lock() {
            *live.entry(id.to_string()).or_insert(0) += 1;
        }
        Live(id.to_string())
    }
}

impl Drop for Live {
    fn drop(&mut self) {
        if let Ok(mut live) = LIVE.lock() {
            if let Some(n) = live.get_mut(&self.0) {
                *n -= 1;
                if *n == 0 {
                    live.remove(&self.0);
                }
            }
        }
    }
}

fn cancel_all() {
    let ids: Vec<String> = LIVE
        .lock()
        .map(|l| l.keys().cloned().collect())
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
