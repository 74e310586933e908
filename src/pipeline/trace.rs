//! The trace of a run (Nextflow's `trace.txt`): one row per stage, and for a
//! stage computed on a cluster one row per job or array task and attempt —
//! job id, array index, node, scheduler state, attempt, elapsed time, CPU
//! time and peak memory (MaxRSS) from `sacct` where accounting is on
//! (`squeue` gives state, node and elapsed time otherwise). Written as
//! `results/<name>/trace.csv` and `trace.json` (the last run, linked from
//! `modalflow show` and the report) and kept per run under
//! `results/<name>/trace.d/`.

use crate::pipeline::execute::{StageReport, Status};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// One job (or array job) a stage waited on, as the executor saw it.
#[derive(Clone, Debug)]
pub struct JobRow {
    pub stage: String,
    pub key: String,
    /// `job`, `merge` (a sharded stage's merge) or `shards`.
    pub unit: String,
    pub id: String,
    /// The stage's array tasks (`None`: a plain or group job).
    pub tasks: Option<Vec<usize>>,
    pub attempt: u32,
    /// The scheduler's final state as seen, `COMPLETED` for a committed result.
    pub state: String,
    pub exit: String,
    /// Seconds since the Unix epoch.
    pub submitted: u64,
    /// Seconds from submission (or adoption) until the result or the end.
    pub waited: f64,
    /// Adopted from an earlier `modalflow run`.
    pub adopted: bool,
}

/// One line of the trace.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct TraceRow {
    pub stage: String,
    pub key: String,
    /// The stage's status in the run: ran, cached, failed, skipped.
    pub status: String,
    /// `local`, `slurm` or empty (not computed).
    pub executor: String,
    pub unit: String,
    pub job_id: String,
    pub array_index: Option<usize>,
    pub attempt: Option<u32>,
    pub adopted: bool,
    pub state: String,
    pub exit: String,
    pub node: String,
    /// UTC, `YYYY-MM-DDTHH:MM:SSZ`.
    pub submitted: String,
    pub waited_s: Option<f64>,
    /// Run time: the stage's own seconds (local), Slurm's `Elapsed` (jobs).
    pub elapsed: String,
    pub cpu_time: String,
    pub max_rss: String,
}

/// What the scheduler's accounting says about one job or array task.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Accounting {
    pub state: String,
    pub exit: String,
    pub node: String,
    pub elapsed: String,
    pub cpu_time: String,
    pub max_rss: String,
}

/// Accounting of every job in `ids` (one call): `sacct` with steps for
/// MaxRSS, else `squeue --states=all` (state, node, elapsed). Keys are
/// `123` and `123_4`.
pub fn accounting(ids: &[String]) -> HashMap<String, Accounting> {
    if ids.is_empty() {
        return HashMap::new();
    }
    let list = ids.join(",");
    let sacct = Command::new("sacct")
        .args([
            "-n",
            "-P",
            "-o",
            "JobID,State,ExitCode,NodeList,Elapsed,TotalCPU,MaxRSS",
        ])
        .args(["-j", &list])
        .stdin(Stdio::null())
        .output();
    if let Some(o) = sacct.ok().filter(|o| o.status.success()) {
        return parse_sacct(&String::from_utf8_lossy(&o.stdout));
    }
    let squeue = Command::new("squeue")
        .args(["-h", "-t", "all", "-o", "%i|%T|%N|%M", "--jobs", &list])
        .stdin(Stdio::null())
        .output();
    let mut out = HashMap::new();
    if let Ok(o) = squeue {
        for line in String::from_utf8_lossy(&o.stdout).lines() {
            let f: Vec<&str> = line.trim().split('|').collect();
            if let [id, state, node, elapsed] = f.as_slice() {
                out.insert(
                    id.to_string(),
                    Accounting {
                        state: state.to_string(),
                        node: node.to_string(),
                        elapsed: elapsed.to_string(),
                        ..Accounting::default()
                    },
                );
            }
        }
    }
    out
}

