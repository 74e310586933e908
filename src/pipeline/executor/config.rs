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
//!   retries: 1               # resubmit after TIMEOUT / OUT_OF_MEMORY / NODE_FAIL
//!   kinds:                   # per stage kind, on top of the values above
//!     gsa: {cpus: 8, shards: 16, array_parallelism: 4}
//!     report: {local: true}        # runs on the submitting machine
//!     evaluate: {group: 8}         # up to 8 ready evaluate stages per job
//!   stages:                  # per stage (base name or one expansion)
//!     big_gsa: {memory: 8G * attempt, time: "02:00:00"}
//! ```

use super::resources::{self, Resolved, Resources};
use indexmap::IndexMap;
use serde::Deserialize;
use std::path::PathBuf;
use std::time::Duration;

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

/// The `executor:` block as written: the kind, the block's own resources
/// (flattened), per-kind and per-stage overrides, and the block-only keys.
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
    pub retries: Option<u32>,
    pub array_parallelism: Option<usize>,
    pub group: Option<usize>,
    #[serde(default, deserialize_with = "text")]
    pub scratch: Option<String>,
    /// Stage kind → resources overriding the ones above.
    #[serde(default)]
    pub kinds: IndexMap<String, Resources>,
    /// Stage (base name for every expansion, or one expansion) → resources
    /// overriding the kind's.
    #[serde(default)]
    pub stages: IndexMap<String, Resources>,
    /// The `modalflow` the jobs run (default: the running binary's path,
    /// which the compute nodes must see); relative to the pipeline file.
    pub binary: Option<PathBuf>,
    /// Longest wait between two job-status queries, seconds (default 30).
    pub poll: Option<f64>,
}

/// Shortest `poll` accepted, seconds.
pub const MIN_POLL: f64 = 0.2;
/// The first status queries of a run come this often (or every `poll` if
/// that is shorter); the interval then grows by half each time to `poll`.
pub const FIRST_POLL: Duration = Duration::from_secs(2);

/// A problem in the block: where (path below `executor`) and what to do.
#[derive(Debug)]
pub struct Problem {
    pub path: Vec<String>,
    pub message: String,
    pub help: String,
}

