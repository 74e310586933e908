//! The `executor:` block of a pipeline file: which executor runs the stages
//! and, for Slurm, the `sbatch` resources of a stage's job, with overrides
//! per stage kind. Never part of a cache key: where a stage runs does not
//! change its result.
//!
//! ```yaml
//! executor:
//!   kind: slurm              # local (default) | slurm; `run --executor` overrides
//!   partition: compute       # default: the cluster's default partition
//!   account: my-project      # default: the user's default account
//!   time: "01:00:00"         # default: the partition's default limit
//!   cpus: 2                  # --cpus-per-task, default 1
//!   memory: 4G               # --mem, default: the cluster's default
//!   kinds:                   # per stage kind, on top of the values above
//!     gsa: {cpus: 8, shards: 16}   # 16 array tasks evaluate the design
//!     report: {local: true}        # runs on the submitting machine
//! ```

use indexmap::IndexMap;
use serde::{Deserialize, Deserializer};
use std::path::PathBuf;

/// Where stages run.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum ExecutorKind {
    /// In the `modalflow run` process (threads).
    #[default]
    Local,
    /// As Slurm batch jobs running `modalflow exec` on a shared cache.
    Slurm,
}

/// The `executor:` block as written.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExecutorSpec {
    #[serde(default)]
    pub kind: ExecutorKind,
    #[serde(default, deserialize_with = "text")]
    pub partition: Option<String>,
    #[serde(default, deserialize_with = "text")]
    pub account: Option<String>,
    #[serde(default, deserialize_with = "text")]
    pub time: Option<String>,
    pub cpus: Option<u32>,
    #[serde(default, deserialize_with = "text")]
    pub memory: Option<String>,
    pub shards: Option<usize>,
    pub local: Option<bool>,
    /// Further `sbatch` options, e.g. `["--qos=short"]`.
    pub sbatch: Option<Vec<String>>,
    /// Stage kind → resources overriding the ones above.
    #[serde(default)]
    pub kinds: IndexMap<String, Resources>,
    /// The `modalflow` the jobs run (default: the running binary's path,
    /// which the compute nodes must see).
    pub binary: Option<PathBuf>,
    /// Longest wait between two job-status queries, seconds (default 30).
    pub poll: Option<f64>,
}

/// Resources of one stage kind's jobs; unset fields fall back to the block's.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Resources {
    #[serde(default, deserialize_with = "text")]
    pub partition: Option<String>,
    #[serde(default, deserialize_with = "text")]
    pub account: Option<String>,
    #[serde(default, deserialize_with = "text")]
    pub time: Option<String>,
    pub cpus: Option<u32>,
    #[serde(default, deserialize_with = "text")]
    pub memory: Option<String>,
    /// Array tasks a shardable stage's batch is split over (default 1).
    pub shards: Option<usize>,
    /// Run on the submitting machine instead of as a job (default false).
    pub local: Option<bool>,
    pub sbatch: Option<Vec<String>>,
}

/// Resources of one stage with every default applied.
#[derive(Clone, Debug, PartialEq)]
pub struct Resolved {
    pub partition: Option<String>,
    pub account: Option<String>,
    pub time: Option<String>,
    pub cpus: u32,
    pub memory: Option<String>,
    pub shards: usize,
    pub local: bool,
    pub sbatch: Vec<String>,
}

/// Largest `shards` accepted: Slurm's default `MaxArraySize` allows task
/// indices 0..1000.
pub const MAX_SHARDS: usize = 1000;

/// A problem in the block: where (path below `executor`) and what to do.
#[derive(Debug)]
pub struct Problem {
    pub path: Vec<String>,
    pub message: String,
    pub help: String,
}

/// A string, or a number taken as its text (`time: 30`, `memory: 4000`).
fn text<'de, D: Deserializer<'de>>(d: D) -> Result<Option<String>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Text {
        S(String),
        N(u64),
    }
    Ok(Option::<Text>::deserialize(d)?.map(|t| match t {
        Text::S(s) => s,
        Text::N(n) => n.to_string(),
    }))
}

impl ExecutorSpec {
    fn own(&self) -> Resources {
        Resources {
            partition: self.partition.clone(),
            account: self.account.clone(),
            time: self.time.clone(),
            cpus: self.cpus,
            memory: self.memory.clone(),
            shards: self.shards,
            local: self.local,
            sbatch: self.sbatch.clone(),
        }
    }

    /// The resources of a stage of kind `kind`.
    pub fn resources(&self, kind: &str) -> Resolved {
        let base = self.own();
        let over = self.kinds.get(kind).cloned().unwrap_or_default();
        Resolved {
            partition: over.partition.or(base.partition),
            account: over.account.or(base.account),
            time: over.time.or(base.time),
            cpus: over.cpus.or(base.cpus).unwrap_or(1),
            memory: over.memory.or(base.memory),
            shards: over.shards.or(base.shards).unwrap_or(1),
            local: over.local.or(base.local).unwrap_or(false),
            sbatch: over.sbatch.or(base.sbatch).unwrap_or_default(),
        }
    }

    /// Longest wait between status queries.
    pub fn poll_max(&self) -> std::time::Duration {
        std::time::Duration::from_secs_f64(self.poll.unwrap_or(30.0))
    }

