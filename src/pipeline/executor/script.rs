//! Batch scripts: the `#SBATCH` lines of a stage's resources at an attempt,
//! then `modalflow exec` on one description (a job), one per array task (a
//! shard array, an array of matrix expansions), or several in turn (a
//! group job).
//!
//! No value reaches the script unchecked. `#SBATCH` lines are read by
//! sbatch, not by the shell, but a newline in one would start a shell
//! line: every value there is refused if it has a control character and
//! quoted for sbatch's parser if it has a space, quote, `\` or `#`
//! ([`sbatch_word`]); `sbatch:` entries must be options. The job name is
//! reduced to a safe alphabet and the comment line loses its control
//! characters (stage names carry matrix values). Shell words are single
//! quoted ([`quote`]), except `scratch:`, which becomes a double-quoted word
//! in which only variables (`$NAME`, `${NAME}`) expand ([`scratch_word`]).

use super::resources::{
    self, no_control, sbatch_option, scratch_parts, shown, Resolved, ScratchPart, Unsafe,
};
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// Why a script was not written.
#[derive(Debug, thiserror::Error)]
pub enum ScriptError {
    #[error("{0}; {help}", help = .0.help())]
    Unsafe(#[from] Unsafe),
    #[error("`{field}: {value}` is not a valid sbatch value")]
    Invalid { field: &'static str, value: String },
    #[error("the {what} path `{path}` contains a control character; sbatch cannot take it")]
    PathControl { what: &'static str, path: String },
    #[error("the {what} path `{path}` is not valid UTF-8; a job script cannot name it")]
    NotUtf8 { what: &'static str, path: String },
}

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
    /// The script, or why a value cannot go into it.
    pub fn text(&self) -> Result<String, ScriptError> {
        let lines = self.sbatch_lines()?;
        let exec = self.exec_command()?;
        let mut t = String::from("#!/bin/sh\n");
        for l in &lines {
            let _ = writeln!(t, "#SBATCH {l}");
        }
        let _ = writeln!(
            t,
            "# modalflow {} (attempt {})",
            comment(self.name),
            self.attempt
        );
        let _ = writeln!(
            t,
            "export RAYON_NUM_THREADS=\"${{SLURM_CPUS_PER_TASK:-1}}\""
        );
        self.write_body(&mut t, &exec)?;
        Ok(t)
    }

    /// The `#SBATCH` options (without the prefix): name, directory, log,
    /// CPUs, the array, memory and time as scaled for the attempt,
    /// partition, account and the `sbatch:` entries, each value checked.
    fn sbatch_lines(&self) -> Result<Vec<String>, ScriptError> {
        let r = self.resources;
        let log = match self.tasks {
            Some(_) => "%A_%a.out",
            None => "%j.out",
        };
        let mut lines = vec![
            format!("--job-name=modalflow:{}", job_name(self.name)),
            format!(
                "--chdir={}",
                sbatch_word(sbatch_path("job directory", self.dir)?)
            ),
            format!(
                "--output={}",
                sbatch_word(sbatch_path("log", &self.dir.join("log").join(log))?)
            ),
            format!("--cpus-per-task={}", r.cpus),
        ];
        if let Some(tasks) = self.tasks {
            let throttle = r
                .array_parallelism
                .map(|n| format!("%{n}"))
                .unwrap_or_default();
            lines.push(format!("--array={}{throttle}", array_spec(tasks)));
        }
        // The values as written, then as scaled for the attempt.
        no_control("memory", &r.memory)?;
        if let Some(time) = &r.time {
            no_control("time", time)?;
        }
        let memory = r.memory_at(self.attempt);
        no_control("memory", &memory)?;
        if !resources::valid_memory(&memory) {
            return Err(ScriptError::Invalid {
                field: "memory",
                value: memory,
            });
        }
        lines.push(format!("--mem={memory}"));
        if let Some(time) = r.time_at(self.attempt) {
            no_control("time", &time)?;
            if !resources::valid_time(&time) {
                return Err(ScriptError::Invalid {
                    field: "time",
                    value: time,
                });
            }
            lines.push(format!("--time={time}"));
        }
        for (opt, value) in [("partition", &r.partition), ("account", &r.account)] {
            if let Some(v) = value {
                no_control(opt, v)?;
                lines.push(format!("--{opt}={}", sbatch_word(v)));
            }
        }
        for extra in &r.sbatch {
            sbatch_option(extra)?;
            lines.push(extra.clone());
        }
        Ok(lines)
    }

    /// The `modalflow exec` command line the body runs, without the job
    /// descriptions.
    fn exec_command(&self) -> Result<String, ScriptError> {
        let r = self.resources;
        let mut exec = format!(
            "{} exec --cache {}",
            shell_path("modalflow binary", self.binary)?,
            shell_path("cache", self.cache)?
        );
        if let Some(s) = &r.scratch {
            let _ = write!(exec, " --scratch {}", scratch_word(s)?);
        }
        Ok(exec)
    }

    /// Append the script's body to `t`: `exec` on one description (a task of
    /// it for a shard array), on description i for array task i, or on all
    /// of them in turn.
    fn write_body(&self, t: &mut String, exec: &str) -> Result<(), ScriptError> {
        match &self.body {
            Body::One {
                description,
                shards,
            } => {
                let _ = write!(t, "exec {exec} {}", shell_path("job", description)?);
                if *shards {
                    t.push_str(" --shard \"$SLURM_ARRAY_TASK_ID\"");
                }
                t.push('\n');
            }
            Body::PerTask(descriptions) => {
                t.push_str("case \"$SLURM_ARRAY_TASK_ID\" in\n");
                for (i, d) in descriptions.iter().enumerate() {
                    let _ = writeln!(t, "  {i}) job={} ;;", shell_path("job", d)?);
                }
                t.push_str(
                    "  *) echo \"no job for task $SLURM_ARRAY_TASK_ID\" >&2; exit 1 ;;\nesac\n",
                );
                let _ = writeln!(t, "exec {exec} \"$job\"");
            }
            Body::Group(descriptions) => {
                let list = descriptions
                    .iter()
                    .map(|d| shell_path("job", d))
                    .collect::<Result<Vec<_>, _>>()?;
                let _ = writeln!(t, "exec {exec} {}", list.join(" "));
            }
        }
        Ok(())
    }
}

/// A job name Slurm shows as is: `[A-Za-z0-9._:=,[]-]`, anything else `_`.
fn job_name(stage: &str) -> String {
    stage
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "_-.,:=[]".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// A stage name for the script's comment line: control characters (a
/// newline would end the comment) become `_`.
fn comment(stage: &str) -> String {
    stage
        .chars()
        .map(|c| if c.is_control() { '_' } else { c })
        .collect()
}

/// One value of an `#SBATCH` line as sbatch's parser reads it: as is when
/// it has no space, quote, `\` or `#`, else in double quotes with `\`,
/// `"` and `#` escaped by `\` (Slurm's `_get_argument`, old and new). The
/// value has no control character ([`no_control`]).
pub fn sbatch_word(value: &str) -> String {
    if !value.contains(|c: char| c.is_whitespace() || "\"'\\#".contains(c)) {
        return value.to_string();
    }
    let mut w = String::from("\"");
    for c in value.chars() {
        if "\"\\#".contains(c) {
            w.push('\\');
        }
        w.push(c);
    }
    w.push('"');
    w
}

/// A path for an `#SBATCH` line: UTF-8 without control characters.
fn sbatch_path<'p>(what: &'static str, path: &'p Path) -> Result<&'p str, ScriptError> {
    let text = path.to_str().ok_or_else(|| ScriptError::NotUtf8 {
        what,
        path: path.display().to_string(),
    })?;
    if text.contains(char::is_control) {
        return Err(ScriptError::PathControl {
            what,
            path: shown(text),
        });
    }
    Ok(text)
}

/// A path as one single-quoted shell word (UTF-8: a lossy conversion would
/// name another file).
fn shell_path(what: &'static str, path: &Path) -> Result<String, ScriptError> {
    path.to_str()
        .map(quote)
        .ok_or_else(|| ScriptError::NotUtf8 {
            what,
            path: path.display().to_string(),
        })
}

/// `scratch:` as one double-quoted shell word in which only variables
/// (`$NAME`, `${NAME}`) expand: the value is refused unless every `$` starts
/// a variable name and it has no backtick, `\`, `"` or control character.
pub fn scratch_word(value: &str) -> Result<String, Unsafe> {
    let mut w = String::from("\"");
    for part in scratch_parts(value)? {
        match part {
            ScratchPart::Text(text) => w.push_str(text),
            // As written: `$NAME` ends where the shell ends it too.
            ScratchPart::Var { name, braced: true } => {
                let _ = write!(w, "${{{name}}}");
            }
            ScratchPart::Var {
                name,
                braced: false,
            } => {
                let _ = write!(w, "${name}");
            }
        }
    }
    w.push('"');
    Ok(w)
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

/// Text as one single-quoted shell word (`'` as `'\\''`): nothing in it
/// expands, newlines included.
pub fn quote(text: &str) -> String {
    format!("'{}'", text.replace('\'', "'\\''"))
}

#[cfg(test)]
#[path = "script_tests.rs"]
mod tests;