/// A string, or a number taken as its text (`time: 30`, `memory: 4000`).
fn text<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<String>, D::Error> {
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
            retries: self.retries,
            array_parallelism: self.array_parallelism,
            group: self.group,
            scratch: self.scratch.clone(),
        }
    }

    /// The resources of stage `stage` (expanded name) of kind `kind`: its
    /// expansion's entry over its base name's over its kind's over the block's.
    pub fn resources(&self, kind: &str, stage: &str) -> Resolved {
        let base = stage.split('[').next().unwrap_or(stage);
        let none = Resources::default();
        let of =
            |map: &IndexMap<String, Resources>, k: &str| map.get(k).cloned().unwrap_or_default();
        let mut r = self.own();
        r = of(&self.kinds, kind).over(&r);
        r = of(&self.stages, base).over(&r);
        if base != stage {
            r = of(&self.stages, stage).over(&r);
        }
        r.over(&none).resolve()
    }

    /// The first and the longest wait between status queries.
    pub fn poll_range(&self) -> (Duration, Duration) {
        let max = Duration::from_secs_f64(self.poll.unwrap_or(30.0).max(MIN_POLL));
        (FIRST_POLL.min(max), max)
    }

    /// Every value problem (kind and stage names are checked by the
    /// caller, which knows them).
    pub fn problems(&self) -> Vec<Problem> {
        let mut out = Vec::new();
        if let Some(p) = self.poll {
            if !(p.is_finite() && p >= MIN_POLL) {
                out.push(Problem {
                    path: vec!["poll".into()],
                    message: format!("`poll` must be at least {MIN_POLL} s, not {p}"),
                    help: "the longest wait between two job-status queries; default 30 \
                           (every poll is one `sacct` call for all of the run's jobs)"
                        .into(),
                });
            }
        }
        let levels = std::iter::once((Vec::new(), self.own()))
            .chain(
                self.kinds
                    .iter()
                    .map(|(k, r)| (vec!["kinds".to_string(), k.clone()], r.clone())),
            )
            .chain(
                self.stages
                    .iter()
                    .map(|(k, r)| (vec!["stages".to_string(), k.clone()], r.clone())),
            );
        for (at, r) in levels {
            for p in resources::problems(&r) {
                let mut path = at.clone();
                path.push(p.field.to_string());
                if let Some(i) = p.index {
                    path.push(i.to_string());
                }
                out.push(Problem {
                    path,
                    message: p.message,
                    help: p.help,
                });
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stage_over_kind_over_block_over_defaults() {
        let spec: ExecutorSpec = serde_yaml_ng::from_str(
            "kind: slurm\npartition: p\ntime: 30\ncpus: 2\nretries: 1\nkinds:\n  gsa: {cpus: 8, shards: 4}\n  report: {local: true}\nstages:\n  sens: {memory: 8G * attempt}\n  \"sens[n=2]\": {cpus: 16}\n",
        )
        .expect("valid block");
        assert_eq!(spec.kind, ExecutorKind::Slurm);
        let gsa = spec.resources("gsa", "other");
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
        assert_eq!((gsa.memory.as_str(), gsa.retries), ("2G", 1));
        let report = spec.resources("report", "r");
        assert!(report.local && report.cpus == 2 && report.shards == 1);
        let sens = spec.resources("gsa", "sens[n=1]");
        assert_eq!((sens.cpus, sens.memory_at(2).as_str()), (8, "16G"));
        assert_eq!(spec.resources("gsa", "sens[n=2]").cpus, 16);
        assert!(spec.problems().is_empty());
        assert_eq!(ExecutorSpec::default().resources("gsa", "g").cpus, 1);
    }

    #[test]
    fn bad_values_are_named_with_their_path() {
        let spec: ExecutorSpec = serde_yaml_ng::from_str(
            "time: one hour\nmemory: 4GB\nkinds:\n  gsa: {shards: 0, cpus: 0}\nstages:\n  a: {array_parallelism: 0, retries: 99}\npoll: 0.01\n",
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
                "kinds.gsa.shards",
                "stages.a.retries",
                "stages.a.array_parallelism"
            ]
        );
        assert!(serde_yaml_ng::from_str::<ExecutorSpec>("cpu: 2\n").is_err());
    }

    #[test]
    fn values_that_would_inject_into_a_job_script_are_problems() {
        let spec: ExecutorSpec = serde_yaml_ng::from_str(
            "partition: \"p\\nrm -rf /tmp/decoy\"\naccount: \"a\\u0000\"\nsbatch: [\"--qos=short\", \"--qos=x\\nrm -rf /tmp/decoy\", \"rm -rf /tmp/decoy\"]\nscratch: \"$(touch /tmp/pwned)\"\nkinds:\n  gsa: {scratch: \"`touch /tmp/pwned`\", time: \"30\\r\"}\nstages:\n  s: {sbatch: [\"-J x;y\"], scratch: \"$TMPDIR/${USER}_x\", memory: \"4G\\n* attempt\"}\n",
        )
        .expect("types are fine");
        let problems = spec.problems();
        let paths: Vec<String> = problems.iter().map(|p| p.path.join(".")).collect();
        assert_eq!(
            paths,
            [
                "scratch",
                "partition",
                "account",
                "sbatch.1",
                "sbatch.2",
                "kinds.gsa.time",
                "kinds.gsa.scratch",
                "stages.s.memory"
            ]
        );
        for p in &problems {
            let field = p.path.iter().rev().find(|s| s.parse::<usize>().is_err());
            let field = field.map_or("", String::as_str);
            assert!(p.message.contains(&format!("`{field}")), "{}", p.message);
            assert!(!p.message.contains(['\n', '\r', '\0']), "{:?}", p.message);
        }
        assert!(problems[0].message.contains("`$(...)` is not allowed"));
        assert!(problems[0].help.contains("`$NAME` or `${NAME}`"));
        assert!(problems[3].message.contains("control character (\\n)"));
        assert!(problems[4].message.contains("not an sbatch option"));
    }
}