/// Allocation lines give state, exit, node, elapsed and CPU time; step
/// lines (`123_4.batch`) their peak memory, of which the largest counts.
pub fn parse_sacct(text: &str) -> HashMap<String, Accounting> {
    let mut out: HashMap<String, Accounting> = HashMap::new();
    for line in text.lines() {
        let f: Vec<&str> = line.trim().split('|').collect();
        let [id, state, exit, node, elapsed, cpu, rss] = f.as_slice() else {
            continue;
        };
        let (job, step) = match id.split_once('.') {
            Some((j, s)) => (j, Some(s)),
            None => (*id, None),
        };
        let a = out.entry(job.to_string()).or_default();
        if step.is_none() {
            a.state = state
                .split_whitespace()
                .next()
                .unwrap_or_default()
                .to_string();
            a.exit = exit.to_string();
            a.node = node.to_string();
            a.elapsed = elapsed.to_string();
            a.cpu_time = cpu.to_string();
        }
        if bytes_of(rss) > bytes_of(&a.max_rss) {
            a.max_rss = rss.to_string();
        }
    }
    out
}

/// Bytes of a sacct size (`1234K`, `2.5M`).
fn bytes_of(s: &str) -> f64 {
    let s = s.trim();
    let (num, scale) = match s.chars().last() {
        Some('K') => (&s[..s.len() - 1], 1e3),
        Some('M') => (&s[..s.len() - 1], 1e6),
        Some('G') => (&s[..s.len() - 1], 1e9),
        Some('T') => (&s[..s.len() - 1], 1e12),
        _ => (s, 1.0),
    };
    num.parse::<f64>().map_or(-1.0, |n| n * scale)
}

/// The rows of a run: the stages in order, each with its jobs.
pub fn rows(
    reports: &[StageReport],
    jobs: &[JobRow],
    acct: &HashMap<String, Accounting>,
    local: &dyn Fn(&str, &str) -> bool,
) -> Vec<TraceRow> {
    let mut by_stage: HashMap<&str, Vec<&JobRow>> = HashMap::new();
    for j in jobs {
        by_stage.entry(j.stage.as_str()).or_default().push(j);
    }
    let mut out = Vec::new();
    for r in reports {
        let base = TraceRow {
            stage: r.name.clone(),
            key: r.key.clone().unwrap_or_default(),
            status: status(r.status).into(),
            ..TraceRow::default()
        };
        let mine = by_stage.get(r.name.as_str()).cloned().unwrap_or_default();
        if mine.is_empty() {
            let computed = matches!(r.status, Status::Ran | Status::Failed) && r.key.is_some();
            out.push(TraceRow {
                executor: if computed && local(&r.kind, &r.name) {
                    "local".into()
                } else {
                    String::new()
                },
                elapsed: if r.status == Status::Ran {
                    format!("{:.3}", r.seconds)
                } else {
                    String::new()
                },
                ..base
            });
            continue;
        }
        for j in mine {
            let tasks: Vec<Option<usize>> = match &j.tasks {
                Some(t) => t.iter().map(|&i| Some(i)).collect(),
                None => vec![None],
            };
            for task in tasks {
                let name = match task {
                    Some(i) => format!("{}_{i}", j.id),
                    None => j.id.clone(),
                };
                let a = acct.get(&name).cloned().unwrap_or_default();
                // The job's own state when it failed; accounting's once it
                // is final (a job that committed its result and then ran
                // over its limit is TIMEOUT there; one still finishing is
                // RUNNING, and COMPLETED is what the stage saw).
                let state = if j.state == "COMPLETED"
                    && crate::pipeline::executor::queue::is_terminal(&a.state)
                {
                    a.state
                } else {
                    j.state.clone()
                };
                out.push(TraceRow {
                    executor: "slurm".into(),
                    unit: j.unit.clone(),
                    job_id: name,
                    array_index: task,
                    attempt: Some(j.attempt),
                    adopted: j.adopted,
                    state,
                    exit: if a.exit.is_empty() {
                        j.exit.clone()
                    } else {
                        a.exit
                    },
                    node: a.node,
                    submitted: utc(j.submitted),
                    waited_s: Some((j.waited * 1000.0).round() / 1000.0),
                    elapsed: a.elapsed,
                    cpu_time: a.cpu_time,
                    max_rss: a.max_rss,
                    ..base.clone()
                });
            }
        }
    }
    out
}