    /// Every value problem (kinds are checked by the caller, which knows them).
    pub fn problems(&self) -> Vec<Problem> {
        let mut out = Vec::new();
        if let Some(p) = self.poll {
            if !(p.is_finite() && p > 0.0) {
                out.push(Problem {
                    path: vec!["poll".into()],
                    message: format!("`poll` must be a positive number of seconds, not {p}"),
                    help: "the longest wait between two job-status queries; default 30".into(),
                });
            }
        }
        check_resources(&self.own(), &[], &mut out);
        for (kind, r) in &self.kinds {
            check_resources(r, &["kinds", kind], &mut out);
        }
        out
    }
}

fn check_resources(r: &Resources, at: &[&str], out: &mut Vec<Problem>) {
    let path = |field: &str| -> Vec<String> {
        at.iter()
            .map(|s| s.to_string())
            .chain([field.to_string()])
            .collect()
    };
    if let Some(t) = &r.time {
        if !valid_time(t) {
            out.push(Problem {
                path: path("time"),
                message: format!("`time: {t}` is not a Slurm time limit"),
                help: "write minutes (`30`), `HH:MM:SS` (`\"01:30:00\"`) or `D-HH:MM:SS`".into(),
            });
        }
    }
    if let Some(m) = &r.memory {
        if !valid_memory(m) {
            out.push(Problem {
                path: path("memory"),
                message: format!("`memory: {m}` is not a Slurm memory size"),
                help: "write megabytes (`4000`) or a size with a unit: `512M`, `4G`, `1T`".into(),
            });
        }
    }
    if r.cpus == Some(0) {
        out.push(Problem {
            path: path("cpus"),
            message: "`cpus` must be at least 1".into(),
            help: "CPUs per task (`--cpus-per-task`); the stage's threads use them".into(),
        });
    }
    if let Some(s) = r.shards {
        if s == 0 || s > MAX_SHARDS {
            out.push(Problem {
                path: path("shards"),
                message: format!("`shards: {s}` is out of range"),
                help: format!("give 1 (no sharding) to {MAX_SHARDS} array tasks"),
            });
        }
    }
    for (field, value) in [("partition", &r.partition), ("account", &r.account)] {
        if value
            .as_deref()
            .is_some_and(|v| v.is_empty() || v.chars().any(char::is_whitespace))
        {
            out.push(Problem {
                path: path(field),
                message: format!("`{field}` must be one word"),
                help: "the name as `sinfo` / `sacctmgr show assoc` list it".into(),
            });
        }
    }
}

/// Slurm's time formats: `M`, `M:S`, `H:M:S`, `D-H`, `D-H:M`, `D-H:M:S`.
fn valid_time(t: &str) -> bool {
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    let (days, rest) = match t.split_once('-') {
        Some((d, r)) => (Some(d), r),
        None => (None, t),
    };
    if days.is_some_and(|d| !digits(d)) {
        return false;
    }
    let parts: Vec<&str> = rest.split(':').collect();
    parts.len() <= 3 && parts.iter().all(|p| digits(p))
}

fn valid_memory(m: &str) -> bool {
    let number = m.trim_end_matches(['K', 'M', 'G', 'T', 'k', 'm', 'g', 't']);
    m.len() - number.len() <= 1 && !number.is_empty() && number.bytes().all(|b| b.is_ascii_digit())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kind_overrides_fall_back_to_the_block_and_defaults() {
        let spec: ExecutorSpec = serde_yaml_ng::from_str(
            "kind: slurm\npartition: p\ntime: 30\ncpus: 2\nkinds:\n  gsa: {cpus: 8, shards: 4}\n  report: {local: true}\n",
        )
        .expect("valid block");
        assert_eq!(spec.kind, ExecutorKind::Slurm);
        let gsa = spec.resources("gsa");
        assert_eq!(
            (
                gsa.partition.as_deref(),
                gsa.time.as_deref(),
                gsa.cpus,
                gsa.shards,
                gsa.local
            ),
            (Some("p"), Some("30"), 8, 4, false)
        );
        let report = spec.resources("report");
        assert!(report.local && report.cpus == 2 && report.shards == 1);
        assert!(spec.problems().is_empty());
        assert_eq!(ExecutorSpec::default().resources("gsa").cpus, 1);
    }

    #[test]
    fn bad_values_are_named_with_their_path() {
        let spec: ExecutorSpec = serde_yaml_ng::from_str(
            "time: one hour\nmemory: 4GB\nkinds:\n  gsa: {shards: 0, cpus: 0}\npoll: -1\n",
        )
        .expect("types are fine");
        let paths: Vec<String> = spec.problems().iter().map(|p| p.path.join(".")).collect();
        assert_eq!(
            paths,
            [
                "poll",
                "time",
                "memory",
                "kinds.gsa.cpus",
                "kinds.gsa.shards"
            ]
        );
        assert!(serde_yaml_ng::from_str::<ExecutorSpec>("cpu: 2\n").is_err());
        for ok in ["30", "10:00", "01:30:00", "2-00", "2-12:00:00"] {
            assert!(valid_time(ok), "{ok}");
        }
        for bad in ["", "1:2:3:4", "a-10", "1h"] {
            assert!(!valid_time(bad), "{bad}");
        }
        assert!(valid_memory("4000") && valid_memory("4G") && !valid_memory("G"));
    }
}
