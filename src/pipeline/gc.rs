//! Garbage collection: drop run records and objects that no pipeline's last
//! run references. Holds the cache exclusively, so no run is in flight.

use super::provenance;
use super::store::{self, Store, StoreError};
use std::collections::HashSet;
use std::fs;
use std::path::Path;

/// What `gc` removed (or would remove with `dry_run`).
#[derive(Debug, Default, serde::Serialize)]
pub struct GcReport {
    pub dry_run: bool,
    pub kept_objects: usize,
    pub kept_bytes: u64,
    pub removed_objects: usize,
    pub removed_bytes: u64,
    pub removed_records: usize,
    pub removed_temp: usize,
}

pub fn collect(store: &Store, dry_run: bool) -> Result<GcReport, StoreError> {
    let _guard = store.lock_cache(true)?;
    let mut live_keys = HashSet::new();
    let mut live_objects = HashSet::new();
    for last in provenance::load_all(store) {
        for stage in last.stages.values() {
            let Some(rec) = store.record(&stage.key) else {
                continue;
            };
            live_keys.insert(stage.key.clone());
            for out in rec.outputs.values() {
                live_objects.extend(store.object_hashes(&out.artifact));
            }
        }
    }
    let mut report = GcReport {
        dry_run,
        ..GcReport::default()
    };
    for (hash, path, bytes) in store::list_objects(store) {
        if live_objects.contains(&hash) {
            report.kept_objects += 1;
            report.kept_bytes += bytes;
        } else {
            report.removed_objects += 1;
            report.removed_bytes += bytes;
            if !dry_run {
                let _ = fs::remove_file(path);
            }
        }
    }
    // `jobs/` holds the descriptions, logs and shard records of cluster jobs
    // of runs that failed or were interrupted; no run holds the cache now,
    // but jobs a killed or detached run submitted may still be queued: their
    // directories (and shared batch directories) stay for the next run.
    // `models/` holds facts of model files (`stages::params::model_facts`),
    // found again by building the model: collected like temporary files.
    for sub in ["runs", "tmp", "locks", "jobs", "models"] {
        let Ok(dir) = fs::read_dir(store.root().join(sub)) else {
            continue;
        };
        for entry in dir.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            let remove = match sub {
                "runs" => !live_keys.contains(name.trim_end_matches(".json")),
                "jobs" => !in_flight(store, &entry.path()),
                _ => true,
            };
            if !remove {
                continue;
            }
            match sub {
                "runs" => report.removed_records += 1,
                "tmp" | "jobs" | "models" => report.removed_temp += 1,
                _ => {}
            }
            if !dry_run {
                let p = entry.path();
                let _ = if p.is_dir() {
                    fs::remove_dir_all(&p)
                } else {
                    fs::remove_file(&p)
                };
            }
        }
    }
    Ok(report)
}

/// A job directory with a submission in flight, or a shared batch
/// directory one of whose members has one.
fn in_flight(store: &Store, dir: &Path) -> bool {
    use super::executor::inflight;
    if inflight::any(dir) {
        return true;
    }
    fs::read_to_string(dir.join("members")).is_ok_and(|keys| {
        keys.lines()
            .any(|k| inflight::any(&store.job_dir(k.trim())))
    })
}