fn status(s: Status) -> &'static str {
    match s {
        Status::Ran => "ran",
        Status::Cached => "cached",
        Status::Failed => "failed",
        Status::Skipped => "skipped",
        Status::WillRun => "will-run",
    }
}

/// `YYYY-MM-DDTHH:MM:SSZ` of Unix seconds (proleptic Gregorian, Hinnant's
/// days-to-civil algorithm).
pub fn utc(secs: u64) -> String {
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// Write the trace as `trace.csv` / `trace.json` in `results` (the pipeline's
/// results directory) and a copy per run in `trace.d/`; returns the CSV path.
pub fn write(results: &Path, rows: &[TraceRow], stamp: u64) -> std::io::Result<PathBuf> {
    let mut csv = csv::Writer::from_writer(Vec::new());
    for r in rows {
        csv.serialize(r).map_err(std::io::Error::other)?;
    }
    let csv = csv
        .into_inner()
        .map_err(|e| std::io::Error::other(e.to_string()))?;
    // Compact JSON: a 5,000-stage run's trace is written on every run.
    let json = serde_json::to_vec(rows).map_err(std::io::Error::other)?;
    let history = results.join("trace.d");
    std::fs::create_dir_all(&history)?;
    let name = format!("{}-{}", utc(stamp).replace(':', ""), std::process::id());
    for (ext, data) in [("csv", &csv), ("json", &json)] {
        let latest = results.join(format!("trace.{ext}"));
        put(&latest, data)?;
        // The run's own copy shares the bytes (a copy where links fail).
        let own = history.join(format!("{name}.{ext}"));
        if std::fs::hard_link(&latest, &own).is_err() {
            put(&own, data)?;
        }
    }
    prune(&history);
    Ok(results.join("trace.csv"))
}

/// Runs whose traces `trace.d/` keeps.
pub const HISTORY: usize = 50;

/// Keep the newest [`HISTORY`] runs (names start with their UTC time).
fn prune(history: &Path) {
    let Ok(dir) = std::fs::read_dir(history) else {
        return;
    };
    let mut csvs: Vec<PathBuf> = dir
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    csvs.sort();
    let old = csvs.len().saturating_sub(HISTORY);
    for p in &csvs[..old] {
        let _ = std::fs::remove_file(p);
        let _ = std::fs::remove_file(p.with_extension("json"));
    }
}

fn put(path: &Path, data: &[u8]) -> std::io::Result<()> {
    let tmp = path.with_extension(format!("tmp-{}", std::process::id()));
    std::fs::write(&tmp, data)?;
    std::fs::rename(&tmp, path)
}

/// The rows of the last run's trace in `results`, if there is one.
pub fn read(results: &Path) -> Option<Vec<TraceRow>> {
    let bytes = std::fs::read(results.join("trace.json")).ok()?;
    serde_json::from_slice(&bytes).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sacct_steps_give_the_peak_memory() {
        let a = parse_sacct(
            "12_3|COMPLETED|0:0|n1|00:00:05|00:04.100|\n12_3.batch|COMPLETED|0:0|n1|00:00:05|00:04.100|2048K\n12_3.extern|COMPLETED|0:0|n1|00:00:05|00:00:00|1M\n13|TIMEOUT|0:15|n2|00:01:00|00:59.000|\n",
        );
        let t = &a["12_3"];
        assert_eq!(
            (t.node.as_str(), t.elapsed.as_str(), t.max_rss.as_str()),
            ("n1", "00:00:05", "2048K")
        );
        assert_eq!(
            (a["13"].state.as_str(), a["13"].exit.as_str()),
            ("TIMEOUT", "0:15")
        );
    }

    #[test]
    fn utc_of_known_instants() {
        assert_eq!(utc(0), "1970-01-01T00:00:00Z");
        assert_eq!(utc(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(utc(1_735_689_599), "2024-12-31T23:59:59Z");
    }
}
