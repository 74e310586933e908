//! Batch scripts: the `#SBATCH` lines of a stage's resources at an attempt,
//! then `modalflow exec` on one description (a job), one per array task (a
//! shard array, an array of matrix expansions), or several in turn (a
//! group job).

use super::resources::Resolved;
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// What one script runs.
pub enum Body<'a> {
    /// One description; `shards`: run task `$SLURM_ARRAY_TASK_ID` of it.
    One { description: &'a Path, shards: bool },
    /// Array task i runs description i.
    PerTask(&'a [PathBuf]),
    /// Every description in turn, in one job.
    Group(&'a [PathBuf]),
}

/// One batch script.
pub struct Script<'a> {
    pub name: &'a str,
    /// Working directory; logs go to `log/` below it.
    pub dir: &'a Path,
    pub resources: &'a Resolved,
    pub attempt: u32,
    /// Array task indices, or `None` for a single job.
    pub tasks: Option<&'a [usize]>,
    pub binary: &'a Path,
    pub cache: &'a Path,
    pub body: Body<'a>,
}

impl Script<'_> {
    pub fn text(&self) -> String {
        let r = self.resources;
        let mut t = String::from("#!/bin/sh\n");
        let log = match self.tasks {
            Some(_) => "%A_%a.out",
            None => "%j.out",
        };
        let mut line = |opt: String| {
            let _ = writeln!(t, "#SBATCH {opt}");
        };
        line(format!("--job-name=modalflow:{}", job_name(self.name)));
        line(format!("--chdir={}", self.dir.display()));
        line(format!(
            "--output={}",
            self.dir.join("log").join(log).display()
        ));
        line(format!("--cpus-per-task={}", r.cpus));
        if let Some(tasks) = self.tasks {
            let throttle = r
                .array_parallelism
                .map(|n| format!("%{n}"))
                .unwrap_or_default();
            line(format!("--array={}{throttle}", array_spec(tasks)));
        }
        line(format!("--mem={}", r.memory_at(self.attempt)));
        if let Some(time) = r.time_at(self.attempt) {
            line(format!("--time={time}"));
        }
        for (opt, value) in [("partition", &r.partition), ("account", &r.account)] {
            if let Some(v) = value {
                line(format!("--{opt}={v}"));
            }
        }
        for extra in &r.sbatch {
            line(extra.clone());
        }
        let _ = writeln!(t, "# modalflow {} (attempt {})", self.name, self.attempt);
        let _ = writeln!(
            t,
            "export RAYON_NUM_THREADS=\"${{SLURM_CPUS_PER_TASK:-1}}\""
        );
        let mut exec = format!("{} exec --cache {}", quote(self.binary), quote(self.cache));
        if let Some(s) = &r.scratch {
            // Double quotes: the job's shell expands `$TMPDIR` on the node.
            let _ = write!(exec, " --scratch \"{}\"", s.replace(['"', '\\', '`'], ""));
        }
        match &self.body {
            Body::One {
                description,
                shards,
            } => {
                let _ = write!(t, "exec {exec} {}", quote(description));
                if *shards {
                    t.push_str(" --shard \"$SLURM_ARRAY_TASK_ID\"");
                }
                t.push('\n');
            }
            Body::PerTask(descriptions) => {
                t.push_str("case \"$SLURM_ARRAY_TASK_ID\" in\n");
                for (i, d) in descriptions.iter().enumerate() {
                    let _ = writeln!(t, "  {i}) job={} ;;", quote(d));
                }
                t.push_str(
                    "  *) echo \"no job for task $SLURM_ARRAY_TASK_ID\" >&2; exit 1 ;;\nesac\n",
                );
                let _ = writeln!(t, "exec {exec} \"$job\"");
            }
            Body::Group(descriptions) => {
                let list: Vec<String> = descriptions.iter().map(|d| quote(d)).collect();
                let _ = writeln!(t, "exec {exec} {}", list.join(" "));
            }
        }
        t
    }
}

/// A job name Slurm shows as is.
fn job_name(stage: &str) -> String {
    stage
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "_-.,=[]".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// `0-3,5,7-8` from sorted task indices.
pub fn array_spec(tasks: &[usize]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < tasks.len() {
        let mut j = i;
        while j + 1 < tasks.len() && tasks[j + 1] == tasks[j] + 1 {
            j += 1;
        }
        parts.push(if i == j {
            tasks[i].to_string()
        } else {
            format!("{}-{}", tasks[i], tasks[j])
        });
        i = j + 1;
    }
    parts.join(",")
}

/// A path as one single-quoted shell word.
pub fn quote(p: &Path) -> String {
    format!("'{}'", p.display().to_string().replace('\'', "'\\''"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::executor::resources::Resources;

    #[test]
    fn array_specs_compress_runs() {
        assert_eq!(array_spec(&[0, 1, 2, 3]), "0-3");
        assert_eq!(array_spec(&[1, 3, 4, 5, 9]), "1,3-5,9");
        assert_eq!(array_spec(&[7]), "7");
        assert_eq!(quote(Path::new("/a b/it's")), "'/a b/it'\\''s'");
    }

    #[test]
    fn scripts_carry_throttle_attempt_resources_and_scratch() {
        let r = Resources {
            time: Some("10 * attempt".into()),
            memory: Some("1G * attempt".into()),
            array_parallelism: Some(2),
            scratch: Some("$TMPDIR".into()),
            ..Resources::default()
        }
        .resolve();
        let d = [
            PathBuf::from("/c/jobs/a/job.json"),
            PathBuf::from("/c/jobs/b/job.json"),
        ];
        let s = Script {
            name: "ident",
            dir: Path::new("/c/jobs/batch-1"),
            resources: &r,
            attempt: 2,
            tasks: Some(&[0, 1]),
            binary: Path::new("/bin/modalflow"),
            cache: Path::new("/c"),
            body: Body::PerTask(&d),
        }
        .text();
        for want in [
            "#SBATCH --array=0-1%2\n",
            "#SBATCH --mem=2G\n",
            "#SBATCH --time=00:20:00\n",
            "  1) job='/c/jobs/b/job.json' ;;\n",
            "exec '/bin/modalflow' exec --cache '/c' --scratch \"$TMPDIR\" \"$job\"\n",
        ] {
            assert!(s.contains(want), "{want} in\n{s}");
        }
    }
}
